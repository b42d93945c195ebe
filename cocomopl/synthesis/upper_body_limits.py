"""Keep the upper body of a kinematic walk (torso, arms, head) within its joint limits.

The primitives reproduce the OC steps' joint angles to a few hundredths of a radian, but a
small kink where two generated steps meet is a large acceleration, and the arms' torque
limits are tight: the OC walks already run their elbows at 0.94 of theirs.  The upper body
carries no sole, so its joints can be corrected without moving one.  The correction ``dq``
(one value per instant and upper-body joint) is the smallest and smoothest change of their
angles that keeps them within their position limits and within ``margin`` of their torque
and velocity limits,

    min  ||dq||^2 + SMOOTHNESS ||D2 dq||^2
    s.t. |tau_k + M_UU(q_k) (A dq)_k| <= margin * tau_max
         |v_k + (V dq)_k|             <= margin * v_max
         q_lower <= q_k + dq_k        <= q_upper

where ``V`` and ``A`` are the finite differences with which
:func:`~cocomopl.dynamics.inverse_dynamics_with_contacts` turns positions into velocities
and accelerations, and ``M_UU`` the upper body's block of the joint-space inertia matrix
(an upper-body joint's torque is its row of ``M a + h``: no contact Jacobian reaches it).
The torque constraint is linearised, so the QP is re-solved about its last answer until
the inverse dynamics agree.  The QPs are sparse and solved with ProxQP (proxsuite), the
QP solver of the Pinocchio developers.  The legs are the dynamics filter's
(:mod:`cocomopl.synthesis.dynamics_filter`), which runs first.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import scipy.sparse as sp
from proxsuite import proxqp

from cocomopl.dynamics import inverse_dynamics_with_contacts
from cocomopl.robot import Robot

MARGIN = 0.95  # fraction of a limit the corrected motion is held to: the rest absorbs linearisation error
# weight of the correction's second differences (per sample, rad) against its size: large
# enough that the correction spreads over a few samples instead of adding a new kink
SMOOTHNESS = 30.0
ITERATIONS = 4  # QPs solved at most, each linearised about the last correction
TOLERANCE = 0.01  # relative excess over the margin that ends the iteration
NEAR = 0.8  # fraction of the margin from which a torque or velocity is constrained
POSITION_NEAR = 0.05  # rad from a position limit from which an angle is constrained
POSITION_TOLERANCE = 1e-6  # rad beyond a position limit that ends the iteration
# ProxQP's outer and inner iterations per QP: the corrections of trained models converge in
# under 10; a walk too far from consistent to correct (tens of times its torque limits) must
# not stall the placement
QP_MAX_ITERATIONS = 50
QP_MAX_INNER_ITERATIONS = 50
QP_TOLERANCE = 1e-7  # N m, rad/s and rad of constraint violation; the margin leaves 5 %


def difference_operators(t: np.ndarray, impacts: np.ndarray) -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray]:
    """The linear maps from a joint's angle at each instant to its velocity and its
    interval acceleration at each sample, as :func:`~cocomopl.dynamics.inverse_dynamics_with_contacts`
    computes them.

    Returns
    -------
    V, A : (n, u) sparse, u the number of distinct instants (pre-impact duplicates share
        their post-impact twin's instant)
    instant : (n,) the instant of each sample
    """
    n = len(t)
    instant = np.cumsum(np.r_[0, np.diff(t) > 0])
    rows, cols, vals = [], [], []
    for k in range(1, n):
        if t[k] > t[k - 1]:
            h = t[k] - t[k - 1]
            rows += [k, k]
            cols += [k, k - 1]
            vals += [1 / h, -1 / h]
    backward = sp.csr_matrix((vals, (rows, cols)), shape=(n, n)).tolil()
    bounds = np.concatenate([[-1], impacts, [n - 1]])
    segments = list(zip(bounds[:-1] + 1, bounds[1:]))
    for first, _ in segments:
        backward[first] = backward[first + 1] if first == 0 else 0.5 * (backward[first - 1] + backward[first + 1])
    backward = backward.tocsr()
    # forward difference of the velocities over each interval; a segment's last sample repeats it
    rows, cols, vals = [], [], []
    for first, last in segments:
        for k in range(first, last + 1):
            i = min(k, last - 1)
            h = t[i + 1] - t[i]
            rows += [k, k]
            cols += [i + 1, i]
            vals += [1 / h, -1 / h]
    forward = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    to_samples = sp.csr_matrix((np.ones(n), (np.arange(n), instant)), shape=(n, instant[-1] + 1))
    V = (backward @ to_samples).tocsr()
    return V, (forward @ V).tocsr(), instant


def _smoothness_metric(instants: int, joints: int) -> sp.csc_matrix:
    second = sp.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(max(instants - 2, 0), instants))
    D2 = sp.kron(second, sp.eye(joints))
    return (sp.eye(instants * joints) + SMOOTHNESS * (D2.T @ D2)).tocsc()


def _torque_rows(robot: Robot, q: np.ndarray, A: sp.csr_matrix, samples: np.ndarray, rows_of: np.ndarray, upper: np.ndarray) -> sp.csr_matrix:
    """d tau / d angles of joint ``upper[rows_of[i]]`` at ``samples[i]``: its inertia row
    times the acceleration map (velocity-dependent terms left out; the iteration picks them
    up)."""
    model, data = robot.model, robot.model.createData()
    m = len(upper)
    inertia = {}
    rows, cols, vals = [], [], []
    for i, (k, a) in enumerate(zip(samples, rows_of)):
        if k not in inertia:
            M = pin.crba(model, data, q[k])
            inertia[k] = (np.triu(M) + np.triu(M, 1).T)[np.ix_(6 + upper, 6 + upper)]  # crba may fill only the upper triangle
        row = A.getrow(k)
        rows.append(np.full(m * row.nnz, i))
        cols.append((row.indices[:, None] * m + np.arange(m)).ravel())
        vals.append(np.outer(row.data, inertia[k][a]).ravel())
    shape = (len(samples), A.shape[1] * m)
    if not rows:
        return sp.csr_matrix(shape)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape)


def _solve_qp(H: sp.csc_matrix, C: sp.csc_matrix, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
    """argmin ½ xᵀHx subject to lower ≤ Cx ≤ upper with ProxQP, or None if it finds none."""
    qp = proxqp.sparse.QP(H.shape[0], 0, C.shape[0])
    qp.settings.eps_abs = QP_TOLERANCE
    qp.settings.max_iter = QP_MAX_ITERATIONS
    qp.settings.max_iter_in = QP_MAX_INNER_ITERATIONS
    # the KKT systems are banded (each row couples a few neighbouring instants): a sparse
    # factorisation, not the matrix-free backend ProxQP may pick for large problems
    qp.settings.sparse_backend = proxqp.SparseBackend.SparseCholesky
    qp.init(H, np.zeros(H.shape[0]), None, None, C, lower, upper)
    qp.solve()
    return qp.results.x.copy() if qp.results.info.status == proxqp.PROXQP_SOLVED else None


def _limited_values(robot: Robot, t, q, contact, impacts, intervals: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The upper body's torques on each interval, then its velocities at each sample, as
    one vector (sample-major)."""
    v, tau, _ = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=impacts)
    return np.concatenate([tau[intervals][:, upper].ravel(), v[:, 6 + upper].ravel()])


