"""Is a motion safe to send to a robot?  The gate in front of ``cocomopl export``.

:func:`safety_report` gives the worst value of each check and where it happens; the
checks are joint position, velocity and torque limits, the ZMP of the contact wrenches
inside the support polygon, and the 3-D distance between the two feet's meshes (Coal,
through Pinocchio's geometry model), at every sample.  :func:`check_safe` turns the
failed checks into one line each, naming what fails, where and by how much.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.analysis.feasibility import zmp_margins
from cocomopl.dynamics import SIDES
from cocomopl.errors import Error
from cocomopl.motion import Motion
from cocomopl.robot import Robot

POSITION_TOLERANCE = 1e-3  # rad beyond a joint limit
FOOT_CLEARANCE = 0.01  # m between the two feet's meshes


def _worst_joint(robot: Robot, motion: Motion, values: np.ndarray) -> dict:
    """The largest of ``values`` (n, nu): its value, time and joint."""
    k, j = np.unravel_index(int(np.argmax(values)), values.shape)
    return {"value": float(values[k, j]), "t": float(motion.t[k]), "joint": robot.joint_names[j], "sample": int(k)}


def zmp_margin(robot: Robot, motion: Motion) -> dict:
    """Smallest signed distance (m) of the contact wrenches' ZMP inside the support polygon,
    and when (``inf`` if it is nowhere defined)."""
    intervals, margins = zmp_margins(robot, motion)
    if np.all(np.isnan(margins)):
        return {"value": np.inf, "t": float(motion.t[0])}
    i = int(np.nanargmin(margins))
    return {"value": float(margins[i]), "t": float(motion.t[intervals[i]])}


def feet_geometry(robot: Robot) -> pin.GeometryModel:
    """The meshes of the two links that carry the soles, each left mesh paired with each right one."""
    visual = robot.visual_model()
    feet = pin.GeometryModel()
    ids = {}
    for side in SIDES:
        joint = robot.model.frames[robot.foot_frames[side]].parentJoint
        meshes = [g for g in visual.geometryObjects if g.parentJoint == joint]
        if not meshes:
            raise Error(f"robot {robot.name!r} has no mesh on its {side} foot to check the feet against each other")
        ids[side] = [feet.addGeometryObject(g) for g in meshes]
    for a in ids[SIDES[0]]:
        for b in ids[SIDES[1]]:
            feet.addCollisionPair(pin.CollisionPair(a, b))
    return feet


def foot_distance(robot: Robot, motion: Motion) -> dict:
    """Smallest 3-D distance (m) between the two feet over the motion, and when."""
    feet = feet_geometry(robot)
    data, geometry_data = robot.model.createData(), pin.GeometryData(feet)
    distances = np.empty(motion.n)
    for k, q in enumerate(motion.q):
        pin.computeDistances(robot.model, data, feet, geometry_data, q)
        distances[k] = min(r.min_distance for r in geometry_data.distanceResults)
    k = int(np.argmin(distances))
    return {"value": float(max(distances[k], 0.0)), "t": float(motion.t[k])}  # Coal reports penetration as < 0


def safety_report(robot: Robot, motion: Motion) -> dict:
    """Worst value of every safety check, and where it happens.

    Returns
    -------
    dict
        ``joint_position_excess`` (rad beyond a limit, 0 inside), ``joint_velocity_ratio``
        and ``torque_ratio`` (max of |value| / limit): each ``{"value", "t", "joint",
        "sample"}``; ``zmp_margin`` (m, negative outside the support polygon) and
        ``foot_distance`` (m between the feet's meshes): each ``{"value", "t"}``.
    """
    q = motion.q[:, 7:]
    excess = np.maximum(np.maximum(robot.q_lower - q, q - robot.q_upper), 0.0)
    return {
        "joint_position_excess": _worst_joint(robot, motion, excess),
        "joint_velocity_ratio": _worst_joint(robot, motion, np.abs(motion.v[:, 6:]) / robot.v_max),
        "torque_ratio": _worst_joint(robot, motion, np.abs(motion.tau) / robot.tau_max),
        "zmp_margin": zmp_margin(robot, motion),
        "foot_distance": foot_distance(robot, motion),
    }


def check_safe(robot: Robot, motion: Motion) -> list[str]:
    """Reasons the motion is unsafe for the robot, one line each; empty if it is safe."""
    report = safety_report(robot, motion)
    reasons = []
    position = report["joint_position_excess"]
    if position["value"] > POSITION_TOLERANCE:
        j = robot.joint_names.index(position["joint"])
        reasons.append(
            f"{position['joint']} reaches {motion.q[position['sample'], 7 + j]:.3f} rad at t = {position['t']:.2f} s, "
            f"outside its limits [{robot.q_lower[j]:.3f}, {robot.q_upper[j]:.3f}]"
        )
    for name, key in (("velocity", "joint_velocity_ratio"), ("torque", "torque_ratio")):
        worst = report[key]
        if worst["value"] > 1.0:
            reasons.append(f"{name} of {worst['joint']} reaches {worst['value']:.2f}x its limit at t = {worst['t']:.2f} s")
    zmp = report["zmp_margin"]
    if zmp["value"] < 0.0:
        reasons.append(f"the ZMP leaves the support polygon by {-zmp['value'] * 1000:.0f} mm at t = {zmp['t']:.2f} s")
    feet = report["foot_distance"]
    if feet["value"] < FOOT_CLEARANCE:
        reasons.append(
            f"the feet come within {feet['value'] * 1000:.0f} mm of each other at t = {feet['t']:.2f} s "
            f"(at least {FOOT_CLEARANCE * 1000:.0f} mm needed)"
        )
    return reasons
