"""Which OCPs make a training set, and in what order they can be solved.

The paper's set for lengths ``L1 < ... < Ln``: a start, cyclic and stop step per length
and transitions between neighbouring lengths in both directions; 5 lengths give 23 OCPs,
6 give 28.
Cyclic steps come first: every other step starts or ends in a cyclic step's start state.
"""

from __future__ import annotations

import math

from cocomopl.errors import Error
from cocomopl.motion import StepSpec

# The paper's lengths, 150, 250, 300, 350 and 400 mm, and 200 mm in their one 100 mm gap: the
# primitives interpolate badly across it (README, "Training set").
DEFAULT_LENGTHS_M = (0.15, 0.20, 0.25, 0.30, 0.35, 0.40)
MAX_LENGTH_M = 0.80  # beyond any human-sized humanoid's stride; the IK rejects earlier


def length_mm_to_m(item: str) -> float:
    """One step length given in millimetres, in metres; an :class:`Error` unless a positive number within reach."""
    try:
        value = float(item)
    except ValueError:
        raise Error(f"step length {item!r} is not a number (millimetres expected)") from None
    if not math.isfinite(value) or value <= 0:
        raise Error(f"step length {item!r} mm must be a positive finite number")
    if value / 1000 > MAX_LENGTH_M:
        raise Error(f"step length {value:g} mm is beyond reach (at most {MAX_LENGTH_M * 1000:g} mm)")
    return round(value / 1000, 6)


def parse_lengths_mm(text: str) -> tuple[float, ...]:
    """Parse a comma-separated list of step lengths in millimetres into metres.

    Raises
    ------
    Error
        On anything but a list of distinct positive numbers.
    """
    items = [s.strip() for s in str(text).split(",") if s.strip()]
    if not items:
        raise Error("no step lengths given: expected e.g. --lengths-mm 150,250,300")
    lengths = [length_mm_to_m(item) for item in items]
    if len(set(lengths)) != len(lengths):
        raise Error("step lengths must be distinct")
    return tuple(sorted(lengths))


def training_specs(lengths: tuple[float, ...]) -> list[StepSpec]:
    """The right-support OCPs of a training set, cyclic steps first."""
    specs = [StepSpec("cyclic", L, L) for L in lengths]
    specs += [StepSpec("start", 0.0, L) for L in lengths]
    for a, b in zip(lengths[:-1], lengths[1:]):
        specs += [StepSpec("transition", a, b), StepSpec("transition", b, a)]
    specs += [StepSpec("stop", L, 0.0) for L in lengths]
    return specs


def successors(spec: StepSpec, specs: list[StepSpec]) -> list[StepSpec]:
    """The steps of ``specs`` that may follow ``spec`` (the other foot swings next)."""
    if spec.kind == "stop":
        return []
    length = spec.end_length
    return [
        s
        for s in specs
        if s.kind in ("cyclic", "transition", "stop") and s.start_length == length and s.swing_side != spec.swing_side
    ]
