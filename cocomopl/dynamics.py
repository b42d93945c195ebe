"""Rigid-body quantities recomputed from a motion with Pinocchio: sole placements, ZMP,
inverse dynamics.  Used to build motions and, independently of any solver, to check them."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.motion import Motion
from cocomopl.robot import Robot

SIDES = ("left", "right")
GRAVITY = 9.81  # m/s^2


def sole_placements(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Sole frame positions (n, 2, 3) of (left, right), world frame."""
    model, data = robot.model, robot.model.createData()
    out = np.empty((len(q), 2, 3))
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(model, data, qk)
        for j, side in enumerate(SIDES):
            out[k, j] = data.oMf[robot.foot_frames[side]].translation
    return out


def zmp_from_wrenches(soles: np.ndarray, wrenches: np.ndarray, height: float = 0.0) -> np.ndarray:
    """Zero-moment point (n, 3) on the plane ``z = height`` of contact wrenches.

    ``wrenches`` (n, 2, 6) act at the sole origins ``soles`` (n, 2, 3), world-aligned axes.
    Where no foot pushes (flight, impacts) the ZMP is undefined and NaN.
    """
    force = wrenches[..., :3].sum(axis=1)
    moment = (np.cross(soles, wrenches[..., :3]) + wrenches[..., 3:]).sum(axis=1)
    fz = force[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        # moment about (px, py, h) has zero horizontal part: solve for px, py
        px = (-moment[:, 1] - height * force[:, 0]) / fz
        py = (moment[:, 0] - height * force[:, 1]) / fz
    out = np.stack([px, py, np.full_like(px, height)], axis=1)
    out[fz <= 1e-6] = np.nan
    return out


def finite_difference_accelerations(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Accelerations over each interval (n-1, nv) of a symplectic-Euler motion: dv/dt."""
    dt = np.diff(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.diff(v, axis=0) / dt[:, None]


def inverse_dynamics_residual(robot: Robot, q, v, *, a, tau, wrenches) -> np.ndarray:
    """``M a + h - S^T tau - sum J^T f`` per sample (n, nv): zero for consistent dynamics."""
    model, data = robot.model, robot.model.createData()
    out = np.empty((len(q), model.nv))
    for k in range(len(q)):
        rhs = pin.rnea(model, data, q[k], v[k], a[k]).copy()
        rhs[6:] -= tau[k]
        pin.computeJointJacobians(model, data, q[k])
        pin.updateFramePlacements(model, data)
        for j, side in enumerate(SIDES):
            if np.any(wrenches[k, j]):
                J = pin.getFrameJacobian(model, data, robot.foot_frames[side], pin.LOCAL_WORLD_ALIGNED)
                rhs -= J.T @ wrenches[k, j]
        out[k] = rhs
    return out


def pelvis_placements(robot: Robot, q: np.ndarray) -> list[pin.SE3]:
    """Placement of the pelvis frame per sample."""
    model, data = robot.model, robot.model.createData()
    out = []
    for qk in q:
        pin.framesForwardKinematics(model, data, qk)
        out.append(data.oMf[robot.pelvis_frame].copy())
    return out


def inverse_dynamics_with_contacts(
    robot: Robot, t: np.ndarray, q: np.ndarray, *, contact: np.ndarray, impacts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocities, joint torques and contact wrenches that realise a kinematic motion.

    Velocities are backward differences within each impact-free segment, ``q[k] = q[k-1] +
    v[k] dt`` as in the symplectic Euler of the OC motions, and accelerations forward
    differences of them (:func:`finite_difference_accelerations`).  So every interval up to
    a touchdown has its real acceleration.  The post-impact velocity is unknown from
    positions alone; the OCPs land softly, so it is taken as the central difference across
    the touchdown, the mean of the differences just before and just after it.  (Taking the
    next difference instead, i.e. zero acceleration over the first interval after a
    touchdown, made the arms' velocity terms alone exceed their torque limits there and fed
    the dynamics filter a false ZMP error.)  The floating base is unactuated, so
    the contact wrenches must supply the base rows of inverse dynamics; in double support
    the least-norm split between the soles is taken.  Torques and wrenches hold over each
    interval; a segment's last sample repeats the one before.

    Returns
    -------
    v : (n, nv), tau : (n, nu) N m, wrenches : (n, 2, 6) at the sole origins, world-aligned
    """
    model, data = robot.model, robot.model.createData()
    n = len(t)
    v = np.zeros((n, model.nv))
    tau = np.zeros((n, model.nv - 6))
    wrenches = np.zeros((n, 2, 6))
    bounds = np.concatenate([[-1], impacts, [n - 1]])
    for first, last in zip(bounds[:-1] + 1, bounds[1:]):
        for k in range(first + 1, last + 1):
            v[k] = pin.difference(model, q[k - 1], q[k]) / (t[k] - t[k - 1])
        # a walk's first sample has nothing before it; after a touchdown, the central difference
        v[first] = v[first + 1] if first == 0 else 0.5 * (v[first - 1] + v[first + 1])
        for k in range(first, last):
            a = (v[k + 1] - v[k]) / (t[k + 1] - t[k])
            tau[k], wrenches[k] = contact_inverse_dynamics(robot, data, q[k], v[k], a, contact[k])
        tau[last], wrenches[last] = tau[last - 1], wrenches[last - 1]
    return v, tau, wrenches


def contact_inverse_dynamics(robot: Robot, data: pin.Data, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                             contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques (nu,) and contact wrenches (2, 6) that realise acceleration ``a`` at
    ``(q, v)`` with the soles in ``contact`` (2,) bearing the base's rows of inverse dynamics,
    the least-norm split in double support (:func:`inverse_dynamics_with_contacts`)."""
    model = robot.model
    rhs = pin.rnea(model, data, q, v, a)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    sides = [j for j in range(2) if contact[j]]
    J = np.vstack([pin.getFrameJacobian(model, data, robot.foot_frames[SIDES[j]], pin.LOCAL_WORLD_ALIGNED) for j in sides])
    f = np.linalg.lstsq(J[:, :6].T, rhs[:6], rcond=None)[0]
    wrenches = np.zeros((2, 6))
    wrenches[sides] = f.reshape(len(sides), 6)
    return rhs[6:] - J[:, 6:].T @ f, wrenches


def total_wrench_zmp(robot: Robot, data: pin.Data, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The ZMP (x, y) on the ground of the whole contact wrench that ``(q, v, a)`` needs: the
    floating base's rows of inverse dynamics, however the soles share them."""
    tau = pin.rnea(robot.model, data, q, v, a)
    base = robot.model.jointPlacements[1] * pin.XYZQUATToSE3(q[:7])  # RNEA leaves data.oMi as it was
    wrench = base.act(pin.Force(tau[:6]))  # about the world origin, world axes
    return np.array([-wrench.angular[1], wrench.angular[0]]) / wrench.linear[2]


def kinematic_motion(
    robot: Robot,
    t: np.ndarray,
    q: np.ndarray,
    *,
    contact: np.ndarray,
    impacts: np.ndarray,
    phases: list,
    steps: list,
    step_starts: np.ndarray,
    producer: str,
    zmp: np.ndarray | None = None,
) -> Motion:
    """The :class:`Motion` of a kinematic walk by ``producer``: velocities, torques and contact wrenches by
    :func:`inverse_dynamics_with_contacts`; ``zmp`` as given (a reference) or, by default,
    the ZMP of those wrenches."""
    v, tau, wrenches = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=impacts)
    if zmp is None:
        zmp = zmp_from_wrenches(sole_placements(robot, q), wrenches)
    return Motion(
        t=t,
        q=q,
        v=v,
        tau=tau,
        wrenches=wrenches,
        contact=contact,
        zmp=zmp,
        phases=phases,
        impacts=np.asarray(impacts, dtype=int),
        steps=list(steps),
        step_starts=np.asarray(step_starts, dtype=int),
        joint_names=list(robot.joint_names),
        robot=robot.name,
        producer=producer,
    )
