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
from cocomopl.robot import Robot

PASSES = 6
RELAXATION = 0.5  # fraction of the cart-table correction applied per pass: a full step overshoots
# relative weight of the correction's size and of the rest conditions at both ends: small
# enough that the ZMP error dominates, large enough to pick the bounded cart-table solution
SIZE_WEIGHT = 1e-3
REST_WEIGHT = 1e3
IK_ITERATIONS = 20
IK_TOLERANCE = 1e-7
IK_REACHED = 1e-5  # m: a sole this close to its footstep is on it  # m and rad of sole error
IK_DAMPING = 1e-8
# m of sole error traded for 1 m of pelvis height change in the legs' inverse kinematics.
# By default the height moves only when it must, as a pattern generator that prescribes
# the CoM height wants (the Kajita baseline).  The filter lets it move ten times more
# readily, so the pelvis sinks rather than a leg stretching to its knee stop to reach a far
# footstep: at 1e-2 its passes diverged after the fourth and M_gen's plan kept straight
# knees that then bent at 1.15 x their velocity limit; at 1e-3 they converge monotonically
# (README, "Known limitations (stage 2)")
HEIGHT_WEIGHT = 1e-2
FILTER_HEIGHT_WEIGHT = 1e-3


def leg_joints(robot: Robot) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per side, the (q, v) indices of the joints between the pelvis and that sole."""
    model = robot.model
    out = {}
    for side in SIDES:
        joints = [i + 2 for i in robot.leg_chain(side)]
        out[side] = (np.array([model.idx_qs[j] for j in joints]), np.array([model.idx_vs[j] for j in joints]))
    return out


def place_legs(
    robot: Robot, q: np.ndarray, targets: dict[str, pin.SE3], legs: dict, height_weight: float = HEIGHT_WEIGHT
) -> np.ndarray:
    """``q`` with the legs moved so each sole reaches ``targets[side]``.

    Levenberg-Marquardt on the two 6-D sole errors with the twelve leg joints and the
    pelvis height.  The height is weakly held where it was, by ``height_weight`` (m of sole
    error per m of height): it gives way when a leg would otherwise have to stretch beyond
    its knee limit (long steps in double support).
    """
    model, data = robot.model, robot.model.createData()
    q = q.copy()
    height = q[2]
    columns = np.concatenate([legs[side][1] for side in SIDES])
    rows = np.concatenate([legs[side][0] for side in SIDES])
    for _ in range(IK_ITERATIONS):
        pin.forwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        up = data.oMi[1].rotation.T[:, 2]  # world z in the pelvis frame: base twists are local
        residuals, jacobians = [], []
        for side in SIDES:
            frame = robot.foot_frames[side]
            error = targets[side].actInv(pin.updateFramePlacement(model, data, frame))
            J = pin.Jlog6(error) @ pin.getFrameJacobian(model, data, frame, pin.LOCAL)
            residuals.append(pin.log6(error).vector)
            jacobians.append(np.column_stack([J[:, :3] @ up, J[:, columns]]))
        residuals.append([height_weight * (q[2] - height)])
        jacobians.append(np.eye(1, 1 + len(columns)) * height_weight)
        r, J = np.concatenate(residuals), np.vstack(jacobians)
        if r @ r < IK_TOLERANCE**2:
            break
        # Levenberg-Marquardt: damping grows with the error, so an unreachable target
        # (a leg stretched beyond its knee) gives a short, safe step instead of a wild one
        step = np.linalg.solve(J.T @ J + (IK_DAMPING + r @ r) * np.eye(J.shape[1]), J.T @ r)
        q[2] -= step[0]
        q[rows] = np.clip(q[rows] - step[1:], model.lowerPositionLimit[rows], model.upperPositionLimit[rows])
    return q


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


def _stance_error(robot: Robot, q: np.ndarray, ground: list[list[pin.SE3 | None]]) -> float:
    """Largest distance (m) of a sole in contact from its planned ground position."""
    soles = sole_placements(robot, q)
    return max(
        (float(np.linalg.norm(soles[k, j] - g.translation)) for k, row in enumerate(ground) for j, g in enumerate(row) if g is not None),
        default=0.0,
    )


def multibody_zmp(robot: Robot, t, q, contact, impacts) -> np.ndarray:
    """ZMP (n, 3) of the contact wrenches that inverse dynamics needs for the motion."""
    _, _, wrenches = inverse_dynamics_with_contacts(robot, t, q, contact, impacts)
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


def dynamics_filter(
    robot: Robot,
    t: np.ndarray,
    q: np.ndarray,
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
            [place_legs(robot, qk, dict(zip(SIDES, tk)), legs, FILTER_HEIGHT_WEIGHT) for qk, tk in zip(q_pass, targets)]
        )
        zmp = multibody_zmp(robot, t, q_pass, contact, impacts)
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
