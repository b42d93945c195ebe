"""Maximise the free energy (eq. 6) by variational EM.

The bound is badly conditioned in its joint parameters: the curvature along the type means
chi is about 1e6 times that along the variational variances, and the whitened means tie
every kernel change to a change of the means.  So the parameters are updated in blocks,
each to its exact maximum given the others, which can only raise the bound:

* **E-step**, per primitive s in turn: ``Q(MP_s)`` and then every ``Q(W_is)``, both Gaussian
  in closed form (coordinate ascent on the mean-field posterior);
* the type means ``chi`` (a generalised least-squares mean per weight GP) and the noise
  ``sigma_i^2`` (the expected squared residual) in closed form;
* **M-step**: the kernel hyperparameters by L-BFGS-B on the two KL terms, the posteriors held.

Rounds repeat until the bound rises by less than ``TOLERANCE`` nats.  After an E-step the
posteriors have exactly the form :mod:`cocomopl.primitives.bound` parametrises
(``Sigma_s = (A_s^-1 + d_s I)^-1``, ``Omega_is = (B_is^-1 + c_is I)^-1``), so the bound is
evaluated, and the fit returned, by the same code as the joint optimiser's.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from cocomopl.primitives.bound import JITTER, BoundData, free_energy, mp_prior, posterior, weight_prior
from cocomopl.primitives.kernels import time_kernel
from cocomopl.primitives.optimise import LOG_BOUNDS, _prediction_arrays, initial_parameters

TOLERANCE = 1.0  # nats: a round that raises the bound by less ends the fit
HYPERPARAMETERS = ("log_alpha_t", "log_ell_t", "log_alpha_w", "log_gamma_w")
GRID_POINTS = 61  # log-spaced candidate widths per kernel in an M-step: 12 % apart for the time kernels


def _shifted_solve(K: np.ndarray, scale: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``(I + scale K)^-1 rhs`` for kernels ``K`` (..., n, n), scales (...) and ``rhs`` (..., n, k).

    Written without ``K^-1``: the kernels carry a 1e-6 nugget, so their inverses are
    ill-conditioned where ``I + scale K`` is not.
    """
    return np.linalg.solve(np.eye(K.shape[-1]) + scale[..., None, None] * K, rhs)


def e_step(q: dict, A: np.ndarray, B: np.ndarray, data: BoundData) -> dict:
    """One sweep over the primitives: ``Q(MP_s)``, then ``Q(W_is)`` of every signal, each set
    to its optimum given the rest.  ``q`` also gets the precisions the posteriors were
    computed with, ``d`` (S,) and ``c`` (I, S): ``Sigma_s = (A_s^-1 + d_s I)^-1`` and
    ``Omega_is = (B_is^-1 + c_is I)^-1``."""
    X, mask, mu = data.X, data.mask, data.mu
    m, Sig, w, Om = (q[k].copy() for k in ("m", "Sig", "w", "Om"))
    inv_s2 = 1.0 / q["sigma2"]
    d, c = np.empty(len(m)), np.empty(w.shape[:2])
    fit = np.einsum("isgn,st->gnit", w, m)
    for s in range(len(m)):
        fit -= np.einsum("ign,t->gnit", w[:, s], m[s])
        rest = X - fit  # the data less every other primitive's share
        second = w[:, s] ** 2 + np.diagonal(Om[:, s], axis1=-2, axis2=-1)  # E[W_is^2], (I, G, N)
        d[s] = np.einsum("ign,gn,i->", second, mask, inv_s2)
        r = np.einsum("ign,gn,i,gnit->t", w[:, s], mask, inv_s2, rest)
        Sig[s] = _shifted_solve(A[s], d[s], A[s])
        m[s] = _shifted_solve(A[s], d[s], (mu[s] + A[s] @ r)[:, None])[:, 0]
        c[:, s] = (m[s] @ m[s] + np.trace(Sig[s])) * inv_s2
        y = np.einsum("gnit,t,i,gn->ign", rest, m[s], inv_s2, mask)
        Bs = B[:, s]  # (I, G, N, N)
        shift = np.broadcast_to(c[:, s, None], Bs.shape[:2])
        Om[:, s] = _shifted_solve(Bs, shift, Bs)
        prior_mean = np.broadcast_to(q["chi"][:, s, :, None], y.shape)
        w[:, s] = _shifted_solve(Bs, shift, (prior_mean + np.einsum("ignk,igk->ign", Bs, y))[..., None])[..., 0]
        fit += np.einsum("ign,t->gnit", w[:, s], m[s])
    return {**q, "m": m, "Sig": Sig, "w": w, "Om": Om, "d": d, "c": c}


