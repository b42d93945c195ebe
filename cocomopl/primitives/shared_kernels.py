"""The weight GPs' priors in EM: each kernel shape factorised once, for every GP that has it.

Each weight GP's prior covariance is ``B_is = alpha_is K(gamma_is, eta_is)`` on each step
type's block (:func:`~cocomopl.primitives.bound.weight_prior`).  EM's M-step takes every
kernel's width and nugget from one grid (:func:`~cocomopl.primitives.em.kernel_grids`), so
a few shapes ``K`` serve many GPs: 29 for the 396 (signal, primitive) GPs of the bundled
omnidirectional model.  Factorised once per shape and type, ``K = U diag(lam) U'`` and
``K = L L'``, every matrix function of ``B_is`` that EM needs is a function of the
eigenvalues ``b = alpha lam`` between two products with ``U``, or a product with ``L``:
the posterior ``(I + c B)^-1 (...)``, its covariance ``B (I + c B)^-1``, inverses,
log-determinants and the Cholesky whitening of the bound's parametrisation
(:mod:`cocomopl.primitives.bound`).  The dense priors cost a factorisation per GP and per
round, and an (I, S, G, N, N) array (1 GB for that model) that EM never forms.

Vectors are in the slot layout (I, S, G, N) (:mod:`~cocomopl.primitives.slot_algebra`).
Only a type's first n slots, its steps, are used; results are zero on the empty slots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cocomopl.primitives.bound import BoundData


def distinct_shapes(gamma: np.ndarray, eta: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
    """The distinct kernel shapes among widths ``gamma`` and nuggets ``eta`` (I, S): their
    widths and nuggets, (k,) each, and the index of each GP's shape, (I, S)."""
    shapes, shape_of = np.unique(np.stack([gamma.ravel(), eta.ravel()]), axis=1, return_inverse=True)
    return (shapes[0], shapes[1]), shape_of.reshape(gamma.shape)


class ShapeCache:
    """Per unit kernel shape ``K(gamma, eta) = exp(-gamma d2) + eta I`` and per size group of
    step types: its eigenvalues ``lam`` (g, n), eigenvectors ``U``, Cholesky factor ``L`` and
    that factor's inverse (g, n, n), computed on first use."""

    def __init__(self, data: BoundData):
        self.groups = data.groups
        self.slots = data.mask.shape
        self._d2 = data.d2
        self._factors: dict[tuple[float, float], list[dict[str, np.ndarray]]] = {}

    def __len__(self) -> int:
        """The number of shapes factorised so far."""
        return len(self._factors)

    def factors(self, gamma: float, eta: float) -> list[dict[str, np.ndarray]]:
        key = (float(gamma), float(eta))
        if key not in self._factors:
            self._factors[key] = [self._factorise(np.exp(-gamma * self._d2[idx, :n, :n]) + eta * np.eye(n))
                                  for n, idx in self.groups]
        return self._factors[key]

    @staticmethod
    def _factorise(K: np.ndarray) -> dict[str, np.ndarray]:
        lam, U = np.linalg.eigh(K)
        L = np.linalg.cholesky(K)
        return {"lam": lam, "U": U, "L": L, "L_inv": np.linalg.inv(L)}


