"""The PCA start of the fit, the arrays prediction needs, and the joint L-BFGS-B optimiser.

The estimator fits by variational EM (:mod:`cocomopl.primitives.em`) from this start.  The
joint optimiser, which the models before format version 3 were fitted with, is kept as the
reference EM is measured against (``benchmarks/learner_em.py --joint``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree
from scipy.optimize import minimize

from cocomopl.primitives import slot_algebra
from cocomopl.primitives.bound import JITTER, BoundData, free_energy, mp_prior, posterior, weight_prior
from cocomopl.primitives.shared_kernels import ShapeCache, WeightKernels

# (lower, upper) for the log-parameters; the rest are unbounded.  They keep the kernels
# numerically sane: time length scales between a grid step and 10 steps, weight-kernel
# widths between 7 mm and 0.7 m of step length, their nuggets from the time kernels'
# JITTER to the kernel's amplitude.
LOG_BOUNDS = {
    "log_alpha_t": (np.log(1e-8), np.log(1e2)),
    "log_alpha_w": (np.log(1e-12), np.log(1e2)),
    "log_gamma_w": (np.log(1.0), np.log(1e4)),
    "log_eta_w": (np.log(JITTER), 0.0),
    "log_sigma": (np.log(1e-6), np.log(1.0)),
    "log_d": (-30.0, 40.0),
    "log_c": (-30.0, 40.0),
}


GAMMA_GRID = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 3e3, 1e4)  # 1/m^2: widths 0.7 m .. 7 mm, the start's
ETA_GRID = tuple(np.geomspace(JITTER, 1.0, 7))  # relative nuggets, a decade apart


def bound_data(X_slots: np.ndarray, mask: np.ndarray, d2: np.ndarray, *, tau: np.ndarray, mu: np.ndarray) -> BoundData:
    return BoundData(X_slots, mask, d2, np.abs(tau[:, None] - tau[None, :]), mu)


def initial_parameters(X_slots: np.ndarray, mask: np.ndarray, d2: np.ndarray, *, tau: np.ndarray, S: int,
                       signal_weights: np.ndarray, widths=GAMMA_GRID):
    """PCA start: MP means are the leading right singular vectors of the (steps x signals,
    time) data, each signal scaled by ``signal_weights`` (I,); the weight kernels' widths
    (inverse squared, 1/m^2) from ``widths``."""
    I, T = X_slots.shape[2:]
    real = X_slots[mask > 0]  # (K, I, T)
    _, _, Vt = np.linalg.svd((real * signal_weights[None, :, None]).reshape(-1, T), full_matrices=False)
    mu = Vt[:S] * np.sqrt(T)  # unit RMS primitives
    w = np.einsum("gnit,st->isgn", X_slots, mu) / T  # PCA weights
    residual = real - np.einsum("isk,st->kit", w.transpose(0, 1, 2, 3)[:, :, mask > 0], mu)
    sigma = np.maximum(np.sqrt((residual**2).mean(axis=(0, 2))), 1e-5)
    counts = mask.sum(axis=1)
    chi = (w * mask).sum(axis=-1) / counts
    alpha_w, gamma_w, eta_w = _weight_kernel_start(w - chi[..., None], mask, d2, widths)
    params = {
        "u": np.zeros((S, T)),
        "log_d": np.log(np.einsum("isgn,i->s", w**2 * mask, 1 / sigma**2) + 1.0),
        "log_c": np.log(np.full((I, S), T) / sigma[:, None] ** 2),
        "log_alpha_t": np.full(S, np.log(1e-2)),
        "log_ell_t": np.full(S, np.log(0.1)),
        "log_alpha_w": np.log(alpha_w),
        "log_gamma_w": np.log(gamma_w),
        "log_eta_w": np.log(eta_w),
        "chi": chi,
        "log_sigma": np.log(sigma),
    }
    data = bound_data(X_slots, mask, d2, tau=tau, mu=mu)
    prior = WeightKernels(ShapeCache(data), alpha_w, gamma_w, eta=eta_w)
    params["v"] = prior.whiten((w - chi[..., None]) * mask) * mask
    return params, data


def unit_weight_kernels(d2: np.ndarray, mask: np.ndarray, gamma, *, eta) -> np.ndarray:
    """Eq. (5)'s kernel of unit amplitude plus the relative nugget, per step type: (..., G, N, N)
    for widths ``gamma`` and nuggets ``eta`` (...), with an identity on empty slots so that it
    stays invertible."""
    eye = np.eye(mask.shape[1])
    both = mask[:, :, None] * mask[:, None, :]
    gamma, eta = (np.asarray(x)[..., None, None, None] for x in (gamma, eta))
    return np.exp(-gamma * d2) * both + eta * eye * mask[:, :, None] + eye * (1.0 - mask[:, :, None])


def _weight_kernel_start(deviation: np.ndarray, mask: np.ndarray, d2: np.ndarray, widths) -> tuple[np.ndarray, ...]:
    """Per (signal, primitive), the eq. (5) kernel that best explains the PCA weights:
    amplitude, width and nugget.

    A grid over the width (``widths``) and the nugget, with the amplitude in closed form (profile
    likelihood).  Starting L-BFGS from widths the data support matters: with a too-wide
    kernel the whitened weights blow up and the KL term swamps the bound.
    """
    n, groups = mask.sum(), slot_algebra.size_groups(mask)
    I, S, G, N = deviation.shape
    rhs = (deviation * mask).reshape(I * S, G, N).transpose(1, 2, 0)  # (G, N, I S): one kernel for all (i, s)
    best = None
    for gamma, eta in itertools.product(widths, ETA_GRID):
        L = slot_algebra.cholesky(unit_weight_kernels(d2, mask, gamma, eta=eta), groups)  # (G, N, N)
        z = slot_algebra.solve(L, rhs, groups).transpose(2, 0, 1).reshape(I, S, G, N)
        alpha = np.maximum((z**2).sum(axis=(-1, -2)) / n, 1e-12)
        log_det = 2 * (np.log(np.diagonal(L, axis1=-2, axis2=-1)) * mask).sum()
        score = -0.5 * (n * np.log(alpha) + log_det)
        candidate = (score, alpha, np.full_like(alpha, gamma), np.full_like(alpha, eta))
        if best is None:
            best = candidate
        else:
            better = score > best[0]
            best = tuple(np.where(better, new, old) for new, old in zip(candidate, best))
    return best[1:]


def maximise_bound(
    X_slots,
    mask,
    d2,
    *,
    tau,
    S: int,
    kernel: str,
    max_iterations: int,
    signal_weights: np.ndarray,
    on_iteration: Callable[[float], None] | None = None,
) -> dict:
    """Fit Q and the kernel hyperparameters, starting from the PCA of the signals scaled by
    ``signal_weights`` (I,); return the arrays prediction needs.

    ``on_iteration``, if given, is called after every L-BFGS-B iteration with the bound reached.
    """
    params, data = initial_parameters(X_slots, mask, d2, tau=tau, S=S, signal_weights=signal_weights)
    flat, unravel = ravel_pytree({k: jnp.asarray(v) for k, v in params.items()})
    bounds = _bounds(params, tau)
    scale = float(mask.sum() * X_slots.shape[2] * X_slots.shape[3])  # per datum, for L-BFGS tolerances

    @jax.jit
    def objective(x):
        value, grad = jax.value_and_grad(lambda y: -free_energy(unravel(y), data, kernel) / scale)(x)
        return value, grad

    def fun(x):
        value, grad = objective(jnp.asarray(x))
        return float(value), np.asarray(grad, dtype=float)

    def callback(intermediate_result):  # this parameter name makes SciPy pass the objective too
        on_iteration(-intermediate_result.fun * scale)

    result = minimize(
        fun, np.asarray(flat), jac=True, method="L-BFGS-B", bounds=bounds,
        callback=None if on_iteration is None else callback,
        options={"maxiter": max_iterations, "maxcor": 30, "ftol": 1e-12, "gtol": 1e-8},
    )
    best = {k: np.asarray(v) for k, v in unravel(jnp.asarray(result.x)).items()}
    return {
        "arrays": _prediction_arrays(best, data, kernel),
        "bound": float(-result.fun * scale),
        "iterations": int(result.nit),
        "reconstruction": np.einsum("isgn,st->gnit", np.asarray(posterior(best, data, kernel)["w"]),
                                    np.asarray(posterior(best, data, kernel)["m"])),
    }


def _bounds(params: dict, tau: np.ndarray) -> list:
    grid = float(tau[1] - tau[0])
    limits = dict(LOG_BOUNDS, log_ell_t=(np.log(grid), np.log(10.0)))
    out = []
    for key in sorted(params):  # ravel_pytree flattens dict leaves in sorted key order
        out += [limits.get(key, (None, None))] * np.asarray(params[key]).size
    return out


def _prediction_arrays(params: dict, data: BoundData, kernel: str, priors: tuple | None = None) -> dict:
    """What prediction needs: MP posterior, weight-GP hyperparameters and solves, noise;
    ``priors`` as for :func:`~cocomopl.primitives.bound.posterior`."""
    A, B = priors or (mp_prior(params, data, kernel, xp=np), weight_prior(params, data, np))
    q = posterior(params, data, kernel, xp=np, priors=(A, B))
    d = np.exp(params["log_d"])[:, None, None]
    m_cov = A @ np.linalg.inv(np.eye(A.shape[-1]) + d * A)  # (S, T, T): each primitive's posterior covariance
    if isinstance(B, WeightKernels):  # EM's priors, factorised per kernel shape
        beta = B.solve_whitened(params["v"]) * data.mask
    else:
        L_B = slot_algebra.cholesky(B, data.groups)
        beta = slot_algebra.solve(np.swapaxes(L_B, -1, -2), params["v"][..., None], data.groups)[..., 0] * data.mask
    return {
        "m": q["m"],
        "m_var": np.diagonal(m_cov, axis1=1, axis2=2),
        "m_cov_start": m_cov[:, :, 0],
        "alpha_w": np.exp(params["log_alpha_w"]),
        "gamma_w": np.exp(params["log_gamma_w"]),
        "eta_w": np.exp(params["log_eta_w"]),
        "chi": params["chi"],
        "beta": beta,
        "c_w": np.exp(params["log_c"]),
        "sigma": np.exp(params["log_sigma"]),
        "alpha_t": np.exp(params["log_alpha_t"]),
        "ell_t": np.exp(params["log_ell_t"]),
    }
