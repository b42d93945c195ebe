"""Phase durations as functions of the step lengths: one small exact GP per step type and phase.

Log durations are regressed, so predicted durations stay positive.  The kernel is eq. (5)'s
RBF on (start length, end length); its amplitude, width and noise maximise the marginal
likelihood.
"""

from __future__ import annotations

import numpy as np

LOG_BOUNDS = [(np.log(1e-8), np.log(10.0)), (np.log(1.0), np.log(1e4)), (np.log(1e-10), np.log(1.0))]


def _kernel(za: np.ndarray, zb: np.ndarray, alpha: float, gamma: float) -> np.ndarray:
    d2 = ((za[:, None, :] - zb[None, :, :]) ** 2).sum(-1)
    return alpha * np.exp(-gamma * d2)


def _neg_log_marginal(log_hyper: np.ndarray, z: np.ndarray, y: np.ndarray) -> float:
    alpha, gamma, noise = np.exp(log_hyper)
    K = _kernel(z, z, alpha, gamma) + (noise + 1e-12) * np.eye(len(y))
    L = np.linalg.cholesky(K)
    a = np.linalg.solve(L, y)
    return 0.5 * a @ a + np.log(np.diag(L)).sum()


def fit_gp(z: np.ndarray, y: np.ndarray) -> dict:
    """Fit a GP ``y(z)``; returns its mean, hyperparameters, ``K^-1 (y - mean)`` and ``K^-1``."""
    from scipy.optimize import minimize  # 0.5 s to load: only training pays it, not prediction

    mean = float(y.mean())
    centred = y - mean
    start = np.log([max(centred.var(), 1e-6), 50.0, 1e-6])
    best = minimize(_neg_log_marginal, start, args=(z, centred), method="L-BFGS-B", bounds=LOG_BOUNDS)
    alpha, gamma, noise = np.exp(best.x)
    K_inv = np.linalg.inv(_kernel(z, z, alpha, gamma) + (noise + 1e-12) * np.eye(len(y)))
    return {"z": z, "mean": mean, "alpha": alpha, "gamma": gamma, "beta": K_inv @ centred, "K_inv": K_inv}

