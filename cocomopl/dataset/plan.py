"""Which OCPs make a training set, and in what order they can be solved.

The paper's set for lengths ``L1 < ... < Ln``: a start, cyclic and stop step per length
and transitions between neighbouring lengths in both directions; 5 lengths give 23 OCPs,
6 give 28.  Extra transitions between lengths further apart can be added; by default the
two 100 mm changes of the paper's test walk M_gen, 150 <-> 250 and 250 <-> 350 mm, where the
default lengths include them: 32 OCPs (README, "Training set").
Cyclic steps come first: every other step starts or ends in a cyclic step's start state.
"""

from __future__ import annotations

import math

from cocomopl.errors import Error
from cocomopl.motion import StepSpec

# The paper's lengths, 150, 250, 300, 350 and 400 mm, and 200 mm in their one 100 mm gap: the
# primitives interpolate badly across it (README, "Training set").
DEFAULT_LENGTHS_M = (0.15, 0.20, 0.25, 0.30, 0.35, 0.40)
# M_gen's two 100 mm changes: the paper trained 150 <-> 250 (neighbours on its lengths); with
# 250 <-> 350 too, M_gen and the random walks stand better (README, "Training set")
DEFAULT_EXTRA_TRANSITIONS_M = ((0.15, 0.25), (0.25, 0.35))
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


def parse_transitions_mm(text: str, lengths: tuple[float, ...]) -> tuple[tuple[float, float], ...]:
    """Parse extra transitions such as ``150-250,250-350`` (mm) into pairs of lengths (m).

    Raises
    ------
    Error
        Unless every pair joins two different lengths of ``lengths``.
    """
    pairs = []
    for item in (s.strip() for s in str(text).split(",") if s.strip()):
        ends = item.split("-")
        if len(ends) != 2:
            raise Error(f"transition {item!r} is not two lengths in millimetres joined by '-', e.g. 150-250")
        try:
            a, b = (length_mm_to_m(end) for end in ends)
        except Error as exc:
            raise Error(f"transition {item!r}: {exc}") from None
        for end in (a, b):
            if end not in lengths:
                raise Error(f"transition {item!r}: {end * 1000:g} mm is not one of the training lengths")
        if a == b:
            raise Error(f"transition {item!r} joins a length to itself (that is a cyclic step)")
        pairs.append((min(a, b), max(a, b)))
    return tuple(sorted(set(pairs)))


def default_transitions(lengths: tuple[float, ...]) -> tuple[tuple[float, float], ...]:
    """The default extra transitions that join two of ``lengths``."""
    return tuple(pair for pair in DEFAULT_EXTRA_TRANSITIONS_M if set(pair) <= set(lengths))


def training_specs(lengths: tuple[float, ...], extra_transitions: tuple[tuple[float, float], ...] = ()) -> list[StepSpec]:
    """The right-support OCPs of a training set, cyclic steps first.

    Transitions join neighbouring ``lengths`` and each pair of ``extra_transitions``, both ways.
    """
    specs = [StepSpec("cyclic", L, L) for L in lengths]
    specs += [StepSpec("start", 0.0, L) for L in lengths]
    pairs = sorted(set(zip(lengths[:-1], lengths[1:])) | set(extra_transitions))
    for a, b in pairs:
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
