"""How well a model's training steps cover the steps it may be asked for.

A step's distance is measured as the weight GPs measure it: in the model's inputs
(:func:`~cocomopl.primitives.training.step_lengths`, metres of step length), to the nearest
training step of its learned type, as :meth:`~cocomopl.primitives.estimator.MovementPrimitives.predict`
gives it as ``distance``.  Over steps drawn uniformly from the allowed step space, the largest
such distance estimates the training set's *fill distance*: no allowed step lies farther from
the training data.  A step is inside the support where its distance is at most its type's
``support_radius_`` (the training steps' largest nearest-neighbour spacing), the rule
``predict`` applies for ``in_support``.

A footstep model (six inputs) is measured over the allowed footsteps
(:func:`~cocomopl.dataset.design.allowed_footsteps`): a start step at each drawn footstep
(from rest), a stop from it, a cyclic step repeating it, and transitions between two of them
drawn independently.  A straight model (two inputs, the lengths) is measured over lengths
drawn uniformly within its trained length range.  Mirror images share their inputs and
training steps, so steps swing the left foot.

The draws are deterministic for a ``seed``.  Their random streams are derived from it and
differ from the ones a dataset design draws with any seed (``cocomopl dataset generate
--design-seed``: a scrambled Sobol sequence and farthest-point picks for ``maximin``,
:func:`~cocomopl.dataset.design.allowed_footsteps` for ``random``), so that the default seed
measures no design at its own footsteps.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from cocomopl.errors import Error
from cocomopl.motion import STEP_KINDS, Footstep, StepSpec
from cocomopl.primitives.estimator import SUPPORT_TOLERANCE
from cocomopl.primitives.training import FOOTSTEP_PARAMETERS, step_lengths, step_type

if TYPE_CHECKING:
    from cocomopl.primitives.estimator import MovementPrimitives
    from cocomopl.robot import Robot

DEFAULT_SAMPLES = 4000  # transitions (and, for a straight model, steps of each kind) drawn
DEFAULT_FOOTSTEPS = 200  # allowed footsteps drawn for a footstep model: checking each costs milliseconds
DEFAULT_SEED = 0
_STREAM = 0x0C0FE5  # mixed into the seed: the draws share no stream with a design's


@dataclass(frozen=True)
class KindCoverage:
    """Coverage of the steps of one kind.

    Attributes
    ----------
    kind : the step kind (``start``, ``cyclic``, ``transition``, ``stop``)
    steps : how many steps were measured
    fill_distance : the largest distance to the nearest training step, m
    p95, median : the 95th percentile and the median of those distances, m
    support_radius : the kind's support radius (its learned type's ``support_radius_``; the
        smallest of its parts' for a kind learned in parts), m
    in_support : the fraction of the steps inside the support, in [0, 1]
    """

    kind: str
    steps: int
    fill_distance: float
    p95: float
    median: float
    support_radius: float
    in_support: float

    def to_json(self) -> dict:
        return {"steps": self.steps, "fill_distance_m": self.fill_distance, "p95_m": self.p95,
                "median_m": self.median, "support_radius_m": self.support_radius, "in_support": self.in_support}


@dataclass(frozen=True)
class Coverage:
    """Coverage of a model's step space by its training steps (module docstring).

    Attributes
    ----------
    kinds : per step kind measured (those the model has learned), in :data:`~cocomopl.motion.STEP_KINDS` order
    parameters : the model's inputs per step: 2 (lengths) or 6 (footsteps)
    seed : the seed of the draws; None for steps given explicitly
    footsteps : the allowed footsteps drawn (a footstep model); None otherwise
    """

    kinds: tuple[KindCoverage, ...]
    parameters: int
    seed: int | None
    footsteps: int | None

    @property
    def fill_distance(self) -> float:
        """The largest distance over every kind, m."""
        return max(k.fill_distance for k in self.kinds)

    def kind(self, name: str) -> KindCoverage:
        """The coverage of the steps of kind ``name``.

        Raises
        ------
        Error
            If no step of that kind was measured.
        """
        for k in self.kinds:
            if k.kind == name:
                return k
        raise Error(f"no {name} steps were measured; measured: {', '.join(k.kind for k in self.kinds)}")

    def table_lines(self) -> list[str]:
        """The text ``model info`` shows: per kind, the distances (mm) and the share inside the support."""
        drawn = ("over the given steps" if self.seed is None else
                 f"over lengths drawn uniformly within the trained range, seed {self.seed}" if self.footsteps is None
                 else f"over {self.footsteps} allowed footsteps drawn uniformly, seed {self.seed}")
        lines = [f"coverage (distance to the nearest training step, in the model's inputs) {drawn}:",
                 f"  {'kind':<10} {'steps':>6} {'largest':>8} {'95%':>8} {'median':>8} {'radius':>8} {'in support':>10}"]
        for k in self.kinds:
            mm = [f"{1000 * x:.0f} mm" for x in (k.fill_distance, k.p95, k.median, k.support_radius)]
            lines.append(f"  {k.kind:<10} {k.steps:>6} {mm[0]:>8} {mm[1]:>8} {mm[2]:>8} {mm[3]:>8} "
                         f"{100 * k.in_support:>9.1f}%")
        return lines

    def to_json(self) -> dict:
        return {"parameters": self.parameters, "seed": self.seed, "footsteps": self.footsteps,
                "fill_distance_m": self.fill_distance, "kinds": {k.kind: k.to_json() for k in self.kinds}}


def coverage(model: MovementPrimitives, *, samples: int = DEFAULT_SAMPLES, footsteps: int = DEFAULT_FOOTSTEPS,
             seed: int = DEFAULT_SEED, robot: Robot | None = None,
             steps: Sequence[StepSpec] | None = None) -> Coverage:
    """Distances from allowed steps to the model's training steps, per step kind.

    Parameters
    ----------
    model : MovementPrimitives
        A fitted model.
    samples : int
        Transitions drawn; for a straight model, steps of each kind.
    footsteps : int
        Allowed footsteps drawn for a footstep model: one start, stop and cyclic step each, and
        the pool the transitions' two footsteps are drawn from.  Checking that a footstep is
        allowed (the feet's meshes) is what costs.
    seed : int
        Seed of the draws (its streams are not the ones a dataset design draws with).
    robot : Robot, optional
        Whose allowed footsteps (default: the robot the model's metadata names, else the
        default robot).  Not used for a straight model.
    steps : sequence of StepSpec, optional
        Measure these steps instead of drawing any (either swing side).

    Returns
    -------
    Coverage
        Per kind: the largest, 95th-percentile and median distance, the support radius and
        the fraction of steps inside it.

    Raises
    ------
    Error
        If ``samples`` or ``footsteps`` is not a positive whole number, ``steps`` is empty, a step has no learned
        type in the model, or a straight model is given a step that turns or side-steps.
    """
    for name, value in (("samples", samples), ("footsteps", footsteps)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise Error(f"coverage {name} must be a positive whole number, not {value!r}")
    parameters = int(model.lengths_.shape[-1])
    if steps is not None:
        if not steps:
            raise Error("coverage needs at least one step to measure")
        return Coverage(_measure(model, list(steps)), parameters, None, None)
    learned = [kind for kind in STEP_KINDS if model.trajectory_types(f"{kind}_left")]
    if parameters == FOOTSTEP_PARAMETERS:
        drawn = _footstep_steps(_robot(model, robot), footsteps, samples, seed, learned)
        return Coverage(_measure(model, drawn), parameters, seed, footsteps)
    return Coverage(_measure(model, _straight_steps(model, samples, seed, learned)), parameters, seed, None)


def _rng(seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng(_seed(seed, stream))


def _seed(seed: int, stream: int) -> int:
    """A seed for the draws' ``stream`` derived from ``seed`` and :data:`_STREAM`."""
    return int(np.random.SeedSequence((int(seed), _STREAM, stream)).generate_state(1)[0])


def _robot(model, robot):
    if robot is not None:
        return robot
    from cocomopl.primitives.model_file import model_robot

    return model_robot(model)


def _footstep_steps(robot, count: int, samples: int, seed: int, kinds: list[str]) -> list[StepSpec]:
    """A start, stop and cyclic step at each of ``count`` allowed footsteps, and ``samples``
    transitions between two different ones, each drawn uniformly from them: of ``kinds`` only."""
    from cocomopl.dataset.design import allowed_footsteps

    pool = [Footstep(*map(float, f)) for f in allowed_footsteps(robot, count, seed=_seed(seed, 0))]
    rest = Footstep(0.0)
    specs = [StepSpec.between(kind, *pair) for f in pool
             for kind, pair in (("start", (rest, f)), ("stop", (f, rest)), ("cyclic", (f, f))) if kind in kinds]
    if "transition" in kinds and len(pool) > 1:
        rng = _rng(seed, 1)
        start = rng.integers(len(pool), size=samples)
        end = rng.integers(len(pool) - 1, size=samples)
        end += end >= start  # uniform over the other footsteps
        specs += [StepSpec.between("transition", pool[a], pool[b]) for a, b in zip(start, end)]
    return specs


def _straight_steps(model, samples: int, seed: int, kinds: list[str]) -> list[StepSpec]:
    """``samples`` steps of each of ``kinds`` at lengths drawn uniformly within the model's trained range."""
    low, high = model.footstep_range()["length"]
    a, b = _rng(seed, 2).uniform(low, high, size=(2, samples))
    return [spec for x, y in zip(a.tolist(), b.tolist())
            for spec in (StepSpec("start", 0.0, x), StepSpec("stop", x, 0.0), StepSpec("cyclic", x, x),
                         StepSpec("transition", x, y)) if spec.kind in kinds]


def _measure(model, specs: list[StepSpec]) -> tuple[KindCoverage, ...]:
    """Per kind, the distances of ``specs`` to the nearest training step of their learned type.

    ``predict`` computes the same distance among everything else it predicts; at thousands of
    steps that costs seconds, so the nearest training step is found with a k-d tree
    (:class:`scipy.spatial.cKDTree`) over the same inputs, and ``in_support`` follows
    ``predict``'s rule.  A kind learned in parts takes its farthest part, as a joined
    :class:`~cocomopl.primitives.estimator.PredictedStep` does.
    """
    from scipy.spatial import cKDTree

    if not specs:
        raise Error("the model has none of the step kinds to measure")
    count = int(model.lengths_.shape[-1])
    index = {t: g for g, t in enumerate(model.types)}
    by_type: dict[str, list[int]] = {}
    for k, spec in enumerate(specs):
        by_type.setdefault(step_type(spec), []).append(k)
    distance, inside = np.empty(len(specs)), np.empty(len(specs), dtype=bool)
    radius: dict[str, float] = {}
    for name, rows in by_type.items():
        parts = model.trajectory_types(name)
        if not parts:
            spec = specs[rows[0]]
            raise Error(f"the model has no {spec.kind} steps swinging the {spec.swing_side} foot")
        z = np.array([step_lengths(specs[k], count) for k in rows])
        d, ok = np.zeros(len(rows)), np.ones(len(rows), dtype=bool)
        for part in parts:
            g = index[part]
            part_distance = cKDTree(model.lengths_[g][model.mask_[g] > 0]).query(z)[0]
            part_radius = float(model.support_radius_[g])
            d, ok = np.maximum(d, part_distance), ok & (part_distance <= part_radius + SUPPORT_TOLERANCE)
            kind = specs[rows[0]].kind
            radius[kind] = min(radius.get(kind, np.inf), part_radius)
        distance[rows], inside[rows] = d, ok
    kinds = np.array([spec.kind for spec in specs])
    out = []
    for kind in STEP_KINDS:
        mask = kinds == kind
        if mask.any():
            d = distance[mask]
            out.append(KindCoverage(kind, int(mask.sum()), float(d.max()), float(np.percentile(d, 95)),
                                    float(np.median(d)), radius[kind], float(inside[mask].mean())))
    return tuple(out)
