"""Maximise the free energy (eq. 6) by variational EM.

The bound is badly conditioned in its joint parameters: the curvature along the type means
chi is about 1e6 times that along the variational variances, and the whitened means tie
every kernel change to a change of the means.  So the parameters are updated in blocks,
each to its exact maximum given the others, which can only raise the bound:

* **E-step**, per primitive s in turn: ``Q(MP_s)`` and then every ``Q(W_is)``, both Gaussian
  in closed form (coordinate ascent on the mean-field posterior);
* the type means ``chi`` (a generalised least-squares mean per weight GP) and the noise
  ``sigma_i^2`` (the expected squared residual) in closed form;
* **M-step**: the kernel hyperparameters, the posteriors held: each kernel's shape (width,
  and the weight kernels' nugget) from a log grid or its present value, its amplitude in
  closed form.  A grid rather than L-BFGS-B: every candidate costs one matrix product for all
  kernels at once, and keeping the present value among them means the bound cannot fall.

Rounds repeat until one raises the bound by less than ``RELATIVE_TOLERANCE`` of its value,
or ``max_rounds``.  Past that point the bound creeps up by a steady few parts in a million
per round and the predictions stay where they are: on held-out footstep steps a fit stopped
there predicts within 0.1 mrad of one run 40 rounds (docs/results.md#the-learner).
After an E-step the posteriors have exactly the form :mod:`cocomopl.primitives.bound`
parametrises (``Sigma_s = (A_s^-1 + d_s I)^-1``, ``Omega_is = (B_is^-1 + c_is I)^-1``), so
the bound is evaluated, and the fit returned, by the same code as the joint optimiser's.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cocomopl.primitives import DEFAULT_WIDTHS
from cocomopl.primitives.bound import JITTER, BoundData, free_energy, mp_prior
from cocomopl.primitives.kernels import time_kernel
from cocomopl.primitives.optimise import (
    ETA_GRID,
    GAMMA_GRID,
    LOG_BOUNDS,
    _prediction_arrays,
    initial_parameters,
)
from cocomopl.primitives.shared_kernels import ShapeCache, WeightKernels, distinct_shapes

RELATIVE_TOLERANCE = 1e-5  # a round that raises the bound by less than this fraction of it ends the fit
HYPERPARAMETERS = ("log_alpha_t", "log_ell_t", "log_alpha_w", "log_gamma_w", "log_eta_w")
GRID_POINTS = 61  # log-spaced candidate widths per time kernel in an M-step, 12 % apart


def _shifted_solve(K: np.ndarray, scale: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``(I + scale K)^-1 rhs`` for time kernels ``K`` (..., T, T), scales (...) and ``rhs`` (..., T, k).

    Written without ``K^-1``: the kernels' nuggets can be as small as 1e-6, so their inverses
    are ill-conditioned where ``I + scale K`` is not.
    """
    return np.linalg.solve(np.eye(K.shape[-1]) + scale[..., None, None] * K, rhs)


def priors(hyper: dict, data: BoundData, kernel: str, *, cache: ShapeCache) -> tuple[np.ndarray, WeightKernels]:
    """The prior covariances of the hyperparameters ``hyper``: the MPs' ``A`` (S, T, T) and
    the weight GPs', their shapes factorised once in ``cache``."""
    A = mp_prior(hyper, data, kernel, xp=np)
    alpha, gamma, eta = (np.exp(hyper[k]) for k in ("log_alpha_w", "log_gamma_w", "log_eta_w"))
    return A, WeightKernels(cache, alpha, gamma, eta=eta)


def e_step(q: dict, A: np.ndarray, B: WeightKernels, *, data: BoundData) -> dict:
    """One sweep over the primitives: ``Q(MP_s)``, then ``Q(W_is)`` of every signal, each set
    to its optimum given the rest.  ``q`` also gets the precisions the posteriors were
    computed with, ``d`` (S,) and ``c`` (I, S): ``Sigma_s = (A_s^-1 + d_s I)^-1`` and
    ``Omega_is = (B_is^-1 + c_is I)^-1``."""
    mask, mu = data.mask, data.mu
    m, Sig, w = (q[k].copy() for k in ("m", "Sig", "w"))
    held = q["Om"].diagonal()  # of the weight posteriors as they are, under the priors they were computed with
    inv_s2 = 1.0 / q["sigma2"]
    d, c = np.empty(len(m)), np.empty(w.shape[:2])
    steps = np.nonzero(mask)  # the residuals are taken over the steps alone, not the empty slots
    rest = data.X[steps] - np.einsum("isk,st->kit", w[:, :, *steps], m)  # (K, I, T)
    for s in range(len(m)):
        rest += np.einsum("ik,t->kit", w[:, s][:, *steps], m[s])  # the data less every other primitive's share
        second = w[:, s][:, *steps] ** 2 + held[:, s][:, *steps]  # E[W_is^2], (I, K)
        d[s] = inv_s2 @ second.sum(axis=1)
        r = np.einsum("ik,kit->t", w[:, s][:, *steps] * inv_s2[:, None], rest)
        Sig[s] = _shifted_solve(A[s], d[s], A[s])
        m[s] = _shifted_solve(A[s], d[s], (mu[s] + A[s] @ r)[:, None])[:, 0]
        c[:, s] = (m[s] @ m[s] + np.trace(Sig[s])) * inv_s2
        y = np.zeros(w.shape[:1] + w.shape[2:])  # (I, G, N)
        y[:, *steps] = (rest @ m[s]).T * inv_s2[:, None]
        prior_mean = q["chi"][:, s, :, None] * mask
        w[:, s] = B.primitive(s).posterior_mean(c[:, s, None], prior_mean[:, None], y[:, None])[:, 0]
        rest -= np.einsum("ik,t->kit", w[:, s][:, *steps], m[s])
    return {**q, "m": m, "Sig": Sig, "w": w, "Om": B.posterior_covariance(c), "d": d, "c": c}


