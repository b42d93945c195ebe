"""Leave-one-length-out comparison of the movement primitives with two peers.

For each step length L of the bundled dataset (150, 200, 250, 300, 350 and 400 mm), every step
that starts or ends at L (cyclic, start and stop steps of L, transitions into and out of
L, both swing sides) is held out, each method is fitted on the remaining steps, and each
held-out step is predicted from its spec alone (no conditioning on a previous step).
Holding out 150 or 400 mm asks for extrapolation beyond the training lengths.

Methods:

* ``movement_primitives``: the paper's model with the bundled model's number of primitives
  and kernel, fitted as ``cocomopl train`` fits, ``DEFAULT_MAX_ITERATIONS`` EM rounds (the
  folds are fitted two at a time in spawned processes).
* ``promp``: per step type, the 36 signals projected onto the normalised RBF basis of
  ``movement_primitives.promp.ProMP`` (20 basis functions per signal), and the weight
  vectors and log phase durations regressed on (start, end) length with one shared RBF
  kernel of fixed width 0.1 m (kernel ridge / GP posterior mean).
* ``pca_interpolation``: PCA of all training steps' standardised signals (11
  components); for a new step, its type's PCA coefficients and phase durations are
  linearly interpolated in (start, end) length, nearest neighbour outside the data.

Per held-out step, on the normalised time grid of the training set's phase templates
(each method warps the OC step as it warps its training steps): RMS error of the 30
joint angles, of the horizontal ZMP (and of x, y, z), of the pelvis orientation, and the
absolute error of the total duration.  Errors are pooled per held-out length and
overall (transitions, held out twice, count twice).  The generation time is the median
wall time of one ``predict``, averaged over the held-out steps.

Usage::

    pip install -e ".[bench]"
    python benchmarks/primitive_peers.py [--quick] [--json]

``--quick`` (5 primitives, 5 rounds, fewer timing repeats) checks that everything
runs, in well under a minute; its movement-primitive signal errors mean nothing.  The
fit time is the mean wall time of one fold's fit (the primitives' two at a time).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from dataclasses import dataclass

import numpy as np
from peers_evaluation import evaluate_lolo, fit_folds, length_mm, lolo_folds
from scipy.spatial import Delaunay, QhullError

from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL
from cocomopl.motion import StepSpec
from cocomopl.primitives import DEFAULT_MAX_ITERATIONS
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.model_file import model_metadata
from cocomopl.primitives.training import (
    TrainingSteps,
    load_training_steps,
    parameter_count,
    phase_templates,
    resample,
    step_lengths,
    step_type,
)

DATASET = BUNDLED_DATASET
N_GRID = 100  # the movement primitives' default grid, so that all methods compare on the same points


@dataclass
class GridStep:
    """A peer's predicted step: ``values`` (T, I) on the grid ``tau``, phase ``durations`` (s)."""

    spec: StepSpec
    tau: np.ndarray
    values: np.ndarray
    durations: np.ndarray


class _GridPeer:
    """What both peers share with :class:`MovementPrimitives`: the per-type phase templates
    of the training steps and the uniform grid on which steps are learned and compared."""

    def _resample_training(self, steps: TrainingSteps) -> np.ndarray:
        """Store the templates and grid, and return the training signals on them, (K, I, T)."""
        self.templates_ = phase_templates(steps)
        self.tau_ = np.linspace(0.0, 1.0, N_GRID)
        return resample(steps, self.templates_, self.tau_)

    @property
    def types(self) -> list[str]:
        return sorted(self.templates_)

    def reconstruct(self, steps: TrainingSteps) -> tuple[np.ndarray, np.ndarray]:
        """Signals of ``steps`` on the grid (K, I, T) and the peer's predictions of them."""
        X = resample(steps, self.templates_, self.tau_)
        X_hat = np.stack([self.predict(spec).values.T for spec in steps.specs])
        return X, X_hat


