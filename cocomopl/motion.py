"""The currency of the pipeline: :class:`StepSpec` and :class:`Motion`."""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, field, fields, replace
from typing import NamedTuple

import numpy as np

STEP_KINDS = ("start", "cyclic", "transition", "stop")


class Footstep(NamedTuple):
    """Where a sole lands relative to the other sole (:class:`StepSpec` says how it is
    measured): ``length`` and ``width`` (m), ``turn`` (rad)."""

    length: float
    width: float = 0.0
    turn: float = 0.0

    @property
    def straight(self) -> bool:
        return self.width == 0.0 and self.turn == 0.0

    @property
    def gait_key(self) -> float | tuple[float, float, float]:
        """The key of the gait state ``S`` of this footstep: the length alone for a straight
        footstep, as the straight dataset keys its gait states; else the whole footstep."""
        return self.length if self.straight else tuple(self)

    @property
    def label(self) -> str:
        """``250`` (mm) for a straight footstep, ``200_w50_t15`` (mm, mm, degrees) otherwise."""
        length = f"{1000 * self.length:g}"
        return length if self.straight else f"{length}_w{1000 * self.width:g}_t{math.degrees(self.turn):.4g}"


def as_footstep(footstep: float | tuple) -> Footstep:
    """A footstep from a footstep, a (length, width, turn) triple or a step length (m; the
    straight footstep of that length: what :attr:`Footstep.gait_key` gives back)."""
    if isinstance(footstep, Footstep):
        return footstep
    return Footstep(*map(float, footstep)) if isinstance(footstep, tuple) else Footstep(float(footstep))


@dataclass(frozen=True)
class StepSpec:
    """One step: its kind, the footstep before and after it, and the swinging foot.

    Step length is the distance between the feet along the walking direction at double
    support.  A start step begins with the feet together (``start_length == 0``); a stop
    ends with them together (``end_length == 0``).

    A footstep is where a sole lands relative to the other sole, in that sole's frame, as
    (length, width, turn): ``length`` forward (m; negative is backward), ``width`` sideways
    beyond the robot's nominal foot separation (m; positive is outward, away from the other
    sole) and ``turn`` its yaw (rad; positive turns the toes outward, away from the other
    sole).  Width and turn are measured from the side of the sole that lands, so a mirrored
    step has the same numbers and turns and side-steps the other way.  The ``end_*`` footstep
    is where this step's swing sole lands; the ``start_*`` footstep is the one before, where
    the stance sole landed relative to the swing sole (the previous step's ``end_*``).  A
    straight step has zero width and turn, as every step before omnidirectional walking.
    """

    kind: str
    start_length: float
    end_length: float
    swing_side: str = "left"
    start_width: float = 0.0
    end_width: float = 0.0
    start_turn: float = 0.0
    end_turn: float = 0.0

    def __post_init__(self):
        if self.kind not in STEP_KINDS:
            raise ValueError(f"step kind must be one of {STEP_KINDS}, not {self.kind!r}")
        if self.swing_side not in ("left", "right"):
            raise ValueError(f"swing side must be 'left' or 'right', not {self.swing_side!r}")
        numbers = (self.start_length, self.end_length, *self.omni_parameters())
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in numbers):
            raise ValueError(f"step lengths, widths and turns must be finite numbers, not {numbers}")

    @property
    def name(self) -> str:
        """A stable, readable identifier such as ``transition_250_300_L``."""
        mm = [round(1000 * self.start_length), round(1000 * self.end_length)]
        side = "L" if self.swing_side == "left" else "R"
        if self.kind == "start":
            lengths = f"{mm[1]}"
        elif self.kind in ("cyclic", "stop"):
            lengths = f"{mm[0]}"
        else:
            lengths = f"{mm[0]}_{mm[1]}"
        return f"{self.kind}_{lengths}{self._omni_suffix()}_{side}"

    @classmethod
    def between(cls, kind: str, start: Footstep, end: Footstep, *, swing_side: str = "left") -> StepSpec:
        """The step of ``kind`` from footstep ``start`` to footstep ``end``."""
        return cls(kind, start.length, end.length, swing_side, start.width, end.width, start.turn, end.turn)

    @property
    def start_footstep(self) -> Footstep:
        return Footstep(self.start_length, self.start_width, self.start_turn)

    @property
    def end_footstep(self) -> Footstep:
        return Footstep(self.end_length, self.end_width, self.end_turn)

    @property
    def straight(self) -> bool:
        """Whether both footsteps are straight ahead at the nominal width."""
        return not any(self.omni_parameters())

    def omni_parameters(self) -> tuple[float, float, float, float]:
        """(start width, end width, start turn, end turn): what a straight step has as zeros."""
        return (self.start_width, self.end_width, self.start_turn, self.end_turn)

    def _omni_suffix(self) -> str:
        """``w<start>_<end>t<start>_<end>`` in mm and degrees, for a step that is not straight."""
        if self.straight:
            return ""
        widths = [round(1000 * w) for w in (self.start_width, self.end_width)]
        turns = [round(math.degrees(a), 1) for a in (self.start_turn, self.end_turn)]
        return f"_w{widths[0]}_{widths[1]}_t{turns[0]:g}_{turns[1]:g}"

    def as_dict(self) -> dict:
        """The step as plain data; a straight step without the omnidirectional fields, so that
        it is written exactly as before they existed."""
        out = asdict(self)
        if self.straight:
            for key in ("start_width", "end_width", "start_turn", "end_turn"):
                del out[key]
        return out

    def mirrored(self) -> StepSpec:
        return replace(self, swing_side="right" if self.swing_side == "left" else "left")


