"""Variational EM for the primitives' bound: each block update is its exact maximum."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.primitives import em, slot_algebra
from cocomopl.primitives.bound import free_energy, mp_prior, weight_diagonals, weight_prior
from cocomopl.primitives.estimator import SlotLayout, pca_signal_weights
from cocomopl.primitives.optimise import LOG_BOUNDS, initial_parameters, maximise_bound
from cocomopl.primitives.shared_kernels import ShapeCache, WeightKernels
from cocomopl.primitives.training import learned_parts, load_training_steps, phase_templates, resample

S, KERNEL = 3, "matern52"


@pytest.fixture(scope="module")
def problem():
    steps = load_training_steps(BUNDLED_DATASET)
    # every step type, but only the steps between 150 and 250 mm: a small problem
    steps = steps.subset(k for k, s in enumerate(steps.specs) if max(s.start_length, s.end_length) <= 0.25)
    parts, types = learned_parts(steps)
    tau = np.linspace(0.0, 1.0, 20)
    X = resample(parts, phase_templates(parts, types), tau, types=types)
    layout = SlotLayout(parts, types)
    return layout.to_slots(X), layout.mask, layout.d2, tau, pca_signal_weights(X, steps.signal_names)


def _start(problem):
    X, mask, d2, tau, weights = problem
    params, data = initial_parameters(X, mask, d2, tau=tau, S=S, signal_weights=weights)
    hyper = {k: np.asarray(params[k], dtype=float) for k in em.HYPERPARAMETERS}
    A, B = em.priors(hyper, data, KERNEL, cache=ShapeCache(data))
    q = {**em.posterior_start(params, A, B, data=data), "chi": params["chi"], "sigma2": np.exp(2 * params["log_sigma"])}
    return q, hyper, A, B, data, params


def _gradient(params: dict, data) -> dict:
    grad = jax.grad(lambda p: free_energy(p, data, KERNEL))({k: jnp.asarray(v) for k, v in params.items()})
    return {k: np.asarray(v) for k, v in grad.items()}


@pytest.mark.slow
def test_the_bound_never_falls_over_the_rounds(problem):
    X, mask, d2, tau, weights = problem
    result = em.maximise_bound_em(X, mask, d2, tau=tau, S=S, kernel=KERNEL, max_rounds=8, signal_weights=weights)
    steps = np.diff(result["bounds"])
    assert np.all(steps >= -1e-6 * abs(result["bounds"][-1])), steps
    # and it ends above the joint L-BFGS-B optimiser's, from the same start
    joint = maximise_bound(X, mask, d2, tau=tau, S=S, kernel=KERNEL, max_iterations=30, signal_weights=weights)
    assert result["bound"] > joint["bound"]


@pytest.mark.slow
def test_the_fit_stops_at_the_first_round_below_the_relative_tolerance(problem):
    X, mask, d2, tau, weights = problem
    result = em.maximise_bound_em(X, mask, d2, tau=tau, S=S, kernel=KERNEL, max_rounds=80, signal_weights=weights)
    bounds = np.array(result["bounds"])
    gains = np.diff(bounds) / np.abs(bounds[1:])
    assert result["iterations"] == len(bounds) < 80  # this small problem settles before the cap
    assert gains[-1] < em.RELATIVE_TOLERANCE  # the round that ended it
    assert np.all(gains[:-1] >= em.RELATIVE_TOLERANCE)  # and none before it would have


@pytest.mark.slow
def test_each_closed_form_update_is_a_stationary_point(problem):
    q, hyper, A, B, data, start = _start(problem)
    mask = data.mask
    updated = em.e_step(q, A, B, data=data)
    # the last block updated, Q(W_i,S-1) of every signal, is at its optimum given the rest:
    # the bound's gradient along its mean and precision vanishes
    params = em.as_parameters(updated, hyper, A, B=B, data=data)
    at_start, after = _gradient(start, data), _gradient(params, data)
    assert np.abs(after["v"][:, -1] * mask).max() < 1e-6 * np.abs(at_start["v"][:, -1] * mask).max()
    assert np.abs(after["log_c"][:, -1]).max() < 1e-6 * np.abs(at_start["log_c"][:, -1]).max()
    # the noise at its optimum, given the posteriors
    closed = em.means_and_noise(updated, B, data)
    gradient = _gradient(em.as_parameters(closed, hyper, A, B=B, data=data), data)
    assert np.abs(gradient["log_sigma"]).max() < 1e-6 * np.abs(after["log_sigma"]).max()


def _held_kl(q: dict, hyper: dict, data) -> float:
    """The hyperparameter-dependent part of KL(Q || prior), Q held, from the prior matrices."""
    A, B = np.asarray(mp_prior(hyper, data, KERNEL)), np.asarray(weight_prior(hyper, data))
    mask = data.mask
    Om = np.eye(mask.shape[1]) * (1.0 - mask[:, :, None])  # empty slots: identities, constant
    Om = np.broadcast_to(Om, B.shape).copy()
    for (n, idx), block in zip(data.groups, q["Om"].blocks()):
        Om[..., idx, :n, :n] = block
    out = 0.0
    for K, cov, deviation in ((A, q["Sig"], q["m"] - data.mu), (B, Om, (q["w"] - q["chi"][..., None]) * mask)):
        inverse = np.linalg.inv(K)
        out += 0.5 * float(np.sum(np.einsum("...nm,...nm->...", inverse, cov)
                                  + np.einsum("...n,...nm,...m->...", deviation, inverse, deviation)
                                  + np.linalg.slogdet(K)[1]))
    return out


def test_the_m_step_cannot_lower_the_bound_and_moves_the_time_kernels(problem):
    q, hyper, A, B, data, _ = _start(problem)
    q = em.means_and_noise(em.e_step(q, A, B, data=data), B, data)
    new = em.m_step(q, hyper, data, kernel=KERNEL)
    assert _held_kl(q, new, data) <= _held_kl(q, hyper, data) + 1e-9 * abs(_held_kl(q, hyper, data))
    assert np.abs(new["log_ell_t"] - hyper["log_ell_t"]).max() > 0.1  # the time kernels learn
    assert np.abs(new["log_alpha_t"] - hyper["log_alpha_t"]).max() > 0.1
    assert np.all((new["log_eta_w"] >= LOG_BOUNDS["log_eta_w"][0]) & (new["log_eta_w"] <= LOG_BOUNDS["log_eta_w"][1]))


@pytest.mark.slow
@pytest.mark.parametrize("xp", [np, jnp], ids=["numpy", "jax"])
def test_slot_algebra_at_each_types_size_equals_the_dense_algebra(xp):
    """Types of 3, 7, 3 and 5 steps padded to 7 slots: Cholesky factors and solves taken per
    type at its own size equal NumPy's on the padded matrices (a padded slot has only a
    diagonal entry, as in the weight GPs' priors and posteriors)."""
    rng = np.random.default_rng(0)
    sizes, N = [3, 7, 3, 5], 7
    mask = (np.arange(N) < np.array(sizes)[:, None]).astype(float)
    M = np.zeros((2, len(sizes), N, N))
    for b, g in np.ndindex(M.shape[:2]):
        n = sizes[g]
        A = rng.normal(size=(n, n))
        M[b, g, :n, :n] = A @ A.T + n * np.eye(n)
        M[b, g, n:, n:] = np.diag(rng.uniform(1.0, 2.0, N - n))
    groups = slot_algebra.size_groups(mask)
    assert [n for n, _ in groups] == [3, 5, 7] and list(groups[0][1]) == [0, 2]
    R = rng.normal(size=(2, len(sizes), N, 3))
    L = slot_algebra.cholesky(xp.asarray(M), groups, xp)
    np.testing.assert_allclose(np.asarray(L), np.linalg.cholesky(M), atol=1e-14)
    np.testing.assert_allclose(np.asarray(slot_algebra.solve(xp.asarray(M), xp.asarray(R), groups, xp=xp)),
                               np.linalg.solve(M, R), atol=1e-13)
    # triangular factors, and right-hand sides with more leading axes than the matrices
    R5 = rng.normal(size=(5, 2, len(sizes), N, 2))
    np.testing.assert_allclose(np.asarray(slot_algebra.solve(xp.asarray(np.asarray(L)), xp.asarray(R5), groups, xp=xp)),
                               np.linalg.solve(np.linalg.cholesky(M), R5), atol=1e-13)


