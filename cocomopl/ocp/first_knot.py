"""A step OCP's first knot, whose state is pinned: its first step taken exactly against its barriers.

The first knot starts at the pinned state ``x0``. So its control alone sets that knot's contact
wrenches, and it sets them affinely.

Box-FDDP models the knot's cost by Gauss-Newton. A quadratic barrier, such as a wrench cone,
gives curvature there only on the rows already past their bounds. At a refined step's
optimum, the sole that has just landed carries as little as its cone allows: its
least-normal-force row and two yaw-moment rows lie on their bounds.

A warm start has those rows inside, so the model does not see the cone. The first full step
then pushes the wrench past it by 1-3 N. That adds hundreds or thousands to a step's cost of
40-60, and costs a second iteration to repair
(docs/method.md#refinement; docs/experiments/bumps-and-refinement-leads.md).

Here the first step at that knot is the exact minimiser of the solver's own quadratic model
of the knot. Each of the knot's barrier rows enters as the piecewise-quadratic penalty it is:
one slack per row in a small QP (ProxQP, as :mod:`cocomopl.ocp.contact_controls` uses). The
torque limits stay hard bounds. Every other knot takes box-FDDP's step.

The step is a full one, without a line search, so :func:`cocomopl.ocp.refine.refine_walk`
takes it only from a solved step's guess, which is consistent and near the optimum. From the
generated step it took a median 21 iterations instead of 11.
"""

from __future__ import annotations

import crocoddyl
import numpy as np
from proxsuite import proxqp

from cocomopl.ocp.contact_controls import OPEN

TOLERANCE = 1e-9  # of the QP (ProxQP's absolute tolerance, N and N m on the barrier rows)


def first_knot_step(solver: crocoddyl.SolverBoxFDDP) -> np.ndarray | None:
    """The control step at the first knot after ``solver``'s backward pass (``computeDirection``).

    The step minimises the pass's quadratic model ``Qu' du + du' Quu du / 2``, less the
    Gauss-Newton terms of the knot's quadratic barriers. Each barrier enters instead as
    ``w dt dist(r + Ru du, [lb, ub])^2 / 2``, exactly, because the knot's state is pinned. The
    torque limits are kept.

    Returns ``None`` where the knot has no barrier on its control, or where the QP fails.
    """
    model, data = _inner(solver.problem.runningModels[0]), _inner(solver.problem.runningDatas[0])
    if not isinstance(model, crocoddyl.IntegratedActionModelEuler):
        return None
    Quu, Qu = np.array(solver.Quu[0]), np.array(solver.Qu[0])
    rows = []  # (Ru, r, lb, ub, weight) of every barrier row that the control moves
    for name, item in model.differential.costs.costs.todict().items():
        if not item.active or not isinstance(item.cost.activation, crocoddyl.ActivationModelQuadraticBarrier):
            continue
        residual = data.differential.costs.costs[name].residual
        r, Ru = np.array(residual.r), np.array(residual.Ru)
        bounds = item.cost.activation.bounds
        lb, ub = np.array(bounds.lb), np.array(bounds.ub)
        weight = model.dt * item.weight
        # the backward pass's Gauss-Newton terms of the rows already past their bounds
        past = np.maximum(r - ub, 0.0) + np.minimum(r - lb, 0.0)
        on = (r <= lb) | (r >= ub)
        Quu -= weight * Ru[on].T @ Ru[on]
        Qu -= weight * Ru[on].T @ past[on]
        moved = np.linalg.norm(Ru, axis=1) > 0
        rows += [(Ru[j], r[j], lb[j], ub[j], weight) for j in np.flatnonzero(moved)]
    if not rows:
        return None
    Ru, r, lb, ub, weights = (np.array(column) for column in zip(*rows))
    knot = solver.problem.runningModels[0]
    return barrier_qp(Quu, Qu, Ru, r=r, lb=lb, ub=ub, weights=weights,
                      du_lb=knot.u_lb - solver.us[0], du_ub=knot.u_ub - solver.us[0])