SAMPLED = ("q", "v", "tau", "wrenches", "contact", "zmp")  # a Motion's arrays with a row per sample, besides t
# s: a time this close to a knot or a phase edge is at it (float sums and linspace round, 0.4 s lands at 0.39999...)
TIME_TOLERANCE = 1e-9


class _Record:
    """Typed metadata that a motion file stores in its JSON attribute ``meta`` under the
    field names, in field order: a field with a default is stored only when it is not None."""

    def as_meta(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.default is MISSING or getattr(self, f.name) is not None}

    @classmethod
    def from_meta(cls, meta: dict):
        """The record of ``meta``'s keys, removed from it; None (``meta`` unchanged) unless
        it has every field without a default."""
        if not all(f.name in meta for f in fields(cls) if f.default is MISSING):
            return None
        return cls(**{f.name: meta.pop(f.name) for f in fields(cls) if f.name in meta})


@dataclass(frozen=True)
class PlanRecord(_Record):
    """How a generated walk was placed (:func:`cocomopl.synthesis.world.place_steps`).

    Attributes
    ----------
    dynamics_filter_zmp_error_m : RMS ZMP error (m) of each run of the dynamics filter
    dynamics_filter_kept_error_m : that of the run kept
    upper_body_limits : what the upper body's correction into its joint limits did
    plan_zmp_error_m : RMS error (m) of the placed walk's ZMP from the learned one
    model : file name of the model that generated the walk
    lengths_mm : the step lengths (mm) of a straight walk
    footsteps : the landings of a walk planned on footsteps or goals, as plain data
    """

    dynamics_filter_zmp_error_m: list
    dynamics_filter_kept_error_m: float
    upper_body_limits: dict
    plan_zmp_error_m: float
    model: str | None = None
    lengths_mm: list | None = None
    footsteps: list | None = None


@dataclass(frozen=True)
class SolutionRecord(_Record):
    """How an optimal-control motion was solved (:mod:`cocomopl.ocp`).

    Attributes
    ----------
    solver : the solver's statistics (iterations, cost, solve time, ...); a list of them,
        one per step, for a walk of chained or refined steps
    duration_search : the step durations tried before the one solved
    mirrored : whether the motion is the mirror image of one solved
    solved_now : the steps of a chained walk solved for it (the others came from a dataset)
    refined_from : the producer of the walk that the solution refines
    """

    solver: dict | list | None
    duration_search: list | None = None
    mirrored: bool | None = None
    solved_now: list | None = None
    refined_from: str | None = None


