"""Crocoddyl action models for one knot of a walking step.

One function per cost or constraint; :func:`contact_knot`, :func:`impulse_knot` and
:func:`terminal_knot` assemble them.  Everything a user may tune lives in
:class:`~cocomopl.ocp.settings.OCPSettings`.  Constraints are imposed as in the paper's ``J_pen``: a Lagrangian
relaxation with quadratic barriers that vanish when the constraint holds, plus hard torque
bounds in the box-constrained solver.
"""

from __future__ import annotations

import crocoddyl
import numpy as np
import pinocchio as pin

from cocomopl.dynamics import GRAVITY
from cocomopl.errors import Error
from cocomopl.ocp.settings import OCPSettings
from cocomopl.robot import Robot

INF = 1e9  # crocoddyl barriers take finite bounds


def contact_6d(
    robot: Robot, state: crocoddyl.StateMultibody, side: str, *, placement: pin.SE3, nu: int, dt: float
) -> crocoddyl.ContactModel6D:
    """A flat, rigid sole contact at ``placement``.

    The contact is enforced at acceleration level; symplectic Euler integration lets the
    sole drift by O(dt |J'v|) per knot, and an optimiser learns to exploit that drift (a
    sliding stance foot saves torque).  Baumgarte feedback on the planned placement holds
    the sole in place.
    """
    # position gain 1/(4 dt^2), velocity gain 1/dt: the velocity error is removed within a
    # knot and the position drift is held to a few millimetres
    gains = np.array([0.25 / dt**2, 1.0 / dt]) if dt > 0 else np.zeros(2)
    return crocoddyl.ContactModel6D(state, robot.foot_frames[side], placement, pin.LOCAL_WORLD_ALIGNED, nu, gains)


def torque_cost(state, nu: int) -> crocoddyl.CostModelResidual:
    """Eq. (1) of the paper: the integral of squared joint torques."""
    return crocoddyl.CostModelResidual(state, crocoddyl.ResidualModelControl(state, nu))


def posture_cost(robot: Robot, state, nu: int, *, x_ref: np.ndarray, settings: OCPSettings):
    """Weak pull towards a reference state; resolves null-space drift (a small J_pen term)."""
    upper = robot.upper_body_joint_indices()
    joints = np.full(robot.nu, settings.w_posture)
    joints[upper] = settings.w_upper_posture
    velocities = np.full(robot.model.nv, settings.w_velocity)
    velocities[6 + upper] = settings.w_upper_velocity
    weights = np.concatenate(
        [
            np.zeros(3),  # base position is free: the step moves it
            10.0 * np.ones(3),  # base orientation
            joints,
            velocities,
        ]
    )
    residual = crocoddyl.ResidualModelState(state, x_ref, nu)
    return crocoddyl.CostModelResidual(state, crocoddyl.ActivationModelWeightedQuad(weights**2), residual)


def wrench_cone_cost(robot: Robot, state, side: str, *, nu: int, settings: OCPSettings):
    """Friction cone, unilateral normal force and ZMP/CoP inside the sole with a margin."""
    sole = robot.sole
    half_length = min(sole.front, sole.back) - settings.zmp_margin
    half_width = sole.half_width - settings.zmp_margin
    cone = crocoddyl.WrenchCone(np.eye(3), settings.friction, np.array([2 * half_length, 2 * half_width]), 4, True)
    residual = crocoddyl.ResidualModelContactWrenchCone(state, robot.foot_frames[side], cone, nu, True)
    activation = crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(cone.lb, cone.ub))
    return crocoddyl.CostModelResidual(state, activation, residual)


def load_transfer_cost(robot: Robot, state, side: str, *, force: float, nu: int) -> crocoddyl.CostModelResidual:
    """Pull on the vertical force of ``side``'s sole towards ``force`` (N)."""
    residual = crocoddyl.ResidualModelContactForce(
        state, robot.foot_frames[side], pin.Force(np.array([0.0, 0.0, force, 0.0, 0.0, 0.0])), 6, nu, True
    )
    vertical = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    return crocoddyl.CostModelResidual(state, crocoddyl.ActivationModelWeightedQuad(vertical), residual)


def knee_bounds(robot: Robot, min_flexion: float) -> tuple[np.ndarray, np.ndarray]:
    """The joint position limits (nu,) each, rad, with both knees kept bent by at least
    ``min_flexion`` from straight (0 rad), on the side their limits allow them to bend to."""
    lower, upper = robot.q_lower.copy(), robot.q_upper.copy()
    for roles in robot.leg_roles().values():
        j = roles["knee"]
        if abs(lower[j]) <= abs(upper[j]):  # bends towards positive angles
            lower[j] = max(lower[j], min_flexion)
        else:
            upper[j] = min(upper[j], -min_flexion)
    if np.any(lower > upper):
        raise Error(f"a knee bend of at least {min_flexion:g} rad is beyond {robot.name}'s knee limits")
    return lower, upper


