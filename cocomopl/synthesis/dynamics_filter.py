"""Make a kinematic walk dynamically consistent with its reference ZMP.

Learned joint angles are accurate to a few hundredths of a radian, but the ZMP of the
whole body depends on their second derivatives: a 2 cm wobble of the CoM over 0.4 s moves
the ZMP by half a metre.  The dynamics filter of Kajita et al. (IROS 2003, sec. IV) removes
that: compute the multibody ZMP of the motion by inverse dynamics, compare it with the
reference (here the learned ZMP), and shift the pelvis horizontally by the correction that
the cart-table model says cancels the error,

    Δp = Δc - (h / g) Δc̈,

then place the legs by inverse kinematics so the soles stay where they must be.  A few
passes converge because the cart-table model is close to the real response.

Kajita solves for Δc with preview control, online.  The whole walk is known here, so the
correction is the least-squares solution over the whole horizon with the walk's ends at
rest, a banded linear system.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from cocomopl.dynamics import (
    GRAVITY,
    SIDES,
    inverse_dynamics_with_contacts,
    sole_placements,
    zmp_from_wrenches,
)
from cocomopl.kinematics import IK_REACHED, leg_joints, place_legs
from cocomopl.motion import Motion
from cocomopl.robot import Robot

PASSES = 6
RELAXATION = 0.5  # fraction of the cart-table correction applied per pass: a full step overshoots
# relative weight of the correction's size and of the rest conditions at both ends: small
# enough that the ZMP error dominates, large enough to pick the bounded cart-table solution
SIZE_WEIGHT = 1e-3
REST_WEIGHT = 1e3
# m of sole error per m of pelvis height in the filter's leg placement: ten times more
# readily than kinematics.HEIGHT_WEIGHT, so the pelvis sinks rather than a leg stretching
# to its knee stop to reach a far footstep.  At 1e-2 the passes diverged after the fourth
# and M_gen's plan kept straight knees that then bent at 1.15 x their velocity limit; at
# 1e-3 they converge monotonically (docs/experiments/filter-weights.md).
FILTER_HEIGHT_WEIGHT = 1e-3


def swing_targets(t: np.ndarray, placements: list[list[pin.SE3]], ground: list[list[pin.SE3 | None]]) -> list[list[pin.SE3]]:
    """Sole targets (n, 2): the ground placement in contact; in the air the sole's own path,
    bent smoothly so it leaves from where it stood and lands where it is planned to.

    ``placements[k][j]`` is where sole ``j`` is at sample ``k``; ``ground[k][j]`` its planned
    ground placement, or None while it swings.
    """
    n = len(t)
    out = [[ground[k][j] for j in range(2)] for k in range(n)]
    for j in range(2):
        k = 0
        while k < n:
            if ground[k][j] is not None:
                k += 1
                continue
            first = k
            while k < n and ground[k][j] is None:
                k += 1
            before, after = first - 1, min(k, n - 1)
            lift = _offset(placements[before][j], ground[before][j])
            land = _offset(placements[after][j], ground[after][j] if ground[after][j] is not None else placements[after][j])
            span = t[after] - t[before]
            for i in range(first, k):
                s = (t[i] - t[before]) / span if span > 0 else 1.0
                s = s * s * (3 - 2 * s)  # smoothstep: no velocity jump at lift-off or touchdown
                out[i][j] = pin.exp6((1 - s) * lift + s * land) * placements[i][j]
    return out


def _offset(current: pin.SE3, target: pin.SE3) -> pin.Motion:
    """The world-frame twist that moves ``current`` onto ``target`` in unit time."""
    return pin.log6(target * current.inverse())


def zmp_correction(t: np.ndarray, error: np.ndarray, height: float) -> np.ndarray:
    """Horizontal CoM shift (n, 2) whose cart-table ZMP cancels ``error`` (n, 2).

    Least squares over the whole walk of ``Δc_k - (h/g) Δc̈_k + e_k`` with Δc̈ the central
    second difference (as :func:`~cocomopl.dynamics.inverse_dynamics_with_contacts` measures it), a small penalty on |Δc|, and Δc and
    its velocity zero at both ends (the walk starts and ends at rest).  NaN errors (no foot
    pushing) are left out.
    """
    n = len(t)
    dt = np.diff(t)
    # central second difference on a non-uniform grid, at k = 1 .. n-2
    k = np.arange(1, n - 1)
    h0, h1 = dt[k - 1], dt[k]
    c0, c1, c2 = 2 / (h0 * (h0 + h1)), -2 / (h0 * h1), 2 / (h1 * (h0 + h1))
    D2 = sp.csr_matrix((np.concatenate([c0, c1, c2]), (np.tile(k - 1, 3), np.concatenate([k - 1, k, k + 1]))), shape=(n - 2, n))
    A = sp.eye(n, format="csr")[1 : n - 1] - (height / GRAVITY) * D2
    inner = error[1 : n - 1]
    valid = np.all(np.isfinite(inner), axis=1)
    ends = sp.csr_matrix(([1.0, 1.0, 1.0, 1.0], ([0, 1, 2, 3], [0, 1, n - 2, n - 1])), shape=(4, n))
    M = sp.vstack([A[valid], REST_WEIGHT * ends, np.sqrt(SIZE_WEIGHT) * sp.eye(n, format="csr")]).tocsr()
    out = np.zeros((n, 2))
    for axis in range(2):
        rhs = np.concatenate([-inner[valid, axis], np.zeros(4 + n)])
        out[:, axis] = spsolve((M.T @ M).tocsc(), M.T @ rhs)
    return out


def pelvis_shift_response(robot: Robot, q: np.ndarray) -> tuple[float, float]:
    """How the multibody ZMP answers a horizontal shift ``Δc`` of the pelvis with the soles
    held (the legs following by their Jacobians), linearised at the double-support posture
    ``q`` with the robot at rest: ``Δp = κ (Δc - (h / g) Δc̈)``.

    ``κ`` is the share of the shift the CoM takes (the legs stay behind), ``h`` the height of
    the cart-table model that answers alike (above the CoM's: the upper body swings with the
    pelvis, its angular momentum with it).  TALOS's reference posture: κ 0.84, h 1.00 m
    (its CoM at 0.88 m).  Averaged over the two horizontal axes.

    Returns
    -------
    kappa, height : (unitless, m)
    """
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    legs = leg_joints(robot)
    weight = pin.computeTotalMass(model) * GRAVITY
    base = model.jointPlacements[1] * pin.XYZQUATToSE3(q[:7])
    at_rest = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv)).copy()
    kappas, coefficients = [], []
    for axis in range(2):
        motion = np.zeros(model.nv)  # unit pelvis translation along the world axis, soles fixed
        motion[:3] = base.rotation.T[:, axis]
        for side in SIDES:
            J = pin.getFrameJacobian(model, data, robot.foot_frames[side], pin.LOCAL)
            columns = legs[side][1]
            motion[columns] = -np.linalg.solve(J[:, columns], J[:, :6] @ motion[:6])
        kappas.append((pin.jacobianCenterOfMass(model, data, q) @ motion)[axis])
        wrench = base.act(pin.Force(pin.rnea(model, data, q, np.zeros(model.nv), motion)[:6] - at_rest[:6]))
        coefficients.append((-wrench.angular[1] if axis == 0 else wrench.angular[0]) / weight)
    kappa = float(np.mean(kappas))
    return kappa, float(-np.mean(coefficients) * GRAVITY / kappa)


def _stance_error(robot: Robot, q: np.ndarray, ground: list[list[pin.SE3 | None]]) -> float:
    """Largest distance (m) of a sole in contact from its planned ground position."""
    soles = sole_placements(robot, q)
    return max(
        (float(np.linalg.norm(soles[k, j] - g.translation)) for k, row in enumerate(ground) for j, g in enumerate(row) if g is not None),
        default=0.0,
    )


def multibody_zmp(robot: Robot, t, q, *, contact, impacts) -> np.ndarray:
    """ZMP (n, 3) of the contact wrenches that inverse dynamics needs for the motion."""
    _, _, wrenches = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=impacts)
    return zmp_from_wrenches(sole_placements(robot, q), wrenches)


def _zmp_samples(n: int, impacts: np.ndarray) -> np.ndarray:
    """(n,) mask of the samples that carry a ZMP of their own: all but the pre-impact
    samples ``impacts``, which repeat their interval's wrench at the touchdown's instant."""
    keep = np.ones(n, dtype=bool)
    keep[impacts] = False
    return keep


def rms_zmp_error(zmp: np.ndarray, zmp_ref: np.ndarray, impacts: np.ndarray) -> float:
    """RMS (m), over the samples and both horizontal axes, of ``zmp - zmp_ref`` (n, 3),
    leaving out the pre-impact samples ``impacts`` (not ZMP samples of their own).  NaN
    samples (no contact force) are skipped."""
    keep = _zmp_samples(len(zmp), impacts)
    return float(np.sqrt(np.nanmean((zmp[keep, :2] - zmp_ref[keep, :2]) ** 2)))


def plan_zmp_error(robot: Robot, motion: Motion) -> float:
    """:func:`rms_zmp_error` of a planned motion: the ZMP of its contact wrenches against its
    reference ZMP, its pre-impact samples left out (m)."""
    return rms_zmp_error(zmp_from_wrenches(sole_placements(robot, motion.q), motion.wrenches), motion.zmp, motion.impacts)


def dynamics_filter(
    robot: Robot,
    t: np.ndarray,
    q: np.ndarray,
    *,
    contact: np.ndarray,
    impacts: np.ndarray,
    ground: list[list[pin.SE3 | None]],
    zmp_ref: np.ndarray,
    passes: int = PASSES,
) -> tuple[np.ndarray, list[float], int]:
    """Pelvis and legs of a kinematic walk corrected so its multibody ZMP follows ``zmp_ref``.

    Parameters
    ----------
    t, q, contact, impacts : the motion's knots, as in :class:`~cocomopl.motion.Motion`
    ground : per sample and sole (left, right), the planned ground placement, None in the air
    zmp_ref : (n, 3) the reference ZMP, world frame

    Returns
    -------
    q : the corrected configurations (soles exactly on ``ground`` while in contact)
    errors : the RMS horizontal ZMP error (m) before each pass and after the last; the pass
        with the smallest is returned (the iteration need not decrease monotonically), among
        those whose soles in contact reach their footsteps if any do
    kept : the index in ``errors`` of the returned pass
    """
    model, data = robot.model, robot.model.createData()
    legs = leg_joints(robot)
    placements = [[robot.frame_placement(qk, robot.foot_frames[s]) for s in SIDES] for qk in q]
    targets = swing_targets(t, placements, ground)
    keep = _zmp_samples(len(t), impacts)  # the correction is smooth: one value per instant
    height = float(np.mean([pin.centerOfMass(model, data, qk)[2] for qk in q[:: max(len(q) // 20, 1)]]))
    shift = np.zeros((len(t), 2))
    errors, best = [], None
    for i in range(passes + 1):
        q_pass = q.copy()
        q_pass[:, :2] += shift
        q_pass = np.array(
            [place_legs(robot, qk, dict(zip(SIDES, tk)), legs=legs, height_weight=FILTER_HEIGHT_WEIGHT, data=data)
             for qk, tk in zip(q_pass, targets)]
        )
        zmp = multibody_zmp(robot, t, q_pass, contact=contact, impacts=impacts)
        error = zmp[:, :2] - zmp_ref[:, :2]
        errors.append(rms_zmp_error(zmp, zmp_ref, impacts))
        # a pass whose shift put a planned footstep out of the legs' reach is not a candidate
        score = (_stance_error(robot, q_pass, ground) > IK_REACHED, errors[-1])
        if best is None or score < best[0]:
            best = (score, q_pass, i)
        if i < passes:
            shift[keep] += RELAXATION * zmp_correction(t[keep], error[keep], height)
            shift[~keep] = shift[np.flatnonzero(~keep) + 1]
    return best[1], errors, best[2]