class ProMPPeer(_GridPeer):
    """Per step type, ProMP weights regressed on the step lengths.

    Each training step's signals are projected by least squares onto the library's
    normalised RBF basis, the same ``n_basis`` functions for every signal (a ProMP's basis
    is block diagonal over signals, so one (B, T) matrix serves all 36).  The weight
    vectors, with the log phase durations appended, are the multi-output targets of one
    kernel ridge regression on (start, end) length per type: an RBF kernel of fixed
    ``width`` (m) shared by all outputs, about the type's mean.  That is the posterior mean
    of a GP with those hyperparameters; per-output marginal-likelihood fits (as the
    primitives' duration GPs do) would cost 36 x B optimisations per type and fold for a
    baseline.  A ``ridge`` of 1e-4 (relative to the unit kernel amplitude) nearly
    interpolates the noise-free OC steps while keeping the solve well conditioned.

    Parameters
    ----------
    n_basis : int
        Basis functions per signal.  20 leave a projection error of the training steps of
        about 3 mrad (joints), 6 mm (ZMP, whose touchdown jumps an RBF basis smooths) and
        2 mrad (pelvis), well below the interpolation errors measured here.
    width : float
        Length scale of the kernel on step lengths, m.
    ridge : float
        Added to the kernel matrix's diagonal.
    """

    def __init__(self, n_basis: int = 20, width: float = 0.1, ridge: float = 1e-4):
        self.n_basis = n_basis
        self.width = width
        self.ridge = ridge

    def fit(self, steps: TrainingSteps) -> ProMPPeer:
        from movement_primitives.promp import ProMP

        X = self._resample_training(steps)
        # the basis on the grid, through the library's public API: the trajectory of each unit
        # weight vector of a one-signal ProMP (copies: the library normalises time in place)
        promp = ProMP(n_dims=1, n_weights_per_dim=self.n_basis)
        self.basis_ = np.stack([promp.trajectory_from_weights(self.tau_.copy(), e)[:, 0] for e in np.eye(self.n_basis)])
        # least squares for all steps and signals at once; equals ProMP.weights per step
        weights = np.linalg.lstsq(self.basis_.T, X.reshape(-1, N_GRID).T, rcond=None)[0]  # (B, K * I)
        weights = weights.T.reshape(len(steps), -1)  # (K, I * B), signal-major like ProMP's
        self.n_signals_ = X.shape[1]
        self.regressions_ = {}
        for type_ in self.types:
            ks = [k for k, s in enumerate(steps.specs) if step_type(s) == type_]
            z = np.array([step_lengths(steps.specs[k]) for k in ks])
            targets = np.hstack([weights[ks], np.log([steps.durations[k] for k in ks])])
            mean = targets.mean(axis=0)
            K = self._kernel(z[:, None, :], z[None, :, :]) + self.ridge * np.eye(len(ks))
            self.regressions_[type_] = {"z": z, "mean": mean, "coef": np.linalg.solve(K, targets - mean)}
        return self

    def _kernel(self, za: np.ndarray, zb: np.ndarray) -> np.ndarray:
        return np.exp(-((za - zb) ** 2).sum(axis=-1) / (2 * self.width**2))

    def predict(self, spec: StepSpec) -> GridStep:
        r = self.regressions_[step_type(spec)]
        out = r["mean"] + self._kernel(r["z"], step_lengths(spec)) @ r["coef"]
        n_weights = self.n_signals_ * self.n_basis
        values = (out[:n_weights].reshape(self.n_signals_, self.n_basis) @ self.basis_).T
        return GridStep(spec, self.tau_, values, np.exp(out[n_weights:]))