@dataclass(frozen=True)
class RolloutRecord(_Record):
    """How a measured motion was simulated (:func:`cocomopl.sim.rollout.simulate`).

    Attributes
    ----------
    reference_producer : the producer of the motion followed
    stabilizer : whether the stabilizer ran, and ``stabilizer_gains`` its gains
    reference_cutoff_hz : the reference's low-pass cutoff (Hz; 0 for none)
    feedforward : whether the reference's torques were fed forward
    fell : whether the robot fell, and ``fall_time_s`` when (s)
    timestep_s : the simulator's time step (s)
    sim_model : the MuJoCo model simulated
    contact_time_constant_s : the contacts' time constant (s)
    servos : the servo model's settings
    pushes : the pushes applied
    recoveries, reaimed : the replanner's changes of the walk, where one replanned
    """

    reference_producer: str
    stabilizer: bool
    stabilizer_gains: dict | None
    reference_cutoff_hz: float
    feedforward: bool
    fell: bool
    fall_time_s: float | None
    timestep_s: float
    sim_model: str | None
    contact_time_constant_s: float
    servos: dict | None
    pushes: list
    recoveries: list | None = None
    reaimed: list | None = None


_RECORDS = {"plan": PlanRecord, "solution": SolutionRecord, "simulation": RolloutRecord}


@dataclass
class Motion:
    """A whole-body motion, whoever produced it (OC, primitives, simulator, baseline).

    Samples are at knots ``t``; at a touchdown the same time appears twice (pre- and
    post-impact state) and ``impacts`` lists the pre-impact sample indices.  Torques and
    contact wrenches hold over ``[t[k], t[k+1])`` (zero-order hold; the last sample repeats
    the one before).  Everything is SI and in the motion's frame: for a single step, the
    stance sole's frame at the step's start (x forward, z up).

    Attributes
    ----------
    t : (n,) time, s
    q : (n, nq) configuration: base position, base quaternion (x, y, z, w), joint angles (rad)
    v : (n, nv) velocity: base twist in the base frame, joint velocities
    tau : (n, nu) joint torques, N m, in ``joint_names`` order
    wrenches : (n, 2, 6) contact wrench of (left, right) sole: force (N), moment (N m),
        world-aligned axes, about the sole frame origin; zero when the foot is in the air
    contact : (n, 2) bool, (left, right) sole in contact
    zmp : (n, 3) zero-moment point of the contact wrenches, m, on the ground
    phases : list of (kind, first, last) sample ranges, kind in ``ds``, ``ss``
    impacts : (m,) int, pre-impact sample indices
    steps : list of StepSpec, and ``step_starts`` the first sample of each
    joint_names, robot : the robot the motion is for
    meta : free-form provenance (a motion file stores it and the fields below as one JSON object)
    producer : what produced the motion: ``ocp``, ``primitives``, ``mujoco``, ``kajita``, ...
    plan : how a generated walk was placed, ``solution`` how an OC motion was solved,
        ``simulation`` how a measured motion was simulated; None where they do not apply
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    wrenches: np.ndarray
    contact: np.ndarray
    zmp: np.ndarray
    phases: list
    impacts: np.ndarray
    steps: list
    step_starts: np.ndarray
    joint_names: list
    robot: str
    meta: dict = field(default_factory=dict)
    producer: str | None = None
    plan: PlanRecord | None = None
    solution: SolutionRecord | None = None
    simulation: RolloutRecord | None = None

    @property
    def n(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def name(self) -> str:
        return "+".join(s.name for s in self.steps)

    def meta_json(self) -> dict:
        """The metadata as a motion file stores it: ``producer``, the records' fields and the
        free-form ``meta``, in that order."""
        out = {} if self.producer is None else {"producer": self.producer}
        for name in _RECORDS:
            record = getattr(self, name)
            if record is not None:
                out.update(record.as_meta())
        return {**out, **self.meta}

    @staticmethod
    def split_meta(meta: dict) -> dict:
        """The keyword arguments of :class:`Motion` of a motion file's metadata ``meta``
        (:meth:`meta_json`): its known keys as typed fields, the rest as ``meta``."""
        meta = dict(meta)
        out = {"producer": meta.pop("producer")} if isinstance(meta.get("producer"), str) else {}
        out.update((name, record.from_meta(meta)) for name, record in _RECORDS.items())
        return {**out, "meta": meta}

    def kept_samples(self) -> np.ndarray:
        """Indices of the samples without the pre-impact duplicates: a strictly increasing time grid."""
        keep = np.ones(self.n, dtype=bool)
        keep[self.impacts] = False
        return np.flatnonzero(keep)
