"""Static double-support postures by inverse kinematics: initial guesses and rest poses."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.errors import Error
from cocomopl.robot import Robot


def double_support_posture(
    robot: Robot,
    left_xy: tuple[float, float],
    right_xy: tuple[float, float],
    com_xy: tuple[float, float] | None = None,
) -> np.ndarray:
    """A posture with both soles flat on the ground at the given (x, y) positions.

    The CoM is placed horizontally at ``com_xy`` (default: midway between the feet).

    Raises
    ------
    Error
        If the feet cannot be placed there (the robot cannot reach that stance).
    """
    if com_xy is None:
        com_xy = (0.5 * (left_xy[0] + right_xy[0]), 0.5 * (left_xy[1] + right_xy[1]))
    feet = {side: np.array([xy[0], xy[1], 0.0]) for side, xy in (("left", left_xy), ("right", right_xy))}
    q = robot.q_ref.copy()
    q[0:2] = com_xy
    return inverse_kinematics(robot, feet, com_xy, q)


def inverse_kinematics(
    robot: Robot,
    feet: dict[str, np.ndarray],
    com_xy: tuple[float, float],
    q_init: np.ndarray,
    iterations: int = 200,
    check: bool = True,
) -> np.ndarray:
    """A posture with flat soles at the positions ``feet[side]`` (3,) and the CoM above ``com_xy``.

    Damped Gauss-Newton on the tasks; the remaining joints (arms, head, base height) are
    pulled towards the reference posture in the tasks' null space.

    Raises
    ------
    Error
        If the tasks cannot be met (the robot cannot reach that stance).
    With ``check=False`` the best effort is returned (a warm start need not be exact).
    """
    model, data = robot.model, robot.model.createData()
    targets = {robot.foot_frames[side]: pin.SE3(np.eye(3), np.asarray(p, dtype=float)) for side, p in feet.items()}
    q = q_init.copy()
    step_ref = 0.1
    for _ in range(iterations):
        pin.framesForwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        residuals, jacobians = [], []
        for frame, target in targets.items():
            err = pin.log6(target.actInv(data.oMf[frame])).vector
            J = pin.Jlog6(target.actInv(data.oMf[frame])) @ pin.getFrameJacobian(model, data, frame, pin.LOCAL)
            residuals.append(err)
            jacobians.append(J)
        com = pin.centerOfMass(model, data, q)
        Jcom = pin.jacobianCenterOfMass(model, data, q)
        residuals.append(com[:2] - np.asarray(com_xy))
        jacobians.append(Jcom[:2])
        r, J = np.concatenate(residuals), np.vstack(jacobians)
        # tasks first; the posture of the remaining joints (arms, head, base height) is
        # pulled towards the reference only in the tasks' null space
        J_pinv = np.linalg.pinv(J, rcond=1e-6)
        to_ref = -pin.difference(model, robot.q_ref, q)
        to_ref[:6] = 0.0
        dq = -J_pinv @ r + step_ref * (to_ref - J_pinv @ (J @ to_ref))
        q = pin.integrate(model, q, dq)
        q[7:] = np.clip(q[7:], robot.q_lower, robot.q_upper)
        if np.linalg.norm(dq) < 1e-10:
            break
    n_foot_rows = 6 * len(feet)
    if check and np.abs(r[:n_foot_rows]).max() > 1e-4:
        raise Error(
            f"robot {robot.name!r} cannot place its feet at {[[round(float(c), 3) for c in p] for p in feet.values()]} "
            f"(foot placement error {np.abs(r[:n_foot_rows]).max():.3f} m)"
        )
    return q