def joint_limit_cost(robot: Robot, state, nu: int, *, settings: OCPSettings):
    """Joint position and velocity limits from the URDF, as a barrier on the state.

    A penalty barrier tolerates small violations, so it starts inside the limits by a
    margin; the true limits then hold (``cocomopl dataset check`` verifies it).  The knees
    keep ``settings.min_knee_flexion`` (:func:`knee_bounds`).
    """
    q_margin, v_scale = settings.position_limit_margin, settings.velocity_limit_scale
    q_lower, q_upper = knee_bounds(robot, settings.min_knee_flexion)
    lower = np.concatenate([-INF * np.ones(6), q_lower + q_margin, -INF * np.ones(6), -v_scale * robot.v_max])
    upper = np.concatenate([INF * np.ones(6), q_upper - q_margin, INF * np.ones(6), v_scale * robot.v_max])
    # the residual from the neutral state is, for revolute joints, the angles and velocities
    residual = crocoddyl.ResidualModelState(state, state.zero(), nu)
    activation = crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(lower, upper, 1.0))
    return crocoddyl.CostModelResidual(state, activation, residual)


def swing_clearance_cost(robot: Robot, state, swing: str, *, nu: int, min_height: float, min_lateral: float | None,
                         stance_y: float):
    """Swing sole above ``min_height`` and, unless ``min_lateral`` is None, at least
    ``min_lateral`` beside the stance sole at ``stance_y`` (m): its lane."""
    lower = np.array([-INF, -INF, min_height])
    upper = np.array([INF, INF, INF])
    if min_lateral is not None and swing == "left":  # the left sole passes on the stance sole's left
        lower[1] = stance_y + min_lateral
    elif min_lateral is not None:
        upper[1] = stance_y - min_lateral
    residual = crocoddyl.ResidualModelFrameTranslation(state, robot.foot_frames[swing], np.zeros(3), nu)
    activation = crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(lower, upper))
    return crocoddyl.CostModelResidual(state, activation, residual)


def _sole_outline(robot: Robot) -> np.ndarray:
    """The (4, 3) corners of a sole in its own frame, counter-clockwise seen from above."""
    sole = robot.sole
    return np.array([[sole.front, sole.half_width, 0.0], [-sole.back, sole.half_width, 0.0],
                     [-sole.back, -sole.half_width, 0.0], [sole.front, -sole.half_width, 0.0]])


def sole_corners(robot: Robot, placement: pin.SE3) -> np.ndarray:
    """The (4, 3) corners of a sole at ``placement``, world frame, in order round its edge."""
    return placement.translation + _sole_outline(robot) @ placement.rotation.T


_FLIP = np.array([1.0, -1.0])  # (dx, dy) turned to (dy, -dx): outward of a counter-clockwise edge


def _edge_normals(polygon: np.ndarray) -> np.ndarray:
    """The outward unit normals (n, 2) on the ground of a counter-clockwise polygon's edges."""
    ground = polygon[:, :2]
    step = np.concatenate((ground[1:], ground[:1])) - ground
    return step[:, ::-1] * (_FLIP / np.hypot(step[:, 0], step[:, 1])[:, None])


def polygons_gap(a: np.ndarray, b: np.ndarray, b_normals: np.ndarray | None = None,
                 ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, bool]:
    """How far apart two convex polygons are on the ground, by their separating axes.

    ``a`` and ``b`` are corners (n, 3) in counter-clockwise order seen from above; only x and
    y count.  Along each edge normal u of either polygon (pointing from ``b`` towards ``a``)
    the polygons are ``min(u . a) - max(u . b)`` apart; the gap is the largest of these: the
    distance between polygons apart beside each other (less where they are closest corner to
    corner), minus the depth of the overlap of overlapping ones, and continuous between.
    ``b_normals`` are ``b``'s edge normals, when known.

    Returns the gap (m), that axis u (3,), the corner of ``a`` and of ``b`` that set it, and
    whether u is the normal of an edge of ``a`` (which turns with ``a``).
    """
    b_normals = _edge_normals(b) if b_normals is None else b_normals
    axes = np.concatenate((b_normals, -_edge_normals(a)))
    on_a, on_b = a[:, :2] @ axes.T, b[:, :2] @ axes.T  # (corners, axes)
    separation = on_a.min(axis=0) - on_b.max(axis=0)
    k = int(separation.argmax())
    axis = np.array([axes[k, 0], axes[k, 1], 0.0])
    return float(separation[k]), axis, a[on_a[:, k].argmin()], b[on_b[:, k].argmax()], k >= len(b)