def test_the_weight_priors_factorised_per_shape_give_the_dense_algebra(problem):
    """EM's weight priors share their factors among the GPs of one kernel shape
    (shared_kernels); every matrix function EM takes of them equals the dense one's."""
    X, mask, d2, tau, weights = problem
    _, data = initial_parameters(X, mask, d2, tau=tau, S=S, signal_weights=weights)
    rng = np.random.default_rng(0)
    I = X.shape[2]
    pick = rng.random((I, S)) < 0.5  # two shapes, shared by about half of the GPs each
    alpha, gamma, eta = rng.uniform(0.1, 2.0, (I, S)), np.where(pick, 30.0, 300.0), np.where(pick, 1e-3, 1e-1)
    kernels = WeightKernels(ShapeCache(data), alpha, gamma, eta=eta)
    assert len(kernels.cache) == 2  # factorised once per shape, not per GP
    B = np.asarray(weight_prior({"log_alpha_w": np.log(alpha), "log_gamma_w": np.log(gamma), "log_eta_w": np.log(eta)},
                                data, np))
    c = rng.uniform(1.0, 100.0, (I, S))
    x, y = (rng.normal(size=B.shape[:-1]) * mask for _ in range(2))
    chi = rng.normal(size=(I, S, mask.shape[0], 1)) * mask
    shifted = np.eye(B.shape[-1]) + c[..., None, None, None] * B

    def dense(M, v):
        return (M @ v[..., None])[..., 0]

    def dense_solve(M, v):
        return np.linalg.solve(M, v[..., None])[..., 0]

    np.testing.assert_allclose(kernels.posterior_mean(c, chi, y), dense_solve(shifted, chi + dense(B, y)),
                               rtol=1e-8, atol=1e-10)
    Om = B @ np.linalg.inv(shifted)
    for (n, idx), block in zip(data.groups, kernels.posterior_covariance(c).blocks()):
        np.testing.assert_allclose(block, Om[..., idx, :n, :n], rtol=1e-8, atol=1e-12)
    L = np.linalg.cholesky(B)
    np.testing.assert_allclose(kernels.whiten(x), dense_solve(L, x), rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(kernels.unwhiten(x), dense(L, x), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(kernels.solve_whitened(kernels.whiten(x)), dense_solve(B, x),
                               rtol=1e-6, atol=1e-8)
    ones = dense_solve(B, np.broadcast_to(mask, x.shape))
    np.testing.assert_allclose(kernels.gls_means(x, mask), (ones * x).sum(-1) / (ones * mask).sum(-1), rtol=1e-7)
    # the bound's terms: the same diagonals, and log-determinant terms with the same sum per type
    mine, theirs = kernels.bound_terms(c, x), weight_diagonals(B, c, x, groups=data.groups, xp=np)
    for a, b in zip(mine[:3], theirs[:3]):
        np.testing.assert_allclose(a * mask, b * mask, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose((mine[3] * mask).sum(-1), (theirs[3] * mask).sum(-1), rtol=1e-10)
