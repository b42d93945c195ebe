"""A motion on a robot controller's uniform time grid (5 ms: HRP-2's control cycle).

Touchdown duplicates are dropped first, so at an impact the post-impact sample counts.
The joint angles and the waist pose are the reference the simulator plays
(:func:`cocomopl.sim.rollout.low_passed`): linear between knots, then the zero-phase
low-pass at ``REFERENCE_CUTOFF_HZ``, so the exported reference is the one whose
simulation ``cocomopl walk`` reports.  (Linear interpolation alone steps the velocity at
every knot: on a 5 ms grid that asks the joints for accelerations, and torques, several
times those of the plan.)  Velocities and accelerations are finite differences of those
exported positions, not the motion's stored velocities.  Contact flags and wrenches are
held: the optimal control applies each over its knot interval ``[t[k], t[k+1])``, so a
grid time takes the knot at or before it.  Torques are the inverse dynamics of the
exported motion under those wrenches, so what is written is what the safety gate checks.
The reference ZMP is interpolated linearly.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import pinocchio as pin

from cocomopl.dynamics import SIDES
from cocomopl.motion import TIME_TOLERANCE, Motion
from cocomopl.robot import Robot
from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ, low_passed

CONTROL_DT = 0.005  # s, HRP-2's control cycle


@dataclass(frozen=True)
class GridMotion:
    """A motion every ``dt`` seconds; arrays have one row per grid time.

    Attributes
    ----------
    t : (n,) time from the motion's start, s
    joints : (n, nu) joint angles, rad
    velocities : (n, nu) joint velocities, rad/s, central differences of ``joints``
    torques : (n, nu) joint torques, N m, inverse dynamics of the exported motion
    forces : (n, 2, 3) contact force on the (left, right) sole, N, world axes
    moments : (n, 2, 3) contact moment about the sole frame origin, N m, world axes
    contact : (n, 2) 1.0 where the (left, right) sole is in contact, else 0.0
    waist : (n, 3) waist (base) position, m, world frame
    waist_rpy : (n, 3) waist roll, pitch, yaw, rad, unwrapped
    zmp : (n, 3) reference ZMP in the waist frame, m
    """

    t: np.ndarray
    joints: np.ndarray
    velocities: np.ndarray
    torques: np.ndarray
    forces: np.ndarray
    moments: np.ndarray
    contact: np.ndarray
    waist: np.ndarray
    waist_rpy: np.ndarray
    zmp: np.ndarray

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0]) if len(self.t) > 1 else CONTROL_DT


def _interpolate(t: np.ndarray, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` (n, m) at the knots ``t``, linearly interpolated at ``grid``; rows with a NaN
    are skipped (the ZMP is undefined where no foot pushes)."""
    ok = np.all(np.isfinite(values), axis=1)
    return np.stack([np.interp(grid, t[ok], values[ok, i]) for i in range(values.shape[1])], axis=1)


def _interpolate_segments(motion: Motion, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Like :func:`_interpolate`, but touchdown by touchdown: up to an impact the pre-impact
    sample ends the segment, so a value that switches with the contact (the ZMP moving to
    the new support) is not blended into the times before the switch."""
    out = np.empty((len(grid), values.shape[1]))
    edges = [0, *(int(i) + 1 for i in motion.impacts), motion.n]
    for first, end in pairwise(edges):
        t = motion.t[first:end]
        last_segment = end == motion.n
        inside = (grid >= t[0] - TIME_TOLERANCE) & ((grid <= t[-1] + TIME_TOLERANCE) if last_segment else (grid < t[-1] - TIME_TOLERANCE))
        if inside.any():
            out[inside] = _interpolate(t, grid[inside], values[first:end])
    return out


def _hold(t: np.ndarray, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` at the knots ``t``, each held until the next knot (zero-order hold)."""
    return values[np.searchsorted(t, grid + TIME_TOLERANCE, side="right") - 1]


def configurations(robot: Robot, waist: np.ndarray, waist_rpy: np.ndarray, *, joints: np.ndarray) -> np.ndarray:
    """Pinocchio configurations (n, nq) of a waist pose and joint angles."""
    quaternions = [pin.Quaternion(pin.rpy.rpyToMatrix(r)).coeffs() for r in waist_rpy]  # (x, y, z, w)
    return np.column_stack([waist, np.array(quaternions).reshape(-1, 4), joints])


def finite_differences(robot: Robot, q: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocities (central differences, one-sided at the ends) and accelerations (second
    differences, zero at the ends) of configurations ``q`` every ``dt`` s, (n, nv) each."""
    steps = np.array([pin.difference(robot.model, a, b) / dt for a, b in pairwise(q)])
    v = np.empty((len(q), robot.model.nv))
    v[0], v[-1] = steps[0], steps[-1]
    v[1:-1] = 0.5 * (steps[:-1] + steps[1:])
    a = np.zeros_like(v)
    a[1:-1] = np.diff(steps, axis=0) / dt
    return v, a


def joint_torques(robot: Robot, q: np.ndarray, v: np.ndarray, *, a: np.ndarray, wrenches: np.ndarray) -> np.ndarray:
    """Joint torques (n, nu) of inverse dynamics, ``M a + h - sum J^T f`` in the joint rows,
    with the contact wrenches (n, 2, 6) at the sole origins, world-aligned."""
    model, data = robot.model, robot.model.createData()
    out = np.empty((len(q), model.nv - 6))
    for k in range(len(q)):
        rhs = pin.rnea(model, data, q[k], v[k], a[k]).copy()
        pin.computeJointJacobians(model, data, q[k])
        pin.updateFramePlacements(model, data)
        for j, side in enumerate(SIDES):
            if np.any(wrenches[k, j]):
                rhs -= pin.getFrameJacobian(model, data, robot.foot_frames[side], pin.LOCAL_WORLD_ALIGNED).T @ wrenches[k, j]
        out[k] = rhs[6:]
    return out


def resample(robot: Robot, motion: Motion, *, dt: float = CONTROL_DT,
             cutoff: float = REFERENCE_CUTOFF_HZ) -> GridMotion:
    """``motion`` every ``dt`` seconds from its first to its last knot, for ``robot``."""
    keep = motion.kept_samples()
    t = motion.t[keep]
    grid = np.arange(t[0], t[-1] + TIME_TOLERANCE, dt)
    q = motion.q[keep]
    rpy = np.unwrap([pin.rpy.matrixToRpy(pin.Quaternion(x[6], x[3], x[4], x[5]).toRotationMatrix()) for x in q], axis=0)
    pose = low_passed(_interpolate(t, grid, np.column_stack([q[:, :3], rpy, q[:, 7:]])), dt, cutoff)
    waist, waist_rpy, joints = pose[:, :3], pose[:, 3:6], pose[:, 6:]
    wrenches = _hold(t, grid, motion.wrenches[keep])
    configuration = configurations(robot, waist, waist_rpy, joints=joints)
    v, a = finite_differences(robot, configuration, dt)
    zmp = _interpolate_segments(motion, grid, motion.zmp)
    return GridMotion(
        t=grid - grid[0],
        joints=joints,
        velocities=v[:, 6:],
        torques=joint_torques(robot, configuration, v, a=a, wrenches=wrenches),
        forces=wrenches[:, :, :3],
        moments=wrenches[:, :, 3:],
        contact=_hold(t, grid, motion.contact[keep]).astype(float),
        waist=waist,
        waist_rpy=waist_rpy,
        zmp=np.array([pin.rpy.rpyToMatrix(r).T @ (p - w) for r, p, w in zip(waist_rpy, zmp, waist)]),
    )
