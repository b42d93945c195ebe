"""Smooth torques: the paper's torque-rate control, as a state augmentation.

The paper makes the torque rate the control (``x = (q, v, tau)``, ``u = d tau / dt``).
Here every action model of a step is wrapped so that its state also carries the torque of
the previous knot, ``x~ = (x, tau_prev)``, its control stays the torque and its cost gains

    w_rate * integral |d tau / dt|^2 dt  ~=  sum_k  w_rate / dt * |tau_k - tau_{k-1}|^2,

which is the same problem written with the torque as control: a penalty on the torque rate
that the paper's formulation implies, with torque limits still hard bounds in box-FDDP.
The wrappers delegate all dynamics and costs to the wrapped Crocoddyl models.
"""

from __future__ import annotations

import crocoddyl
import numpy as np


class TorqueRateState(crocoddyl.StateAbstract):
    """A state followed by a vector of ``nu`` torques (a Euclidean part)."""

    def __init__(self, inner: crocoddyl.StateAbstract, nu: int):
        crocoddyl.StateAbstract.__init__(self, inner.nx + nu, inner.ndx + nu)
        self.inner = inner
        self.n_torques = nu

    def zero(self):
        return np.concatenate([self.inner.zero(), np.zeros(self.n_torques)])

    def rand(self):
        return np.concatenate([self.inner.rand(), np.zeros(self.n_torques)])

    def diff(self, x0, x1):
        n = self.inner.nx
        return np.concatenate([self.inner.diff(x0[:n], x1[:n]), x1[n:] - x0[n:]])

    def integrate(self, x, dx):
        n, nd = self.inner.nx, self.inner.ndx
        return np.concatenate([self.inner.integrate(x[:n], dx[:nd]), x[n:] + dx[nd:]])

    def _pad(self, blocks, signs):
        out = []
        for block, sign in zip(blocks, signs):
            J = np.zeros((self.ndx, self.ndx))
            J[: self.inner.ndx, : self.inner.ndx] = block
            J[self.inner.ndx :, self.inner.ndx :] = sign * np.eye(self.n_torques)
            out.append(J)
        return out

    def Jdiff(self, x0, x1, firstsecond=crocoddyl.Jcomponent.both):
        n = self.inner.nx
        blocks = self.inner.Jdiff(x0[:n], x1[:n], firstsecond)
        signs = {crocoddyl.Jcomponent.first: [-1.0], crocoddyl.Jcomponent.second: [1.0]}.get(firstsecond, [-1.0, 1.0])
        return self._pad(blocks, signs)

    def Jintegrate(self, x, dx, firstsecond=crocoddyl.Jcomponent.both):
        n, nd = self.inner.nx, self.inner.ndx
        blocks = self.inner.Jintegrate(x[:n], dx[:nd], firstsecond)
        return self._pad(blocks, [1.0] * len(blocks))

    def JintegrateTransport(self, x, dx, Jin, firstsecond):
        n, nd = self.inner.nx, self.inner.ndx
        out = np.array(Jin, copy=True)
        out[:nd] = self.inner.JintegrateTransport(x[:n], dx[:nd], Jin[:nd], firstsecond)
        return out


class TorqueRateModel(crocoddyl.ActionModelAbstract):
    """An action model whose state carries the previous knot's torque.

    A knot that takes time penalises ``weight / 2 * |u - tau_prev|^2`` and passes its torque
    on; a touchdown impulse (no control) and the terminal knot pass ``tau_prev`` through.
    """

    def __init__(self, inner: crocoddyl.ActionModelAbstract, state: TorqueRateState, weight: float):
        crocoddyl.ActionModelAbstract.__init__(self, state, inner.nu, inner.nr)
        self.inner = inner
        self.weight = weight
        if inner.nu > 0:
            self.u_lb = inner.u_lb
            self.u_ub = inner.u_ub

    def createData(self):
        data = crocoddyl.ActionModelAbstract.createData(self)
        data.inner = self.inner.createData()
        return data

    def calc(self, data, x, u=None):
        n = self.inner.state.nx
        if u is None:  # terminal knot
            self.inner.calc(data.inner, x[:n])
            data.xnext[:] = x
            data.cost = data.inner.cost
            return
        self.inner.calc(data.inner, x[:n], u)
        if self.nu == 0:  # impulse: the torque of the last knot carries over
            data.xnext[:] = np.concatenate([data.inner.xnext, x[n:]])
            data.cost = data.inner.cost
            return
        jump = u - x[n:]
        data.xnext[:] = np.concatenate([data.inner.xnext, u])
        data.cost = data.inner.cost + 0.5 * self.weight * jump @ jump

    def calcDiff(self, data, x, u=None):
        n, nd = self.inner.state.nx, self.inner.state.ndx
        if u is None:
            self.inner.calcDiff(data.inner, x[:n])
        else:
            self.inner.calcDiff(data.inner, x[:n], u)
        data.Lx[:nd] = data.inner.Lx
        data.Lxx[:nd, :nd] = data.inner.Lxx
        if u is None:
            return
        data.Fx[:nd, :nd] = data.inner.Fx
        if self.nu == 0:
            data.Fx[nd:, nd:] = np.eye(self.state.ndx - nd)
            return
        eye = np.eye(self.nu)
        jump = u - x[n:]
        data.Fu[:nd] = data.inner.Fu
        data.Fu[nd:] = eye
        data.Lx[nd:] = -self.weight * jump
        data.Lu[:] = data.inner.Lu + self.weight * jump
        data.Lxx[nd:, nd:] = self.weight * eye
        data.Luu[:, :] = data.inner.Luu + self.weight * eye
        data.Lxu[:nd] = data.inner.Lxu
        data.Lxu[nd:] = -self.weight * eye


def with_torque_rate(
    problem: crocoddyl.ShootingProblem, tau0: np.ndarray, weight_per_knot: float
) -> crocoddyl.ShootingProblem:
    """The same problem with a torque-rate penalty; ``tau0`` is the torque before the first knot."""
    state = TorqueRateState(problem.runningModels[0].state, len(tau0))
    running = [TorqueRateModel(m, state, weight_per_knot) for m in problem.runningModels]
    terminal = TorqueRateModel(problem.terminalModel, state, weight_per_knot)
    return crocoddyl.ShootingProblem(np.concatenate([problem.x0, tau0]), running, terminal)