class PCAPeer(_GridPeer):
    """PCA of whole steps, its coefficients linearly interpolated between training steps.

    Signals are standardised (each divided by its standard deviation over the training
    steps and the grid) before the SVD, so that ZMP metres and joint radians weigh alike.
    Each step type's coefficients and phase durations are interpolated linearly in its step
    parameters (:func:`~cocomopl.primitives.training.step_lengths`) over the affine hull
    that its training steps span: along one length for start, cyclic and stop steps of the
    straight model, barycentrically in the Delaunay triangulation of (start, end) lengths
    for its transitions, and likewise in the few dimensions that a footstep grid's steady
    gaits span.  Outside the training data a step takes its nearest training step's
    coefficients and durations.

    Parameters
    ----------
    n_components : int
        PCA components, as many as the movement primitives have primitives.
    """

    def __init__(self, n_components: int = 11):
        self.n_components = n_components

    def fit(self, steps: TrainingSteps) -> PCAPeer:
        X = self._resample_training(steps)
        self.scale_ = X.std(axis=(0, 2))
        flat = (X / self.scale_[:, None]).reshape(len(steps), -1)
        self.mean_ = flat.mean(axis=0)
        _, _, Vt = np.linalg.svd(flat - self.mean_, full_matrices=False)
        self.components_ = Vt[: self.n_components]
        coefficients = (flat - self.mean_) @ self.components_.T
        self.n_parameters_ = parameter_count(steps.specs)
        self.tables_ = {}
        for type_ in self.types:
            ks = [k for k, s in enumerate(steps.specs) if step_type(s) == type_]
            self.tables_[type_] = {
                "hull": _AffineHull(np.array([step_lengths(steps.specs[k], self.n_parameters_) for k in ks])),
                "coefficients": coefficients[ks],
                "durations": np.array([steps.durations[k] for k in ks]),
            }
        return self

    def predict(self, spec: StepSpec) -> GridStep:
        table = self.tables_[step_type(spec)]
        w = table["hull"].weights(step_lengths(spec, self.n_parameters_))
        flat = self.mean_ + (w @ table["coefficients"]) @ self.components_
        values = (flat.reshape(len(self.scale_), N_GRID) * self.scale_[:, None]).T
        return GridStep(spec, self.tau_, values, w @ table["durations"])


class _AffineHull:
    """Linear interpolation among points ``z`` (n, D) in the affine subspace they span."""

    def __init__(self, z: np.ndarray):
        self.z, self.origin = z, z.mean(axis=0)
        _, singular, Vt = np.linalg.svd(z - self.origin, full_matrices=False)
        self.axes = Vt[singular > 1e-9 * max(1.0, singular.max(initial=0.0))]  # (r, D)
        if len(self.axes) == z.shape[1]:  # spanning all: the points' own coordinates
            self.origin, self.axes = np.zeros(z.shape[1]), np.eye(z.shape[1])
        self.coords = (z - self.origin) @ self.axes.T  # (n, r)
        self.triangulation = None
        if len(self.axes) >= 2:
            with contextlib.suppress(QhullError):  # degenerate: nearest neighbour only
                self.triangulation = Delaunay(self.coords)

    def weights(self, target: np.ndarray) -> np.ndarray:
        """Weights of the points whose sum interpolates them linearly at ``target`` (D,),
        projected onto their subspace; the nearest point's alone outside their hull."""
        x = (target - self.origin) @ self.axes.T
        w = np.zeros(len(self.z))
        if len(self.axes) == 1:
            order = np.argsort(self.coords[:, 0])
            xs = self.coords[order, 0]
            j = int(np.searchsorted(xs, x[0]))
            if 0 < j < len(xs):
                f = (x[0] - xs[j - 1]) / (xs[j] - xs[j - 1])
                w[order[j - 1]], w[order[j]] = 1.0 - f, f
                return w
        elif self.triangulation is not None:
            simplex = int(self.triangulation.find_simplex(x))
            if simplex >= 0:
                T = self.triangulation.transform[simplex]
                b = T[:-1] @ (x - T[-1])
                w[self.triangulation.simplices[simplex]] = [*b, 1.0 - b.sum()]
                return w
        w[np.argmin(((self.z - target) ** 2).sum(axis=1))] = 1.0
        return w


