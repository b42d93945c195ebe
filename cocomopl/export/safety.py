"""Is a motion safe to send to a robot?  The gate in front of ``cocomopl export``.

Each check names what fails, where and by how much: joint position, velocity and torque
limits, the ZMP of the contact wrenches inside the support polygon, and the two feet
keeping clear of each other.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.analysis.feasibility import polygon_margin, support_polygon
from cocomopl.dynamics import sole_placements, zmp_from_wrenches
from cocomopl.motion import Motion
from cocomopl.robot import Robot

POSITION_TOLERANCE = 1e-3  # rad beyond a joint limit
FOOT_CLEARANCE = 0.01  # m between the two soles' outlines
LOW_FOOT = 0.05  # m: soles lower than this can collide in the horizontal plane


def _worst(values: np.ndarray) -> tuple[int, int]:
    """(sample, column) of the largest value."""
    k, j = np.unravel_index(int(np.argmax(values)), values.shape)
    return int(k), int(j)


def limit_violations(robot: Robot, motion: Motion) -> list[str]:
    """One line per exceeded limit kind, naming the worst joint, time and value."""
    out = []
    q = motion.q[:, 7:]
    excess = np.maximum(robot.q_lower - q, q - robot.q_upper)
    if excess.max() > POSITION_TOLERANCE:
        k, j = _worst(excess)
        out.append(
            f"{robot.joint_names[j]} reaches {q[k, j]:.3f} rad at t = {motion.t[k]:.2f} s, "
            f"outside its limits [{robot.q_lower[j]:.3f}, {robot.q_upper[j]:.3f}]"
        )
    for name, values, limit, unit in (
        ("velocity", motion.v[:, 6:], robot.v_max, "rad/s"),
        ("torque", motion.tau, robot.tau_max, "N m"),
    ):
        ratio = np.abs(values) / limit
        if ratio.max() > 1.0:
            k, j = _worst(ratio)
            out.append(
                f"{name} of {robot.joint_names[j]} reaches {ratio[k, j]:.2f}x its limit "
                f"({abs(values[k, j]):.1f} {unit}) at t = {motion.t[k]:.2f} s"
            )
    return out


def zmp_violation(robot: Robot, motion: Motion) -> list[str]:
    """The ZMP of the contact wrenches outside the support polygon (worst sample)."""
    intervals = np.flatnonzero(np.diff(motion.t) > 0)
    zmp = zmp_from_wrenches(sole_placements(robot, motion.q[intervals]), motion.wrenches[intervals])
    worst, at = np.inf, None
    for i, k in enumerate(intervals):
        if motion.contact[k].any() and np.all(np.isfinite(zmp[i, :2])):
            margin = polygon_margin(support_polygon(robot, motion.q[k], motion.contact[k]), zmp[i, :2])
            if margin < worst:
                worst, at = margin, k
    if at is None or worst >= 0:
        return []
    return [f"the ZMP leaves the support polygon by {-worst * 1000:.0f} mm at t = {motion.t[at]:.2f} s"]


def _outline(robot: Robot, placement_xy: np.ndarray, yaw: float) -> np.ndarray:
    """Corners (4, 2) of a sole grown by half the clearance, in the horizontal plane."""
    grow = FOOT_CLEARANCE / 2
    corners = robot.sole.corners() + np.sign(robot.sole.corners()) * grow
    c, s = np.cos(yaw), np.sin(yaw)
    return corners @ np.array([[c, s], [-s, c]]) + placement_xy


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Do two convex polygons overlap?  (Separating-axis test.)"""
    for polygon in (a, b):
        edges = np.roll(polygon, -1, axis=0) - polygon
        for normal in np.stack([-edges[:, 1], edges[:, 0]], axis=1):
            pa, pb = a @ normal, b @ normal
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def foot_collision(robot: Robot, motion: Motion) -> list[str]:
    """The two soles closer than ``FOOT_CLEARANCE`` while both are near the ground."""
    model, data = robot.model, robot.model.createData()
    for k, q in enumerate(motion.q):
        pin.framesForwardKinematics(model, data, q)
        soles = [data.oMf[robot.foot_frames[side]] for side in ("left", "right")]
        if max(M.translation[2] for M in soles) > LOW_FOOT:
            continue
        outlines = [_outline(robot, M.translation[:2], np.arctan2(M.rotation[1, 0], M.rotation[0, 0])) for M in soles]
        if _overlap(*outlines):
            return [f"the feet come within {FOOT_CLEARANCE * 1000:.0f} mm of each other at t = {motion.t[k]:.2f} s"]
    return []


def check_safe(robot: Robot, motion: Motion) -> list[str]:
    """Reasons the motion is unsafe for the robot, one line each; empty if it is safe."""
    return limit_violations(robot, motion) + zmp_violation(robot, motion) + foot_collision(robot, motion)
