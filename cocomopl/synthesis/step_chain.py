"""From a list of step lengths to a chain of predicted steps, each started where the last ended."""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives.estimator import MovementPrimitives, PredictedStep, signal_groups
from cocomopl.primitives.training import step_type


class OutOfSupportWarning(UserWarning):
    """A step's parameters lie outside the training data's support: trust it less."""


def generate_steps(model: MovementPrimitives, specs: Sequence[StepSpec], *, strict: bool = False) -> list[PredictedStep]:
    """Predict each step, conditioning its start on the previous step's end.

    Every walk's steps, whether from step lengths, a footstep file or the planner, are
    checked against the model's training support here: each step outside it comes with one
    :class:`OutOfSupportWarning` naming it (its number in the walk, from 1, and its name),
    its distance from the nearest training step and the support radius
    (:func:`outside_support`), and its predicted joint-angle standard deviation; with
    ``strict`` the first such step raises :class:`Error` instead.
    """
    steps, end = [], None
    for number, (spec, step) in enumerate(zip(specs, model.predict_many(specs)), start=1):
        if end is not None:
            step = step.conditioned_on(end)
        if not step.in_support:
            message = (f"step {number} ({spec.name}): {outside_support(model, step)}; "
                       f"predicted joint-angle std up to {joint_std_max(model, step):.3f} rad")
            if strict:
                raise Error(f"refused (--strict): {message}")
            warnings.warn(message, OutOfSupportWarning, stacklevel=2)
        steps.append(step)
        end = in_next_step_frame(model, spec, step.values[-1])
    return steps


def support_radius(model: MovementPrimitives, spec: StepSpec) -> float:
    """The support radius of the learned type of ``spec`` (m, in the model's inputs,
    :func:`~cocomopl.primitives.training.step_lengths`): the largest distance from one of its
    training steps to the nearest other.  A type learned in parts takes its parts' smallest
    (they are parts of the same training steps)."""
    return min(model.type_arrays(t).support_radius for t in model.trajectory_types(step_type(spec)))


def outside_support(model: MovementPrimitives, step: PredictedStep) -> str:
    """How far ``step`` lies from the model's training steps, against its support radius, as
    the warnings and refusals say it: e.g. ``"216 mm from the nearest training step of its
    type, support radius 212 mm"``."""
    return (f"{step.distance * 1000:.0f} mm from the nearest training step of its type, "
            f"support radius {support_radius(model, step.spec) * 1000:.0f} mm")


def in_next_step_frame(model: MovementPrimitives, spec: StepSpec, end: np.ndarray) -> np.ndarray:
    """The signals ``end`` at the end of step ``spec``, in the frame of the step after it.

    Each step's signals are in its stance sole's frame; the next step stands on the sole
    that just landed, turned by the step's footstep, so only the pelvis yaw changes.  A
    stop's swing sole lands at its start footstep and the other closes up beside it,
    parallel: the next step (a start) stands turned by that footstep's turn.
    """
    footstep_turn = spec.start_turn if spec.kind == "stop" else spec.end_turn
    turn = footstep_turn if spec.swing_side == "left" else -footstep_turn
    if turn == 0.0:
        return end
    out = end.copy()
    out[model.signal_names.index("pelvis_yaw")] -= turn
    return out


def joint_std_max(model: MovementPrimitives, step: PredictedStep) -> float:
    """The largest predicted standard deviation of a joint angle over a step, rad."""
    return float(step.std[:, signal_groups(model.signal_names)["joints"]].max())