def soles_gap(robot: Robot, swing: pin.SE3, stance: pin.SE3) -> float:
    """The gap (m) on the ground between the soles' rectangles at ``swing`` and ``stance``
    (:func:`polygons_gap`)."""
    return polygons_gap(sole_corners(robot, swing), sole_corners(robot, stance))[0]


class SoleGapData(crocoddyl.ResidualDataAbstract):
    """A residual's data that also keeps what :meth:`SoleGapResidual.calc` found for its ``calcDiff``."""

    def __init__(self, model, collector):
        super().__init__(model, collector)
        self.gap_parts: tuple = ()


class SoleGapResidual(crocoddyl.ResidualModelAbstract):
    """The gap (m) between the swing sole and the stance sole at ``stance`` (:func:`soles_gap`).

    The soles' rectangles, not the feet's meshes: a gap and its gradient in closed form at
    every knot, also where they overlap, so that a swing guessed through the other foot is
    pushed out of it.  The gradient is exact for a level swing sole; how a tilted sole's edges
    turn on the ground is left out (a 2 % error at 0.1 rad of random joint noise).
    """

    def __init__(self, robot: Robot, state, swing: str, *, stance: pin.SE3, nu: int):
        super().__init__(state, 1, nu, True, False, False)
        self._model = robot.model
        self._frame = robot.foot_frames[swing]
        self._outline = _sole_outline(robot)
        self._stance = sole_corners(robot, stance)
        self._stance_normals = _edge_normals(self._stance)

    def createData(self, collector):
        return SoleGapData(self, collector)

    def calc(self, data, x, u=None):
        # as crocoddyl's own frame residuals do: the dynamics leave the frames' placements stale
        placement = pin.updateFramePlacement(self._model, data.shared.pinocchio, self._frame)
        origin = placement.translation
        corners = origin + self._outline @ placement.rotation.T
        # a diverged iterate's NaN gap: the solver rejects it, as it does its own
        with np.errstate(invalid="ignore", divide="ignore"):
            gap, axis, on_swing, on_stance, turns = polygons_gap(corners, self._stance, self._stance_normals)
        data.gap_parts = (axis, on_swing, on_stance, turns, origin)
        data.r[0] = gap

    def calcDiff(self, data, x, u=None):
        # crocoddyl calls calcDiff after calc at the same x, as its own residuals assume
        axis, on_swing, on_stance, turns, origin = data.gap_parts
        jacobian = pin.getFrameJacobian(self._model, data.shared.pinocchio, self._frame, pin.LOCAL_WORLD_ALIGNED)
        # the velocity of the swing sole's corner, not of the sole frame's origin: u . (v + w x c) = u . v + (c x u) . w
        (ux, uy, _), (cx, cy, cz) = axis, on_swing - origin
        gradient = axis @ jacobian[:3] + np.array([-cz * uy, cz * ux, cx * uy - cy * ux]) @ jacobian[3:]
        if turns:  # the axis is an edge normal of the swing sole and turns with it: u x (corner - corner)
            (dx, dy, _) = on_swing - on_stance
            gradient += (ux * dy - uy * dx) * jacobian[5]
        data.Rx[..., : self._model.nv] = gradient  # (1, ndx), which the bindings show as (ndx,)


def sole_gap_cost(robot: Robot, state, swing: str, *, stance: pin.SE3, nu: int, min_gap: float):
    """The swing sole at least ``min_gap`` (m) from the stance sole at ``stance`` (:func:`soles_gap`)."""
    activation = crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(np.array([min_gap]), np.array([INF])))
    return crocoddyl.CostModelResidual(state, activation, SoleGapResidual(robot, state, swing, stance=stance, nu=nu))


def foot_placement_cost(robot: Robot, state, side: str, *, placement: pin.SE3, nu: int):
    """Sole at a placement (position and flat orientation)."""
    residual = crocoddyl.ResidualModelFramePlacement(state, robot.foot_frames[side], placement, nu)
    return crocoddyl.CostModelResidual(state, residual)


def state_target_cost(state, x_target: np.ndarray, nu: int):
    """The whole state equal to a target: continuity with the neighbouring step."""
    return crocoddyl.CostModelResidual(state, crocoddyl.ResidualModelState(state, x_target, nu))


