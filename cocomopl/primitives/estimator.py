"""The movement-primitive model of the paper (sec. III-C) as a scikit-learn style estimator.

>>> model = MovementPrimitives(n_primitives=11, kernel="rbf").fit(load_training_steps(path))
>>> step = model.predict(StepSpec("cyclic", 0.39, 0.39, "left"))
>>> step.values            # (T, 36) signals on the step's normalised time grid
>>> model.score(steps)     # explained variance of the signals, 1 is perfect

Fitting maximises the free energy of :mod:`cocomopl.primitives.bound` by variational EM
(:mod:`cocomopl.primitives.em`).  Prediction is NumPy only: a fitted model keeps, per step type, the few
arrays the weight GPs need, so that a step costs a handful of small matrix products.
"""

from __future__ import annotations

import functools
import inspect
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from cocomopl.errors import Error, require_extra
from cocomopl.gait import TURN_SCALE, WIDTH_SCALE
from cocomopl.motion import StepSpec
from cocomopl.primitives import DEFAULT_MAX_ITERATIONS, DEFAULT_WIDTHS, TIME_KERNELS
from cocomopl.primitives import durations as duration_gp
from cocomopl.primitives.checks import Check, one_of, whole
from cocomopl.primitives.training import (
    FOOTSTEP_PARAMETERS,
    TrainingSteps,
    learned_parts,
    parameter_count,
    phase_templates,
    resample,
    resample_step,
    step_lengths,
    step_type,
)

SUPPORT_TOLERANCE = 1e-9  # m: a training step's own distance may round above its type's radius

SIGNAL_GROUPS = ("joints", "zmp", "pelvis")
CONDITION_RATIO = 1e-6  # start-state noise relative to the predicted start variance: "nearly equal"
VARIANCE_FLOOR = 1e-6  # relative to the prior: keeps conditioning defined at training points
# Eigenbases larger than this (in double precision) are kept in single precision: the
# variance's products then run from memory, at half the traffic, and move a walk's signals by
# a few microradians; smaller ones stay in cache and in double precision.
SINGLE_PRECISION_BYTES = 2**20
SAME_LENGTHS_M2 = 1e-12  # squared length distance (1 um) below which a step has a training step's lengths
# The estimator's parameters that need a check (:meth:`MovementPrimitives.validate`); model
# files check their recorded settings with the same rules.
PARAMETER_CHECKS: dict[str, Check] = {
    "n_primitives": whole(1),
    "kernel": one_of(TIME_KERNELS),
    "n_grid": whole(2),
    "max_iterations": whole(1),
    "n_widths": whole(1),
}


def signal_groups(names: list[str]) -> dict[str, np.ndarray]:
    """Indices of the joint, ZMP and pelvis-orientation signals."""
    group = ["zmp" if n.startswith("zmp_") else "pelvis" if n.startswith("pelvis_") else "joints" for n in names]
    return {g: np.flatnonzero([x == g for x in group]) for g in SIGNAL_GROUPS}


def explained_variance(X: np.ndarray, X_hat: np.ndarray, names: list[str]) -> dict[str, float]:
    """Per signal group, ``1 - SSE / total variance`` of (K, I, T) signals about each signal's mean."""
    return {g: _fraction_explained(X, X_hat, idx) for g, idx in signal_groups(names).items()}


def _fraction_explained(X: np.ndarray, X_hat: np.ndarray, signals) -> float:
    """``1 - SSE / total variance`` of the given signals of (K, I, T) arrays, each about its own mean."""
    centred = X - X.mean(axis=(0, 2), keepdims=True)
    return float(1.0 - ((X - X_hat)[:, signals] ** 2).sum() / (centred[:, signals] ** 2).sum())


def pca_signal_weights(X: np.ndarray, names: list[str]) -> np.ndarray:
    """Scale (I,) of each signal in the PCA that gives the primitives their prior means.

    The signals are in different units (rad, m) and the groups differ in size (30 joint
    angles, 3 ZMP coordinates, 3 pelvis angles), so each signal is standardised and each
    group given the same total weight; unscaled, the joints swamp the PCA, and the prior
    means it gives left the ZMP's touchdown features out of every primitive.
    """
    variance = X.var(axis=(0, 2))
    weights = np.empty(len(names))
    for idx in signal_groups(names).values():
        weights[idx] = 1.0 / np.sqrt(np.maximum(variance[idx], 1e-12) * len(idx))
    return weights


@dataclass(frozen=True)
class _Part:
    """One learned trajectory of a predicted step (a step, or a part of one), unconditioned:
    the signals' mean (T, I), the weights' posterior mean and variance (I, S), what
    conditioning on the part's start takes (:func:`_condition`): ``gain``, ``cross`` (T, I)
    and ``observed`` (I,), and what its phase durations' standard deviations take: its
    type's arrays and its squared distances ``d2`` (n,) to their training steps."""

    mean: np.ndarray
    weights: np.ndarray
    weight_var: np.ndarray
    gain: np.ndarray
    cross: np.ndarray
    observed: np.ndarray
    arrays: TypeArrays
    d2: np.ndarray


