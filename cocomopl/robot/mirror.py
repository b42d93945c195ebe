"""Left/right mirroring about the sagittal plane ``y = 0`` of the frame a motion is in.

Every function accepts a single sample or a time series (leading axes) and is an exact
involution: applying it twice returns the input bit for bit.
"""

from __future__ import annotations

import numpy as np

from cocomopl.robot.description import Robot

# Reflection P = diag(1, -1, 1): vectors (positions, linear velocities, forces) flip y;
# pseudo-vectors (angular velocities, moments) transform as -P and so flip x and z.
_VECTOR = np.array([1.0, -1.0, 1.0])
_PSEUDO = np.array([-1.0, 1.0, -1.0])


def mirror_joints(robot: Robot, values: np.ndarray) -> np.ndarray:
    """Mirror actuated-joint values (angles, velocities or torques), shape (..., nu)."""
    return values[..., robot.mirror_perm] * robot.mirror_sign


def mirror_configuration(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Mirror configurations ``q = (base xyz, base quaternion xyzw, joints)``."""
    out = np.empty_like(q)
    out[..., 0:3] = q[..., 0:3] * _VECTOR
    # P R P as a quaternion: (x, y, z, w) -> (-x, y, -z, w)
    out[..., 3:7] = q[..., 3:7] * np.array([-1.0, 1.0, -1.0, 1.0])
    out[..., 7:] = mirror_joints(robot, q[..., 7:])
    return out


def mirror_velocity(robot: Robot, v: np.ndarray) -> np.ndarray:
    """Mirror generalized velocities or accelerations (base twist in the base frame, joints)."""
    out = np.empty_like(v)
    out[..., 0:3] = v[..., 0:3] * _VECTOR
    out[..., 3:6] = v[..., 3:6] * _PSEUDO
    out[..., 6:] = mirror_joints(robot, v[..., 6:])
    return out


def mirror_state(robot: Robot, x: np.ndarray) -> np.ndarray:
    """Mirror states ``x = (q, v)``."""
    nq = robot.model.nq
    return np.concatenate([mirror_configuration(robot, x[..., :nq]), mirror_velocity(robot, x[..., nq:])], axis=-1)


def mirror_wrenches(wrenches: np.ndarray) -> np.ndarray:
    """Mirror contact wrenches, shape (..., 2, 6) ordered (left, right), each (force, moment)
    expressed in world-aligned axes: the feet swap and the wrench reflects."""
    out = np.empty_like(wrenches)
    out[..., 0:3] = wrenches[..., ::-1, 0:3] * _VECTOR
    out[..., 3:6] = wrenches[..., ::-1, 3:6] * _PSEUDO
    return out


def mirror_points(points: np.ndarray) -> np.ndarray:
    """Mirror points or vectors (..., 3) such as the ZMP."""
    return points * _VECTOR


def mirror_motion(robot: Robot, motion):
    """The left/right mirror image of a :class:`~cocomopl.motion.Motion` about its frame's
    ``y = 0`` plane (for a step, the stance sole's)."""
    from dataclasses import replace

    return replace(
        motion,
        q=mirror_configuration(robot, motion.q),
        v=mirror_velocity(robot, motion.v),
        tau=mirror_joints(robot, motion.tau),
        wrenches=mirror_wrenches(motion.wrenches),
        contact=motion.contact[:, ::-1].copy(),
        zmp=mirror_points(motion.zmp),
        steps=[s.mirrored() for s in motion.steps],
        solution=None if motion.solution is None else replace(motion.solution, mirrored=not motion.solution.mirrored),
    )