def means_and_noise(q: dict, B: WeightKernels, data: BoundData) -> dict:
    """``chi`` and ``sigma^2`` at their optima given the rest.

    ``chi_isg`` is the generalised least-squares mean of the weights under the type's kernel,
    ``1' B^-1 w / 1' B^-1 1`` over its steps; ``sigma_i^2`` the expected squared residual per
    datum of signal i, ``E ||x - sum_s W_s MP_s||^2 / (K T)``.
    """
    mask = data.mask
    chi = B.gls_means(q["w"], mask)
    m, w = q["m"], q["w"]
    m2 = (m**2).sum(axis=1) + np.trace(q["Sig"], axis1=1, axis2=2)  # E||MP_s||^2
    residual = data.X - np.einsum("isgn,st->gnit", w, m)
    omega = q["Om"].diagonal()
    spread = np.einsum("isgn,s->gni", w**2 + omega, m2) - np.einsum("isgn,s->gni", w**2, (m**2).sum(axis=1))
    sq = (residual**2).sum(axis=-1) + spread  # (G, N, I)
    sigma2 = np.einsum("gni,gn->i", sq, mask) / (mask.sum() * data.X.shape[-1])
    return {**q, "chi": chi, "sigma2": sigma2}


def _inverse_and_log_det(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``K^-1`` and ``log|K|`` of symmetric positive-definite kernels (..., n, n), by Cholesky."""
    L = np.linalg.cholesky(K)
    L_inv = np.linalg.inv(L)
    return np.swapaxes(L_inv, -1, -2) @ L_inv, 2.0 * np.log(np.diagonal(L, axis1=-2, axis2=-1)).sum(-1)


def _best_kernels(grid: tuple, current: tuple, moment: np.ndarray, n: float, log_alpha_limits) -> tuple:
    """Per kernel, the candidate shape (width, and nugget for the weight kernels) and the log
    amplitude that minimise its KL terms, the posterior held.

    A kernel is ``alpha K(shape)``; with the posterior's second moment about the prior mean,
    ``M = S + d d'``, its KL terms are ``(n log alpha + tr(K^-1 M) / alpha + log|K|) / 2``, so
    for each shape the amplitude has a closed form, ``alpha = tr(K^-1 M) / n``.

    ``grid`` is (shape parameters, each (C,); unit-amplitude inverses (C, E), flattened;
    log-determinants (C,)), shared by every kernel; ``current`` the same for each kernel's
    present shape, with (...) for (C,); ``moment`` is (..., E), flattened alike.  Keeping the
    present shape among the candidates means the KL terms cannot rise.
    """
    (grid_shapes, grid_inverse, grid_log_det), (shapes, inverse, log_det) = grid, current
    batch = shapes[0].shape

    def candidates(on_grid: np.ndarray, now: np.ndarray) -> np.ndarray:
        """(C + 1, *batch): the grid's values for every kernel, then each kernel's present one."""
        return np.concatenate([np.broadcast_to(on_grid.reshape(-1, *[1] * len(batch)), (len(on_grid), *batch)), now[None]])

    flat = moment.reshape(int(np.prod(batch)), -1)
    traces = np.concatenate([(grid_inverse @ flat.T).reshape(-1, *batch),
                             (inverse.reshape(flat.shape) * flat).sum(-1).reshape(1, *batch)])
    low, high = log_alpha_limits
    log_alpha = np.clip(np.log(np.maximum(traces, 1e-300) / n), low, high)
    value = 0.5 * (n * log_alpha + traces * np.exp(-log_alpha) + candidates(grid_log_det, log_det))
    best = np.argmin(value, axis=0)[None]
    chosen = [np.take_along_axis(candidates(g, now), best, axis=0)[0] for g, now in zip(grid_shapes, shapes)]
    return chosen, np.take_along_axis(log_alpha, best, axis=0)[0]


def _time_kernels(kernel: str, r: np.ndarray, ell: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses, flattened (..., T T), and log-determinants (...) of the unit-amplitude time
    kernels ``K(ell) + JITTER I`` of widths ``ell`` (...)."""
    K = time_kernel(kernel, r, 1.0, ell=ell[..., None, None], xp=np)
    inverse, log_det = _inverse_and_log_det(K + JITTER * np.eye(len(r)))
    return inverse.reshape(*inverse.shape[:-2], -1), log_det


def _on_steps(blocks) -> np.ndarray:
    """Per-type blocks (..., g, n, n), one array per size group, flattened into one (..., E)
    in the order of ``BoundData.groups``: the entries of the weight kernels that couple steps."""
    return np.concatenate([b.reshape(*b.shape[:-3], -1) for b in blocks], axis=-1)


def _weight_kernels(data: BoundData, gamma: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverses on the steps (..., E) (:func:`_on_steps`) and log-determinants (..., summed
    over the types) of the unit-amplitude weight kernels ``exp(-gamma d2) + eta I`` of widths
    ``gamma`` and nuggets ``eta`` (...), each type at its own size: an empty slot's identity
    adds nothing to either."""
    inverses, log_det = [], 0.0
    for n, idx in data.groups:
        K = np.exp(-gamma[..., None, None, None] * data.d2[idx, :n, :n]) + eta[..., None, None, None] * np.eye(n)
        inverse, type_log_det = _inverse_and_log_det(K)
        inverses.append(inverse)
        log_det = log_det + type_log_det.sum(-1)
    return _on_steps(inverses), log_det


def _current_weight_kernels(data: BoundData, gamma: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_weight_kernels` of the kernels' present shapes (I, S), each distinct shape
    factorised once: most GPs share theirs (:mod:`~cocomopl.primitives.shared_kernels`)."""
    shapes, shape_of = distinct_shapes(gamma, eta)
    inverse, log_det = _weight_kernels(data, *shapes)
    return inverse[shape_of], log_det[shape_of]


def weight_widths(points: int) -> np.ndarray:
    """``points`` candidate widths of the weight kernels (inverse squared, 1/m^2), log-spaced
    over their bounds (7 mm .. 0.7 m): 31 are 36 % apart, 9 a half-decade."""
    return np.geomspace(*np.exp(LOG_BOUNDS["log_gamma_w"]), points)


def start_widths(points: int) -> tuple | np.ndarray:
    """The widths the PCA start picks from (:func:`~cocomopl.primitives.optimise.initial_parameters`):
    the half-decade ``GAMMA_GRID``, or EM's own candidates when they are no more.  An M-step
    keeps a kernel's width if no candidate beats it, so a start width off a coarse grid would
    stay beside the grid's and add to the distinct widths that prediction pays for."""
    return weight_widths(points) if points <= len(GAMMA_GRID) else GAMMA_GRID


def kernel_grids(data: BoundData, kernel: str, widths: np.ndarray) -> dict:
    """The M-step's candidate kernels, the same in every round: the log-spaced widths (and
    nuggets) of the time kernels, the weight kernels' ``widths`` with every nugget, with their
    inverses (flattened; the weight kernels' on the steps, :func:`_on_steps`) and log-determinants."""
    ells = np.geomspace(float(data.r[0, 1]), 10.0, GRID_POINTS)
    gammas, etas = (g.ravel() for g in np.meshgrid(widths, ETA_GRID))
    return {"time": ((ells,), *_time_kernels(kernel, data.r, ells)),
            "weight": ((gammas, etas), *_weight_kernels(data, gammas, etas))}


def m_step(q: dict, hyper: dict, data: BoundData, *, kernel: str, grids: dict | None = None) -> dict:
    """The kernel hyperparameters at their best, the posteriors held: per kernel the width
    (and for the weight kernels the nugget) from a log-spaced grid (:func:`kernel_grids`,
    computed here with the default widths unless given) or its current value (so the bound
    cannot fall), and the amplitude in closed form (:func:`_best_kernels`)."""
    grids = kernel_grids(data, kernel, weight_widths(DEFAULT_WIDTHS)) if grids is None else grids
    # time kernels, per primitive
    ell_now = np.exp(hyper["log_ell_t"])
    deviation = q["m"] - data.mu
    moment = q["Sig"] + deviation[:, :, None] * deviation[:, None, :]  # (S, T, T)
    (ell,), log_alpha_t = _best_kernels(
        grids["time"], ((ell_now,), *_time_kernels(kernel, data.r, ell_now)), moment.reshape(len(moment), -1),
        data.r.shape[0], LOG_BOUNDS["log_alpha_t"],
    )
    # weight kernels, per (signal, primitive), over all step types at once
    deviation = q["w"] - q["chi"][..., None]
    moment = _on_steps([block + deviation[..., idx, :n, None] * deviation[..., idx, None, :n]
                        for (n, idx), block in zip(data.groups, q["Om"].blocks())])
    gamma_now, eta_now = np.exp(hyper["log_gamma_w"]), np.exp(hyper["log_eta_w"])
    (gamma, eta), log_alpha_w = _best_kernels(
        grids["weight"], ((gamma_now, eta_now), *_current_weight_kernels(data, gamma_now, eta_now)), moment,
        data.mask.sum(), LOG_BOUNDS["log_alpha_w"],
    )
    return {"log_alpha_t": log_alpha_t, "log_ell_t": np.log(ell), "log_alpha_w": log_alpha_w,
            "log_gamma_w": np.log(gamma), "log_eta_w": np.log(eta)}


def as_parameters(q: dict, hyper: dict, A: np.ndarray, *, B: WeightKernels, data: BoundData) -> dict:
    """The posterior after an E-step in :func:`~cocomopl.primitives.bound.free_energy`'s
    parametrisation: whitened means and the precisions ``d``, ``c``."""
    mask = data.mask
    u = np.linalg.solve(np.linalg.cholesky(A), (q["m"] - data.mu)[..., None])[..., 0]
    v = B.whiten((q["w"] - q["chi"][..., None]) * mask) * mask
    return {**hyper, "u": u, "v": v, "chi": q["chi"], "log_d": np.log(q["d"]), "log_c": np.log(q["c"]),
            "log_sigma": 0.5 * np.log(q["sigma2"])}


def maximise_bound_em(
    X_slots,
    mask,
    d2,
    *,
    tau,
    S: int,
    kernel: str,
    max_rounds: int,
    signal_weights: np.ndarray,
    widths: int = DEFAULT_WIDTHS,
    on_iteration: Callable[[float], None] | None = None,
) -> dict:
    """Fit Q and the kernel hyperparameters by variational EM from the PCA start of
    :func:`~cocomopl.primitives.optimise.initial_parameters`; return what
    :func:`~cocomopl.primitives.optimise.maximise_bound` returns, with ``bounds``: the bound
    after each round's E-step and closed-form updates (non-decreasing).

    The weight kernels' widths are picked from ``widths`` candidates (:func:`weight_widths`).
    ``on_iteration``, if given, is called after every round with the bound reached.
    """
    params, data = initial_parameters(X_slots, mask, d2, tau=tau, S=S, signal_weights=signal_weights,
                                      widths=start_widths(widths))
    hyper = {k: np.asarray(params[k], dtype=float) for k in HYPERPARAMETERS}
    cache = ShapeCache(data)
    q = {**posterior_start(params, *priors(hyper, data, kernel, cache=cache), data=data), "chi": params["chi"],
         "sigma2": np.exp(2.0 * params["log_sigma"])}
    grids = kernel_grids(data, kernel, weight_widths(widths))
    bounds = []
    for _ in range(max(max_rounds, 1)):
        if bounds:
            hyper = m_step(q, hyper, data, kernel=kernel, grids=grids)
        A, B = priors(hyper, data, kernel, cache=cache)
        q = means_and_noise(e_step(q, A, B, data=data), B, data)
        params = as_parameters(q, hyper, A, B=B, data=data)
        bounds.append(float(free_energy(params, data, kernel, xp=np, priors=(A, B))))
        if on_iteration is not None:
            on_iteration(bounds[-1])
        if len(bounds) > 1 and bounds[-1] - bounds[-2] < RELATIVE_TOLERANCE * abs(bounds[-1]):
            break
    reconstruction = np.einsum("isgn,st->gnit", q["w"], q["m"])
    return {
        "arrays": _prediction_arrays(params, data, kernel, (A, B)),
        "bound": bounds[-1],
        "bounds": bounds,
        "iterations": len(bounds),
        "reconstruction": reconstruction,
    }


def posterior_start(params: dict, A: np.ndarray, B: WeightKernels, *, data: BoundData) -> dict:
    """The PCA start as explicit posteriors: means and covariances, under the priors ``A`` and ``B``."""
    d = np.exp(params["log_d"])
    return {
        "m": data.mu + np.einsum("stu,su->st", np.linalg.cholesky(A), params["u"]),
        "Sig": _shifted_solve(A, d, A),
        "w": params["chi"][..., None] + B.unwhiten(params["v"]),
        "Om": B.posterior_covariance(np.exp(params["log_c"])),
    }
