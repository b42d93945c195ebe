"""Inverse kinematics, in one place for every stage.

* :func:`double_support_posture` and :func:`inverse_kinematics`: whole-body postures with
  the soles flat at given positions and the CoM above a point (the OCPs' warm starts and
  rest poses);
* :func:`place_legs`: the twelve leg joints and the pelvis height moved so each sole
  reaches its target, the rest of the body kept (the dynamics filter of generated walks and
  the Kajita baseline).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.dynamics import SIDES
from cocomopl.errors import Error
from cocomopl.robot import Robot

# Leg inverse kinematics (place_legs): Levenberg-Marquardt iterations and tolerances
IK_ITERATIONS = 20
IK_TOLERANCE = 1e-7
IK_REACHED = 1e-5  # m and rad of sole error: a sole this close to its footstep is on it
IK_DAMPING = 1e-8
# m of sole error traded for 1 m of pelvis height change in place_legs.  By default the
# height moves only when it must, as a pattern generator that prescribes the CoM height
# wants (the Kajita baseline); the dynamics filter passes a smaller weight of its own.
HEIGHT_WEIGHT = 1e-2


def double_support_posture(
    robot: Robot,
    left_xy: tuple[float, float],
    right_xy: tuple[float, float],
    *,
    com_xy: tuple[float, float] | None = None,
    yaws: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """A posture with both soles flat on the ground at the given (x, y) positions, turned by
    ``yaws`` = (left, right) (rad).

    The CoM is placed horizontally at ``com_xy`` (default: midway between the feet).

    Raises
    ------
    Error
        If the feet cannot be placed there (the robot cannot reach that stance).
    """
    if com_xy is None:
        com_xy = (0.5 * (left_xy[0] + right_xy[0]), 0.5 * (left_xy[1] + right_xy[1]))
    q = robot.q_ref.copy()
    q[0:2] = com_xy
    if yaws == (0.0, 0.0):
        feet = {side: np.array([xy[0], xy[1], 0.0]) for side, xy in (("left", left_xy), ("right", right_xy))}
    else:
        feet = {side: flat_placement(xy[0], xy[1], yaw) for side, xy, yaw in (("left", left_xy, yaws[0]),
                                                                              ("right", right_xy, yaws[1]))}
        # start the base facing between the feet
        q[3:7] = pin.Quaternion(flat_placement(0.0, 0.0, 0.5 * (yaws[0] + yaws[1])).rotation).coeffs()
    return inverse_kinematics(robot, feet, com_xy, q_init=q)


def inverse_kinematics(
    robot: Robot,
    feet: dict[str, np.ndarray | pin.SE3],
    com_xy: tuple[float, float],
    *,
    q_init: np.ndarray,
    iterations: int = 200,
    check: bool = True,
) -> np.ndarray:
    """A posture with the soles at ``feet[side]``, a position (3,) of a sole kept level and
    straight ahead or a placement, and the CoM above ``com_xy``.

    Damped Gauss-Newton on the tasks; the remaining joints (arms, head, base height) are
    pulled towards the reference posture in the tasks' null space.

    Raises
    ------
    Error
        If the tasks cannot be met (the robot cannot reach that stance).
    With ``check=False`` the best effort is returned (a warm start need not be exact).
    """
    model, data = robot.model, robot.model.createData()
    targets = {robot.foot_frames[side]: p if isinstance(p, pin.SE3) else pin.SE3(np.eye(3), np.asarray(p, dtype=float))
               for side, p in feet.items()}
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
            f"robot {robot.name!r} cannot place its feet at {[[round(float(c), 3) for c in t.translation] for t in targets.values()]} "
            f"(foot placement error {np.abs(r[:n_foot_rows]).max():.3f} m)"
        )
    return q


def leg_joints(robot: Robot) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per side, the (q, v) indices of the joints between the pelvis and that sole."""
    model = robot.model
    out = {}
    for side in SIDES:
        joints = [i + 2 for i in robot.leg_chain(side)]
        out[side] = (np.array([model.idx_qs[j] for j in joints]), np.array([model.idx_vs[j] for j in joints]))
    return out


def place_legs(
    robot: Robot,
    q: np.ndarray,
    targets: dict[str, pin.SE3],
    *,
    legs: dict,
    height_weight: float = HEIGHT_WEIGHT,
    data: pin.Data | None = None,
) -> np.ndarray:
    """``q`` with the legs moved so each sole reaches ``targets[side]``.

    Levenberg-Marquardt on the two 6-D sole errors with the twelve leg joints and the
    pelvis height.  The height is weakly held where it was, by ``height_weight`` (m of sole
    error per m of height): it gives way when a leg would otherwise have to stretch beyond
    its knee limit (long steps in double support).  ``data``, a ``robot.model`` data to work
    in, spares callers placing many samples its creation (0.2 ms, as long as the solve).
    """
    model = robot.model
    data = model.createData() if data is None else data
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


def check_reach(robot: Robot, lengths) -> None:
    """An :class:`Error` for a step length (m) beyond the longest the robot's description vouches for."""
    longest = max(lengths)
    if longest > robot.max_step_length:
        raise Error(
            f"step length {longest * 1000:g} mm is beyond {robot.name}'s reach "
            f"(at most {robot.max_step_length * 1000:g} mm, from its description)"
        )


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


def feet_distances(robot: Robot, q: np.ndarray) -> np.ndarray:
    """The smallest 3-D distance (m; negative where they overlap) between the two feet's meshes
    at each configuration of ``q`` (n, nq)."""
    feet = feet_geometry(robot)
    data, geometry_data = robot.model.createData(), pin.GeometryData(feet)
    distances = np.empty(len(q))
    for k, qk in enumerate(q):
        pin.computeDistances(robot.model, data, feet, geometry_data, qk)
        distances[k] = min(r.min_distance for r in geometry_data.distanceResults)
    return distances


def flat_placement(x: float, y: float, yaw: float) -> pin.SE3:
    """A sole's placement flat on the ground at (x, y), turned by ``yaw`` (rad) about the
    vertical (exactly level and straight ahead at yaw 0)."""
    rotation = np.eye(3) if yaw == 0.0 else pin.utils.rpyToMatrix(0.0, 0.0, yaw)
    return pin.SE3(rotation, np.array([x, y, 0.0]))


def soles_distance(robot: Robot, placements: dict[str, pin.SE3]) -> float:
    """Smallest 3-D distance (m; negative where they overlap) between the two feet's meshes
    with the soles at ``placements[side]``."""
    feet = feet_geometry(robot)
    geometry_data = pin.GeometryData(feet)
    for g, geometry in enumerate(feet.geometryObjects):
        side = next(s for s in SIDES if robot.model.frames[robot.foot_frames[s]].parentJoint == geometry.parentJoint)
        sole_in_joint = robot.model.frames[robot.foot_frames[side]].placement
        geometry_data.oMg[g] = placements[side] * sole_in_joint.inverse() * geometry.placement
    pin.computeDistances(feet, geometry_data)
    return min(r.min_distance for r in geometry_data.distanceResults)
