"""Training steps spread over the step space: every step the footstep range allows.

A step goes from a start footstep to an end footstep, each (length, width, turn), within
the robot's :func:`~cocomopl.gait.footstep_range` and passing :func:`~cocomopl.gait.check_footstep`.  A
design is a set of footsteps, each solved as a start, a cyclic and a stop step, and pairs of
them, each solved as a transition both ways.  Distances are measured as the weight GPs measure
them (:data:`~cocomopl.gait.FOOTSTEP_METRIC`): a footstep is a point in metres, a transition
the six coordinates of its two footsteps.

``maximin`` designs fill the space greedily (farthest-point sampling, within twice the best
possible largest gap): each footstep is the allowed candidate farthest from those already
picked, starting at a corner of the range, and each pair the one whose transitions lie farthest
from the transitions already picked.  The footsteps are ordered along a nearest-neighbour path,
the order continuation sweeps them in, and consecutive ones are joined too, so that each
footstep has a transition to its neighbour.  ``random`` designs draw footsteps uniformly over
the allowed range and pairs uniformly among them: the held-out sets the benchmarks measure on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cocomopl.errors import Error
from cocomopl.gait import FOOTSTEP_METRIC, check_footstep, footstep_range
from cocomopl.motion import Footstep, as_footstep
from cocomopl.robot import Robot

SAMPLINGS = ("maximin", "random")
DEFAULT_STEP_SPACE = (60, 80)  # footsteps, pairs: the bundled omnidirectional set
DEFAULT_STEP_SPACE_TEXT = "/".join(map(str, DEFAULT_STEP_SPACE))
CANDIDATES = 2048  # Sobol points a maximin design picks its footsteps from, by default
_GRID = 5  # and a grid of this many values per parameter, the range's bounds included


@dataclass(frozen=True)
class StepSpaceDesign:
    """Which OCPs a step-space set solves: ``footsteps`` (in continuation order) and the extra
    ``pairs`` of them whose transitions are solved both ways (consecutive footsteps are joined
    as well, :func:`~cocomopl.dataset.plan.training_specs`)."""

    footsteps: tuple[Footstep, ...]
    pairs: tuple[tuple[Footstep, Footstep], ...]
    sampling: str
    seed: int

    @property
    def record(self) -> dict:
        """How the design was made, as the dataset records it."""
        return {"design": {"sampling": self.sampling, "seed": self.seed, "footsteps": len(self.footsteps),
                           "pairs": len(self.pairs)}}


def rounded(footstep) -> Footstep:
    """``footstep`` to 1 mm and 0.1 degree, so that step names stay short and exact."""
    length, width, turn = footstep
    return Footstep(round(float(length), 3) + 0.0, round(float(width), 3) + 0.0,
                    math.radians(round(math.degrees(float(turn)), 1)) + 0.0)


def is_allowed(robot: Robot, footstep) -> bool:
    """Whether a sole may land at ``footstep`` (:func:`~cocomopl.gait.check_footstep`)."""
    try:
        check_footstep(robot, "left", tuple(float(x) for x in footstep))
    except Error:
        return False
    return True


def allowed_footsteps(robot: Robot, count: int, *, seed: int) -> np.ndarray:
    """``count`` footsteps (length, width, turn), drawn uniformly over the allowed range."""
    rng = np.random.default_rng(seed)
    low, high = _bounds(robot)
    out: list[np.ndarray] = []
    while len(out) < count:
        footstep = np.array(rounded(rng.uniform(low, high)))
        if is_allowed(robot, footstep):
            out.append(footstep)
    return np.array(out).reshape(-1, 3)


def _bounds(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """The low and high (length, width, turn) of the robot's footsteps (:func:`~cocomopl.gait.footstep_range`)."""
    limits = footstep_range(robot)
    return tuple(np.array([limits[key][i] for key in ("length", "width", "turn")]) for i in (0, 1))


def _candidates(robot: Robot, seed: int, count: int) -> np.ndarray:
    """Allowed footsteps to pick from: a scrambled Sobol sequence over the range and a grid
    that holds its bounds, where farthest-point sampling puts its first picks."""
    from scipy.stats import qmc

    low, high = _bounds(robot)
    grid = np.stack(np.meshgrid(*(np.linspace(lo, hi, _GRID) for lo, hi in zip(low, high)), indexing="ij"), -1)
    sobol = qmc.scale(qmc.Sobol(3, seed=seed).random(count), low, high)
    points = {rounded(p) for p in np.vstack([grid.reshape(-1, 3), sobol])}
    return np.array(sorted(p for p in points if is_allowed(robot, p)))