def barrier_qp(
    Quu: np.ndarray,
    Qu: np.ndarray,
    Ru: np.ndarray,
    *,
    r: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    weights: np.ndarray,
    du_lb: np.ndarray,
    du_ub: np.ndarray,
) -> np.ndarray | None:
    """The control step minimising a quadratic model plus barrier rows, each as its exact
    piecewise-quadratic penalty: ``argmin Qu' du + du' Quu du / 2 + sum w s^2 / 2`` over ``du``
    and the slacks ``s``, subject to ``lb - s <= r + Ru du <= ub + s`` and ``du_lb <= du <= du_ub``.

    Parameters
    ----------
    Quu, Qu : np.ndarray
        The quadratic model's Hessian ``(nu, nu)`` and gradient ``(nu,)``.
    Ru : np.ndarray
        The barrier rows' derivatives ``(m, nu)`` in the control.
    r, lb, ub, weights : np.ndarray
        The rows' values at ``du = 0``, their bounds (infinite where open) and their weights, ``(m,)``.
    du_lb, du_ub : np.ndarray
        Bounds of the step ``(nu,)``.

    Returns
    -------
    np.ndarray or None
        The step ``du``, or ``None`` if the QP fails.
    """
    nu, m = Qu.size, r.size
    H = np.zeros((nu + m, nu + m))
    H[:nu, :nu] = 0.5 * (Quu + Quu.T)
    H[nu:, nu:] = np.diag(weights)
    g = np.concatenate([Qu, np.zeros(m)])
    slack = np.eye(m)
    C = np.vstack([np.hstack([Ru, -slack]), np.hstack([Ru, slack]), np.eye(nu, nu + m)])
    lower = np.concatenate([np.full(m, -OPEN), np.maximum(lb - r, -OPEN), du_lb])
    upper = np.concatenate([np.minimum(ub - r, OPEN), np.full(m, OPEN), du_ub])
    qp = proxqp.dense.QP(nu + m, 0, C.shape[0])
    # rows meant to lie just past their bounds must end there, not a solver tolerance inside
    qp.settings.eps_abs = TOLERANCE
    qp.init(H, g, None, None, C, lower, upper)
    qp.solve()
    if qp.results.info.status != proxqp.QPSolverOutput.PROXQP_SOLVED:
        return None
    return qp.results.x[:nu]


def full_step(solver: crocoddyl.SolverBoxFDDP, first_step: np.ndarray) -> tuple[list, list, float] | None:
    """Box-FDDP's forward pass at step length 1, after its backward pass, with the first
    knot's control step replaced by ``first_step``.

    Crocoddyl's Python bindings read the gains but cannot set them, so the pass is written out
    here. With the gains it gives every knot ``u = u_bar - k - K dx``, clamped to the torque
    limits, and it rolls the dynamics out from ``x0``, which closes every gap.

    Returns the states, the controls and their cost, or ``None`` if the rollout diverges.
    """
    problem = solver.problem
    xs_bar, us_bar, k, K = list(solver.xs), list(solver.us), list(solver.k), list(solver.K)
    k[0] = -first_step  # Crocoddyl's convention: u = u_bar - k - K dx
    x = np.array(xs_bar[0])
    xs, us, cost = [x], [], 0.0
    for t, (model, data) in enumerate(zip(problem.runningModels, problem.runningDatas)):
        u = np.zeros(0)
        if model.nu > 0:
            u = np.clip(us_bar[t] - k[t] - K[t] @ model.state.diff(xs_bar[t], x), model.u_lb, model.u_ub)
        model.calc(data, x, u)
        x = np.array(data.xnext)
        if not np.all(np.isfinite(x)):
            return None
        cost += data.cost
        xs.append(x)
        us.append(u)
    problem.terminalModel.calc(problem.terminalData, x)
    return xs, us, cost + problem.terminalData.cost


def _inner(model_or_data):
    """The step's own model or data, inside the torque-rate wrapper where there is one."""
    return getattr(model_or_data, "inner", model_or_data)


__all__ = ["barrier_qp", "first_knot_step", "full_step"]
