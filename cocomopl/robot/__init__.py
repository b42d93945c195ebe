"""The robot: a Pinocchio model, its feet, limits and left/right mirror map."""

from cocomopl.robot.description import DEFAULT_ROBOT, Robot, Sole, available_robots
from cocomopl.robot.mirror import (
    mirror_configuration,
    mirror_joints,
    mirror_motion,
    mirror_points,
    mirror_state,
    mirror_velocity,
    mirror_wrenches,
)

__all__ = [
    "DEFAULT_ROBOT",
    "Robot",
    "Sole",
    "available_robots",
    "mirror_configuration",
    "mirror_joints",
    "mirror_motion",
    "mirror_points",
    "mirror_state",
    "mirror_velocity",
    "mirror_wrenches",
]
