"""Is a motion physically consistent and feasible?  Recomputed with Pinocchio from the
stored states, torques and wrenches alone: inverse dynamics, the contact wrenches' ZMP
against the support polygon, friction, unilateral forces, limits, and soles that stay put
while in contact.  Works on any motion, whoever produced it.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.dynamics import (
    SIDES,
    finite_difference_accelerations,
    inverse_dynamics_residual,
    sole_placements,
    zmp_from_wrenches,
)
from cocomopl.motion import Motion
from cocomopl.robot import Robot

# Tolerances, SI units.  A check passes when its worst value is on the right side.
TOLERANCES = {
    "inverse_dynamics_residual": 1e-6,  # N m / N, max |M a + h - S^T tau - J^T f|
    "zmp_margin": 0.0,  # m, min signed distance of the ZMP inside the support polygon (>=)
    # max |f_t| / (mu f_n) (<=): the OCPs' cone is linearised and penalised, and a solution
    # on its edge exceeds it by the solver's resolution (G1's corner stops: up to 7e-6)
    "friction_ratio": 1.0 + 1e-4,
    "min_normal_force": 0.0,  # N, min f_n of a foot in contact (>=)
    "joint_position_excess": 1e-3,  # rad beyond a limit (<=)
    "joint_velocity_ratio": 1.0,  # max |v| / v_max (<=)
    "torque_ratio": 1.0 + 1e-9,  # max |tau| / tau_max (<=)
    "stance_foot_slip": 0.005,  # m at 25 ms knots: see tolerances()
    "continuity": 5e-3,  # max state mismatch between consecutive steps (<=)
}
AT_LEAST = {"zmp_margin", "min_normal_force"}
# N: a contact force no larger than this is zero.  Where a sole unloads before it lifts,
# the solvers' penalised wrench cone leaves forces of a few mN of either sign, which
# would otherwise count as pulling and, divided by a zero normal force, as slipping
FORCE_RESOLUTION = 1e-2  # 1e-5 of TALOS's weight


def support_polygon(robot: Robot, q: np.ndarray, contact: np.ndarray) -> np.ndarray:
    """Corners (m, 2) of the convex hull of the soles in contact, counter-clockwise."""
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, q)
    return soles_polygon(robot, [data.oMf[robot.foot_frames[side]] for j, side in enumerate(SIDES) if contact[j]])


def soles_polygon(robot: Robot, placements: list[pin.SE3]) -> np.ndarray:
    """Corners (m, 2) of the convex hull of the soles at ``placements`` (world), counter-clockwise."""
    from scipy.spatial import ConvexHull

    points = np.array([(M.rotation @ np.array([c[0], c[1], 0.0]) + M.translation)[:2]
                       for M in placements for c in robot.sole.corners()])
    return points[ConvexHull(points).vertices]


def nearest_inside(polygon: np.ndarray, point: np.ndarray, inset: float = 0.0) -> np.ndarray:
    """``point`` (2,) if it lies inside the convex ``polygon``, else the polygon's nearest
    boundary point moved ``inset`` (m) towards the polygon's centre."""
    if polygon_margin(polygon, point) >= 0.0:
        return point
    starts, edges = polygon, np.roll(polygon, -1, axis=0) - polygon
    along = np.clip(np.einsum("ij,ij->i", point[None, :] - starts, edges) / np.einsum("ij,ij->i", edges, edges), 0, 1)
    candidates = starts + along[:, None] * edges
    nearest = candidates[np.argmin(np.linalg.norm(candidates - point[None, :], axis=1))]
    inward = polygon.mean(axis=0) - nearest
    return nearest + inset * inward / np.linalg.norm(inward)


def polygon_margin(polygon: np.ndarray, point: np.ndarray) -> float:
    """Signed distance of ``point`` inside a convex counter-clockwise polygon (negative outside)."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return float(np.min(np.einsum("ij,ij->i", normals, point[None, :] - polygon)))


def zmp_margins(robot: Robot, motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (m) of the contact wrenches' ZMP inside the support polygon on each
    interval of the motion (a touchdown's pre-impact sample starts none).

    Returns the intervals' first samples and their margins; NaN where no sole is in contact
    or the ZMP is undefined, and -inf where the soles span no polygon (a diverged solve
    throws them kilometres away, where the hull loses all precision).
    """
    from scipy.spatial import QhullError

    intervals = np.array([k for k in range(motion.n - 1) if motion.t[k + 1] > motion.t[k]])
    zmp = zmp_from_wrenches(sole_placements(robot, motion.q[intervals]), motion.wrenches[intervals])
    margins = np.full(len(intervals), np.nan)
    for i, k in enumerate(intervals):
        if motion.contact[k].any() and np.all(np.isfinite(zmp[i, :2])):
            try:
                margins[i] = polygon_margin(support_polygon(robot, motion.q[k], motion.contact[k]), zmp[i, :2])
            except (QhullError, ValueError):
                margins[i] = -np.inf
    return intervals, margins


def check_motion(robot: Robot, motion: Motion, friction: float) -> dict:
    """Worst values of every per-motion check."""
    intervals, margins = zmp_margins(robot, motion)
    a = finite_difference_accelerations(motion.t, motion.v)
    residual = inverse_dynamics_residual(
        robot, motion.q[intervals], motion.v[intervals], a=a[intervals], tau=motion.tau[intervals],
        wrenches=motion.wrenches[intervals]
    )
    soles = sole_placements(robot, motion.q)
    forces = motion.wrenches[intervals][..., :3]
    in_contact = motion.contact[intervals]
    forces = np.where(np.linalg.norm(forces, axis=-1, keepdims=True) <= FORCE_RESOLUTION, 0.0, forces)
    fn = forces[..., 2][in_contact]
    ft = np.linalg.norm(forces[..., :2], axis=-1)[in_contact]
    slip = 0.0
    for j in range(2):
        for _, first, last in motion.phases:
            if motion.contact[first:last, j].all():
                drift = np.linalg.norm(soles[first : last + 1, j] - soles[first, j], axis=1)
                slip = max(slip, float(drift.max()))
    q = motion.q[:, 7:]
    return {
        "inverse_dynamics_residual": float(np.abs(residual).max()),
        "zmp_margin": float(np.min(margins)),
        "friction_ratio": float(np.max(ft / (friction * np.maximum(fn, 1e-9)))),
        "min_normal_force": float(fn.min()),
        "joint_position_excess": float(max(np.max(robot.q_lower - q), np.max(q - robot.q_upper), 0.0)),
        "joint_velocity_ratio": float(np.max(np.abs(motion.v[:, 6:]) / robot.v_max)),
        "torque_ratio": float(np.max(np.abs(motion.tau) / robot.tau_max)),
        "stance_foot_slip": slip,
    }


def tolerances(dt: float = 0.025) -> dict:
    """Tolerances for a motion sampled every ``dt`` seconds.

    The stance-sole drift of an Euler-discretised contact grows linearly with the knot
    spacing (O(dt^2) per knot over T/dt knots), so its tolerance scales with ``dt``.
    """
    return {**TOLERANCES, "stance_foot_slip": TOLERANCES["stance_foot_slip"] * dt / 0.025}


def passes(name: str, value: float, limits: dict = TOLERANCES) -> bool:
    """Whether a check's worst value is within its tolerance."""
    limit = limits[name]
    return value >= limit if name in AT_LEAST else value <= limit


def violations(report: dict, limits: dict = TOLERANCES) -> list[str]:
    """The checks of a :func:`check_motion` report that fail."""
    return sorted(key for key, value in report.items() if not passes(key, value, limits))