COLUMNS = (  # (header, unit, metric, scale)
    ("joints", "mrad", "joints_rms_rad", 1e3),
    ("ZMP xy", "mm", "zmp_xy_rms_m", 1e3),
    ("ZMP xyz", "mm", "zmp_rms_m", 1e3),
    ("pelvis", "mrad", "pelvis_rms_rad", 1e3),
    ("duration", "ms", "duration_error_s", 1e3),
)
LABEL_WIDTH = 26


def _table(title: str, first: str, rows: list[tuple[str, dict]], extra: tuple = ()) -> None:
    """Print rows of pooled errors; ``extra`` adds (header, unit, key, scale) columns."""
    columns = COLUMNS + extra
    print(title)
    print(f"{first:<{LABEL_WIDTH}}" + "".join(f"{c[0]:>10}" for c in columns))
    print(f"{'':<{LABEL_WIDTH}}" + "".join(f"{c[1]:>10}" for c in columns))
    for label, values in rows:
        print(f"{label:<{LABEL_WIDTH}}" + "".join(f"{values[c[2]] * c[3]:10.1f}" for c in columns))


def print_tables(report: dict) -> None:
    """The overall table, one row per method, then one row per method and held-out length."""
    methods = report["methods"]
    n_steps = next(iter(methods.values()))["overall"]["n_steps"]
    overall = [
        (name, {**r["overall"], "generation_time_s": r["generation_time_s"], "fit_time_s": r["fit_time_s"]})
        for name, r in methods.items()
    ]
    extra = (("generate", "us", "generation_time_s", 1e6), ("fit", "s", "fit_time_s", 1.0))
    _table(
        f"Leave-one-length-out errors (RMS; duration: mean |error|), {n_steps} held-out steps", "method", overall, extra
    )
    per_length = [(f"{name} {mm}", m) for name, r in methods.items() for mm, m in r["per_length"].items()]
    print()
    _table("Per held-out length (150 and 400 mm are extrapolation)", "method, held-out mm", per_length)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a fast smoke run: a small, barely fitted primitive model")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    args = parser.parse_args()

    steps = load_training_steps(DATASET)
    folds = lolo_folds(steps)
    bundled = model_metadata(BUNDLED_MODEL)
    n_primitives, iterations = (5, 5) if args.quick else (bundled["n_primitives"], DEFAULT_MAX_ITERATIONS)
    mp = MovementPrimitives(n_primitives=n_primitives, kernel=bundled["kernel"], n_grid=N_GRID, max_iterations=iterations)
    # (estimator, fitting processes): a primitive fit takes tens of seconds on one core, so two
    # folds at a time; the peers fit in milliseconds
    methods = {"movement_primitives": (mp, 2), "promp": (ProMPPeer(), 1), "pca_interpolation": (PCAPeer(), 1)}
    repeats = 20 if args.quick else 200

    started = time.perf_counter()
    report = {
        "dataset": steps.source,
        "heldout_lengths_mm": [length_mm(f.length) for f in folds],
        "grid_points": N_GRID,
        "quick": args.quick,
        "methods": {},
    }
    for name, (estimator, workers) in methods.items():
        print(f"fitting {name} on {len(folds)} folds ...", file=sys.stderr)
        fitted = fit_folds(estimator, folds, workers=workers, progress=True)
        models = [m for m, _ in fitted]
        print(f"evaluating {name} ...", file=sys.stderr)
        report["methods"][name] = {
            "settings": vars(estimator).copy(),
            "fit_time_s": float(np.mean([s for _, s in fitted])),
            **evaluate_lolo(models, folds, repeats),
        }
    print(f"done in {time.perf_counter() - started:.0f} s", file=sys.stderr)

    if args.json:
        print(json.dumps(report))
    else:
        print_tables(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