def means_and_noise(q: dict, B: np.ndarray, data: BoundData) -> dict:
    """``chi`` and ``sigma^2`` at their optima given the rest.

    ``chi_isg`` is the generalised least-squares mean of the weights under the type's kernel,
    ``1' B^-1 w / 1' B^-1 1`` over its steps; ``sigma_i^2`` the expected squared residual per
    datum of signal i, ``E ||x - sum_s W_s MP_s||^2 / (K T)``.
    """
    mask = data.mask
    L = np.linalg.cholesky(B)
    ones = np.broadcast_to(mask, B.shape[:-1])
    a = np.linalg.solve(L, ones[..., None])[..., 0]
    b = np.linalg.solve(L, (q["w"] * mask)[..., None])[..., 0]
    chi = (a * b).sum(-1) / (a * a).sum(-1)
    m, w = q["m"], q["w"]
    m2 = (m**2).sum(axis=1) + np.trace(q["Sig"], axis1=1, axis2=2)  # E||MP_s||^2
    residual = data.X - np.einsum("isgn,st->gnit", w, m)
    omega = np.diagonal(q["Om"], axis1=-2, axis2=-1)
    spread = np.einsum("isgn,s->gni", w**2 + omega, m2) - np.einsum("isgn,s->gni", w**2, (m**2).sum(axis=1))
    sq = (residual**2).sum(axis=-1) + spread  # (G, N, I)
    sigma2 = np.einsum("gni,gn->i", sq, mask) / (mask.sum() * data.X.shape[-1])
    return {**q, "chi": chi, "sigma2": sigma2}


def _profiled(inverse: np.ndarray, cov: np.ndarray, deviation: np.ndarray) -> np.ndarray:
    """``tr(K^-1 S) + d' K^-1 d`` for kernel inverses ``K^-1`` (..., n, n) and posteriors
    ``N(., S)`` with deviations ``d`` from the prior mean, batched (broadcast)."""
    return np.einsum("...nm,...nm->...", inverse, cov) + np.einsum("...n,...nm,...m->...", deviation, inverse, deviation)


