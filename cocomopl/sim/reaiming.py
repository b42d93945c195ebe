"""Footstep re-aiming: each landing aimed at its planned place from where the robot stands.

A position-controlled robot does not land its feet exactly where the plan does: its servos
give a little under load, so each landing is a few millimetres off, and played open loop
those errors add up over a walk (7-13 mm per step on the bundled model's walks).  A
robot that walks to a goal measures where its stance sole stands, as a real one does by
leg odometry, and aims the next step from there.

:class:`Reaiming` does that once per step, early in its single support, when the stance sole
has settled: the step before is taken to have landed where the stance sole is measured, and
the step under way to land where the original plan put it (:func:`reaimed_specs`).  The
primitives then generate the changed walk (a step is conditioned only on those before it)
and the rollout follows it from that moment (:func:`cocomopl.sim.rollout.simulate`; a
:class:`~cocomopl.sim.hooks.Replanner`).  The
plan's world thus stays the measured one, so the stabilizer, where it runs, compares the
robot with a reference on the soles it stands on.

What cannot be re-aimed: a start step (its stance sole has not moved since the walk or the
stop before it began) and a stop's landing, which repeats the footstep before it
(:mod:`cocomopl.planning.footsteps`).  Footsteps are kept within the model's learned range,
and an aim the feet's clearance refuses is tried again at half the correction, then with
none (the step keeps its footstep from the measured sole).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from time import perf_counter
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from cocomopl.errors import Error
from cocomopl.gait import OTHER_SIDE, check_footstep, footsteps, sole_poses, wrap_angle
from cocomopl.motion import Footstep, Motion, StepSpec
from cocomopl.planning.footsteps import relative_footstep, same_footstep
from cocomopl.robot import Robot
from cocomopl.sim.hooks import Step

if TYPE_CHECKING:
    from cocomopl.sim.stabilizer import Stabilizer

SETTLED = 0.2  # fraction of a single support after which its stance sole is taken as settled
SHARES = (1.0, 0.5, 0.0)  # of the measured error a step is aimed to correct, tried in turn


@dataclass
class Reaimed:
    """One re-aimed step: when (s from the walk's start), which step, how far its stance sole
    stood from the plan (m, and deg), how far the re-aimed landing lies from the plan's (m),
    and the wall time (s) of generating and placing the changed walk."""

    time_s: float
    step: int
    stance_error_m: tuple[float, float]
    stance_error_deg: float
    miss_m: float
    generation_s: float

    def as_dict(self) -> dict:
        return {"time_s": self.time_s, "step": self.step, "stance_error_m": [float(v) for v in self.stance_error_m],
                "stance_error_deg": self.stance_error_deg, "miss_m": self.miss_m, "generation_s": self.generation_s}


def landing_targets(robot: Robot, specs: Sequence[StepSpec]) -> list[np.ndarray]:
    """Per step, the world pose (x, y, yaw) where the plan lands its swing sole."""
    return [np.array([*feet["end"][spec.swing_side][:2], feet["yaw"]["end"][spec.swing_side]])
            for spec, feet in zip(specs, footsteps(robot, list(specs)))]


def _kind(kind: str, start: Footstep, end: Footstep) -> str:
    """A step's kind once its footsteps change: starts and stops stay, the others are cyclic
    exactly when the footstep repeats."""
    if kind in ("start", "stop"):
        return kind
    return "cyclic" if same_footstep(start, end) else "transition"


def _with_footsteps(spec: StepSpec, start: Footstep, end: Footstep) -> StepSpec:
    if spec.kind == "start":
        start = Footstep(0.0)
    if spec.kind == "stop":
        end = Footstep(0.0)
    return StepSpec.between(_kind(spec.kind, start, end), start, end, swing_side=spec.swing_side)


def _within(footstep: Footstep, limits: dict[str, tuple[float, float]]) -> Footstep:
    """``footstep`` clipped to ``limits``: beyond the learned range the model extrapolates, and
    a stop that repeats such a footstep lands hard (tuned on random goals of seeds 12-14:
    1 cm beyond it, the largest peak without the stabilizer was 2.52 x weight, within it 1.76).
    A parameter whose limits are one value (one the model did not learn) is set to it."""
    return Footstep(*(float(np.clip(getattr(footstep, key), *limits[key])) for key in Footstep._fields))


def _clear(robot: Robot, side: str, footstep: Footstep) -> bool:
    """Whether sole ``side`` may land at ``footstep`` (:func:`~cocomopl.gait.check_footstep`)."""
    try:
        check_footstep(robot, side, footstep)
    except Error:
        return False
    return True


def _offset(pose: np.ndarray, planned: np.ndarray) -> np.ndarray:
    """Where a sole's pose (x, y, yaw) stands from its planned one: x, y in m and yaw in rad."""
    return np.array([*(pose[:2] - planned[:2]), wrap_angle(pose[2] - planned[2])])


class Reaim(NamedTuple):
    """A walk with one step re-aimed (:func:`reaimed_specs`)."""

    specs: list[StepSpec]
    miss_m: float  # how far the re-aimed step lands from the original plan's landing
    stance_error: np.ndarray  # where the measured stance sole stood from the plan: x, y (m), yaw (rad)


def reaimed_specs(
    robot: Robot,
    specs: Sequence[StepSpec],
    targets: Sequence[np.ndarray],
    *,
    step: int,
    stance: np.ndarray,
    limits: dict[str, tuple[float, float]],
) -> Reaim | None:
    """The walk ``specs`` with step ``step`` re-aimed from the measured pose ``stance`` (x, y,
    yaw) of its stance sole; None where it cannot be re-aimed.

    The step before is given the footstep that puts its sole at ``stance``; step ``step``
    the footstep from there to ``targets[step]`` (the original plan's landing), or to a
    point ``1 - share`` of the stance error short of it where the feet's clearance refuses
    the full aim; the step after starts from that footstep.  Both footsteps are kept within
    the learned footstep range ``limits`` (``length``, ``width``, ``turn``).  Later steps
    keep their footsteps, so they land where the original plan put them.
    """
    spec = specs[step]
    before = specs[step - 1] if step > 0 else None
    side = OTHER_SIDE[spec.swing_side]
    if spec.kind == "start" or before is None or before.kind == "stop" or before.swing_side != side:
        return None
    poses = sole_poses(robot, list(specs[: step + 1]))  # a step's soles depend only on the steps before it
    # where the step before really landed: not refused for the clearance it did not keep
    landed = _within(relative_footstep(robot, poses[step - 1][spec.swing_side], stance, side=side), limits)
    error = _offset(stance, poses[step][side])
    out = list(specs)
    out[step - 1] = _with_footsteps(before, before.start_footstep, landed)
    if spec.kind == "stop":  # its landing repeats the footstep before it
        out[step] = _with_footsteps(spec, landed, Footstep(0.0))
        return Reaim(out, _miss(robot, out, targets, step), error)
    for share in SHARES:
        aim = targets[step] + (1.0 - share) * error
        footstep = _within(relative_footstep(robot, stance, aim, side=spec.swing_side), limits)
        if _clear(robot, spec.swing_side, footstep):
            break
    else:
        return None
    out[step] = _with_footsteps(spec, landed, footstep)
    if step + 1 < len(out):
        after = out[step + 1]
        out[step + 1] = _with_footsteps(after, footstep, after.start_footstep if after.kind == "stop" else after.end_footstep)
    return Reaim(out, _miss(robot, out, targets, step), error)


def _miss(robot: Robot, specs: Sequence[StepSpec], targets: Sequence[np.ndarray], step: int) -> float:
    """How far (m) step ``step`` of ``specs`` lands from ``targets[step]``."""
    return float(np.hypot(*(landing_targets(robot, specs[: step + 1])[step][:2] - targets[step][:2])))


@dataclass
class Reaiming:
    """Re-aims each step of a walk from its measured stance sole, and has the walk
    generated again (see the module's text): a rollout's :class:`~cocomopl.sim.hooks.Replanner`.

    Parameters
    ----------
    robot : the walking robot
    motion : the walk being played
    generate : the changed steps, the walk they change and the re-aimed step's index to the
        changed walk, placed (the primitives and the placement of the pipeline)
    footstep_range : (low, high) of ``length``, ``width`` and ``turn`` a re-aimed footstep may take
    """

    robot: Robot
    motion: Motion
    generate: Callable[[Sequence[StepSpec], Motion, int], Motion]
    footstep_range: dict[str, tuple[float, float]]
    reaimed: list[Reaimed] = field(default_factory=list)

    def __post_init__(self):
        self.specs = list(self.motion.steps)
        self.targets = landing_targets(self.robot, self.specs)
        self._tried: set[int] = set()

    def start(self, stabilizer: Stabilizer | None) -> None:
        """Re-aiming runs with or without the stabilizer."""

    def replan(self, step: Step) -> Motion | None:
        """:meth:`check` on the soles measured at ``step``."""
        return self.check(step.elapsed, step.soles())

    def metadata(self) -> dict[str, list[dict]]:
        return {"reaimed": [change.as_dict() for change in self.reaimed]}

    def check(self, time: float, soles: dict[str, np.ndarray]) -> Motion | None:
        """The walk generated again with the step under way re-aimed, or None: not yet, or
        already done for this step.  ``time``: s from the walk's start; ``soles``: the
        measured world poses (x, y, yaw) of the soles, by side."""
        step = self._settled_step(time)
        if step is None:
            return None
        self._tried.add(step)
        stance = soles[OTHER_SIDE[self.specs[step].swing_side]]
        aim = reaimed_specs(self.robot, self.specs, self.targets, step=step, stance=stance, limits=self.footstep_range)
        if aim is None:
            return None
        started = perf_counter()
        try:
            motion = self.generate(aim.specs, self.motion, step)
        except Error:  # the changed walk is refused (its checks or its placement): keep the plan
            return None
        error = aim.stance_error
        self.reaimed.append(Reaimed(time, step, (float(error[0]), float(error[1])), math.degrees(error[2]), aim.miss_m,
                                    perf_counter() - started))
        self.specs, self.motion = aim.specs, motion
        return motion

    def _settled_step(self, time: float) -> int | None:
        """The step whose single support is under way at ``time``, past ``SETTLED`` of it,
        and not yet re-aimed."""
        t = self.motion.t - self.motion.t[0]
        for kind, first, last in self.motion.phases:
            if kind != "ss" or not t[first] + SETTLED * (t[last] - t[first]) <= time < t[last]:
                continue
            step = int(np.searchsorted(self.motion.step_starts, first, side="right") - 1)
            return None if step in self._tried else step
        return None


__all__ = ["SETTLED", "Reaim", "Reaimed", "Reaiming", "landing_targets", "reaimed_specs"]