class WeightKernels:
    """The weight priors ``B_is = alpha_is K(gamma_is, eta_is)`` of every (signal i,
    primitive s), from the factors of their shapes in ``cache``; ``alpha``, ``gamma`` and
    ``eta`` are (I, S)."""

    def __init__(self, cache: ShapeCache, alpha: np.ndarray, gamma: np.ndarray, *, eta: np.ndarray):
        self.cache, self.alpha, self.gamma, self.eta = cache, alpha, gamma, eta
        shapes, shape_of = distinct_shapes(gamma, eta)
        self._shapes = [(np.nonzero(shape_of == k), cache.factors(g, e)) for k, (g, e) in enumerate(zip(*shapes))]
        self.b = self.eigenvalues()

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """The slot layout's (I, S, G, N)."""
        return (*self.alpha.shape, *self.cache.slots)

    def primitive(self, s: int) -> WeightKernels:
        """The priors of primitive ``s`` alone, (I, 1)."""
        at = (slice(None), slice(s, s + 1))
        return WeightKernels(self.cache, self.alpha[at], self.gamma[at], eta=self.eta[at])

    def _map(self, x: np.ndarray, factor: str, transpose: bool = False, square: bool = False) -> np.ndarray:
        """``F x`` per GP, for the factor ``F`` of its shape named ``factor`` (its transpose,
        or its entries squared), on the steps."""
        out = np.zeros(self.shape)
        x = np.broadcast_to(x, self.shape)
        subscripts = "gmn,pgm->pgn" if transpose else "gnm,pgm->pgn"
        for members, factors in self._shapes:
            for (n, idx), f in zip(self.cache.groups, factors):
                F = f[factor] ** 2 if square else f[factor]
                at = _steps_of(members, idx, n)
                out[at] = np.einsum(subscripts, F, x[at])
        return out

    def eigenvalues(self) -> np.ndarray:
        """``b`` (I, S, G, N): the eigenvalues of each ``B_is`` on its type's steps."""
        lam = np.zeros(self.shape)
        for members, factors in self._shapes:
            for (n, idx), f in zip(self.cache.groups, factors):
                lam[_steps_of(members, idx, n)] = f["lam"]
        return self.alpha[..., None, None] * lam

    def to_eigenbasis(self, x: np.ndarray) -> np.ndarray:
        """``U' x``."""
        return self._map(x, "U", transpose=True)

    def from_eigenbasis(self, z: np.ndarray) -> np.ndarray:
        """``U z``."""
        return self._map(z, "U")

    def diagonal(self, values: np.ndarray) -> np.ndarray:
        """The diagonals of ``U diag(values) U'``."""
        return self._map(values, "U", square=True)

    def blocks(self, values: np.ndarray) -> list[np.ndarray]:
        """``U diag(values) U'`` per size group of types, (I, S, g, n, n) each."""
        out = []
        for n, idx in self.cache.groups:
            block = np.zeros((*self.alpha.shape, len(idx), n, n))
            for members, factors in self._shapes:
                U = factors[len(out)]["U"]
                block[members] = (U * values[members][:, idx, None, :n]) @ np.swapaxes(U, -1, -2)
            out.append(block)
        return out

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """``chol(B)^-1 x``: the bound's whitened means of weights ``x`` about their means."""
        return self._map(x, "L_inv") / np.sqrt(self.alpha)[..., None, None]

    def unwhiten(self, v: np.ndarray) -> np.ndarray:
        """``chol(B) v``."""
        return self._map(v, "L") * np.sqrt(self.alpha)[..., None, None]

    def solve_whitened(self, v: np.ndarray) -> np.ndarray:
        """``chol(B)^-T v``, which is ``B^-1 x`` for ``v`` the whitened ``x``."""
        return self._map(v, "L_inv", transpose=True) / np.sqrt(self.alpha)[..., None, None]

    def posterior_mean(self, c: np.ndarray, prior_mean: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``(I + c B)^-1 (prior_mean + B y)`` for precisions ``c`` (I, S)."""
        b = self.b
        return self.from_eigenbasis((self.to_eigenbasis(prior_mean) + b * self.to_eigenbasis(y)) / (1.0 + c[..., None, None] * b))

    def posterior_covariance(self, c: np.ndarray) -> PosteriorCovariance:
        """``B (I + c B)^-1`` for precisions ``c`` (I, S)."""
        return PosteriorCovariance(self, self.b / (1.0 + c[..., None, None] * self.b))

    def bound_terms(self, c: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
        """What the bound takes of the weight posteriors ``Omega = B (I + c B)^-1`` with
        whitened means ``v``, as :func:`~cocomopl.primitives.bound.weight_diagonals` returns
        it: ``chol(B) v``, the diagonals of ``Omega`` and of ``(I + c B)^-1``, and per slot
        terms that sum over each type's steps to ``log |I + c B|``."""
        shift = 1.0 + c[..., None, None] * self.b
        return self.unwhiten(v), self.diagonal(self.b / shift), self.diagonal(1.0 / shift), np.log(shift)

    def gls_means(self, w: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """Per GP and type the generalised least-squares mean of its weights ``w`` on the steps,
        ``1' K^-1 w / 1' K^-1 1`` (the amplitude cancels)."""
        ones = self.to_eigenbasis(mask)
        inverse = np.divide(1.0, self.b, out=np.zeros(self.shape), where=self.b > 0)
        return (ones * self.to_eigenbasis(w * mask) * inverse).sum(-1) / (ones**2 * inverse).sum(-1)


def _steps_of(members: tuple[np.ndarray, np.ndarray], types: np.ndarray, n: int) -> tuple:
    """The index of the steps of ``types`` (n each) of the GPs ``members`` (signal and
    primitive indices) in the slot layout: (GPs, types, n)."""
    return (*(a[:, None] for a in members), types[None, :], slice(None, n))


@dataclass(frozen=True)
class PosteriorCovariance:
    """The weight posteriors' covariances ``U diag(values) U'`` in the eigenbases of the priors
    ``kernels`` they were computed under: EM holds them so through an M-step that changes the
    priors."""

    kernels: WeightKernels
    values: np.ndarray

    def diagonal(self) -> np.ndarray:
        return self.kernels.diagonal(self.values)

    def blocks(self) -> list[np.ndarray]:
        return self.kernels.blocks(self.values)