def _inverse_and_log_det(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``K^-1`` and ``log|K|`` of symmetric positive-definite kernels (..., n, n), by Cholesky."""
    L = np.linalg.cholesky(K)
    L_inv = np.linalg.inv(L)
    return np.swapaxes(L_inv, -1, -2) @ L_inv, 2.0 * np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(-1)


def _best_widths(widths: np.ndarray, traces: np.ndarray, log_dets: np.ndarray, n: float, log_alpha_limits) -> tuple:
    """Per kernel, the candidate width and the log amplitude that minimise its KL terms.

    A kernel is ``alpha (K(width) + JITTER I)``, so for each width the amplitude has a closed
    form, ``alpha = trace / n``, and what is left to minimise is
    ``(n log alpha + trace / alpha + log|K|) / 2``.  ``widths``, ``traces`` and ``log_dets``
    are (candidates, ...).
    """
    low, high = log_alpha_limits
    log_alpha = np.clip(np.log(np.maximum(traces, 1e-300) / n), low, high)
    value = 0.5 * (n * log_alpha + traces * np.exp(-log_alpha) + log_dets)
    best = np.argmin(value, axis=0)[None]
    return np.take_along_axis(widths, best, axis=0)[0], np.take_along_axis(log_alpha, best, axis=0)[0]


def _time_kernels(kernel: str, r: np.ndarray, ell: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses and log-determinants of the unit-amplitude time kernels ``K(ell) + JITTER I``, widths ``ell`` (...)."""
    K = np.asarray(time_kernel(kernel, r, 1.0, ell[..., None, None]))
    return _inverse_and_log_det(K + JITTER * np.eye(len(r)))


def _weight_kernels(data: BoundData, gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses (..., G, N, N) and log-determinants summed over the types (...) of the
    unit-amplitude weight kernels of widths ``gamma`` (...), an identity on empty slots."""
    mask = data.mask
    both = mask[:, :, None] * mask[:, None, :]
    eye = np.eye(mask.shape[1])
    K = np.exp(-gamma[..., None, None, None] * data.d2) * both + JITTER * eye * mask[:, :, None] + eye * (1.0 - mask[:, :, None])
    inverse, log_det = _inverse_and_log_det(K)
    return inverse, log_det.sum(-1)


def m_step(q: dict, hyper: dict, data: BoundData, kernel: str) -> dict:
    """The kernel hyperparameters at their best, the posteriors held: per kernel the width
    from a log-spaced grid of ``GRID_POINTS`` or its current value (so the bound cannot
    fall), and the amplitude in closed form (:func:`_best_widths`)."""
    S, T = data.mu.shape
    # time kernels: one grid for all primitives, plus each primitive's current width
    ells = np.geomspace(float(data.r[0, 1]), 10.0, GRID_POINTS)
    deviation = q["m"] - data.mu
    inverse, log_det = _time_kernels(kernel, data.r, ells)  # (C, T, T), (C,)
    traces = np.stack([_profiled(k, q["Sig"], deviation) for k in inverse])  # (C, S)
    current, current_log_det = _time_kernels(kernel, data.r, np.exp(hyper["log_ell_t"]))  # (S, T, T), (S,)
    widths = np.vstack([np.broadcast_to(ells[:, None], traces.shape), np.exp(hyper["log_ell_t"])[None]])
    traces = np.vstack([traces, _profiled(current, q["Sig"], deviation)[None]])
    log_dets = np.vstack([np.broadcast_to(log_det[:, None], widths[:-1].shape), current_log_det[None]])
    ell, log_alpha_t = _best_widths(widths, traces, log_dets, T, LOG_BOUNDS["log_alpha_t"])
    # weight kernels, per (signal, primitive), summed over the step types
    mask = data.mask
    Om = q["Om"] * (mask[:, :, None] * mask[:, None, :])
    deviation = (q["w"] - q["chi"][..., None]) * mask
    gammas = np.geomspace(*np.exp(LOG_BOUNDS["log_gamma_w"]), GRID_POINTS)
    inverse, log_det = _weight_kernels(data, gammas)  # (C, G, N, N), (C,)
    traces = np.stack([_profiled(k, Om, deviation).sum(-1) for k in inverse])  # (C, I, S)
    current, current_log_det = _weight_kernels(data, np.exp(hyper["log_gamma_w"]))  # (I, S, G, N, N), (I, S)
    widths = np.vstack([np.broadcast_to(gammas[:, None, None], traces.shape), np.exp(hyper["log_gamma_w"])[None]])
    traces = np.vstack([traces, _profiled(current, Om, deviation).sum(-1)[None]])
    log_dets = np.vstack([np.broadcast_to(log_det[:, None, None], widths[:-1].shape), current_log_det[None]])
    gamma, log_alpha_w = _best_widths(widths, traces, log_dets, mask.sum(), LOG_BOUNDS["log_alpha_w"])
    return {"log_alpha_t": log_alpha_t, "log_ell_t": np.log(ell), "log_alpha_w": log_alpha_w, "log_gamma_w": np.log(gamma)}


def as_parameters(q: dict, hyper: dict, A: np.ndarray, B: np.ndarray, data: BoundData) -> dict:
    """The posterior after an E-step in :func:`~cocomopl.primitives.bound.free_energy`'s
    parametrisation: whitened means and the precisions ``d``, ``c``."""
    mask = data.mask
    u = np.linalg.solve(np.linalg.cholesky(A), (q["m"] - data.mu)[..., None])[..., 0]
    v = np.linalg.solve(np.linalg.cholesky(B), ((q["w"] - q["chi"][..., None]) * mask)[..., None])[..., 0] * mask
    return {**hyper, "u": u, "v": v, "chi": q["chi"], "log_d": np.log(q["d"]), "log_c": np.log(q["c"]),
            "log_sigma": 0.5 * np.log(q["sigma2"])}


def maximise_bound_em(
    X_slots,
    mask,
    d2,
    tau,
    S: int,
    kernel: str,
    max_rounds: int,
    signal_weights: np.ndarray,
    on_iteration: Callable[[float], None] | None = None,
) -> dict:
    """Fit Q and the kernel hyperparameters by variational EM from the PCA start of
    :func:`~cocomopl.primitives.optimise.initial_parameters`; return what
    :func:`~cocomopl.primitives.optimise.maximise_bound` returns, with ``bounds``: the bound
    after each round's E-step and closed-form updates (non-decreasing).

    ``on_iteration``, if given, is called after every round with the bound reached.
    """
    params, data = initial_parameters(X_slots, mask, d2, tau, S, signal_weights)
    hyper = {k: np.asarray(params[k], dtype=float) for k in HYPERPARAMETERS}
    q = {**_posterior_start(params, data, kernel), "chi": params["chi"], "sigma2": np.exp(2.0 * params["log_sigma"])}
    bound = jax.jit(lambda p: free_energy(p, data, kernel))
    bounds = []
    for _ in range(max(max_rounds, 1)):
        if bounds:
            hyper = m_step(q, hyper, data, kernel)
        A, B = np.asarray(mp_prior(hyper, data, kernel)), np.asarray(weight_prior(hyper, data))
        q = means_and_noise(e_step(q, A, B, data), B, data)
        params = as_parameters(q, hyper, A, B, data)
        bounds.append(float(bound({k: jnp.asarray(v) for k, v in params.items()})))
        if on_iteration is not None:
            on_iteration(bounds[-1])
        if len(bounds) > 1 and bounds[-1] - bounds[-2] < TOLERANCE:
            break
    reconstruction = np.einsum("isgn,st->gnit", q["w"], q["m"])
    return {
        "arrays": _prediction_arrays(params, data, kernel),
        "bound": bounds[-1],
        "bounds": bounds,
        "iterations": len(bounds),
        "reconstruction": reconstruction,
    }


def _posterior_start(params: dict, data: BoundData, kernel: str) -> dict:
    """The PCA start as explicit posteriors: means and covariances."""
    A = np.asarray(mp_prior(params, data, kernel))
    B = np.asarray(weight_prior(params, data))
    q = posterior({k: jnp.asarray(v) for k, v in params.items()}, data, kernel)
    d = np.exp(params["log_d"])
    c = np.exp(params["log_c"])
    return {
        "m": np.asarray(q["m"]),
        "Sig": _shifted_solve(A, d, A),
        "w": np.asarray(q["w"]),
        "Om": _shifted_solve(B, np.broadcast_to(c[:, :, None], B.shape[:3]), B),
    }
