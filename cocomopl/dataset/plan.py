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

import itertools
import math

from cocomopl.errors import Error, parse_finite
from cocomopl.gait import check_footstep
from cocomopl.motion import Footstep, StepSpec, as_footstep
from cocomopl.planning.goal import steady_gait

# The paper's lengths, 150, 250, 300, 350 and 400 mm, and 200 mm in their one 100 mm gap: the
# primitives interpolate badly across it (README, "Training set").
DEFAULT_LENGTHS_M = (0.15, 0.20, 0.25, 0.30, 0.35, 0.40)
# M_gen's two 100 mm changes: the paper trained 150 <-> 250 (neighbours on its lengths); with
# 250 <-> 350 too, M_gen and the random walks stand better (README, "Training set")
DEFAULT_EXTRA_TRANSITIONS_M = ((0.15, 0.25), (0.25, 0.35))


# The steady gaits of a gait-grid set: every combination of a length (backward, in place,
# forward), a width (none, side steps) and a turn, so that the learned range, the box the
# footstep planner plans in, holds training steps at its corners.  Turns reach 25 degrees, the
# gaits stepping out beyond 12 (``planning.goal.turn_step_out``): 343 OCPs in about 30
# minutes on 2 cores (docs/method.md#omnidirectional-training-set).
DEFAULT_GAIT_GRID_TEXT = "-150,0,150,300,400/0,75,150/0,12,25"


def gait_footsteps(robot, grids) -> tuple[tuple[Footstep, ...], tuple[tuple[Footstep, Footstep], ...]]:
    """Footsteps and transitions for the steady gaits (length, width, turn) of one or more
    grids (each ``(lengths, widths, turns)``, :func:`parse_gait_grid`; the gaits are their
    union), as the footstep planner walks them (:mod:`cocomopl.planning.goal`): the leading
    foot steps (length, width + d, turn), the trailing one (length, d, -turn) (d:
    :func:`~cocomopl.planning.goal.turn_step_out`), and each gait's
    transitions join the two.

    Raises
    ------
    Error
        Naming the first gait whose footsteps are out of range or collide
        (:func:`~cocomopl.gait.check_footstep`).
    """
    footsteps, pairs = set(), set()
    gaits = dict.fromkeys(gait for grid in grids for gait in itertools.product(*grid))
    for length, width, turn in gaits:
        lead, trail = steady_gait(length, width, turn)
        for side, footstep in (("left", lead), ("right", trail)):
            try:
                check_footstep(robot, side, footstep)
            except Error as error:
                raise Error(f"gait ({length * 1000:g} mm, {width * 1000:g} mm, {math.degrees(turn):g} deg): {error}") from None
        footsteps |= {lead, trail}
        if lead != trail:
            pairs.add((lead, trail))
    return tuple(sorted(footsteps)), tuple(sorted(pairs))


def parse_gait_grid(text: str) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    """A gait grid from ``"LENGTHS_MM/WIDTHS_MM/TURNS_DEG"``, each a comma list, e.g.
    ``-150,0,150,300/0,100/0,12``, to metres and radians."""
    parts = str(text).split("/")
    if len(parts) != 3:
        raise Error(f"gait grid {text!r} must be LENGTHS_MM/WIDTHS_MM/TURNS_DEG, e.g. -150,0,150,300/0,100/0,12")
    out = []
    for part, name, scale in zip(parts, ("length", "width", "turn"), (1e-3, 1e-3, math.radians(1))):
        values = [parse_finite(item, f"gait {name}") * scale for item in part.split(",")]
        if len(set(values)) != len(values):
            raise Error(f"gait {name}s {part!r} repeat a value")
        out.append(tuple(sorted(values)))
    return tuple(out)


def default_lengths(robot) -> tuple[float, ...]:
    """The default training lengths for ``robot``: its description's ``defaults.training_lengths``,
    else TALOS's scaled by its leg length, to 10 mm."""
    given = robot.override("training_lengths")
    if given is not None:
        return tuple(sorted(dict.fromkeys(float(x) for x in given)))
    return tuple(dict.fromkeys(robot.scale.length_m(x) for x in DEFAULT_LENGTHS_M))


def default_transitions(lengths: tuple[float, ...], robot=None) -> tuple[tuple[float, float], ...]:
    """The default extra transitions (TALOS's scaled to ``robot`` as :func:`default_lengths`)
    that join two of ``lengths``."""
    scaled = DEFAULT_EXTRA_TRANSITIONS_M if robot is None else tuple(
        tuple(robot.scale.length_m(x) for x in pair) for pair in DEFAULT_EXTRA_TRANSITIONS_M)
    return tuple(pair for pair in scaled if set(pair) <= set(lengths))


def training_specs(lengths: tuple, extra_transitions: tuple = ()) -> list[StepSpec]:
    """The right-support OCPs of a training set, cyclic steps first.

    ``lengths``: step lengths (m) in increasing order, or footsteps.  Transitions join
    consecutive ones and each pair of ``extra_transitions``, both ways.
    """
    footsteps = [as_footstep(f) for f in lengths]
    rest = Footstep(0.0)
    specs = [StepSpec.between("cyclic", f, f) for f in footsteps]
    specs += [StepSpec.between("start", rest, f) for f in footsteps]
    pairs = list(itertools.pairwise(footsteps))
    pairs += [(as_footstep(a), as_footstep(b)) for a, b in extra_transitions]
    for a, b in sorted({tuple(sorted(pair)) for pair in pairs}):  # a pair given both ways is solved once
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
