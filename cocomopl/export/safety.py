"""Is an exported motion safe to send to a robot?  The gate in front of ``cocomopl export``.

The gate checks exactly what is written: the 5 ms table of :mod:`cocomopl.export.grid`,
after it is formatted as text and read back (:func:`cocomopl.export.table.read_csv`).
Nothing is taken from the motion file on trust: the velocities and accelerations are
finite differences of the written positions, the torques the inverse dynamics of the
written motion under the written contact wrenches, and the limits those of the robot
loaded by cocomopl (bundled, or named on the command line), never an attribute of the
file.  :func:`safety_report` gives the worst value of each check and where it happens;
:func:`check_safe` turns the failures into one line each.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.analysis.feasibility import polygon_margin, support_polygon
from cocomopl.export.grid import GridMotion, configurations, finite_differences, joint_torques
from cocomopl.kinematics import feet_distances
from cocomopl.robot import Robot

POSITION_TOLERANCE = 1e-3  # rad beyond a joint limit
FOOT_CLEARANCE = 0.01  # m between the two feet's meshes


def _worst_joint(robot: Robot, grid: GridMotion, values: np.ndarray) -> dict:
    """The largest of ``values`` (n, nu): its value, time and joint."""
    k, j = np.unravel_index(int(np.argmax(values)), values.shape)
    return {"value": float(values[k, j]), "t": float(grid.t[k]), "joint": robot.joint_names[j], "sample": int(k)}


def non_finite(grid: GridMotion) -> list[str]:
    """The names of the arrays of ``grid`` that hold a NaN or an infinite value."""
    return [name for name, value in vars(grid).items() if not np.all(np.isfinite(value))]


def zmp_margin(robot: Robot, grid: GridMotion, q: np.ndarray) -> dict:
    """Smallest signed distance (m) of the written reference ZMP inside the support polygon
    of the soles the table says are in contact (``inf`` if no sole ever is)."""
    margins = np.full(len(grid.t), np.inf)
    for k in np.flatnonzero(grid.contact.any(axis=1)):
        world = grid.waist[k] + pin.rpy.rpyToMatrix(grid.waist_rpy[k]) @ grid.zmp[k]
        margins[k] = polygon_margin(support_polygon(robot, q[k], grid.contact[k] > 0.5), world[:2])
    k = int(np.argmin(margins))
    return {"value": float(margins[k]), "t": float(grid.t[k])}


def foot_distance(robot: Robot, grid: GridMotion, q: np.ndarray) -> dict:
    """Smallest 3-D distance (m) between the two feet's meshes, and when."""
    distances = feet_distances(robot, q)
    k = int(np.argmin(distances))
    return {"value": float(max(distances[k], 0.0)), "t": float(grid.t[k])}  # Coal reports penetration as < 0


def safety_report(robot: Robot, grid: GridMotion) -> dict:
    """Worst value of every safety check of a written table, and where it happens.

    Returns
    -------
    dict
        ``finite``: the arrays holding NaN or Inf (the other checks are left out if any);
        ``joint_position_excess`` (rad beyond a limit, 0 inside), ``joint_velocity_ratio``,
        ``torque_ratio`` (inverse dynamics) and ``written_torque_ratio`` (max of |value| /
        limit): each ``{"value", "t", "joint", "sample"}``; ``max_acceleration`` (rad/s^2,
        reported, the URDF gives no limit: accelerations enter the torques);
        ``zmp_margin`` (m, negative outside the support polygon) and ``foot_distance`` (m
        between the feet's meshes): each ``{"value", "t"}``; ``samples`` and ``dt``.
    """
    report = {"samples": len(grid.t), "dt": grid.dt, "finite": non_finite(grid)}
    if report["finite"] or len(grid.t) < 3:
        return report
    q = configurations(robot, grid.waist, grid.waist_rpy, joints=grid.joints)
    v, a = finite_differences(robot, q, grid.dt)
    wrenches = np.concatenate([grid.forces, grid.moments], axis=2)
    excess = np.maximum(np.maximum(robot.q_lower - grid.joints, grid.joints - robot.q_upper), 0.0)
    report.update({
        "joint_position_excess": _worst_joint(robot, grid, excess),
        "joint_velocity_ratio": _worst_joint(robot, grid, np.abs(v[:, 6:]) / robot.v_max),
        "max_acceleration": _worst_joint(robot, grid, np.abs(a[:, 6:])),
        "torque_ratio": _worst_joint(robot, grid,
                                     np.abs(joint_torques(robot, q, v, a=a, wrenches=wrenches)) / robot.tau_max),
        "written_torque_ratio": _worst_joint(robot, grid, np.abs(grid.torques) / robot.tau_max),
        "zmp_margin": zmp_margin(robot, grid, q),
        "foot_distance": foot_distance(robot, grid, q),
    })
    return report


def reasons_unsafe(robot: Robot, report: dict) -> list[str]:
    """The failed checks of a :func:`safety_report`, one line each; empty if it passes."""
    if report["finite"]:
        return [f"NaN or infinite values in the exported {', '.join(report['finite'])}"]
    if report["samples"] < 3:
        return [f"{report['samples']} samples are too few to check velocities and accelerations"]
    reasons = []
    position = report["joint_position_excess"]
    if position["value"] > POSITION_TOLERANCE:
        reasons.append(f"{position['joint']} goes {position['value']:.3f} rad beyond its limits at t = {position['t']:.3f} s")
    for name, key in (("velocity", "joint_velocity_ratio"), ("torque (inverse dynamics of the exported motion)",
                                                            "torque_ratio"), ("written torque", "written_torque_ratio")):
        worst = report[key]
        if worst["value"] > 1.0:
            reasons.append(f"{name} of {worst['joint']} reaches {worst['value']:.2f}x its limit at t = {worst['t']:.3f} s")
    zmp = report["zmp_margin"]
    if zmp["value"] < 0.0:
        reasons.append(f"the reference ZMP leaves the support polygon by {-zmp['value'] * 1000:.0f} mm "
                       f"at t = {zmp['t']:.3f} s")
    feet = report["foot_distance"]
    if feet["value"] < FOOT_CLEARANCE:
        reasons.append(f"the feet come within {feet['value'] * 1000:.0f} mm of each other at t = {feet['t']:.3f} s "
                       f"(at least {FOOT_CLEARANCE * 1000:.0f} mm needed)")
    return reasons


def check_safe(robot: Robot, grid: GridMotion) -> tuple[list[str], dict]:
    """Reasons the written table is unsafe for the robot (empty if it is safe) and the report."""
    report = safety_report(robot, grid)
    return reasons_unsafe(robot, report), report


def margins_text(report: dict) -> str:
    """One line of what the gate checked and the margins it found, for a passing motion."""
    return (
        f"checked {report['samples']} samples every {report['dt'] * 1000:.0f} ms: joint positions within limits "
        f"(worst {report['joint_position_excess']['value']:.4f} rad beyond), velocities at most "
        f"{report['joint_velocity_ratio']['value']:.2f} of their limits ({report['joint_velocity_ratio']['joint']}), "
        f"torques at most {report['torque_ratio']['value']:.2f} ({report['torque_ratio']['joint']}, inverse dynamics "
        f"of the exported motion), reference ZMP at least {report['zmp_margin']['value'] * 1000:.0f} mm inside the "
        f"support polygon, feet at least {report['foot_distance']['value'] * 1000:.0f} mm apart"
    )
