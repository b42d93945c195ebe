"""Controls of a warm start: the torques that realise a state trajectory on a step OCP's knots.

A generated walk's own torques split the weight between the soles in double support by the
least-norm rule of :func:`cocomopl.dynamics.inverse_dynamics_with_contacts`.  The step OCP
splits it differently: its load-transfer cost hands the weight over linearly, and its wrench
cones keep each sole's centre of pressure a margin inside the sole.  Given as an OCP's initial
controls, the least-norm torques cost 10-25 times the optimum's load-transfer term, and
centres of pressure past the margin cost more than the whole optimum (the cone barrier's
weight is 1e4 per squared newton).  So here each knot's contact wrenches are chosen as that
knot's own costs would choose them: least torque and load-transfer cost, inside the cones,
with the base rows of the dynamics met exactly.
"""

from __future__ import annotations

import crocoddyl
import numpy as np
import pinocchio as pin
from proxsuite import proxqp

from cocomopl.robot import Robot

REGULARISATION = 1e-8  # on the wrenches, so that the QP stays strictly convex
OPEN = 1e20  # an open side of a bound (the cones' open sides), as a finite number ProxQP accepts


def inverse_dynamics_controls(robot: Robot, problem: crocoddyl.ShootingProblem, xs: list[np.ndarray]) -> list[np.ndarray]:
    """The controls (one per running knot, empty at impulses) that give each knot of
    ``problem`` the acceleration between its state and the next in ``xs``.

    The contact wrenches minimise the knot's torque and load-transfer costs with their own
    weights, subject to the floating base's equations of motion and the knot's wrench cones;
    where no wrench satisfies the cones (a centre of pressure the motion itself puts outside
    them), the cones are dropped at that knot.
    """
    model, data, nq = robot.model, robot.model.createData(), robot.model.nq
    controls = []
    for k, knot in enumerate(problem.runningModels):
        if isinstance(knot, crocoddyl.ActionModelImpulseFwdDynamics):
            controls.append(np.zeros(0))
            continue
        q, v = xs[k][:nq], xs[k][nq:]
        # symplectic Euler, as the knot integrates: v' = v + a dt
        rhs = pin.rnea(model, data, q, v, (xs[k + 1][nq:] - v) / knot.dt)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        costs = knot.differential.costs.costs.todict()
        sides = [name.removesuffix("_contact") for name in knot.differential.contacts.contacts.todict()]
        J = np.vstack([pin.getFrameJacobian(model, data, robot.foot_frames[side], pin.LOCAL_WORLD_ALIGNED)
                       for side in sides])
        wrenches = _split(J, rhs, costs, sides)
        controls.append(rhs[6:] - J[:, 6:].T @ wrenches)
    return controls


def _split(J: np.ndarray, rhs: np.ndarray, costs: dict, sides: list[str]) -> np.ndarray:
    """The stacked sole wrenches (6 per side, world-aligned at the soles) for one knot."""
    n = J.shape[0]
    w_torque = costs["torque"].weight
    H = w_torque * J[:, 6:] @ J[:, 6:].T + REGULARISATION * np.eye(n)
    g = -w_torque * J[:, 6:] @ rhs[6:]
    cones, lower, upper = [], [], []
    for i, side in enumerate(sides):
        load = costs.get(f"{side}_load")
        if load is not None:  # pulls the vertical force towards its share of the weight
            H[6 * i + 2, 6 * i + 2] += load.weight
            g[6 * i + 2] -= load.weight * load.cost.residual.reference.linear[2]
        cone = costs[f"{side}_wrench_cone"].cost
        rows = np.zeros((cone.residual.reference.A.shape[0], n))
        rows[:, 6 * i : 6 * i + 6] = cone.residual.reference.A
        cones.append(rows)
        lower.append(cone.activation.bounds.lb)
        upper.append(cone.activation.bounds.ub)
    C = np.vstack(cones)
    qp = proxqp.dense.QP(n, 6, C.shape[0])
    qp.init(H, g, J[:, :6].T, rhs[:6], C, np.maximum(np.concatenate(lower), -OPEN),
            np.minimum(np.concatenate(upper), OPEN))
    qp.solve()
    if qp.results.info.status == proxqp.QPSolverOutput.PROXQP_SOLVED:
        return qp.results.x
    kkt = np.block([[H, J[:, :6]], [J[:, :6].T, np.zeros((6, 6))]])
    return np.linalg.solve(kkt, np.concatenate([-g, rhs[:6]]))[:n]


__all__ = ["inverse_dynamics_controls"]