class PredictedStep:
    """A step predicted by the model: signals on the template grid, durations and uncertainty.

    Attributes
    ----------
    spec : StepSpec
    tau : (T,) normalised time grid; ``boundaries`` (P+1,) its phase boundaries.  A step
        learned in parts (a stop) repeats the time of the touchdown between them, pre- and
        post-impact, as a :class:`~cocomopl.motion.Motion` does
    values, std : (T, I) posterior mean and standard deviation of the signals
    durations, duration_std : (P,) phase durations and their standard deviation, s (the
        standard deviations and ``std`` are computed when read: generating a walk needs neither)
    distance : distance of the step parameters (:func:`~cocomopl.primitives.training.step_lengths`)
        to the nearest training step of the type, m
    in_support : whether that distance is within the training grid's spacing
    start : (I,) the signals the step's start was conditioned on (None: not conditioned)
    """

    def __init__(self, spec, tau, parts, *, primitives, boundaries, durations, distance, in_support, start=None):
        self.spec = spec
        self.tau = tau
        self._parts = parts
        self._primitives = primitives  # the primitives' means and variances, (S, T) each
        self.boundaries = boundaries
        self.durations = durations
        self.distance = distance
        self.in_support = in_support
        self.start = start

    @functools.cached_property
    def values(self) -> np.ndarray:
        """Posterior mean of the signals, (T, I); computed when first read (a walk's steps
        are predicted unconditioned, then conditioned in order)."""
        return np.concatenate(self._chained_means())

    def _chained_means(self) -> list[np.ndarray]:
        """Each part's mean, conditioned on the step's start (the first part) or on the end
        of the part before it (the others: each part starts where the one before ended, as
        steps do)."""
        out, start = [], self.start
        for part in self._parts:
            out.append(part.mean if start is None else part.mean + part.gain * (start - part.mean[0]))
            start = out[-1][-1]
        return out

    def conditioned_on(self, start: np.ndarray) -> PredictedStep:
        """This step with its start conditioned on the signals ``start`` (I), the previous
        step's end: the initial joint angles and pelvis orientation then (nearly) equal them.
        The ZMP is not conditioned: it jumps at touchdown, in the OC data too."""
        return PredictedStep(self.spec, self.tau, self._parts, primitives=self._primitives, boundaries=self.boundaries,
                             durations=self.durations, distance=self.distance, in_support=self.in_support,
                             start=np.asarray(start, dtype=float))

    @property
    def std(self) -> np.ndarray:
        """Posterior standard deviation of the signals, (T, I); computed on demand."""
        return np.concatenate([_signal_std(part, *self._primitives, conditioned=k > 0 or self.start is not None)
                               for k, part in enumerate(self._parts)])

    @property
    def duration_std(self) -> np.ndarray:
        """Standard deviation (P,) of the phase durations, s; computed on demand: each log
        duration's GP variance carried through the exponential to first order."""
        return self.durations * np.sqrt(np.maximum(np.concatenate([_log_duration_var(p) for p in self._parts]), 0.0))

    @property
    def phase_edges(self) -> np.ndarray:
        """Real time (s) of the phase boundaries, from the step's start: ``boundaries`` in seconds."""
        return np.concatenate([[0.0], np.cumsum(self.durations)])

    @property
    def duration(self) -> float:
        return float(self.durations.sum())

    def values_at(self, tau: np.ndarray) -> np.ndarray:
        """The signals (len(tau), I) linearly interpolated at normalised times ``tau``."""
        return np.stack([np.interp(tau, self.tau, x) for x in self.values.T], axis=1)

    @classmethod
    def joined(cls, spec, parts: list[PredictedStep]) -> PredictedStep:
        """One step from its consecutive parts (unconditioned): each part's grid takes the
        share of the step's normalised time that its predicted duration takes of the whole."""
        shares = np.array([p.duration for p in parts]) / sum(p.duration for p in parts)
        starts = np.concatenate([[0.0], np.cumsum(shares)])
        tau = np.concatenate([a + w * p.tau for a, w, p in zip(starts, shares, parts)])
        boundaries = np.concatenate([[0.0]] + [a + w * p.boundaries[1:] for a, w, p in zip(starts, shares, parts)])
        return cls(
            spec,
            tau,
            [part for p in parts for part in p._parts],
            primitives=parts[0]._primitives,
            boundaries=boundaries,
            durations=np.concatenate([p.durations for p in parts]),
            distance=max(p.distance for p in parts),
            in_support=all(p.in_support for p in parts),
        )


def _signal_std(part: _Part, primitives: np.ndarray, primitive_var: np.ndarray, conditioned: bool) -> np.ndarray:
    """Standard deviation (T, I) of ``x_i(t) = w_i @ MP(t)`` for independent weights
    ``W_is ~ N(w_is, P_is)`` (I, S) and primitives ``MP_s(t) ~ N(m_s(t), v_s(t))`` (S, T),
    ``sum_s P_is m_s(t)^2 + (w_is^2 + P_is) v_s(t)``, less, if the part's start was
    ``conditioned``, the variance that conditioning removed: ``2 g Cov - g^2 Var(x_i(0))``
    (:func:`_condition`)."""
    w, var = part.weights, part.weight_var
    variance = (var @ primitives**2 + (w**2 + var) @ primitive_var).T
    if conditioned:
        variance -= np.maximum(2.0 * part.gain * part.cross - part.gain**2 * part.observed, 0.0)
    return np.sqrt(np.maximum(variance, 0.0))


def _log_duration_var(part: _Part) -> np.ndarray:
    """The GP variance (P,) of a part's log phase durations, ``alpha - k^T K^-1 k``."""
    c = part.arrays
    k = c.dur_alpha * np.exp(-c.dur_gamma * part.d2)  # (P, n)
    return c.dur_alpha[:, 0] - np.einsum("pn,pnm,pm->p", k, c.dur_K_inv, k)


