"""Footstep plans: where each sole lands, in the world, turned into the steps that walk there.

A plan is a list of landings ``(x, y, yaw, side)``, world frame (x forward, z up, metres
and radians), starting from the soles side by side at the origin facing +x, the feet's
midpoint at (0, 0).  Sides alternate.  After the last landing the other foot closes up
beside it, as the learned stop steps do; a stop repeats the footstep of the step before
it (the straight walks' lengths end ..., L, L for the same reason), so the last two
landings must be the same footstep relative to the sole they were taken from.

Footstep files are CSV with the header ``x_m,y_m,yaw_deg,side`` and one landing per row.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from cocomopl.errors import Error, parse_finite
from cocomopl.gait import (
    OTHER_SIDE,
    check_footstep,
    foot_separation,
    footsteps,
    initial_soles,
    mean_yaw,
    wrap_angle,
)
from cocomopl.motion import Footstep, StepSpec
from cocomopl.robot import Robot
from cocomopl.validation import read_csv_table

COLUMNS = ("x_m", "y_m", "yaw_deg", "side")
MAX_LANDINGS = 200  # a longer plan is a mistake in the file, not a walk
# footsteps closer than this (m, and rad) are the same: files give millimetres and tenths of degrees
SAME_LENGTH_M = 5e-4
SAME_TURN_RAD = math.radians(0.05)


class Landing(NamedTuple):
    """Where sole ``side`` lands: (x, y) in m and ``yaw`` in rad, world frame."""

    x: float
    y: float
    yaw: float
    side: str

    def as_dict(self) -> dict:
        return {"x_m": self.x, "y_m": self.y, "yaw_deg": math.degrees(self.yaw), "side": self.side}


def relative_footstep(robot: Robot, other: np.ndarray, landed: np.ndarray, *, side: str) -> Footstep:
    """The footstep (length, width, turn) that puts sole ``side`` at pose ``landed`` from the
    other sole at pose ``other`` (:func:`cocomopl.gait.footstep_pose` inverted for the footstep)."""
    sign = 1.0 if side == "left" else -1.0
    c, s = math.cos(other[2]), math.sin(other[2])
    dx, dy = landed[0] - other[0], landed[1] - other[1]
    forward, sideways = c * dx + s * dy, -s * dx + c * dy
    return Footstep(float(forward), float(sign * sideways - foot_separation(robot)), float(sign * wrap_angle(landed[2] - other[2])))


def same_footstep(a: Footstep, b: Footstep) -> bool:
    return abs(a.length - b.length) < SAME_LENGTH_M and abs(a.width - b.width) < SAME_LENGTH_M and abs(a.turn - b.turn) < SAME_TURN_RAD


def _snapped(footstep: Footstep) -> Footstep:
    """Float noise of the world-to-relative round trip removed (to 1 um and 1 urad), so a
    straight footstep is exactly straight."""
    return Footstep(*(round(v, 6) + 0.0 for v in footstep))


def landing_footsteps(robot: Robot, landings: Sequence[Landing]) -> list[Footstep]:
    """Each landing's footstep from the sole it was taken from.

    Raises
    ------
    Error
        For sides that do not alternate, fewer than two landings, or a footstep out of the
        robot's range or colliding (:func:`cocomopl.gait.check_footstep`), naming the row.
    """
    if len(landings) < 2:
        raise Error(f"a walk needs at least two landings (a start and a stop), got {len(landings)}")
    if len(landings) > MAX_LANDINGS:
        raise Error(f"{len(landings)} landings is more than {MAX_LANDINGS}")
    soles = initial_soles(robot)
    out = []
    for k, landing in enumerate(landings, start=1):
        if k > 1 and landing.side == landings[k - 2].side:
            raise Error(f"landing {k}: the {landing.side} foot lands twice in a row (sides must alternate)")
        pose = np.array([landing.x, landing.y, landing.yaw])
        footstep = _snapped(relative_footstep(robot, soles[OTHER_SIDE[landing.side]], pose, side=landing.side))
        try:
            check_footstep(robot, landing.side, footstep)
        except Error as error:
            raise Error(f"landing {k} ({landing.side} at {landing.x:g}, {landing.y:g} m, {math.degrees(landing.yaw):g} deg): {error}") from None
        soles[landing.side] = pose
        out.append(footstep)
    if not same_footstep(out[-1], out[-2]):
        raise Error(
            f"the last landing must repeat the footstep of the one before it ({out[-2].label} vs {out[-1].label}): "
            "a stop starts where the previous step ended, then the other foot closes up beside it"
        )
    return out


def walk_specs(robot: Robot, landings: Sequence[Landing]) -> list[StepSpec]:
    """The steps (start, cyclic or transition, stop) that make the landings, then close up."""
    footsteps = landing_footsteps(robot, landings)
    return footstep_specs(footsteps[:-1], landings[0].side)


def footstep_specs(footsteps: Sequence[Footstep], first_side: str) -> list[StepSpec]:
    """The steps of a walk whose feet, alternating from ``first_side``, land at ``footsteps``,
    then once more at the last of them (the stop's landing), then close up."""
    side = first_side
    specs = [StepSpec.between("start", Footstep(0.0), footsteps[0], swing_side=side)]
    for previous, footstep in itertools.pairwise(footsteps):
        side = OTHER_SIDE[side]
        kind = "cyclic" if same_footstep(previous, footstep) else "transition"
        specs.append(StepSpec.between(kind, previous, previous if kind == "cyclic" else footstep, swing_side=side))
    specs.append(StepSpec.between("stop", specs[-1].end_footstep, Footstep(0.0), swing_side=OTHER_SIDE[side]))
    return specs


def read_landings(path: str | Path) -> list[Landing]:
    """The landings of a footstep CSV file (``x_m,y_m,yaw_deg,side``; :mod:`this module <cocomopl.planning.footsteps>`).

    Raises
    ------
    Error
        One line naming the file, and the row where it applies: missing or unreadable file,
        another header, a missing or extra value, a value that is not a finite number, a side
        other than left or right.
    """
    out = []
    for row, cells in read_csv_table(path, COLUMNS, what="footstep"):
        x, y, yaw = (parse_finite(text, f"{path}: row {row}: {column}") for text, column in zip(cells[:3], COLUMNS))
        if cells[3] not in OTHER_SIDE:
            raise Error(f"{path}: row {row}: side {cells[3]!r} is not left or right")
        out.append(Landing(x, y, math.radians(yaw), cells[3]))
    return out


def write_landings(path: str | Path, landings: Sequence[Landing]) -> None:
    """A footstep CSV file that :func:`read_landings` reads back (millimetre and millidegree precision)."""
    lines = [",".join(COLUMNS)] + [f"{p.x:.6f},{p.y:.6f},{math.degrees(p.yaw):.6f},{p.side}" for p in landings]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def soles_after(robot: Robot, specs: Sequence[StepSpec]) -> dict[str, np.ndarray]:
    """The soles' poses (x, y, yaw) at the end of the walk ``specs``."""
    end = footsteps(robot, list(specs))[-1]
    return {side: np.array([*end["end"][side][:2], end["yaw"]["end"][side]]) for side in OTHER_SIDE}


def midpoint(soles: dict[str, np.ndarray]) -> np.ndarray:
    """The feet's midpoint and mean heading (x, y, yaw) of two sole poses."""
    left, right = soles["left"], soles["right"]
    return np.array([(left[0] + right[0]) / 2, (left[1] + right[1]) / 2, wrap_angle(mean_yaw(left[2], right[2]))])


def landings_of(robot: Robot, specs: Sequence[StepSpec]) -> list[Landing]:
    """The world landings that walk ``specs`` makes, its stop's closing step left out."""
    out = []
    for spec, feet in zip(specs, footsteps(robot, list(specs))):
        side = spec.swing_side
        out.append(Landing(*(float(v) for v in feet["end"][side][:2]), feet["yaw"]["end"][side], side))
    return out
