"""Where a walk puts its feet, seen from above: the landings it plans and the soles' poses
while they stand, for the report's top view and the video's floor marks."""

from __future__ import annotations

import math

import numpy as np

from cocomopl.dynamics import SIDES
from cocomopl.motion import Motion
from cocomopl.planning.footsteps import Landing
from cocomopl.robot import Robot


def sole_poses(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(x, y, yaw) of the (left, right) soles in the world, (n, 2, 3), for the states ``q`` (n, nq)."""
    placements = [[robot.frame_placement(qk, robot.foot_frames[side]) for side in SIDES] for qk in q]
    return np.array([[[*M.translation[:2], math.atan2(M.rotation[1, 0], M.rotation[0, 0])] for M in row]
                     for row in placements]).reshape(len(q), 2, 3)


def stances(robot: Robot, motion: Motion, *, first: bool = True) -> list[Landing]:
    """Each sole's pose at the middle of each of its contact phases, in time order; without
    ``first``, the phases that begin with the motion are left out (what it lands on only)."""
    phases = []
    for j, side in enumerate(SIDES):
        edges = np.diff(np.concatenate([[0], motion.contact[:, j].astype(int), [0]]))
        for begin, end in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            if first or begin > 0:
                phases.append((int(begin), (int(begin) + int(end) - 1) // 2, side))
    phases.sort()
    if not phases:
        return []
    poses = sole_poses(robot, motion.q[[middle for _, middle, _ in phases]])
    return [Landing(*(float(v) for v in poses[k, SIDES.index(side)]), side) for k, (_, _, side) in enumerate(phases)]


def start_soles(robot: Robot, motion: Motion) -> list[Landing]:
    """The (left, right) soles' poses at the motion's first sample."""
    return [Landing(*(float(v) for v in pose), side) for pose, side in zip(sole_poses(robot, motion.q[:1])[0], SIDES)]


def planned_landings(robot: Robot, motion: Motion) -> list[Landing]:
    """The landings ``motion`` plans: its plan's ``footsteps`` where it has them (a walk on
    landings or to a goal), else where its soles stand after each touchdown."""
    if motion.plan is not None and motion.plan.footsteps is not None:
        return [Landing(float(f["x_m"]), float(f["y_m"]), math.radians(f["yaw_deg"]), f["side"])
                for f in motion.plan.footsteps]
    return stances(robot, motion, first=False)


def sole_outline(robot: Robot, pose: Landing) -> np.ndarray:
    """The corners (4, 2) of the sole rectangle at ``pose``, world frame, counter-clockwise."""
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return robot.sole.corners() @ np.array([[c, s], [-s, c]]) + [pose.x, pose.y]
