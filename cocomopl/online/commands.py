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
from pathlib import Path

from cocomopl.errors import Error, parse_finite
from cocomopl.motion import Footstep, StepSpec
from cocomopl.planning.goal import turn_step_out
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.validation import read_csv_table


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


COLUMNS = ("t_s", "forward_m_s", "sideways_m_s", "yaw_rate_deg_s")
MAX_COMMANDS = 1000  # a longer script is a mistake in the file, not a walk


def read_commands(path: str | Path) -> list[tuple[float, VelocityCommand]]:
    """The timed velocity commands of a command file: CSV with the header
    ``t_s,forward_m_s,sideways_m_s,yaw_rate_deg_s``, one command per row from its time on,
    times increasing from 0, the last a stop (0, 0, 0) so the walk ends standing.

    Raises
    ------
    Error
        One line naming the file, and the row where it applies.
    """
    table = read_csv_table(path, COLUMNS, what="command")
    if len(table) > MAX_COMMANDS:
        raise Error(f"{path}: {len(table)} commands is more than {MAX_COMMANDS}")
    out = []
    for row, cells in table:
        t, forward, sideways, yaw = (parse_finite(c, f"{path}: row {row}: {n}") for c, n in zip(cells, COLUMNS))
        if t < 0 or (out and t <= out[-1][0]):
            raise Error(f"{path}: row {row}: t_s {t:g} must be at least 0 and after the row before's")
        out.append((t, VelocityCommand(forward, sideways, math.radians(yaw))))
    if not out[-1][1].is_stop:
        raise Error(f"{path}: the last command must be a stop (0,0,0): a walk ends standing")
    return out


def check_commands(commands: list[tuple[float, VelocityCommand]], ranges: dict[str, tuple[float, float]]) -> None:
    """An :class:`Error` naming the first command (from 1) outside ``ranges`` (:func:`command_range`)."""
    for number, (t, command) in enumerate(commands, start=1):
        for name in ("forward", "sideways", "yaw_rate"):
            low, high = ranges[name]
            value = getattr(command, name)
            if not low - 1e-9 <= value <= high + 1e-9:
                unit, scale = ("deg/s", math.degrees(1)) if name == "yaw_rate" else ("m/s", 1.0)
                raise Error(f"command {number} (t = {t:g} s): {name} {value * scale:.3g} {unit} is outside "
                            f"{low * scale:.3g}..{high * scale:.3g} {unit}, what the model's footsteps allow")
