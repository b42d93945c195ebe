"""Variational EM for the primitives' bound: each block update is its exact maximum."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.primitives import em
from cocomopl.primitives.bound import free_energy, mp_prior, weight_prior
from cocomopl.primitives.estimator import _SlotLayout, pca_signal_weights
from cocomopl.primitives.optimise import LOG_BOUNDS, initial_parameters, maximise_bound
from cocomopl.primitives.training import learned_parts, load_training_steps, phase_templates, resample

S, KERNEL = 3, "matern52"


@pytest.fixture(scope="module")
def problem():
    steps = load_training_steps(BUNDLED_DATASET)
    # every step type, but only the steps between 150 and 250 mm: a small problem
    steps = steps.subset(k for k, s in enumerate(steps.specs) if max(s.start_length, s.end_length) <= 0.25)
    parts, types = learned_parts(steps)
    tau = np.linspace(0.0, 1.0, 20)
    X = resample(parts, phase_templates(parts, types), tau, types)
    layout = _SlotLayout(parts, types)
    return layout.to_slots(X), layout.mask, layout.d2, tau, pca_signal_weights(X, steps.signal_names)


def _start(problem):
    X, mask, d2, tau, weights = problem
    params, data = initial_parameters(X, mask, d2, tau, S, weights)
    hyper = {k: np.asarray(params[k], dtype=float) for k in em.HYPERPARAMETERS}
    q = {**em._posterior_start(params, data, KERNEL), "chi": params["chi"], "sigma2": np.exp(2 * params["log_sigma"])}
    A, B = np.asarray(mp_prior(hyper, data, KERNEL)), np.asarray(weight_prior(hyper, data))
    return q, hyper, A, B, data, params


def _gradient(params: dict, data) -> dict:
    grad = jax.grad(lambda p: free_energy(p, data, KERNEL))({k: jnp.asarray(v) for k, v in params.items()})
    return {k: np.asarray(v) for k, v in grad.items()}


def test_the_bound_never_falls_over_the_rounds(problem):
    result = em.maximise_bound_em(*problem[:4], S, KERNEL, 8, problem[4])
    steps = np.diff(result["bounds"])
    assert np.all(steps >= -1e-6 * abs(result["bounds"][-1])), steps
    # and it ends above the joint L-BFGS-B optimiser's, from the same start
    joint = maximise_bound(*problem[:4], S, KERNEL, 30, problem[4])
    assert result["bound"] > joint["bound"]


def test_each_closed_form_update_is_a_stationary_point(problem):
    q, hyper, A, B, data, start = _start(problem)
    mask = data.mask
    updated = em.e_step(q, A, B, data)
    # the last block updated, Q(W_i,S-1) of every signal, is at its optimum given the rest:
    # the bound's gradient along its mean and precision vanishes
    params = em.as_parameters(updated, hyper, A, B, data)
    at_start, after = _gradient(start, data), _gradient(params, data)
    assert np.abs(after["v"][:, -1] * mask).max() < 1e-6 * np.abs(at_start["v"][:, -1] * mask).max()
    assert np.abs(after["log_c"][:, -1]).max() < 1e-6 * np.abs(at_start["log_c"][:, -1]).max()
    # the noise at its optimum, given the posteriors
    closed = em.means_and_noise(updated, B, data)
    gradient = _gradient(em.as_parameters(closed, hyper, A, B, data), data)
    assert np.abs(gradient["log_sigma"]).max() < 1e-6 * np.abs(after["log_sigma"]).max()


def _held_kl(q: dict, hyper: dict, data) -> float:
    """The hyperparameter-dependent part of KL(Q || prior), Q held, from the prior matrices."""
    A, B = np.asarray(mp_prior(hyper, data, KERNEL)), np.asarray(weight_prior(hyper, data))
    mask = data.mask
    both = mask[:, :, None] * mask[:, None, :]
    eye = np.eye(mask.shape[1]) * (1.0 - mask[:, :, None])  # empty slots: identities, constant
    out = 0.0
    for K, cov, deviation in ((A, q["Sig"], q["m"] - data.mu),
                              (B, q["Om"] * both + eye, (q["w"] - q["chi"][..., None]) * mask)):
        inverse = np.linalg.inv(K)
        out += 0.5 * float(np.sum(np.einsum("...nm,...nm->...", inverse, cov)
                                  + np.einsum("...n,...nm,...m->...", deviation, inverse, deviation)
                                  + np.linalg.slogdet(K)[1]))
    return out


def test_the_m_step_cannot_lower_the_bound_and_moves_the_time_kernels(problem):
    q, hyper, A, B, data, _ = _start(problem)
    q = em.means_and_noise(em.e_step(q, A, B, data), B, data)
    new = em.m_step(q, hyper, data, KERNEL)
    assert _held_kl(q, new, data) <= _held_kl(q, hyper, data) + 1e-9 * abs(_held_kl(q, hyper, data))
    assert np.abs(new["log_ell_t"] - hyper["log_ell_t"]).max() > 0.1  # the time kernels learn
    assert np.abs(new["log_alpha_t"] - hyper["log_alpha_t"]).max() > 0.1
    assert np.all((new["log_eta_w"] >= LOG_BOUNDS["log_eta_w"][0]) & (new["log_eta_w"] <= LOG_BOUNDS["log_eta_w"][1]))
