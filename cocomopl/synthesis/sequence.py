"""From a list of step lengths to a chain of predicted steps, each started where the last ended."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

from cocomopl.dataset.plan import length_mm_to_m
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.ocp.problems import OTHER
from cocomopl.primitives.model import MovementPrimitives, PredictedStep


class OutOfSupportWarning(UserWarning):
    """A step's parameters lie outside the training data's support: trust it less."""


def sequence_specs(lengths: Sequence[float], first_swing: str = "left") -> list[StepSpec]:
    """Step specs for step lengths (m): a start, then cyclic or transition steps, then a stop.

    The first length is the start step's, the last the stop's; in between, a step whose
    length equals the previous one is cyclic, otherwise a transition.  Feet alternate.  A
    stop starts in the gait of its own length, so the last two lengths must be equal (the
    paper's M_gen ends ...,150,150).
    """
    lengths = [float(x) for x in lengths]
    if len(lengths) < 2:
        raise Error(f"a walk needs at least two steps (a start and a stop), got {len(lengths)}")
    for x in lengths:
        if not math.isfinite(x) or x <= 0:
            raise Error(f"step length {x * 1000:g} mm must be a positive finite number")
    if lengths[-1] != lengths[-2]:
        # a stop step of length L starts in the gait of length L (the paper's S(L))
        a, b = (f"{1000 * x:g}" for x in lengths[-2:])
        raise Error(
            f"the stop step ({b} mm) must repeat the length before it ({a} mm): a stop starts where the "
            f"previous step ended; end the list with ...,{b},{b} or ...,{a},{a}"
        )
    specs = [StepSpec("start", 0.0, lengths[0], first_swing)]
    for previous, length in zip(lengths[:-2], lengths[1:-1]):
        kind = "cyclic" if length == previous else "transition"
        specs.append(StepSpec(kind, previous, length, OTHER[specs[-1].swing_side]))
    specs.append(StepSpec("stop", lengths[-1], 0.0, OTHER[specs[-1].swing_side]))
    return specs


def generate_steps(model: MovementPrimitives, specs: Sequence[StepSpec], strict: bool = False) -> list[PredictedStep]:
    """Predict each step, conditioning its start on the previous step's end.

    Steps outside the training support raise :class:`Error` with ``strict``, and otherwise
    come with an :class:`OutOfSupportWarning` naming their distance to the data.
    """
    steps, end = [], None
    for spec in specs:
        step = model.predict(spec, start=end)
        if not step.in_support:
            message = (
                f"{spec.name} is {step.distance * 1000:.0f} mm from the nearest training step of its type; "
                f"predicted joint-angle std up to {step.std[:, :30].max():.3f} rad"
            )
            if strict:
                raise Error(f"refused (--strict): {message}")
            warnings.warn(message, OutOfSupportWarning, stacklevel=2)
        steps.append(step)
        end = step.values[-1]
    return steps


def parse_sequence_mm(text: str) -> list[float]:
    """Step lengths of a walk from ``"150,150,250,...,150"`` (millimetres) to metres, in order."""
    items = [s.strip() for s in str(text).split(",")]
    if not any(items):
        raise Error("no step lengths given: expected e.g. --lengths-mm 150,150,250,150")
    out = [length_mm_to_m(item) for item in items]
    if len(out) < 2:
        raise Error(f"a walk needs at least two steps (a start and a stop), got {len(out)}")
    return out
