"""The currency of the pipeline: :class:`StepSpec` and :class:`Motion`."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
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
    meta : provenance: producer, solver statistics, versions
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

    @property
    def n(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def name(self) -> str:
        return "+".join(s.name for s in self.steps)

    def kept_samples(self) -> np.ndarray:
        """Indices of the samples without the pre-impact duplicates: a strictly increasing time grid."""
        keep = np.ones(self.n, dtype=bool)
        keep[self.impacts] = False
        return np.flatnonzero(keep)
