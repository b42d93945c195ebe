"""A motion as one CSV table, for ROS and spreadsheet users: one row per control cycle.

Every column name ends with its unit.  The columns, in order:

* ``t_s``: time from the motion's start;
* ``<joint>_rad``: joint angles, in the robot's joint order;
* ``zmp_{x,y,z}_waist_m``: the reference ZMP in the waist (pelvis) frame;
* ``waist_{x,y,z}_m``, ``waist_{roll,pitch,yaw}_rad``: waist pose, world frame;
* ``<joint>_rad_s``: joint velocities;
* ``<joint>_Nm``: joint torques;
* ``{left,right}_f{x,y,z}_N``: contact force on each sole, world axes (zero in the air);
* ``{left,right}_m{x,y,z}_Nm``: contact moment on each sole about its origin, world axes;
* ``{left,right}_contact``: 1 where the sole is in contact, else 0;
* ``com_{x,y,z}_m``: the centre of mass, world frame;
* ``{left,right}_sole_{x,y,z}_m``, ``{left,right}_sole_{roll,pitch,yaw}_rad``: each sole
  frame's pose, world frame, its yaw unwrapped as the waist's.

The centre of mass and the soles are Pinocchio's forward kinematics of the row's waist pose
and joint angles: what a controller following the row would put where.

How each column is made from the motion is in :mod:`cocomopl.export.grid`;
:func:`read_csv` reads the table back, for the safety gate's own re-check.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.dynamics import SIDES
from cocomopl.export.grid import GridMotion, configurations
from cocomopl.robot import Robot

ANGLES = ("roll", "pitch", "yaw")


def body_poses(robot: Robot, grid: GridMotion) -> tuple[np.ndarray, np.ndarray]:
    """The centre of mass (n, 3) and the (left, right) sole frames' poses (n, 2, 6: x, y, z in
    m, roll, pitch, yaw in rad, the yaw unwrapped), world frame, at the grid's rows."""
    model, data = robot.model, robot.model.createData()
    q = configurations(robot, grid.waist, grid.waist_rpy, joints=grid.joints)
    com, soles = np.empty((len(q), 3)), np.empty((len(q), 2, 6))
    for k, qk in enumerate(q):
        com[k] = pin.centerOfMass(model, data, qk)  # also places the joints for the frames below
        pin.updateFramePlacements(model, data)
        for j, side in enumerate(SIDES):
            placement = data.oMf[robot.foot_frames[side]]
            soles[k, j] = [*placement.translation, *pin.rpy.matrixToRpy(placement.rotation)]
    soles[:, :, 5] = np.unwrap(soles[:, :, 5], axis=0)
    return com, soles


def columns(robot: Robot, grid: GridMotion) -> list[tuple[str, np.ndarray]]:
    """The table's columns in order, each as (name with unit, values)."""
    joint_names = robot.joint_names
    named = [("t_s", grid.t)]
    named += [(f"{j}_rad", grid.joints[:, i]) for i, j in enumerate(joint_names)]
    named += [(f"zmp_{a}_waist_m", grid.zmp[:, i]) for i, a in enumerate("xyz")]
    named += [(f"waist_{a}_m", grid.waist[:, i]) for i, a in enumerate("xyz")]
    named += [(f"waist_{a}_rad", grid.waist_rpy[:, i]) for i, a in enumerate(ANGLES)]
    # new columns go last, so readers indexing the columns above keep working
    named += [(f"{j}_rad_s", grid.velocities[:, i]) for i, j in enumerate(joint_names)]
    named += [(f"{j}_Nm", grid.torques[:, i]) for i, j in enumerate(joint_names)]
    named += [(f"{side}_f{a}_N", grid.forces[:, s, i]) for s, side in enumerate(SIDES) for i, a in enumerate("xyz")]
    named += [(f"{side}_m{a}_Nm", grid.moments[:, s, i]) for s, side in enumerate(SIDES) for i, a in enumerate("xyz")]
    named += [(f"{side}_contact", grid.contact[:, s]) for s, side in enumerate(SIDES)]
    com, soles = body_poses(robot, grid)
    named += [(f"com_{a}_m", com[:, i]) for i, a in enumerate("xyz")]
    named += [(f"{side}_sole_{a}", soles[:, s, i]) for s, side in enumerate(SIDES)
              for i, a in enumerate([f"{x}_m" for x in "xyz"] + [f"{x}_rad" for x in ANGLES])]
    return named


def number_text(value: float) -> str:
    return f"{value:.6f}"


def csv_text(robot: Robot, grid: GridMotion) -> str:
    """The CSV file of ``robot``'s motion ``grid``: a header line of column names, then one
    line per grid time."""
    named = columns(robot, grid)
    table = np.column_stack([values for _, values in named])
    rows = (",".join(map(number_text, row)) for row in table)
    return ",".join(name for name, _ in named) + "\n" + "\n".join(rows) + "\n"


def read_csv(text: str, joint_names: list[str]) -> GridMotion:
    """The :class:`GridMotion` of a table written by :func:`csv_text` for ``joint_names``."""
    header, *rows = text.strip("\n").split("\n")
    names = header.split(",")
    table = np.array([[float(x) for x in row.split(",")] for row in rows]).reshape(len(rows), len(names))
    column = {name: table[:, i] for i, name in enumerate(names)}

    def stack(names: list[str]) -> np.ndarray:
        return np.column_stack([column[n] for n in names])

    def per_sole(unit: str, axes: str = "xyz") -> np.ndarray:
        return np.stack([stack([f"{side}_{unit.format(a)}" for a in axes]) for side in SIDES], axis=1)

    return GridMotion(
        t=column["t_s"],
        joints=stack([f"{j}_rad" for j in joint_names]),
        velocities=stack([f"{j}_rad_s" for j in joint_names]),
        torques=stack([f"{j}_Nm" for j in joint_names]),
        forces=per_sole("f{}_N"),
        moments=per_sole("m{}_Nm"),
        contact=stack([f"{side}_contact" for side in SIDES]),
        waist=stack([f"waist_{a}_m" for a in "xyz"]),
        waist_rpy=stack([f"waist_{a}_rad" for a in ANGLES]),
        zmp=stack([f"zmp_{a}_waist_m" for a in "xyz"]),
    )
