"""Velocity commands, as a joystick gives them, and the footsteps that walk them.

A command asks for the walk's speed in the frame of the feet: ``forward`` and ``sideways``
(m/s, positive left) and ``yaw_rate`` (rad/s, positive counter-clockwise).  Each step then
lasts the model's step period (:func:`step_period`), so one step advances ``forward *
period``, turns ``yaw_rate * period``, and every pair of steps moves ``sideways * 2 *
period`` to the side, always by the foot on that side stepping outward, as the goal planner's
steady gaits do (:func:`cocomopl.planning.goal.steady_gait`).  A command beyond what the
model's footsteps allow is saturated to the nearest footstep that they do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cocomopl.errors import Error
from cocomopl.motion import Footstep, StepSpec
from cocomopl.planning.goal import turn_step_out
from cocomopl.primitives.estimator import MovementPrimitives


@dataclass(frozen=True)
class VelocityCommand:
    """The walk's velocity in the frame of the feet.

    Attributes
    ----------
    forward : m/s, negative walks backwards
    sideways : m/s, positive to the left
    yaw_rate : rad/s, positive counter-clockwise
    """

    forward: float = 0.0
    sideways: float = 0.0
    yaw_rate: float = 0.0

    def __post_init__(self):
        for name in ("forward", "sideways", "yaw_rate"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)):
                raise Error(f"velocity command {name} must be a finite number, not {value!r}")

    @property
    def is_stop(self) -> bool:
        """Whether the command asks the robot to stand (every component zero)."""
        return self.forward == 0.0 and self.sideways == 0.0 and self.yaw_rate == 0.0


STOP = VelocityCommand()


def step_period(model: MovementPrimitives) -> float:
    """The duration (s) of the model's cyclic step in place, which a velocity command's
    footsteps are sized by (the bundled step-space models: TALOS 0.95 s, G1 0.55 s)."""
    spec = StepSpec.between("cyclic", Footstep(0.0), Footstep(0.0))
    return model.predict(spec).duration


def command_footstep(command: VelocityCommand, swing_side: str, *, period: float,
                     limits: dict[str, tuple[float, float]]) -> Footstep:
    """The footstep of foot ``swing_side`` that walks ``command`` for one step of ``period``
    seconds, within the footstep ``limits`` (``MovementPrimitives.footstep_range``)."""
    sign = 1.0 if swing_side == "left" else -1.0
    length = _clip(command.forward * period, limits["length"])
    turn = _clip(command.yaw_rate * period, limits["turn"], symmetric=True)
    width = _clip(max(sign * command.sideways * 2.0 * period, 0.0) + turn_step_out(turn), limits["width"])
    return Footstep(length, width, sign * turn + 0.0)


def command_range(*, period: float, limits: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """(low, high) of each velocity command component that moves the footsteps, per
    :func:`command_footstep`: ``forward`` and ``sideways`` (m/s), ``yaw_rate`` (rad/s)."""
    turn = min(-limits["turn"][0], limits["turn"][1])
    side = (limits["width"][1] - turn_step_out(0.0)) / (2.0 * period)
    return {"forward": (limits["length"][0] / period, limits["length"][1] / period),
            "sideways": (-side, side), "yaw_rate": (-turn / period, turn / period)}


def _clip(value: float, bounds: tuple[float, float], symmetric: bool = False) -> float:
    low, high = bounds
    if symmetric:  # both feet take the turn, one toeing out and one in
        high = min(-low, high)
        low = -high
    return min(max(value, low), high)