def limit_upper_body(
    robot: Robot, t: np.ndarray, q: np.ndarray, *, contact: np.ndarray, impacts: np.ndarray, margin: float = MARGIN
) -> tuple[np.ndarray, dict]:
    """``q`` with the upper body's angles changed as little and as smoothly as possible so
    they stay within their position limits, and their inverse-dynamics torques and
    velocities within ``margin`` of theirs.

    Returns the corrected configurations and a report: the upper body's worst torque and
    velocity ratios and position excess (rad) before and after, the largest change (rad)
    and the QPs solved.  Where no change brings them within (a QP is infeasible, or the
    linearisation fails), the iterate that exceeds the limits least is returned and the
    report says by how much.
    """
    upper = robot.upper_body_joint_indices()
    V, A, instant = difference_operators(t, impacts)
    m, u = len(upper), instant[-1] + 1
    H = _smoothness_metric(u, m)
    velocity_rows = sp.kron(V, sp.eye(m)).tocsr()
    intervals = np.flatnonzero(np.r_[np.diff(t) > 0, False])  # a segment's last sample repeats its interval
    n_tau, n_v = len(intervals) * m, len(t) * m
    limit = np.concatenate([np.tile(robot.tau_max[upper], len(intervals)), np.tile(robot.v_max[upper], len(t))])
    first = np.unique(instant, return_index=True)[1]  # a sample of each instant
    angles = q[first][:, 7 + upper].ravel()
    low = np.tile(robot.q_lower[upper], u) - angles  # the position limits as bounds on the change
    high = np.tile(robot.q_upper[upper], u) - angles
    x = np.zeros(u * m)
    before, best, solved = None, None, 0
    near, near_position = np.zeros(n_tau + n_v, dtype=bool), np.zeros(u * m, dtype=bool)
    for iteration in range(ITERATIONS + 1):
        corrected = q.copy()
        corrected[:, 7 + upper] += x.reshape(u, m)[instant]
        value = _limited_values(robot, t, corrected, contact, impacts, intervals, upper)
        ratio = np.abs(value) / limit
        excess = max(float(np.max(x - high)), float(np.max(low - x)), 0.0)
        worst = {"torque_ratio": float(ratio[:n_tau].max()), "velocity_ratio": float(ratio[n_tau:].max()), "position_excess_rad": excess}
        before = before or worst
        over = max(ratio.max() - margin, 0.0) + excess
        if best is None or over < best[0]:
            best = (over, corrected, worst, x)
        if (ratio.max() <= margin * (1 + TOLERANCE) and excess <= POSITION_TOLERANCE) or iteration == ITERATIONS:
            break
        # the rows near their limits, linearised about the current correction; a row once
        # near stays in, so the iteration cannot undo what it fixed
        near |= ratio > NEAR * margin
        near_position |= (x > high - POSITION_NEAR) | (x < low + POSITION_NEAR)
        rows, angle = np.flatnonzero(near), np.flatnonzero(near_position)
        torque = rows[rows < n_tau]
        C = sp.vstack([
            _torque_rows(robot, corrected, A, intervals[torque // m], torque % m, upper),
            velocity_rows[rows[len(torque) :] - n_tau],
            sp.eye(u * m, format="csr")[angle],
        ]).tocsc()
        offset = C[: len(rows)] @ x - value[rows]
        bound = margin * limit[rows]
        solution = _solve_qp(H, C, np.r_[offset - bound, low[angle]], np.r_[offset + bound, high[angle]])
        if solution is None:
            break  # no change within the limits (a joint's gravity torque alone over them): keep the best
        x = solution
        solved += 1
    _, corrected, worst, x = best
    report = {f"{key}_before": value for key, value in before.items()} | {f"{key}_after": value for key, value in worst.items()}
    return corrected, report | {"largest_change_rad": float(np.abs(x).max()), "qps_solved": solved}
