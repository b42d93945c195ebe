"""A motion for a real robot: OpenHRP ``seqplay`` files and CSV, on a uniform 5 ms grid.

The seqplay pattern files are plain text, one line per 5 ms control cycle, each starting
with the time in seconds:

* ``.pos``: joint angles (rad) in the robot's joint order;
* ``.zmp``: the reference ZMP (m) in the waist (pelvis) frame;
* ``.hip``: waist roll, pitch, yaw (rad), the OpenHRP convention the paper's HRP-2 used;
* ``.waist``: waist position x, y, z (m), then roll, pitch, yaw (rad), world frame.

Recent hrpsys-base (``seqplay::loadPattern``) reads ``BASE.hip`` if it exists and then
expects x y z roll pitch yaw in it, ignoring ``BASE.waist``; older versions read roll,
pitch, yaw from ``.hip``.  For a recent hrpsys, delete the ``.hip`` so ``.waist`` is read.
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pinocchio as pin

from cocomopl.motion import Motion
from cocomopl.motion_file import atomic_path, writable_folder
from cocomopl.robot import Robot

CONTROL_DT = 0.005  # s, HRP-2's control cycle
FORMATS = ("seqplay", "csv")


def resample(motion: Motion, dt: float = CONTROL_DT) -> dict[str, np.ndarray]:
    """Time, joint angles, waist position and roll-pitch-yaw and the ZMP in the waist frame,
    linearly interpolated every ``dt`` seconds (touchdown duplicates dropped first)."""
    keep = motion.kept_samples()
    t = motion.t[keep]
    grid = np.arange(t[0], t[-1] + 1e-9, dt)

    def at(values: np.ndarray) -> np.ndarray:
        ok = np.all(np.isfinite(values), axis=1)  # the ZMP is undefined where no foot pushes
        return np.stack([np.interp(grid, t[ok], values[ok, i]) for i in range(values.shape[1])], axis=1)

    q = motion.q[keep]
    rpy = np.unwrap([pin.rpy.matrixToRpy(pin.Quaternion(x[6], x[3], x[4], x[5]).toRotationMatrix()) for x in q], axis=0)
    waist, waist_rpy, zmp = at(q[:, :3]), at(rpy), at(motion.zmp[keep])
    zmp_waist = np.array([pin.rpy.rpyToMatrix(r).T @ (p - w) for r, p, w in zip(waist_rpy, zmp, waist)])
    return {"t": grid - grid[0], "joints": at(q[:, 7:]), "waist": waist, "waist_rpy": waist_rpy, "zmp": zmp_waist}


def _lines(t: np.ndarray, *columns: np.ndarray) -> str:
    table = np.column_stack([t, *columns])
    return "\n".join(" ".join(f"{v:.6f}" for v in row) for row in table) + "\n"


def export_motion(robot: Robot, motion: Motion, fmt: str, prefix: str | Path, dt: float = CONTROL_DT) -> list[Path]:
    """Write ``motion`` as seqplay files (``PREFIX.pos .zmp .hip .waist``) or ``PREFIX.csv``.

    All files appear together or not at all (each is written to a temporary file first).
    Raises :class:`~cocomopl.errors.Error` if the folder of ``prefix`` cannot be written.
    """
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {FORMATS}, not {fmt!r}")
    prefix = Path(prefix)
    writable_folder(prefix.parent, f"the folder of {prefix}")
    data = resample(motion, dt)
    t = data["t"]
    if fmt == "seqplay":
        texts = {
            ".pos": _lines(t, data["joints"]),
            ".zmp": _lines(t, data["zmp"]),
            ".hip": _lines(t, data["waist_rpy"]),
            ".waist": _lines(t, data["waist"], data["waist_rpy"]),
        }
    else:
        header = ",".join(
            ["t_s", *(f"{n}_rad" for n in robot.joint_names), "zmp_x_waist_m", "zmp_y_waist_m", "zmp_z_waist_m",
             "waist_x_m", "waist_y_m", "waist_z_m", "waist_roll_rad", "waist_pitch_rad", "waist_yaw_rad"]
        )
        table = np.column_stack([t, data["joints"], data["zmp"], data["waist"], data["waist_rpy"]])
        texts = {".csv": header + "\n" + "\n".join(",".join(f"{v:.6f}" for v in row) for row in table) + "\n"}
    paths = [prefix.with_name(prefix.name + suffix) for suffix in texts]
    with ExitStack() as stack:
        for path, text in zip(paths, texts.values()):
            stack.enter_context(atomic_path(path)).write_text(text)
    return paths
