"""A motion for a real robot, on a uniform 5 ms grid: OpenHRP ``seqplay`` files or one CSV.

The seqplay pattern files are plain text, one line per 5 ms control cycle, each starting
with the time in seconds:

* ``.pos``: joint angles (rad) in the robot's joint order;
* ``.zmp``: the reference ZMP (m) in the waist (pelvis) frame;
* ``.hip``: waist roll, pitch, yaw (rad), the OpenHRP convention the paper's HRP-2 used;
* ``.waist``: waist position x, y, z (m), then roll, pitch, yaw (rad), world frame.

Recent hrpsys-base (``seqplay::loadPattern``) reads ``BASE.hip`` if it exists and then
expects x y z roll pitch yaw in it, ignoring ``BASE.waist``; older versions read roll,
pitch, yaw from ``.hip``.  For a recent hrpsys, delete the ``.hip`` so ``.waist`` is read.

The CSV (angles, velocities, torques, contact forces, ZMP, waist pose) is described in
:mod:`cocomopl.export.table`; :func:`export_motion` writes either.
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np

from cocomopl.errors import Error
from cocomopl.export.grid import CONTROL_DT, GridMotion, resample
from cocomopl.export.table import csv_text
from cocomopl.motion import Motion
from cocomopl.motion_file import atomic_path, writable_folder
from cocomopl.robot import Robot

FORMATS = ("seqplay", "csv")
SUFFIXES = {"seqplay": (".pos", ".zmp", ".hip", ".waist"), "csv": (".csv",)}  # of the files each writes


def _lines(t: np.ndarray, *columns: np.ndarray) -> str:
    table = np.column_stack([t, *columns])
    return "\n".join(" ".join(f"{v:.6f}" for v in row) for row in table) + "\n"


def seqplay_texts(grid: GridMotion) -> dict[str, str]:
    """The seqplay files' contents, by file suffix."""
    t = grid.t
    return {
        ".pos": _lines(t, grid.joints),
        ".zmp": _lines(t, grid.zmp),
        ".hip": _lines(t, grid.waist_rpy),
        ".waist": _lines(t, grid.waist, grid.waist_rpy),
    }


def export_motion(robot: Robot, motion: Motion, fmt: str, prefix: str | Path, dt: float = CONTROL_DT) -> list[Path]:
    """Write ``motion`` as seqplay files (``PREFIX.pos .zmp .hip .waist``) or ``PREFIX.csv``.

    Parameters
    ----------
    robot : the robot the motion is for (its joint names head the CSV columns)
    motion : the motion, knots at any spacing
    fmt : one of ``FORMATS``
    prefix : output path without suffix; its folder is created if missing
    dt : grid spacing, s

    Returns
    -------
    list of Path
        The files written.  All appear together or not at all (each is written to a
        temporary file first).

    Raises
    ------
    Error
        for an unknown format, or if the folder of ``prefix`` cannot be written.
    """
    if fmt not in FORMATS:
        raise Error(f"unknown motion format {fmt!r}: choose one of {', '.join(FORMATS)}")
    prefix = Path(prefix)
    writable_folder(prefix.parent, f"the folder of {prefix}")
    grid = resample(motion, dt)
    texts = seqplay_texts(grid) if fmt == "seqplay" else {".csv": csv_text(robot.joint_names, grid)}
    paths = [prefix.with_name(prefix.name + suffix) for suffix in texts]
    with ExitStack() as stack:
        for path, text in zip(paths, texts.values()):
            stack.enter_context(atomic_path(path)).write_text(text)
    return paths
