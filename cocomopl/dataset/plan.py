"""Which OCPs make a training set, and in what order they can be solved.

The paper's set for lengths ``L1 < ... < Ln``: a start, cyclic and stop step per length
and transitions between neighbouring lengths in both directions; 5 lengths give 23 OCPs,
6 give 28.  Extra transitions between lengths further apart can be added; by default the
two 100 mm changes of the paper's test walk M_gen, 150 <-> 250 and 250 <-> 350 mm, where the
default lengths include them: 32 OCPs (README, "Training set").
Cyclic steps come first: every other step starts or ends in a cyclic step's start state.

A set may hold footsteps (:class:`~cocomopl.motion.Footstep`: turning, side and backward
steps) in place of lengths: each gets the same start, cyclic and stop steps, and the
transitions join consecutive footsteps as given and the extra pairs.
"""

from __future__ import annotations

from cocomopl.motion import Footstep, StepSpec, as_footstep

# The paper's lengths, 150, 250, 300, 350 and 400 mm, and 200 mm in their one 100 mm gap: the
# primitives interpolate badly across it (README, "Training set").
DEFAULT_LENGTHS_M = (0.15, 0.20, 0.25, 0.30, 0.35, 0.40)
# M_gen's two 100 mm changes: the paper trained 150 <-> 250 (neighbours on its lengths); with
# 250 <-> 350 too, M_gen and the random walks stand better (README, "Training set")
DEFAULT_EXTRA_TRANSITIONS_M = ((0.15, 0.25), (0.25, 0.35))


def default_transitions(lengths: tuple[float, ...]) -> tuple[tuple[float, float], ...]:
    """The default extra transitions that join two of ``lengths``."""
    return tuple(pair for pair in DEFAULT_EXTRA_TRANSITIONS_M if set(pair) <= set(lengths))


def training_specs(lengths: tuple, extra_transitions: tuple = ()) -> list[StepSpec]:
    """The right-support OCPs of a training set, cyclic steps first.

    ``lengths``: step lengths (m) in increasing order, or footsteps.  Transitions join
    consecutive ones and each pair of ``extra_transitions``, both ways.
    """
    footsteps = [as_footstep(f) for f in lengths]
    rest = Footstep(0.0)
    specs = [StepSpec.between("cyclic", f, f) for f in footsteps]
    specs += [StepSpec.between("start", rest, f) for f in footsteps]
    pairs = list(zip(footsteps[:-1], footsteps[1:]))
    pairs += [(as_footstep(a), as_footstep(b)) for a, b in extra_transitions]
    for a, b in sorted(set(pairs)):
        specs += [StepSpec.between("transition", a, b), StepSpec.between("transition", b, a)]
    specs += [StepSpec.between("stop", f, rest) for f in footsteps]
    return specs


def successors(spec: StepSpec, specs: list[StepSpec]) -> list[StepSpec]:
    """The steps of ``specs`` that may follow ``spec`` (the other foot swings next)."""
    if spec.kind == "stop":
        return []
    return [
        s
        for s in specs
        if s.kind in ("cyclic", "transition", "stop") and s.start_footstep == spec.end_footstep
        and s.swing_side != spec.swing_side
    ]
