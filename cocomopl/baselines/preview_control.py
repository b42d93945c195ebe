"""ZMP preview control of the cart-table model (Kajita et al., ICRA 2003).

The centre of mass moves at a constant height ``z_c``; per horizontal axis its state is
``x = (c, c', c'')``, the input is the jerk, and the cart-table ZMP is ``p = c - (z_c/g) c''``.
The servo of Katayama et al. (1985) augments the state with the integral of the ZMP error,
weights it by ``Qe`` and the input by ``R``, and adds a feed-forward of the ZMP reference
over a preview horizon; all its gains follow from one discrete algebraic Riccati equation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_discrete_are

from cocomopl.dynamics import GRAVITY


class PreviewController:
    """Gains of the ZMP preview servo for one sampling period and CoM height.

    Parameters
    ----------
    dt : sampling period, s
    com_height : constant CoM height ``z_c`` above the ground, m
    preview_time : length of the preview horizon, s (Kajita: 1.6 s)
    weight_error : weight ``Qe`` of the integrated ZMP error (Kajita: 1)
    weight_input : weight ``R`` of the jerk (Kajita: 1e-6)

    Attributes
    ----------
    A, B, C : cart-table model ``x+ = A x + B u``, ``p = C x`` per axis
    riccati : solution ``P`` of the augmented system's Riccati equation
    gain_error : (1,) gain on the integrated ZMP error
    gain_state : (3,) gain on the state
    gain_preview : (N,) gains on the reference 1..N samples ahead
    """

    def __init__(
        self,
        dt: float,
        com_height: float,
        *,
        preview_time: float = 1.6,
        weight_error: float = 1.0,
        weight_input: float = 1e-6,
    ):
        self.dt, self.com_height, self.preview_time = dt, com_height, preview_time
        self.weight_error, self.weight_input = weight_error, weight_input
        self.A = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        self.B = np.array([[dt**3 / 6], [dt**2 / 2], [dt]])
        self.C = np.array([[1.0, 0.0, -com_height / GRAVITY]])
        A, B, Q, R = self.augmented_system()
        self.riccati = solve_discrete_are(A, B, Q, R)
        P = self.riccati
        inverse = 1.0 / (R + B.T @ P @ B)[0, 0]
        gain = inverse * (B.T @ P @ A)[0]
        self.gain_error, self.gain_state = gain[:1], gain[1:]
        # feed-forward: the closed loop's response to a unit reference j samples ahead
        closed_loop_t = (A - B @ gain[None, :]).T
        unit = np.zeros(4)
        unit[0] = 1.0
        x = -closed_loop_t @ P @ unit
        preview = [-self.gain_error[0]]
        for _ in range(1, round(preview_time / dt)):
            preview.append(inverse * (B.T @ x)[0])
            x = closed_loop_t @ x
        self.gain_preview = np.array(preview)

    def augmented_system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, Q, R)`` of the servo system on (ZMP error, state increment)."""
        A = np.zeros((4, 4))
        A[0, 0] = 1.0
        A[0, 1:] = (self.C @ self.A)[0]
        A[1:, 1:] = self.A
        B = np.vstack([self.C @ self.B, self.B])
        Q = np.diag([self.weight_error, 0.0, 0.0, 0.0])
        return A, B, Q, np.array([[self.weight_input]])

    def track(
        self, zmp_ref: np.ndarray, com_start: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """CoM motion whose cart-table ZMP follows ``zmp_ref`` (n, 2), sampled every ``dt``.

        The CoM starts at rest above ``com_start`` (default: the first reference point); the
        reference is held at its last value beyond its end, so the preview sees a rest.

        Returns
        -------
        com, com_vel, com_acc, zmp : (n, 2) each: CoM position (m), velocity (m/s),
            acceleration (m/s^2) and cart-table ZMP (m), per sample
        """
        zmp_ref = np.asarray(zmp_ref, dtype=float)
        n, horizon = len(zmp_ref), len(self.gain_preview)
        padded = np.vstack([zmp_ref, np.repeat(zmp_ref[-1:], horizon, axis=0)])
        state = self.at_rest(zmp_ref[0] if com_start is None else com_start)
        states = np.empty((n, 3, 2))
        for k in range(n):
            states[k] = state.x
            state = self.step(state, padded[k : k + 1 + horizon])
        zmp = np.einsum("j,kjd->kd", self.C[0], states)
        return states[:, 0], states[:, 1], states[:, 2], zmp

    def at_rest(self, com: np.ndarray) -> PreviewState:
        """The servo's state with the CoM at rest at ``com`` (d,), one column per axis."""
        com = np.asarray(com, dtype=float)
        x = np.zeros((3, len(com)))
        x[0] = com
        return PreviewState(x, np.zeros(len(com)))

    def step(self, state: PreviewState, zmp_ref: np.ndarray) -> PreviewState:
        """The state one period on: ``zmp_ref`` (horizon + 1, d) is the reference now and over
        the preview horizon (:attr:`gain_preview`), held at its last value where it ends."""
        integral = state.integral + ((self.C @ state.x)[0] - zmp_ref[0])
        jerk = -self.gain_error[0] * integral - self.gain_state @ state.x - self.gain_preview @ zmp_ref[1:]
        return PreviewState(self.A @ state.x + self.B @ jerk[None, :], integral)


@dataclass(frozen=True)
class PreviewState:
    """The preview servo's state: ``x`` (3, d) the CoM's position, velocity and acceleration
    per axis, ``integral`` (d,) the summed ZMP error."""

    x: np.ndarray
    integral: np.ndarray
