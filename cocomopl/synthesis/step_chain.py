"""From a list of step lengths to a chain of predicted steps, each started where the last ended."""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives.estimator import MovementPrimitives, PredictedStep, signal_groups


class OutOfSupportWarning(UserWarning):
    """A step's parameters lie outside the training data's support: trust it less."""


def generate_steps(model: MovementPrimitives, specs: Sequence[StepSpec], strict: bool = False) -> list[PredictedStep]:
    """Predict each step, conditioning its start on the previous step's end.

    Steps outside the training support raise :class:`Error` with ``strict``, and otherwise
    come with an :class:`OutOfSupportWarning` naming their distance to the data.
    """
    steps, end = [], None
    for spec, step in zip(specs, model.predict_many(specs)):
        if end is not None:
            step = step.conditioned_on(end)
        if not step.in_support:
            message = (
                f"{spec.name} is {step.distance * 1000:.0f} mm from the nearest training step of its type; "
                f"predicted joint-angle std up to {joint_std_max(model, step):.3f} rad"
            )
            if strict:
                raise Error(f"refused (--strict): {message}")
            warnings.warn(message, OutOfSupportWarning, stacklevel=2)
        steps.append(step)
        end = in_next_step_frame(model, spec, step.values[-1])
    return steps


def in_next_step_frame(model: MovementPrimitives, spec: StepSpec, end: np.ndarray) -> np.ndarray:
    """The signals ``end`` at the end of step ``spec``, in the frame of the step after it.

    Each step's signals are in its stance sole's frame; the next step stands on the sole
    that just landed, turned by the step's footstep, so only the pelvis yaw changes.
    """
    turn = spec.end_turn if spec.swing_side == "left" else -spec.end_turn
    if turn == 0.0:
        return end
    out = end.copy()
    out[model.signal_names.index("pelvis_yaw")] -= turn
    return out


def joint_std_max(model: MovementPrimitives, step: PredictedStep) -> float:
    """The largest predicted standard deviation of a joint angle over a step, rad."""
    return float(step.std[:, signal_groups(model.signal_names)["joints"]].max())
