"""The protocol by which walks from different generators are compared.

Every figure of every walk is taken over the same walking window: from when the walking
starts to when the shortest walk's steps end, on a common clock (0 = the first step
begins).  Standing time a generator needs (the Kajita walk's prelude and postlude) and the
simulator adds (standing before and holding after) falls outside it, so no walk's mean is
diluted by standing and none is charged for it.  A fall anywhere in a rollout still counts.
For each walk the planned and the simulated motion are measured; the stabilizer gains and
the contact each ran with travel with the figures.
"""

from __future__ import annotations

import dataclasses

from cocomopl.analysis.metrics import (
    fell,
    force_variation,
    mean_torque,
    posture_statistics,
    summary,
    total_force_variation,
    windowed,
)
from cocomopl.dynamics import GRAVITY
from cocomopl.errors import Error
from cocomopl.motion import Motion
from cocomopl.robot import Robot

# Figures that compare walks, all better when lower
MEASURES = (
    "mean_torque",
    "peak_force_over_weight",
    "force_variation_over_weight",
    "total_force_variation_over_weight",
    "max_force_rate",
)


def walking_span(motion: Motion) -> tuple[float, float]:
    """(start, end) in s of the walking itself on the motion's clock: ``meta["walking_span_s"]``
    where a generator adds standing around it (the Kajita walk), else the whole motion."""
    span = motion.meta.get("walking_span_s")
    return (float(motion.t[0]), float(motion.t[-1])) if span is None else (float(span[0]), float(span[1]))


def common_window(motions: dict[str, Motion]) -> tuple[float, float]:
    """The window (s) all ``motions`` walk in: the intersection of their walking spans.

    Raises
    ------
    Error
        If the spans do not overlap.
    """
    spans = [walking_span(m) for m in motions.values()]
    start, end = max(s for s, _ in spans), min(e for _, e in spans)
    if end <= start:
        raise Error(f"the walks {', '.join(motions)} do not walk at the same time: spans {spans}")
    return start, end


def planned_figures(robot: Robot, plan: Motion) -> dict:
    """What a plan asks for: its mean torque, force variation and posture."""
    weight = robot.mass * GRAVITY
    return {
        "mean_torque": mean_torque(plan),
        "force_variation_over_weight": float(force_variation(plan).max() / weight),
        "total_force_variation_over_weight": total_force_variation(plan) / weight,
        **posture_statistics(robot, plan),
    }


def window_figures(robot: Robot, planned: dict[str, Motion], simulated: dict[str, Motion],
                   *, window: tuple[float, float]) -> dict[str, dict]:
    """Per walk, the JSON of :func:`~cocomopl.analysis.metrics.summary` of its simulated motion against its
    plan and :func:`~cocomopl.analysis.metrics.posture_statistics`, both over ``window`` (s,
    on the plans' clock, which the simulated motions share), with the plan's own figures
    under ``"planned"`` and the stabilizer gains the rollout ran with."""
    start, end = window
    out = {}
    for name, plan in planned.items():
        measured = simulated[name]
        plan_in, measured_in = windowed(plan, start, end), windowed(measured, start, end)
        # a fall anywhere in the rollout counts, standing included
        figures = dataclasses.replace(summary(robot, measured_in, plan_in), fell=fell(robot, measured)).to_json()
        figures.update(posture_statistics(robot, measured_in))
        figures["stabilizer_gains"] = None if measured.simulation is None else measured.simulation.stabilizer_gains
        figures["planned"] = planned_figures(robot, plan_in)
        out[name] = figures
    return out


def per_measure(figures: dict[str, dict], first: str, second: str) -> dict[str, dict]:
    """For each of ``MEASURES``, the two walks' values, which is lower, and the first's
    relative difference from the second (``first / second - 1``)."""
    out = {}
    for measure in MEASURES:
        a, b = figures[first][measure], figures[second][measure]
        out[measure] = {first: a, second: b, "lower": first if a < b else second, "relative_difference": a / b - 1}
    return out
