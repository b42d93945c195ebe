"""Recovery by stepping: a push the ankles cannot absorb moves the swing foot's landing.

The stabilizer's DCM feedback (:mod:`cocomopl.sim.stabilizer`) moves the centre of pressure
within the stance sole.  The error ``e`` of the measured DCM ``ξ = c + ċ/ω`` against the
reference's grows as ``ė = ω (e - Δp)`` for a centre of pressure moved by ``Δp`` from the
reference's ZMP; once the reference's ZMP moved by ``e`` lies outside the stance sole, no
centre of pressure under it can even hold the error, and the swing foot must land elsewhere.
So, during a step's single support, :meth:`StepRecovery.check` tests that point against the
stance sole (its measured pose and the robot's sole dimensions).  When it is outside, the
error is carried to the planned touchdown, ``e exp(ω T)`` for the time ``T`` left, and the
landing moves by that much, within the footstep range the model learned.  Every later
landing moves with it, so only that step's footstep changes.  The primitives then generate
the changed walk (the steps before it are generated as before: each is conditioned only on
those before it) and the rollout follows the new reference from that moment
(:func:`cocomopl.sim.rollout.simulate`; a :class:`~cocomopl.sim.hooks.Replanner`).

One change per step, at most ``LATEST`` of the way through its single support (a later one
leaves the swing foot no time to get there), and not in the last two landings: a stop
repeats the footstep before it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from time import perf_counter
from typing import TYPE_CHECKING

import numpy as np

from cocomopl.errors import Error
from cocomopl.gait import OTHER_SIDE, foot_separation, footstep_pose, initial_soles
from cocomopl.motion import Motion
from cocomopl.planning.footsteps import Landing, relative_footstep
from cocomopl.robot import Robot
from cocomopl.sim.hooks import Step

if TYPE_CHECKING:
    from cocomopl.sim.stabilizer import Stabilizer

LATEST = 0.6  # fraction of a single support after which its landing is not moved


@dataclass
class Replanned:
    """One change of plan: when (s from the walk's start), which landing, by how much (m)."""

    time_s: float
    landing: int
    shift_m: tuple[float, float]
    generation_s: float  # wall time of generating and placing the changed walk

    def as_dict(self) -> dict:
        return {"time_s": self.time_s, "landing": self.landing, "shift_m": [float(v) for v in self.shift_m],
                "generation_s": self.generation_s}


@dataclass
class StepRecovery:
    """Moves landings of a walk on footsteps when a push carries its capture point off the
    stance sole, and has the walk generated again: a rollout's
    :class:`~cocomopl.sim.hooks.Replanner`, which needs the stabilizer's DCM error.

    Parameters
    ----------
    robot : the walking robot
    landings : the walk's world landings (:mod:`cocomopl.planning.footsteps`)
    motion : the walk being played, generated on ``landings``
    generate : footsteps to a placed walk (the primitives and the placement of the pipeline)
    footstep_range : (low, high) of ``length`` and ``width`` (m) a moved footstep may take
    """

    robot: Robot
    landings: list[Landing]
    motion: Motion
    generate: Callable[[Sequence[Landing]], Motion]
    footstep_range: dict[str, tuple[float, float]]
    replanned: list[Replanned] = field(default_factory=list)

    def __post_init__(self):
        if len(self.motion.steps) != len(self.landings):
            raise Error(f"recovery needs the walk's landings: {len(self.landings)} for {len(self.motion.steps)} steps")
        self.landings = list(self.landings)
        self._moved: set[int] = set()
        self._stabilizer: Stabilizer | None = None

    def start(self, stabilizer: Stabilizer | None) -> None:
        if stabilizer is None:
            raise Error("recovery by stepping needs the stabilizer")
        self._stabilizer = stabilizer

    def replan(self, step: Step) -> Motion | None:
        """The walk generated again if the reference stands on one sole and the stabilizer's
        DCM error has outgrown it (:meth:`check`); else None."""
        control = self._stabilizer
        stance = control.stance(step.elapsed)
        if stance is None:
            return None
        x, y, yaw = step.soles()[stance]
        return self.check(step.elapsed, control.dcm_error, omega=control.omega, stance_sole=(np.array([x, y]), float(yaw)))

    def metadata(self) -> dict[str, list[dict]]:
        return {"recoveries": [change.as_dict() for change in self.replanned]}

    def check(self, time: float, error: np.ndarray, *, omega: float, stance_sole: tuple[np.ndarray, float]) -> Motion | None:
        """The walk generated again with a landing moved, or None if nothing needs to change.

        ``time``: s from the walk's start; ``error``: the measured DCM minus the reference's
        (world x, y, m); ``omega``: the pendulum's natural frequency (1/s); ``stance_sole``:
        the measured (x, y) and yaw of the sole the reference stands on.
        """
        swing = self._swing_at(time)
        # the error stops growing only with the centre of pressure moved by as much
        if swing is None or _inside(self.robot, self._reference_zmp(time) + error, stance_sole):
            return None
        step, touchdown = swing
        self._moved.add(step)
        landings = self._moved_landings(step, np.asarray(error) * math.exp(omega * (touchdown - time)))
        if landings is None:
            return None
        started = perf_counter()
        try:
            motion = self.generate(landings)
        except Error:  # a footstep the plan's checks refuse (the feet too close): no move
            return None
        old, moved = self.landings[step], landings[step]
        self.replanned.append(Replanned(time, step, (moved.x - old.x, moved.y - old.y), perf_counter() - started))
        self.landings, self.motion = landings, motion
        return motion

    def _reference_zmp(self, time: float) -> np.ndarray:
        t = self.motion.t - self.motion.t[0]
        k = int(np.clip(np.searchsorted(t, time, side="right") - 1, 0, len(t) - 1))
        return self.motion.zmp[k, :2]

    def _swing_at(self, time: float) -> tuple[int, float] | None:
        """The step whose single support is under way at ``time`` and may still be changed,
        and the time (s) of its touchdown."""
        t = self.motion.t - self.motion.t[0]
        for kind, first, last in self.motion.phases:
            if kind != "ss" or not t[first] <= time < t[last]:
                continue
            step = int(np.searchsorted(self.motion.step_starts, first, side="right") - 1)
            late = (time - t[first]) > LATEST * (t[last] - t[first])
            if step in self._moved or late or step > len(self.landings) - 3:
                return None
            return step, float(t[last])
        return None

    def _moved_landings(self, step: int, shift: np.ndarray) -> list[Landing] | None:
        """The landings with ``step``'s moved by ``shift`` as far as the footstep range allows,
        and every later one moved with it; None if no move is possible."""
        old = self.landings[step]
        side = old.side
        stance = self._stance_pose(step)
        wanted = np.array([old.x + shift[0], old.y + shift[1], old.yaw])
        footstep = relative_footstep(self.robot, stance, wanted, side=side)
        length = float(np.clip(footstep.length, *self.footstep_range["length"]))
        width = float(np.clip(footstep.width, *self.footstep_range["width"]))
        landed = footstep_pose(stance, side, (length, width, footstep.turn), separation=foot_separation(self.robot))
        dx, dy = landed[0] - old.x, landed[1] - old.y
        if math.hypot(dx, dy) < 1e-3:
            return None
        return [*self.landings[:step], *(Landing(x.x + dx, x.y + dy, x.yaw, x.side) for x in self.landings[step:])]

    def _stance_pose(self, step: int) -> np.ndarray:
        """(x, y, yaw) of the sole the step swings from: the landing before, or the initial sole."""
        side = OTHER_SIDE[self.landings[step].side]
        before = [x for x in self.landings[:step] if x.side == side]
        if before:
            return np.array([before[-1].x, before[-1].y, before[-1].yaw])
        return np.array(initial_soles(self.robot)[side])


def _inside(robot: Robot, point: np.ndarray, sole: tuple[np.ndarray, float]) -> bool:
    """Whether ``point`` (x, y) lies on the sole at ``sole`` = ((x, y), yaw)."""
    (x, y), yaw = sole
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = point[0] - x, point[1] - y
    forward, sideways = c * dx + s * dy, -s * dx + c * dy
    return -robot.sole.back <= forward <= robot.sole.front and abs(sideways) <= robot.sole.half_width


__all__ = ["LATEST", "Replanned", "StepRecovery"]
