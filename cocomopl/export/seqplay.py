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
from cocomopl.export.safety import check_safe
from cocomopl.export.table import csv_text, number_text, read_csv
from cocomopl.motion import Motion
from cocomopl.motion_file import atomic_path, writable_place
from cocomopl.robot import Robot
from cocomopl.validation import check_motion

FORMATS = ("seqplay", "csv")
SUFFIXES = {"seqplay": (".pos", ".zmp", ".hip", ".waist"), "csv": (".csv",)}  # of the files each writes


def _lines(t: np.ndarray, *columns: np.ndarray) -> str:
    table = np.column_stack([t, *columns])
    return "\n".join(" ".join(map(number_text, row)) for row in table) + "\n"


def seqplay_texts(grid: GridMotion) -> dict[str, str]:
    """The seqplay files' contents, by file suffix."""
    t = grid.t
    return {
        ".pos": _lines(t, grid.joints),
        ".zmp": _lines(t, grid.zmp),
        ".hip": _lines(t, grid.waist_rpy),
        ".waist": _lines(t, grid.waist, grid.waist_rpy),
    }


def written(robot: Robot, motion: Motion, dt: float = CONTROL_DT) -> GridMotion:
    """The table that is written for ``motion``: resampled, formatted as text and read back,
    so the gate checks the very numbers that go into the files."""
    grid = resample(robot, motion, dt=dt)
    return read_csv(csv_text(robot, grid), robot.joint_names)


def export_motion(robot: Robot, motion: Motion, fmt: str, *, prefix: str | Path, dt: float = CONTROL_DT,
                  force: bool = False) -> tuple[list[Path], dict]:
    """Write ``motion`` as seqplay files (``PREFIX.pos .zmp .hip .waist``) or ``PREFIX.csv``,
    behind the safety gate (:mod:`cocomopl.export.safety`).

    Parameters
    ----------
    robot : the robot whose limits the gate checks; the motion must be for it
    motion : the motion, knots at any spacing
    fmt : one of ``FORMATS``
    prefix : output path without suffix; its folder is created if missing
    dt : grid spacing, s
    force : write a motion the gate refuses (never one holding NaN or Inf)

    Returns
    -------
    files : list of Path
        The files written.  All appear together or not at all (each is written to a
        temporary file first).
    report : dict
        The gate's :func:`~cocomopl.export.safety.safety_report`, with ``unsafe``, its
        reasons (empty when it passes; written anyway only with ``force``).

    Raises
    ------
    Error
        for an unknown format, a motion for another robot, a motion the gate refuses
        (unless ``force``), non-finite values, or a folder that cannot be written.
    """
    if fmt not in FORMATS:
        raise Error(f"unknown motion format {fmt!r}: choose one of {', '.join(FORMATS)}")
    check_motion(motion, robot)  # NaN, Inf or a broken motion: refused, forced or not
    prefix = Path(prefix)
    writable_place(prefix.parent, f"the folder of {prefix}")  # before the gate's seconds of work
    grid = written(robot, motion, dt)
    reasons, report = check_safe(robot, grid)
    if report["finite"] or (reasons and not force):
        more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
        hint = "" if report["finite"] else "; --force exports anyway"
        raise Error(f"refused, unsafe for a robot: {reasons[0]}{more}{hint}")
    texts = seqplay_texts(grid) if fmt == "seqplay" else {".csv": csv_text(robot, grid)}
    paths = [prefix.with_name(prefix.name + suffix) for suffix in texts]
    with ExitStack() as stack:
        for path, text in zip(paths, texts.values()):
            stack.enter_context(atomic_path(path)).write_text(text)
    return paths, {**report, "unsafe": reasons}
