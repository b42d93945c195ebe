"""A motion on a robot controller's uniform time grid (5 ms: HRP-2's control cycle).

Touchdown duplicates are dropped first, so at an impact the post-impact sample counts.
The state (joint angles and velocities, waist pose) and the ZMP are interpolated linearly
between knots.  Torques and contact forces are held: the optimal control applies each over
its knot interval ``[t[k], t[k+1])``, so a grid time takes the knot at or before it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from cocomopl.motion import Motion

CONTROL_DT = 0.005  # s, HRP-2's control cycle
KNOT_TOLERANCE = 1e-9  # s: a grid time this close to a knot is at it (the grid is a float sum)


@dataclass(frozen=True)
class GridMotion:
    """A motion every ``dt`` seconds; arrays have one row per grid time.

    Attributes
    ----------
    t : (n,) time from the motion's start, s
    joints : (n, nu) joint angles, rad
    velocities : (n, nu) joint velocities, rad/s
    torques : (n, nu) joint torques, N m
    forces : (n, 2, 3) contact force on the (left, right) sole, N, world axes
    waist : (n, 3) waist (base) position, m, world frame
    waist_rpy : (n, 3) waist roll, pitch, yaw, rad, unwrapped
    zmp : (n, 3) ZMP in the waist frame, m
    """

    t: np.ndarray
    joints: np.ndarray
    velocities: np.ndarray
    torques: np.ndarray
    forces: np.ndarray
    waist: np.ndarray
    waist_rpy: np.ndarray
    zmp: np.ndarray


def _interpolate(t: np.ndarray, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` (n, m) at the knots ``t``, linearly interpolated at ``grid``; rows with a NaN
    are skipped (the ZMP is undefined where no foot pushes)."""
    ok = np.all(np.isfinite(values), axis=1)
    return np.stack([np.interp(grid, t[ok], values[ok, i]) for i in range(values.shape[1])], axis=1)


def _hold(t: np.ndarray, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` at the knots ``t``, each held until the next knot (zero-order hold)."""
    return values[np.searchsorted(t, grid + KNOT_TOLERANCE, side="right") - 1]


def resample(motion: Motion, dt: float = CONTROL_DT) -> GridMotion:
    """``motion`` every ``dt`` seconds from its first to its last knot."""
    keep = motion.kept_samples()
    t = motion.t[keep]
    grid = np.arange(t[0], t[-1] + KNOT_TOLERANCE, dt)
    q = motion.q[keep]
    rpy = np.unwrap([pin.rpy.matrixToRpy(pin.Quaternion(x[6], x[3], x[4], x[5]).toRotationMatrix()) for x in q], axis=0)
    waist, waist_rpy = _interpolate(t, grid, q[:, :3]), _interpolate(t, grid, rpy)
    zmp = _interpolate(t, grid, motion.zmp[keep])
    return GridMotion(
        t=grid - grid[0],
        joints=_interpolate(t, grid, q[:, 7:]),
        velocities=_interpolate(t, grid, motion.v[keep, 6:]),
        torques=_hold(t, grid, motion.tau[keep]),
        forces=_hold(t, grid, motion.wrenches[keep, :, :3]),
        waist=waist,
        waist_rpy=waist_rpy,
        zmp=np.array([pin.rpy.rpyToMatrix(r).T @ (p - w) for r, p, w in zip(waist_rpy, zmp, waist)]),
    )