def contact_knot(
    robot: Robot,
    state: crocoddyl.StateMultibody,
    stance: dict[str, pin.SE3],
    *,
    x_ref: np.ndarray,
    settings: OCPSettings,
    dt: float,
    swing: str | None = None,
    swing_guide: pin.SE3 | None = None,
    clearance: float = 0.0,
    sole_gap: float | None = None,
    x_target: np.ndarray | None = None,
    load_shares: dict[str, float] | None = None,
) -> crocoddyl.IntegratedActionModelEuler:
    """One knot of a double-support (two stance feet) or single-support (one) phase.

    ``stance`` maps each foot in contact to its sole placement.

    With ``dt == 0`` it is a terminal knot: only state costs count, and ``x_target``
    pins the state (continuity with the neighbouring step).  ``load_shares`` maps stance
    feet to the fraction of the body weight their soles should carry at this knot
    (:func:`cocomopl.ocp.problems.load_shares`).  In single support the ``swing`` sole keeps
    above ``clearance`` (m) and in its lane beside the stance sole or, given ``sole_gap`` (m),
    that far from it (:func:`soles_gap`).
    """
    terminal = dt == 0.0
    actuation = crocoddyl.ActuationModelFloatingBase(state)
    nu = actuation.nu
    contacts = crocoddyl.ContactModelMultiple(state, nu)
    costs = crocoddyl.CostModelSum(state, nu)
    for side, placement in stance.items():
        contacts.addContact(f"{side}_contact", contact_6d(robot, state, side, placement=placement, nu=nu, dt=dt))
        # the discretised contact lets a sole creep; an optimiser would use that to save
        # torque, so the sole is also held at its placement by a stiff penalty
        costs.addCost(f"{side}_anchor", foot_placement_cost(robot, state, side, placement=placement, nu=nu),
                      settings.w_anchor)
        if not terminal:
            costs.addCost(f"{side}_wrench_cone", wrench_cone_cost(robot, state, side, nu=nu, settings=settings),
                          settings.w_constraint)
        if not terminal and load_shares is not None and settings.w_load_transfer > 0:
            load = load_shares[side] * robot.mass * GRAVITY
            costs.addCost(f"{side}_load", load_transfer_cost(robot, state, side, force=load, nu=nu),
                          settings.w_load_transfer)
    if not terminal:
        costs.addCost("torque", torque_cost(state, nu), settings.w_torque)
    if x_target is not None:
        costs.addCost("continuity", state_target_cost(state, x_target, nu), settings.w_target)
    costs.addCost("posture", posture_cost(robot, state, nu, x_ref=x_ref, settings=settings), 1.0)
    costs.addCost("joint_limits", joint_limit_cost(robot, state, nu, settings=settings), settings.w_limits)
    if swing is not None:
        (support,) = stance.values()  # single support: one stance sole
        costs.addCost(
            "swing_clearance",
            swing_clearance_cost(
                robot,
                state,
                swing,
                nu=nu,
                min_height=clearance,
                min_lateral=settings.swing_lateral_gap + 2 * robot.sole.half_width if sole_gap is None else None,
                stance_y=support.translation[1],
            ),
            settings.w_constraint * 10,
        )
        if sole_gap is not None:
            costs.addCost("sole_gap", sole_gap_cost(robot, state, swing, stance=support, nu=nu, min_gap=sole_gap),
                          settings.w_sole_gap)
        if swing_guide is not None:
            costs.addCost("swing_guide", foot_placement_cost(robot, state, swing, placement=swing_guide, nu=nu),
                          settings.w_swing_guide)
    dynamics = crocoddyl.DifferentialActionModelContactFwdDynamics(state, actuation, contacts, costs, 0.0, True)
    model = crocoddyl.IntegratedActionModelEuler(dynamics, dt)
    model.u_lb = -robot.tau_max
    model.u_ub = robot.tau_max
    return model


def impulse_knot(
    robot: Robot,
    state: crocoddyl.StateMultibody,
    landing: str,
    *,
    placement: pin.SE3,
    x_ref: np.ndarray,
    settings: OCPSettings,
) -> crocoddyl.ActionModelImpulseFwdDynamics:
    """Touchdown: the swing sole lands flat at ``placement``; both feet get an impulse."""
    impulses = crocoddyl.ImpulseModelMultiple(state)
    for side in ("left", "right"):
        impulses.addImpulse(
            f"{side}_impulse",
            crocoddyl.ImpulseModel6D(state, robot.foot_frames[side], pin.LOCAL_WORLD_ALIGNED),
        )
    costs = crocoddyl.CostModelSum(state, 0)
    costs.addCost("landing", foot_placement_cost(robot, state, landing, placement=placement, nu=0),
                  settings.w_placement)
    costs.addCost("posture", posture_cost(robot, state, 0, x_ref=x_ref, settings=settings), 1.0)
    # the pre-impact state is no running knot's input: limits and a soft touchdown here
    costs.addCost("joint_limits", joint_limit_cost(robot, state, 0, settings=settings), settings.w_limits * settings.dt)
    touchdown = crocoddyl.ResidualModelFrameVelocity(
        state, robot.foot_frames[landing], pin.Motion.Zero(), pin.LOCAL_WORLD_ALIGNED, 0
    )
    costs.addCost("touchdown_velocity", crocoddyl.CostModelResidual(state, touchdown), settings.w_touchdown)
    model = crocoddyl.ActionModelImpulseFwdDynamics(state, impulses, costs)
    return model