@dataclass(frozen=True, eq=False)
class WeightSolves:
    """The weight GPs' solves on one set of training inputs (:func:`_weight_solves`), in an
    eigenbasis per distinct kernel width.

    The weight kernels' hyperparameters are the model's, the same for every learned type, so
    the types trained on the same step parameters (a type and its mirror image) share these
    and the weights' posterior variance: :meth:`MovementPrimitives.predict_many` computes it
    once for the steps of all of them.

    Attributes
    ----------
    lengths : (n, Z) the training steps' parameters
    unique_gamma : (G,) the distinct inverse squared widths; ``basis`` (G, n, n) the
        eigenvectors of ``E(gamma) = exp(-gamma D)`` for each
    chunk_group, chunk_size, block_index : the weights' layout for batched products: weight
        k is column ``block_index[k] % chunk_size`` of chunk ``block_index[k] // chunk_size``,
        and chunk c holds weights of width ``unique_gamma[chunk_group[c]]`` only
    spectral_blocks : (C, n, M) ``1 / (lambda_j + nu_k)`` in that layout
    """

    lengths: np.ndarray
    unique_gamma: np.ndarray
    basis: np.ndarray
    chunk_group: np.ndarray
    chunk_size: int
    block_index: np.ndarray
    spectral_blocks: np.ndarray

    def in_chunks(self, columns: np.ndarray) -> np.ndarray:
        """Per-weight columns (K, n) laid out in chunks (C, n, M), zero-padded."""
        return _in_chunks(columns, self.block_index, len(self.chunk_group), self.chunk_size)

    def cross_kernels(self, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """At squared distances ``d2`` (steps, n) from the training steps: ``E(z)`` (G, steps,
        n), one row per distinct width, and where a step has a training step's lengths."""
        return np.exp(-self.unique_gamma[:, None, None] * d2), d2 < SAME_LENGTHS_M2

    def per_weight(self, x: np.ndarray, blocks: np.ndarray) -> np.ndarray:
        """(G, rows, n) vectors, one per width, each chunk's width's multiplied by the chunk's
        block (C, n, M): (rows, K)."""
        return (x[self.chunk_group] @ blocks).transpose(1, 0, 2).reshape(x.shape[1], -1)[:, self.block_index]


def _in_chunks(columns: np.ndarray, block_index: np.ndarray, chunks: int, size: int) -> np.ndarray:
    out = np.zeros((chunks, columns.shape[1], size))
    out[block_index // size, :, block_index % size] = columns
    return out


@dataclass(frozen=True)
class TypeArrays:
    """What predicting steps of one learned trajectory type takes: contiguous slices of the
    fitted arrays and the weight GPs' solves (:func:`_weight_solves`), so that predicting
    a step costs a few small matrix products.

    Attributes
    ----------
    lengths : (n, Z) step parameters of the type's n training steps
    chi, alpha_w, gamma_w, nugget : (K,) the K = I*S weight GPs' type means, amplitudes,
        inverse squared widths and nuggets ``alpha eta``
    solves : the weight GPs' solves on the type's training inputs (:class:`WeightSolves`),
        shared with the types trained on the same ones
    beta : (K, n) the weight GPs' prior covariances solved against their posterior means, less chi
    mean_blocks : (C, n, M) ``alpha_k beta_k`` in the chunks of ``solves``
    boundaries : (P+1,) the type's phase boundaries on the normalised grid
    support_radius : the largest distance from a training step to its nearest neighbour, m
    dur_mean, dur_alpha, dur_gamma, dur_beta, dur_K_inv : the P log phase durations' GPs,
        shaped for predicting several steps at once
    """

    lengths: np.ndarray
    chi: np.ndarray
    alpha_w: np.ndarray
    gamma_w: np.ndarray
    nugget: np.ndarray
    solves: WeightSolves
    beta: np.ndarray
    mean_blocks: np.ndarray
    boundaries: np.ndarray
    support_radius: float
    dur_mean: np.ndarray
    dur_alpha: np.ndarray
    dur_gamma: np.ndarray
    dur_beta: np.ndarray
    dur_K_inv: np.ndarray


class MovementPrimitives:
    """Temporal movement primitives with GP priors, weights GP functions of the step parameters.

    Parameters
    ----------
    n_primitives : int
        S, the number of primitives.
    kernel : {"rbf", "matern32", "matern52"}
        Time kernel of the primitives' GP priors.
    n_grid : int
        T, points of the normalised time grid per step.
    max_iterations : int
        The most EM rounds; the fit stops earlier once a round raises the bound by less than
        ``em.RELATIVE_TOLERANCE`` of its value.
    n_widths : int
        Candidate widths of the weight kernels, log-spaced from 7 mm to 0.7 m of the step
        parameters (:func:`~cocomopl.primitives.em.weight_widths`); EM picks each kernel's
        width among them.  Predicting a step costs one product with an n x n eigenbasis per
        distinct width picked (n training steps of its type), so a model of many training
        steps predicts faster from fewer.
    verbose : bool
        Show the progress of :meth:`fit` on stderr: its iterations and the bound.

    Attributes
    ----------
    Set by :meth:`fit` or by :func:`~cocomopl.primitives.model_file.load_model`; a model file
    holds each array under its name without the trailing ``_``.  Axes: S primitives, T grid
    points, I signals, G learned trajectory types, N training steps of a type at most (empty
    slots padded), P phases and B = P + 1 phase boundaries of a type at most, Z step parameters.

    tau_ : (T,) the normalised time grid
    signal_names_ : (I,) the signals' names
    unconditioned_ : (I,) the signals not conditioned on a step's start (the ZMP)
    types_ : (G,) the learned trajectory types (step types, or parts of a step learned in parts)
    lengths_ : (G, N, Z) the training steps' parameters (:func:`~cocomopl.primitives.training.step_lengths`)
    mask_ : (G, N) 1 for a training step, 0 for an empty slot
    boundaries_ : (G, B) each type's phase boundaries on the grid (NaN past its phases)
    m_, m_var_, m_cov_start_ : (S, T) each primitive's posterior mean, variance, and covariance with its start
    alpha_w_, gamma_w_, eta_w_ : (I, S) the weight kernels' amplitudes, inverse squared widths and nuggets
    chi_ : (I, S, G) the weight GPs' type means
    beta_ : (I, S, G, N) the weight GPs' prior covariances solved against their posterior means, less chi
    c_w_ : (I, S) the weights' observation precisions
    sigma_ : (I,) the signals' noise standard deviations
    alpha_t_, ell_t_ : (S,) the time kernels' amplitudes and widths
    n_phases_ : (G,) each type's number of phases
    dur_mean_, dur_alpha_, dur_gamma_ : (G, P) the log phase durations' GPs: means, amplitudes, inverse squared widths
    dur_beta_, dur_K_inv_ : (G, P, N), (G, P, N, N) their solves
    support_radius_ : (G,) per type, the largest distance from a training step to its nearest neighbour, m
    bound_ : the free energy reached, nats
    n_iter_ : the EM rounds taken
    fit_time_s_ : the fit's wall time, s
    explained_variance_ : per signal group, of the learned trajectories as the model predicts them
    metadata_ : a loaded model's file metadata (:func:`~cocomopl.primitives.model_file.load_model`)
    """

    def __init__(
        self,
        *,
        n_primitives: int = 11,
        kernel: str = "rbf",
        n_grid: int = 100,
        max_iterations: int = DEFAULT_MAX_ITERATIONS,
        n_widths: int = DEFAULT_WIDTHS,
        verbose: bool = False,
    ):
        self.n_primitives = n_primitives
        self.kernel = kernel
        self.n_grid = n_grid
        self.max_iterations = max_iterations
        self.n_widths = n_widths
        self.verbose = verbose

    # ------------------------------------------------------------------ parameters
    @classmethod
    def _defaults(cls) -> dict:
        """The parameters, as the names and defaults of ``__init__``'s arguments."""
        arguments = list(inspect.signature(cls.__init__).parameters.values())[1:]  # after self
        return {a.name: a.default for a in arguments}

    def get_params(self, deep: bool = True) -> dict:
        """The estimator's parameters, so that ``MovementPrimitives(**get_params())`` is a copy.

        Parameters
        ----------
        deep : bool
            Accepted for scikit-learn compatibility; no parameter is itself an estimator.
        """
        return {name: getattr(self, name) for name in self._defaults()}

    def set_params(self, **params) -> MovementPrimitives:
        """Set parameters by name, as in scikit-learn; a fitted state is kept until the next fit.

        Raises
        ------
        Error
            If a name is not a parameter.
        """
        known = self._defaults()
        unknown = [name for name in params if name not in known]
        if unknown:  # checked before any is set, so that a typo leaves the estimator as it was
            raise Error(f"{type(self).__name__} has no parameter {unknown[0]!r}; it has {', '.join(known)}")
        for name, value in params.items():
            setattr(self, name, value)
        return self

    def __repr__(self) -> str:
        # as scikit-learn's: the parameters that differ from their defaults, never fitted arrays
        defaults = self._defaults()
        changed = [f"{name}={value!r}" for name, value in self.get_params().items() if value != defaults[name]]
        return f"{type(self).__name__}({', '.join(changed)})"

    # ------------------------------------------------------------------ fit
    def fit(self, steps: TrainingSteps) -> MovementPrimitives:
        """Learn primitives, weight GPs and duration GPs from training steps.

        A fit replaces every fitted attribute and drops whatever was derived from the ones before.

        Raises
        ------
        Error
            If JAX, which fitting needs, is missing (the ``[train]`` extra), or the parameters
            cannot be fitted to ``steps`` (:meth:`validate`).
        """
        require_extra("jax", "train", f"{type(self).__name__}.fit")
        from cocomopl.primitives import em  # JAX is needed to fit only

        self.validate(steps)
        started = time.perf_counter()
        parts, types = learned_parts(steps)
        templates = phase_templates(parts, types)
        tau = np.linspace(0.0, 1.0, self.n_grid)
        X = resample(parts, templates, tau, types=types)
        layout = SlotLayout(parts, types)
        description = f"fitting {self.n_primitives} {self.kernel} primitives"
        with tqdm(total=self.max_iterations, desc=description, unit="round", disable=not self.verbose) as bar:
            result = em.maximise_bound_em(
                layout.to_slots(X), layout.mask, layout.d2, tau=tau, S=self.n_primitives, kernel=self.kernel,
                max_rounds=self.max_iterations, signal_weights=pca_signal_weights(X, steps.signal_names),
                widths=self.n_widths,
                on_iteration=functools.partial(_show_iteration, bar) if self.verbose else None,
            )
        fitted = {
            "tau": tau,
            "signal_names": np.array(steps.signal_names),
            "unconditioned": np.array([name.startswith("zmp_") for name in steps.signal_names]),
            "types": np.array(layout.types),
            "lengths": layout.lengths,
            "mask": layout.mask,
            "boundaries": _pad_boundaries([templates[t] for t in layout.types]),
            **result["arrays"],
            **_fit_durations(parts, layout),
        }
        self._forget_fit()
        for name, value in fitted.items():
            setattr(self, f"{name}_", value)
        self.bound_ = result["bound"]
        self.n_iter_ = result["iterations"]
        self.fit_time_s_ = time.perf_counter() - started
        # of the learned trajectories (every step, the stops in their two parts) as the model
        # predicts them from their specs: the weight GPs' nuggets smooth across the steps
        of_type: dict[str, list[int]] = {}
        for k, type_ in enumerate(types):
            of_type.setdefault(type_, []).append(k)
        predicted = self._predict_types({t: [parts.specs[k] for k in ks] for t, ks in of_type.items()})
        X_hat = np.empty_like(X)
        for type_, ks in of_type.items():
            X_hat[ks] = [step.values.T for step in predicted[type_]]
        self.explained_variance_ = explained_variance(X, X_hat, steps.signal_names)
        return self

    def _forget_fit(self) -> None:
        """Drop every fitted attribute (a public name ending in ``_``) and every value a
        :class:`functools.cached_property` derived from them, whatever their names."""
        cached = {name for cls in type(self).__mro__ for name, value in vars(cls).items()
                  if isinstance(value, functools.cached_property)}
        for name in list(vars(self)):
            if name in cached or (name.endswith("_") and not name.startswith("_")):
                del self.__dict__[name]

    def validate(self, steps: TrainingSteps) -> None:
        """Raise :class:`Error` if these parameters cannot be fitted to ``steps``."""
        for name, check in PARAMETER_CHECKS.items():
            expected = check(getattr(self, name))
            if expected:
                raise Error(f"{name} must be {expected}, not {getattr(self, name)!r}")
        if self.n_primitives > self.n_grid:
            raise Error(f"{self.n_primitives} primitives cannot exceed the {self.n_grid} time-grid points")
        if len(steps) < 2:
            raise Error("training needs at least two steps")

    # ------------------------------------------------------------------ predict
    @property
    def types(self) -> list[str]:
        """The learned trajectory types, ``types_`` as strings."""
        return list(self._type_index)

    @property
    def signal_names(self) -> list[str]:
        """The signals' names, ``signal_names_`` as strings."""
        return list(self._signal_names)

    @functools.cached_property
    def _signal_names(self) -> tuple[str, ...]:
        # kept: generation reads the names at every step
        return tuple(str(n) for n in self.signal_names_)

    @functools.cached_property
    def _type_index(self) -> dict[str, int]:
        """Each learned trajectory type's index along the G axis of the fitted arrays."""
        return {str(t): g for g, t in enumerate(self.types_)}

    def footstep_range(self) -> dict[str, tuple[float, float]]:
        """(low, high) of the footsteps' ``length``, ``width`` (m) and ``turn`` (rad) that the
        training steps landed at (their start steps' footsteps): the range a plan may use."""
        self._check_fitted()
        z = np.concatenate([self.type_arrays(t).lengths for t in self.types if t.startswith("start_")])
        columns = {"length": z[:, 1]}
        if z.shape[1] == FOOTSTEP_PARAMETERS:
            columns |= {"width": z[:, 3] / WIDTH_SCALE, "turn": z[:, 5] / TURN_SCALE}
        else:
            columns |= {"width": np.zeros(1), "turn": np.zeros(1)}
        return {key: (float(v.min()), float(v.max())) for key, v in columns.items()}

    def _check_fitted(self) -> None:
        if not any(name.endswith("_") and not name.startswith("_") for name in vars(self)):
            raise Error("this model is not fitted yet: call fit() or load a model file")

    def prepare(self) -> MovementPrimitives:
        """Precompute the per-type arrays prediction uses (otherwise done at each type's first use)."""
        self._check_fitted()
        for type_ in self.types:
            self.type_arrays(type_)
        return self

    @functools.cached_property
    def _primitive_moments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What conditioning takes from the primitives (:func:`_condition`)."""
        taper = 0.5 * (1.0 + np.cos(np.pi * self.tau_))[:, None]
        return self.m_[:, 0], np.vstack([self.m_, self.m_cov_start_]), taper

    @functools.cached_property
    def _type_arrays(self) -> dict[str, TypeArrays]:
        """:meth:`type_arrays` of the types used so far, each built at its first use."""
        return {}

    @functools.cached_property
    def _solves_of_inputs(self) -> dict[bytes, WeightSolves]:
        """The weight GPs' solves built so far, by training inputs (``lengths`` as bytes)."""
        return {}

    @functools.cached_property
    def _weight_floor(self) -> np.ndarray:
        """(K,) variance added to a new step's weights, ``(VARIANCE_FLOOR + eta) alpha``: a
        new step's weights vary about the smooth function by the nugget too."""
        return ((VARIANCE_FLOOR + self.eta_w_) * self.alpha_w_).ravel()

    def type_arrays(self, type_: str) -> TypeArrays:
        """What predicting steps of the learned trajectory type ``type_`` takes (built once).

        Raises
        ------
        Error
            If the model has not learned ``type_``.
        """
        if type_ not in self._type_arrays:
            if type_ not in self._type_index:
                raise Error(f"the model has no trajectory type {type_!r}; it has {', '.join(self.types)}")
            g = self._type_index[type_]
            n = int(self.mask_[g].sum())
            P = int(self.n_phases_[g])
            lengths = np.ascontiguousarray(self.lengths_[g, :n])
            alpha, gamma = self.alpha_w_.ravel(), self.gamma_w_.ravel()
            key = lengths.tobytes()
            if key not in self._solves_of_inputs:
                self._solves_of_inputs[key] = _weight_solves(
                    lengths, gamma, nu=(self.eta_w_ + 1.0 / (self.alpha_w_ * self.c_w_)).ravel())
            solves = self._solves_of_inputs[key]
            beta = self.beta_[:, :, g, :n].reshape(-1, n)
            self._type_arrays[type_] = TypeArrays(
                lengths=lengths,
                chi=self.chi_[:, :, g].ravel(),
                alpha_w=alpha,
                gamma_w=gamma,
                nugget=alpha * self.eta_w_.ravel(),
                solves=solves,
                beta=beta,
                mean_blocks=solves.in_chunks(alpha[:, None] * beta),
                boundaries=self.boundaries_[g, : P + 1],
                support_radius=float(self.support_radius_[g]),
                dur_mean=self.dur_mean_[g, :P],
                dur_alpha=self.dur_alpha_[g, :P, None],
                dur_gamma=self.dur_gamma_[g, :P, None],
                dur_beta=np.ascontiguousarray(self.dur_beta_[g, :P, :n]),
                dur_K_inv=np.ascontiguousarray(self.dur_K_inv_[g, :P, :n, :n]),
            )
        return self._type_arrays[type_]

    def predict(self, spec: StepSpec, start: np.ndarray | None = None) -> PredictedStep:
        """Posterior mean and uncertainty of a step.

        Parameters
        ----------
        spec : StepSpec
        start : (I,) optional
            The previous step's final signals.  The step's initial joint angles and pelvis
            orientation are conditioned to (nearly) equal them (:meth:`PredictedStep.conditioned_on`).
        """
        step = self.predict_many([spec])[0]
        return step if start is None else step.conditioned_on(start)

    def predict_many(self, specs: list[StepSpec]) -> list[PredictedStep]:
        """:meth:`predict` of every step of ``specs``, unconditioned, computed together (a
        walk's steps then cost a few array operations together, not each), and once for steps
        that repeat (a steady gait's): the same (unmodified) :class:`PredictedStep` is
        returned for each."""
        self._check_fitted()
        unique = list(dict.fromkeys(specs))
        trajectories = [self.trajectory_types(step_type(spec)) for spec in unique]
        for spec, types in zip(unique, trajectories):
            if not types:
                raise Error(f"the model has no {spec.kind} steps swinging the {spec.swing_side} foot")
        rows: dict[str, list[int]] = {}  # per trajectory type, the steps (of unique) predicted from it
        for k, types in enumerate(trajectories):
            for type_ in types:
                rows.setdefault(type_, []).append(k)
        predicted = self._predict_types({type_: [unique[k] for k in ks] for type_, ks in rows.items()})
        of_step = {(k, type_): step for type_, ks in rows.items() for k, step in zip(ks, predicted[type_])}
        steps = {spec: of_step[k, types[0]] if len(types) == 1 else PredictedStep.joined(spec, [of_step[k, t] for t in types])
                 for k, (spec, types) in enumerate(zip(unique, trajectories))}
        return [steps[spec] for spec in specs]

    def trajectory_types(self, name: str) -> list[str]:
        """The learned trajectory types the step type ``name`` (:func:`~cocomopl.primitives.training.step_type`)
        is predicted from: itself, or its parts in order (none if the model has neither)."""
        if name not in self._trajectory_types:
            self._trajectory_types[name] = [name] if name in self._type_index else sorted(
                t for t in self._type_index if t.startswith(f"{name}_part"))
        return list(self._trajectory_types[name])

    @functools.cached_property
    def _trajectory_types(self) -> dict[str, list[str]]:
        """:meth:`trajectory_types` of the step types asked so far."""
        return {}

    def _predict_types(self, requests: dict[str, list[StepSpec]]) -> dict[str, list[PredictedStep]]:
        """:meth:`predict_many` for steps of learned trajectory types (step types, or parts of
        one), ``{type: steps}``.

        The weights' posterior variance is computed once for the steps of all types that share
        their training inputs (:class:`WeightSolves`), their means per type, and the rest
        (signals' means, conditioning gains) for all steps at once.
        """
        arrays = {type_: self.type_arrays(type_) for type_ in requests}
        d2 = {}
        for type_, specs in requests.items():
            c = arrays[type_]
            z = np.array([step_lengths(spec, c.lengths.shape[1]) for spec in specs])
            d2[type_] = ((c.lengths - z[:, None]) ** 2).sum(axis=-1)  # (steps, n)
        sharing: dict[WeightSolves, list[str]] = {}
        for type_ in requests:
            sharing.setdefault(arrays[type_].solves, []).append(type_)
        w, var = {}, {}
        for solves, types in sharing.items():
            smooth, same = solves.cross_kernels(np.concatenate([d2[t] for t in types]))
            variance = _weight_variance(arrays[types[0]], smooth, same)
            first = 0
            for type_ in types:
                rows = slice(first, first + len(d2[type_]))
                w[type_], var[type_] = _weight_mean(arrays[type_], smooth[:, rows], same[rows]), variance[rows]
                first = rows.stop
        shape = (-1, *self.alpha_w_.shape)
        w = np.concatenate([w[t] for t in requests]).reshape(shape)
        var = (np.maximum(np.concatenate([var[t] for t in requests]), 0.0) + self._weight_floor).reshape(shape)
        mean = _times(w, self.m_).swapaxes(1, 2)
        gain, cross, observed = _condition(w, var, self._primitive_moments, (~self.unconditioned_).astype(float))
        primitives, out, q = (self.m_, self.m_var_), {}, 0
        for type_, specs in requests.items():
            c, distances = arrays[type_], d2[type_]
            k = c.dur_alpha[:, None] * np.exp(-c.dur_gamma[:, None] * distances)  # (P, steps, n)
            durations = np.exp(c.dur_mean + (k * c.dur_beta[:, None]).sum(axis=-1).T)
            distance = np.sqrt(distances.min(axis=1))
            out[type_] = [
                PredictedStep(spec, self.tau_, [_Part(mean[q + j], w[q + j], var[q + j], gain[q + j], cross[q + j],
                                                      observed[q + j], c, distances[j])],
                              primitives=primitives, boundaries=c.boundaries, durations=durations[j],
                              distance=float(distance[j]),
                              in_support=bool(distance[j] <= c.support_radius + SUPPORT_TOLERANCE))
                for j, spec in enumerate(specs)
            ]
            q += len(specs)
        return out


    # ------------------------------------------------------------------ score
    def reconstruct(self, steps: TrainingSteps) -> tuple[np.ndarray, np.ndarray]:
        """Signals of ``steps`` and the model's predictions of them, (K, I, T) each, on the
        grid ``tau_`` with the phase boundaries of each prediction (a step learned in parts
        is compared whole)."""
        self._check_fitted()
        if list(steps.signal_names) != self.signal_names:
            raise Error("these steps have different signals from the model's")
        X, X_hat = [], []
        for spec, values, phase_time in zip(steps.specs, steps.values, steps.phase_time):
            step = self.predict(spec)
            X.append(resample_step(values, phase_time, step.boundaries, tau=self.tau_))
            X_hat.append(step.values_at(self.tau_).T)
        return np.stack(X), np.stack(X_hat)

    def score(self, steps: TrainingSteps) -> float:
        """Explained variance of all signals of ``steps`` (1 is perfect)."""
        X, X_hat = self.reconstruct(steps)
        return _fraction_explained(X, X_hat, slice(None))


def _weight_solves(lengths: np.ndarray, gamma: np.ndarray, *, nu: np.ndarray) -> WeightSolves:
    """The weight GPs' solves on the training inputs ``lengths`` (n, Z), laid out so that the
    variance of the K weights of several steps costs a few matrix products.

    The solve of weight k is ``C_k = (B_k + I / c_k)^-1`` with the prior ``B_k = alpha_k
    (E(gamma_k) + eta_k I)``, ``E(gamma) = exp(-gamma D)`` over the training inputs' squared
    distances ``D`` (:func:`~cocomopl.primitives.optimise._prediction_arrays`) and ``c_k`` the
    weights' observation precision.  So ``C_k = U diag(1 / (lambda + nu_k)) U^T / alpha_k``
    in the eigenbasis ``E(gamma_k) = U diag(lambda) U^T``, with ``nu_k = eta_k + 1 / (alpha_k
    c_k)``: a quadratic form costs O(n), not O(n^2).  The K weights share a few distinct
    ``gamma``: one eigenbasis each.

    The weights of one ``gamma`` are cut into chunks of at most ``ceil(K / G)`` for batched
    products (G distinct ``gamma``): the groups differ in size (124 of the bundled
    omnidirectional model's 396 weights share one width, one has a width of its own), and
    padding every group to the largest would multiply the products' cost by nearly four,
    while chunks at most double it.
    """
    D = ((lengths[:, None] - lengths[None]) ** 2).sum(axis=-1)
    unique_gamma, gamma_of = np.unique(gamma, return_inverse=True)
    eigenvalues, basis = np.linalg.eigh(np.exp(-unique_gamma[:, None, None] * D))
    M = -(-len(gamma) // len(unique_gamma))
    block_index, chunk_group = np.empty(len(gamma), dtype=int), []
    for g in range(len(unique_gamma)):
        members = np.flatnonzero(gamma_of == g)
        block_index[members] = (len(chunk_group) + np.arange(len(members)) // M) * M + np.arange(len(members)) % M
        chunk_group += [g] * -(-len(members) // M)
    spectral = _in_chunks(1.0 / (eigenvalues[gamma_of] + nu[:, None]), block_index, len(chunk_group), M)
    dtype = np.float32 if basis.nbytes > SINGLE_PRECISION_BYTES else np.float64
    return WeightSolves(lengths, unique_gamma, basis.astype(dtype), np.array(chunk_group), M, block_index,
                        spectral.astype(dtype))


def weight_posterior(c: TypeArrays, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Posterior mean and variance (steps, K) of all K = I*S weights of one type at once, at
    squared distances ``d2`` (steps, n) from its training steps.

    The cross-covariances are ``b_k = alpha_k exp(-gamma_k d2) + nugget_k [d2 = 0]``.  The
    nugget is a step's own variation (kriging's nugget effect): it is shared with a training
    step of the same lengths, which the prediction then reproduces, and with no other.
    """
    smooth, same = c.solves.cross_kernels(d2)
    return _weight_mean(c, smooth, same), _weight_variance(c, smooth, same)


def _weight_mean(c: TypeArrays, smooth: np.ndarray, same: np.ndarray) -> np.ndarray:
    """:func:`weight_posterior`'s mean, from ``smooth`` = E(z) (G, steps, n), one row per
    distinct width, and ``same`` (steps, n), where a step has a training step's lengths."""
    mean = c.chi + c.solves.per_weight(smooth, c.mean_blocks)
    if same.any():
        mean += c.nugget * (same @ c.beta.T)
    return mean


def _weight_variance(c: TypeArrays, smooth: np.ndarray, same: np.ndarray) -> np.ndarray:
    """:func:`weight_posterior`'s variance, as :func:`_weight_mean` takes its inputs: the
    quadratic form ``b_k^T C_k b_k`` in the eigenbasis of :func:`_weight_solves`, ``sum_j
    (u_j^T b_k)^2 / (alpha_k (lambda_j + nu_k))``, with ``u_j^T b_k = alpha_k p_j + nugget_k
    q_j``, ``p = U^T E(z)`` and ``q = U^T [d2 = 0]``.  It depends on the type's inputs and
    the model's hyperparameters only: the same for every type sharing ``c.solves``."""
    s, alpha, nugget = c.solves, c.alpha_w, c.nugget
    p = smooth.astype(s.basis.dtype) @ s.basis
    if not same.any():
        return alpha - alpha * s.per_weight(p**2, s.spectral_blocks)
    q = same.astype(s.basis.dtype) @ s.basis
    pp, pq, qq = s.per_weight(np.concatenate([p**2, p * q, q**2], axis=1), s.spectral_blocks).reshape(3, len(same), -1)
    return alpha - alpha * pp - 2.0 * nugget * pq - nugget**2 / alpha * qq


def _show_iteration(bar: tqdm, bound: float) -> None:
    bar.set_postfix(bound=f"{bound:.8g}", refresh=False)
    bar.update()


def _times(x: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``x @ matrix`` for ``x`` (..., k) and ``matrix`` (k, m) as one 2-D product: NumPy
    multiplies a stack by a matrix one slice at a time, twice as slow for a walk's steps."""
    return (x.reshape(-1, x.shape[-1]) @ matrix).reshape(*x.shape[:-1], matrix.shape[-1])


def _condition(w, var, moments, conditioned) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The gains by which each signal ``x_i(t) = W_i @ MP(t)`` follows its value at the step's start.

    The start is observed with a variance of ``CONDITION_RATIO`` times the predicted one,
    only for the ``conditioned`` signals (I,).  The weights ``W_is ~ N(w_is, var_is)``
    (I, S), independent of each other, and the primitives (means ``m`` (S, T) and their
    covariance with their start) are both uncertain and their product is not Gaussian, so the
    update is linear with the exact first two moments: the Gaussian update moves every
    ``x_i(t)`` by ``k_i(t) = Cov(x_i(t), x_i(0)) / Var(x_i(0))`` times the start's innovation.

    That gain stays near 1 over a whole step for smooth primitives, so an innovation would
    pass unchanged to the step's end, and the next step's start, and accumulate along a
    walk: on a six-step 15 deg turn the pelvis yaw drifted 0.26 deg a step and the feet
    placed from the learned joints disagreed by up to 55 mm.
    But a step's end is fixed by its own footstep (every OC step ends in the gait state of
    its end footstep), not by its start.  So the gain is tapered, ``k_i(t) (1 + cos(pi
    tau)) / 2`` over the normalised time ``tau`` (T,) from 0 to 1: the start is matched, the
    end is the footstep's, and the variance falls by ``2 g Cov - g^2 Var(x_i(0))`` for
    the gain ``g`` actually used.

    ``moments`` is ``(h, primitives, taper)`` (``MovementPrimitives._primitive_moments``):
    the primitives' start values ``h`` (S,), their means over their covariance with the
    start stacked, (2S, T), and the taper (T, 1).

    ``w`` and ``var`` may carry leading axes (several steps at once): so do the results.

    Returns
    -------
    gain, cross, observed : (T, I), (T, I), (I,)
        The gain to apply to the start's innovation, ``Cov(x_i(t), x_i(0))`` and the start's
        variance with the observation's: :func:`_signal_std` takes the three.
    """
    h, primitives, taper = moments
    # Cov(x_i(t), x_i(0)) = sum_s var_is h_s m_s(t) + E[W_is^2] Cov(m_s(t), m_s(0)), (..., T, I)
    cross = _times(np.concatenate([var * h, w**2 + var], axis=-1), primitives).swapaxes(-1, -2)
    observed = cross[..., 0, :] * (1.0 + CONDITION_RATIO)  # Var(x_i(0)) plus the observation's variance
    return cross * (conditioned / observed)[..., None, :] * taper, cross, observed


class SlotLayout:
    """Steps arranged by type, as the bound takes them (:mod:`~cocomopl.primitives.bound`):
    ``slots[g]`` lists the step indices of type ``types[g]``, padded to N slots by ``mask``
    (G, N); ``lengths`` (G, N, Z) are the steps' parameters and ``d2`` (G, N, N) their squared
    distances within each type."""

    def __init__(self, steps: TrainingSteps, types: list[str]):
        self.types = sorted(set(types))
        self.slots = [[k for k, t in enumerate(types) if t == type_] for type_ in self.types]
        G, N = len(self.types), max(len(s) for s in self.slots)
        self.mask = np.zeros((G, N))
        count = parameter_count(steps.specs)
        self.lengths = np.zeros((G, N, count))
        for g, ks in enumerate(self.slots):
            self.mask[g, : len(ks)] = 1.0
            self.lengths[g, : len(ks)] = [step_lengths(steps.specs[k], count) for k in ks]
        self.d2 = ((self.lengths[:, :, None] - self.lengths[:, None, :]) ** 2).sum(-1)
        self.n_steps = len(steps)

    def to_slots(self, X: np.ndarray) -> np.ndarray:
        """Per-step arrays (K, ...) in slots (G, N, ...), zeros in the empty ones."""
        out = np.zeros((*self.mask.shape, *X.shape[1:]))
        for g, ks in enumerate(self.slots):
            out[g, : len(ks)] = X[ks]
        return out

    def from_slots(self, X_slots: np.ndarray) -> np.ndarray:
        """Slotted arrays (G, N, ...) back to per-step ones (K, ...), in the steps' order."""
        out = np.empty((self.n_steps, *X_slots.shape[2:]))
        for g, ks in enumerate(self.slots):
            out[ks] = X_slots[g, : len(ks)]
        return out

    def support_radius(self) -> np.ndarray:
        """Per type, the largest distance from a training step to its nearest neighbour (m)."""
        out = np.empty(len(self.types))
        for g, ks in enumerate(self.slots):
            n = len(ks)
            d = np.sqrt(self.d2[g, :n, :n]) + np.diag(np.full(n, np.inf))
            out[g] = d.min(axis=1).max() if n > 1 else 0.0
        return out


def _pad_boundaries(boundaries: list[np.ndarray]) -> np.ndarray:
    out = np.full((len(boundaries), max(len(b) for b in boundaries)), np.nan)
    for g, b in enumerate(boundaries):
        out[g, : len(b)] = b
    return out


def _fit_durations(steps: TrainingSteps, layout: SlotLayout) -> dict:
    """GP regressions of the log phase durations per type, in slot layout."""
    G, N = layout.mask.shape
    P = max(len(d) for d in steps.durations)
    out = {
        "n_phases": np.zeros(G, dtype=int),
        "dur_mean": np.zeros((G, P)),
        "dur_alpha": np.zeros((G, P)),
        "dur_gamma": np.ones((G, P)),
        "dur_beta": np.zeros((G, P, N)),
        "dur_K_inv": np.zeros((G, P, N, N)),
        "support_radius": layout.support_radius(),
    }
    for g, ks in enumerate(layout.slots):
        n = len(ks)
        y = np.log(np.array([steps.durations[k] for k in ks]))  # (n, P_g)
        out["n_phases"][g] = y.shape[1]
        for p in range(y.shape[1]):
            gp = duration_gp.fit_gp(layout.lengths[g, :n], y[:, p])
            out["dur_mean"][g, p] = gp["mean"]
            out["dur_alpha"][g, p] = gp["alpha"]
            out["dur_gamma"][g, p] = gp["gamma"]
            out["dur_beta"][g, p, :n] = gp["beta"]
            out["dur_K_inv"][g, p, :n, :n] = gp["K_inv"]
    return out
