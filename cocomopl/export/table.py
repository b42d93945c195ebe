"""A motion as one CSV table, for ROS and spreadsheet users: one row per control cycle.

Every column name ends with its unit.  The columns, in order:

* ``t_s``: time from the motion's start;
* ``<joint>_rad``: joint angles, in the robot's joint order;
* ``zmp_{x,y,z}_waist_m``: the reference ZMP in the waist (pelvis) frame;
* ``waist_{x,y,z}_m``, ``waist_{roll,pitch,yaw}_rad``: waist pose, world frame;
* ``<joint>_rad_s``: joint velocities;
* ``<joint>_Nm``: joint torques;
* ``{left,right}_f{x,y,z}_N``: contact force on each sole, world axes (zero in the air).

Angles, velocities, waist pose and ZMP are interpolated linearly; torques and forces are
held over each knot interval (:mod:`cocomopl.export.grid`).
"""

from __future__ import annotations

import numpy as np

from cocomopl.dynamics import SIDES
from cocomopl.export.grid import GridMotion


def columns(joint_names: list[str], grid: GridMotion) -> list[tuple[str, np.ndarray]]:
    """The table's columns in order, each as (name with unit, values)."""
    named = [("t_s", grid.t)]
    named += [(f"{j}_rad", grid.joints[:, i]) for i, j in enumerate(joint_names)]
    named += [(f"zmp_{a}_waist_m", grid.zmp[:, i]) for i, a in enumerate("xyz")]
    named += [(f"waist_{a}_m", grid.waist[:, i]) for i, a in enumerate("xyz")]
    named += [(f"waist_{a}_rad", grid.waist_rpy[:, i]) for i, a in enumerate(("roll", "pitch", "yaw"))]
    # new columns go last, so readers indexing the columns above keep working
    named += [(f"{j}_rad_s", grid.velocities[:, i]) for i, j in enumerate(joint_names)]
    named += [(f"{j}_Nm", grid.torques[:, i]) for i, j in enumerate(joint_names)]
    named += [(f"{side}_f{a}_N", grid.forces[:, s, i]) for s, side in enumerate(SIDES) for i, a in enumerate("xyz")]
    return named


def csv_text(joint_names: list[str], grid: GridMotion) -> str:
    """The CSV file: a header line of column names, then one line per grid time."""
    named = columns(joint_names, grid)
    table = np.column_stack([values for _, values in named])
    rows = (",".join(f"{v:.6f}" for v in row) for row in table)
    return ",".join(name for name, _ in named) + "\n" + "\n".join(rows) + "\n"