def farthest_points(points: np.ndarray, count: int, first: int) -> list[int]:
    """Indices of ``count`` of ``points`` (rows, in the design metric) picked greedily, each
    the farthest from those before it, starting at ``first``."""
    chosen = [first]
    gap = np.linalg.norm(points - points[first], axis=1)
    while len(chosen) < min(count, len(points)):
        chosen.append(int(np.argmax(gap)))
        gap = np.minimum(gap, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return chosen


def nearest_neighbour_path(footsteps) -> list[Footstep]:
    """``footsteps`` ordered along a greedy nearest-neighbour path in the design metric,
    starting from the least in (length, width, turn) order: straight lengths come out sorted."""
    remaining = sorted(as_footstep(f) for f in footsteps)
    if not remaining:
        return []
    path = [remaining.pop(0)]
    while remaining:
        here = np.array(path[-1]) * FOOTSTEP_METRIC
        nearest = min(range(len(remaining)), key=lambda i: float(np.linalg.norm(np.array(remaining[i]) * FOOTSTEP_METRIC - here)))
        path.append(remaining.pop(nearest))
    return path


def transition_points(pairs) -> np.ndarray:
    """Both transitions of each pair (a, b), a -> b and b -> a, as rows (start footstep, end
    footstep) in the design metric."""
    pairs = np.asarray(pairs, dtype=float).reshape(-1, 2, 3) * FOOTSTEP_METRIC
    return np.vstack([pairs.reshape(-1, 6), pairs[:, ::-1].reshape(-1, 6)])


def _maximin_pairs(footsteps: list[Footstep], count: int, joined: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """``count`` pairs of ``footsteps`` (indices) whose transitions, both ways, lie farthest
    from those of the pairs already ``joined`` and picked."""
    z = np.array(footsteps) * FOOTSTEP_METRIC
    candidates = [(i, j) for i in range(len(z)) for j in range(i + 1, len(z)) if (i, j) not in joined]
    there = np.array([np.concatenate([z[i], z[j]]) for i, j in candidates]).reshape(-1, 6)
    back = np.array([np.concatenate([z[j], z[i]]) for i, j in candidates]).reshape(-1, 6)

    def gap_to(points: np.ndarray) -> np.ndarray:
        # a transition's own reverse belongs to the same pair: either way counts
        return np.min([np.minimum(np.linalg.norm(there - p, axis=1), np.linalg.norm(back - p, axis=1))
                       for p in points], axis=0)

    gap = gap_to(transition_points([(footsteps[i], footsteps[j]) for i, j in joined])) if joined \
        else np.full(len(candidates), np.inf)
    picked: list[tuple[int, int]] = []
    while len(picked) < min(count, len(candidates)):
        k = int(np.argmax(gap)) if joined or picked else 0
        picked.append(candidates[k])
        gap = np.minimum(gap, gap_to(np.array([there[k], back[k]])))
    return picked


def step_space_design(robot: Robot, *, footsteps: int = DEFAULT_STEP_SPACE[0], pairs: int = DEFAULT_STEP_SPACE[1],
                      sampling: str = "maximin", seed: int = 0, candidates: int = CANDIDATES) -> StepSpaceDesign:
    """A design of ``footsteps`` footsteps and ``pairs`` extra pairs over the allowed range
    (module docstring); a maximin design picks its footsteps among ``candidates`` Sobol points
    (a power of 2) and the range's corners and edges.

    Raises
    ------
    Error
        On fewer than two footsteps, a negative number of pairs, or an unknown ``sampling``.
    """
    if sampling not in SAMPLINGS:
        raise Error(f"unknown sampling {sampling!r}: one of {', '.join(SAMPLINGS)}")
    if footsteps < 2 or pairs < 0:
        raise Error(f"a step-space design needs at least 2 footsteps and no negative number of pairs, got "
                    f"{footsteps}/{pairs}")
    if sampling == "maximin":
        pool = _candidates(robot, seed, candidates)
        z = pool * FOOTSTEP_METRIC
        chosen = [rounded(pool[i]) for i in farthest_points(z, footsteps, int(np.argmin(z.sum(axis=1))))]
    else:
        chosen = [rounded(f) for f in allowed_footsteps(robot, footsteps, seed=seed)]
    path = nearest_neighbour_path(dict.fromkeys(chosen))
    joined = [(i, i + 1) for i in range(len(path) - 1)]
    if sampling == "maximin":
        picked = _maximin_pairs(path, pairs, joined)
    else:
        rng = np.random.default_rng(seed + 1)
        everything = [(i, j) for i in range(len(path)) for j in range(i + 1, len(path)) if (i, j) not in joined]
        picked = [everything[k] for k in sorted(rng.choice(len(everything), size=min(pairs, len(everything)),
                                                           replace=False))]
    return StepSpaceDesign(tuple(path), tuple((path[i], path[j]) for i, j in picked), sampling, seed)


def parse_step_space(text: str) -> tuple[int, int]:
    """``"FOOTSTEPS/PAIRS"``, e.g. ``40/220``, to two counts."""
    parts = str(text).split("/")
    try:
        footsteps, pairs = (int(part) for part in parts)
    except ValueError:
        raise Error(f"step space {text!r} must be FOOTSTEPS/PAIRS, two whole numbers, e.g. "
                    f"{DEFAULT_STEP_SPACE_TEXT}") from None
    if footsteps < 2 or pairs < 0:
        raise Error(f"step space {text!r}: at least 2 footsteps and 0 or more pairs")
    return footsteps, pairs
