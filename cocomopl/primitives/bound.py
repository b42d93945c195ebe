"""The variational free energy of the movement-primitive model (eq. 6), in JAX.

Model (eq. 2): ``X[k, i, t] = sum_s W[i, s](l_k) MP[s](t) + eta``, ``eta ~ N(0, sigma_i^2)``.
Priors: ``MP_s ~ GP(mu_s, A_s)`` with a time kernel (eq. 3) and ``mu_s`` from a PCA;
``W_is(.) ~ GP(chi_is[type], B_is)`` with eq. (5)'s kernel plus a learned nugget.

Posterior ``Q = prod_s Q(MP_s) prod_is Q(W_is)``, each Gaussian.  Given the other
factors, the optimal covariances are the prior precision plus a multiple of the identity
(the noise is i.i.d. over time and over steps), so they are parametrised exactly so:
``Sigma_s = (A_s^-1 + d_s I)^-1`` and ``Omega_is = (B_is^-1 + c_is I)^-1``.  Means are
whitened, ``m_s = mu_s + chol(A_s) u_s`` and ``w_is = chi_is + chol(B_is) v_is`` (the
parametrisation of the joint optimiser in :mod:`cocomopl.primitives.optimise`; the fit
itself is by variational EM, :mod:`cocomopl.primitives.em`).

Steps are laid out in slots ``(G types, N slots)``; eq. (5)'s Kronecker delta makes the
weight covariance block-diagonal by type, so each type's block is handled on its own and
empty slots are masked out.

Every function takes the array module ``xp``: ``jax.numpy`` (the default), so that the
joint optimiser can differentiate the bound, or NumPy, where EM only needs its value: JAX's
batched factorisations on the CPU take several times NumPy's (the bound of the omni data
took 0.8 s a round in JAX, a third of an EM round).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from cocomopl.primitives import slot_algebra
from cocomopl.primitives.kernels import time_kernel, weight_kernel

jax.config.update("jax_enable_x64", True)

JITTER = 1e-6  # relative nugget keeping the time kernels positive definite (the weight kernels learn theirs)


@dataclass(frozen=True)
class BoundData:
    """The training data in slot layout.

    Attributes
    ----------
    X : (G, N, I, T) signals (zeros in empty slots)
    mask : (G, N) 1 for a step, 0 for an empty slot
    d2 : (G, N, N) squared distances of the (start, end) lengths within a type, m^2
    r : (T, T) distances between the normalised-time grid points
    mu : (S, T) prior mean functions of the MPs (PCA components)
    """

    X: np.ndarray
    mask: np.ndarray
    d2: np.ndarray
    r: np.ndarray
    mu: np.ndarray

    @property
    def groups(self) -> tuple[tuple[int, np.ndarray], ...]:
        """The types by size, for :mod:`~cocomopl.primitives.slot_algebra`."""
        return slot_algebra.size_groups(self.mask)


def _chol_solve_identity(L, xp=jnp):
    """``P^-1`` from the Cholesky factor of ``P`` (batched)."""
    if xp is jnp:
        return jax.scipy.linalg.cho_solve((L, True), jnp.broadcast_to(jnp.eye(L.shape[-1]), L.shape))
    L_inv = np.linalg.inv(L)
    return np.swapaxes(L_inv, -1, -2) @ L_inv


def mp_prior(params: dict, data: BoundData, kernel: str, *, xp=jnp):
    """Prior covariances ``A`` (S, T, T) of the MPs."""
    alpha = xp.exp(params["log_alpha_t"])[:, None, None]
    ell = xp.exp(params["log_ell_t"])[:, None, None]
    T = data.r.shape[0]
    return time_kernel(kernel, data.r[None], alpha, ell=ell, xp=xp) + JITTER * alpha * xp.eye(T)


def weight_prior(params: dict, data: BoundData, xp=jnp):
    """Prior covariances ``B`` (I, S, G, N, N) of the weights; empty slots get an identity row.

    Eq. (5) plus a learned nugget ``alpha eta I``: a step's weight may differ from the smooth
    function of the step lengths by independent variation of relative variance ``eta``.
    """
    alpha = xp.exp(params["log_alpha_w"])[:, :, None, None, None]
    gamma = xp.exp(params["log_gamma_w"])[:, :, None, None, None]
    eta = xp.exp(params["log_eta_w"])[:, :, None, None, None]
    m = xp.asarray(data.mask)
    both = m[:, :, None] * m[:, None, :]
    eye = xp.eye(data.mask.shape[1])
    K = weight_kernel(data.d2, alpha, gamma, xp=xp) * both
    return K + eta * alpha * eye * m[:, :, None] + eye * (1.0 - m[:, :, None])


def posterior(params: dict, data: BoundData, kernel: str, *, xp=jnp, priors: tuple | None = None) -> dict:
    """Means and covariance summaries of Q, and the two KL divergences; ``priors``, the
    prior covariances ``(A, B)`` of ``params`` if already computed."""
    A, B = priors or (mp_prior(params, data, kernel, xp=xp), weight_prior(params, data, xp))
    T = data.mu.shape[1]
    m = data.mu + xp.einsum("stu,su->st", xp.linalg.cholesky(A), params["u"])
    d = xp.exp(params["log_d"])[:, None, None]
    L_PA = xp.linalg.cholesky(xp.eye(T) + d * A)
    PA_inv = _chol_solve_identity(L_PA, xp)
    tr_sigma = xp.sum(A * PA_inv, axis=(1, 2))  # tr(A (I + dA)^-1) = tr(Sigma)
    kl_mp = 0.5 * xp.sum(
        xp.trace(PA_inv, axis1=1, axis2=2)
        + xp.sum(params["u"] ** 2, axis=1)
        - T
        + 2.0 * xp.sum(xp.log(xp.diagonal(L_PA, axis1=1, axis2=2)), axis=1)
    )

    mask = xp.asarray(data.mask)
    v, c = params["v"], xp.exp(params["log_c"])
    # EM's priors come factorised per kernel shape (shared_kernels.WeightKernels), the rest dense
    weight_terms = B.bound_terms(c, v) if hasattr(B, "bound_terms") else weight_diagonals(B, c, v, groups=data.groups, xp=xp)
    whitened, omega, PB_inv_diagonal, log_det_parts = weight_terms
    w = params["chi"][..., None] + whitened
    kl_w = 0.5 * xp.sum(mask * (PB_inv_diagonal + v**2 - 1.0 + log_det_parts))
    return {"m": m, "tr_sigma": tr_sigma, "w": w, "omega": omega, "kl_mp": kl_mp, "kl_w": kl_w}


def weight_diagonals(B, c, v, *, groups, xp=jnp):
    """What the bound takes of the weight posteriors, per slot (I, S, G, N), each type's
    block at its own size (:mod:`~cocomopl.primitives.slot_algebra`): ``chol(B) v``, the
    diagonals of ``Omega = B (I + cB)^-1`` and of ``(I + cB)^-1``, and twice the log-diagonal
    of ``chol(I + cB)``, whose sum over a type's steps is ``log |I + cB|``.

    An empty slot has ``B = 1`` there and no coupling, hence the values the loop starts from."""
    shift = 1.0 + c[:, :, None, None]
    # fresh arrays each: NumPy's blocks are written in place
    whitened, omega = xp.array(v), xp.ones(v.shape) / shift
    P_inv_diagonal, log_det_parts = xp.ones(v.shape) / shift, xp.ones(v.shape) * xp.log(shift)
    for n, idx in groups:
        B_g = B[..., idx, :n, :n]
        at = (..., idx, slice(None, n))
        whitened = slot_algebra.put(whitened, at, xp.einsum("isgnj,isgj->isgn", xp.linalg.cholesky(B_g), v[at]), xp=xp)
        L_P = xp.linalg.cholesky(xp.eye(n) + c[:, :, None, None, None] * B_g)
        L_P_inv = xp.linalg.inv(L_P)
        P_inv = xp.swapaxes(L_P_inv, -1, -2) @ L_P_inv
        omega = slot_algebra.put(omega, at, xp.einsum("isgnj,isgjn->isgn", B_g, P_inv), xp=xp)
        P_inv_diagonal = slot_algebra.put(P_inv_diagonal, at, xp.diagonal(P_inv, axis1=-2, axis2=-1), xp=xp)
        log_det_parts = slot_algebra.put(log_det_parts, at, 2.0 * xp.log(xp.diagonal(L_P, axis1=-2, axis2=-1)), xp=xp)
    return whitened, omega, P_inv_diagonal, log_det_parts


def free_energy(params: dict, data: BoundData, kernel: str, *, xp=jnp, priors: tuple | None = None):
    """The bound L of eq. (6): expected log-likelihood minus KL(Q || prior); ``priors`` as
    for :func:`posterior`."""
    q = posterior(params, data, kernel, xp=xp, priors=priors)
    m, w, omega = q["m"], q["w"], q["omega"]
    mask = xp.asarray(data.mask)
    T = data.r.shape[0]
    sigma2 = xp.exp(2.0 * params["log_sigma"])  # (I,)
    residual = data.X - xp.einsum("isgn,st->gnit", w, m)
    m2 = xp.sum(m**2, axis=1)  # (S,)
    spread = xp.einsum("isgn,s->gni", (w**2 + omega), m2 + q["tr_sigma"]) - xp.einsum("isgn,s->gni", w**2, m2)
    sq = xp.sum(residual**2, axis=-1) + spread  # (G, N, I)
    ell = -0.5 * xp.sum(mask[:, :, None] * (T * xp.log(2.0 * xp.pi * sigma2) + sq / sigma2))
    return ell - q["kl_mp"] - q["kl_w"]
