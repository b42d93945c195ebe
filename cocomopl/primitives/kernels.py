"""Covariance functions of the model, written for JAX so the bound can be differentiated.

Time kernels (the MP priors, eq. 3) act on the distance ``r = |tau - tau'|`` between grid
points of normalised time.  Eq. (3)'s RBF ``alpha exp(-gamma r^2)`` is written with a
length scale, ``gamma = 1 / (2 ell^2)``, so that all three kernels share ``(alpha, ell)``.
Matern kernels have rougher sample paths than the RBF; they are the candidates for the
cusps of the ZMP at touchdown.

The weight kernel (eq. 5) is a Kronecker delta on the step type times an RBF on the
(start length, end length) difference.

Each takes the array module ``xp``: ``jax.numpy`` (the default) where the bound is
differentiated, NumPy where it is only evaluated (:mod:`cocomopl.primitives.em`).
"""

from __future__ import annotations

import jax.numpy as jnp

from cocomopl.primitives import TIME_KERNELS


def time_kernel(name: str, r, alpha, *, ell, xp=jnp):
    """Kernel matrix for distances ``r`` (..., T, T), amplitude ``alpha`` and length ``ell`` (broadcast)."""
    x = r / ell
    if name == "rbf":
        return alpha * xp.exp(-0.5 * x**2)
    if name == "matern32":
        s = xp.sqrt(3.0) * x
        return alpha * (1.0 + s) * xp.exp(-s)
    if name == "matern52":
        s = xp.sqrt(5.0) * x
        return alpha * (1.0 + s + s**2 / 3.0) * xp.exp(-s)
    raise ValueError(f"unknown time kernel {name!r}; choose one of {TIME_KERNELS}")


def weight_kernel(d2, alpha, gamma, *, xp=jnp):
    """Eq. (5) within one step type: ``alpha exp(-gamma |z|^2)`` for squared length distances ``d2``."""
    return alpha * xp.exp(-gamma * d2)
