"""Leave-one-length-out (LOLO) evaluation of step generators against held-out OC steps.

For each step length L of the training set, every step that starts or ends at L (both
swing sides: the cyclic, start and stop steps of L and the transitions into and out of
L) is held out; a generator is fitted on the other steps and predicts each held-out
step from its :class:`StepSpec` alone.  The prediction is compared with the OC step on
the generator's own normalised-time grid, i.e. the OC step warped with the training
set's per-type phase templates (:meth:`reconstruct`), so that errors measure the signals'
shapes and the durations are scored separately.

Any generator with ``fit(steps)``, ``predict(spec)`` (an object with ``values`` (T, I)
and ``durations`` (P,) in s) and ``reconstruct(steps)`` (OC and predicted signals,
each (K, I, T)) can be evaluated: :class:`MovementPrimitives` and the peers of
``primitive_peers.py`` are.  The benchmark is its only user, hence its place beside it.
"""

from __future__ import annotations

import copy
import multiprocessing
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from cocomopl.motion import StepSpec
from cocomopl.primitives.estimator import signal_groups
from cocomopl.primitives.training import TrainingSteps, step_type

RMS_METRICS = ("joints_rms_rad", "zmp_xy_rms_m", "zmp_rms_m", "pelvis_rms_rad")
METRICS = (*RMS_METRICS, "duration_error_s")


class StepGenerator(Protocol):
    """What the evaluation needs of a generator (see the module docstring)."""

    def fit(self, steps: TrainingSteps) -> StepGenerator: ...

    def predict(self, spec: StepSpec): ...

    def reconstruct(self, steps: TrainingSteps) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass
class Fold:
    """One LOLO split.

    Attributes
    ----------
    length : the held-out step length, m
    train : the steps that neither start nor end at ``length``
    heldout : the steps that do, and whose type ``train`` still has examples of
    skipped : specs of held-out steps whose type has no training example left
    """

    length: float
    train: TrainingSteps
    heldout: TrainingSteps
    skipped: list[StepSpec]


def length_mm(length: float) -> int:
    """A step length in whole millimetres, the key of per-length results."""
    return round(1000 * length)


def training_lengths(steps: TrainingSteps) -> list[float]:
    """The distinct non-zero step lengths of ``steps`` (m), ascending.

    Zero is the feet-together end of start and stop steps, not a length one can hold out.
    """
    mm = {length_mm(x) for s in steps.specs for x in (s.start_length, s.end_length)} - {0}
    return [m / 1000 for m in sorted(mm)]


def lolo_folds(steps: TrainingSteps, lengths: list[float] | None = None) -> list[Fold]:
    """The leave-one-length-out splits of ``steps``, one per length (default: all of them).

    A transition touches two lengths, so it is held out in two folds.
    """
    folds = []
    for length in training_lengths(steps) if lengths is None else lengths:
        # compare in mm: 0.3 and 0.30000000000000004 are the same step length
        touches = [length_mm(length) in (length_mm(s.start_length), length_mm(s.end_length)) for s in steps.specs]
        train = steps.subset(k for k, t in enumerate(touches) if not t)
        trained_types = {step_type(s) for s in train.specs}
        heldout = [k for k, t in enumerate(touches) if t]
        covered = [k for k in heldout if step_type(steps.specs[k]) in trained_types]
        skipped = [steps.specs[k] for k in heldout if k not in covered]
        folds.append(Fold(length, train, steps.subset(covered), skipped))
    return folds


def _fit_timed(estimator: StepGenerator, steps: TrainingSteps) -> tuple[StepGenerator, float]:
    started = time.perf_counter()
    fitted = copy.deepcopy(estimator).fit(steps)
    return fitted, time.perf_counter() - started


def fit_folds(
    estimator: StepGenerator, folds: list[Fold], workers: int = 1, progress: bool = False
) -> list[tuple[StepGenerator, float]]:
    """Fit a copy of ``estimator`` on each fold's training steps.

    Parameters
    ----------
    estimator : an unfitted generator; it is copied, never fitted itself
    folds : from :func:`lolo_folds`
    workers : processes to fit in; with more than one they are spawned, not forked,
        because a forked JAX runtime can hang
    progress : report each finished fit on stderr

    Returns
    -------
    list of (fitted generator, fit wall time in s), in the order of ``folds``
    """
    name = type(estimator).__name__
    out = [None] * len(folds)

    def report(i: int) -> None:
        if progress:
            done = sum(r is not None for r in out)
            print(
                f"  {name} without {length_mm(folds[i].length)} mm fitted in {out[i][1]:.1f} s ({done}/{len(folds)})",
                file=sys.stderr,
            )

    if workers <= 1:
        for i, fold in enumerate(folds):
            out[i] = _fit_timed(estimator, fold.train)
            report(i)
        return out
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(_fit_timed, estimator, fold.train): i for i, fold in enumerate(folds)}
        for future in as_completed(futures):
            i = futures[future]
            out[i] = future.result()
            report(i)
    return out


def step_errors(model: StepGenerator, steps: TrainingSteps) -> dict[str, np.ndarray]:
    """Per step, the errors of the model's prediction from the step's spec.

    Parameters
    ----------
    model : a fitted generator that has every type of ``steps``
    steps : the OC steps to predict

    Returns
    -------
    dict of (K,) arrays
        ``joints_rms_rad``, ``zmp_xy_rms_m`` (horizontal ZMP only), ``zmp_rms_m`` (x, y
        and z), ``pelvis_rms_rad``: RMS over the group's signals and all grid points;
        ``duration_error_s``: |predicted - OC| total duration.
    """
    X, X_hat = model.reconstruct(steps)
    groups = signal_groups(steps.signal_names)
    zmp_xy = [steps.signal_names.index(n) for n in ("zmp_x", "zmp_y")]

    def rms(idx) -> np.ndarray:
        return np.sqrt(((X - X_hat)[:, idx] ** 2).mean(axis=(1, 2)))

    predicted = np.array([model.predict(spec).durations.sum() for spec in steps.specs])
    actual = np.array([d.sum() for d in steps.durations])
    return {
        "joints_rms_rad": rms(groups["joints"]),
        "zmp_xy_rms_m": rms(zmp_xy),
        "zmp_rms_m": rms(groups["zmp"]),
        "pelvis_rms_rad": rms(groups["pelvis"]),
        "duration_error_s": np.abs(predicted - actual),
    }


def summarise(errors: dict[str, np.ndarray]) -> dict[str, float]:
    """Pool per-step errors: RMS metrics over all steps' points, the duration error as a mean.

    Every step has the same grid and signals, so the root of the mean squared per-step RMS
    is the RMS over all points of all steps.
    """
    out = {m: float(np.sqrt(np.mean(errors[m] ** 2))) for m in RMS_METRICS}
    out["duration_error_s"] = float(np.mean(errors["duration_error_s"]))
    return out


def generation_time_s(model: StepGenerator, specs: list[StepSpec], repeats: int = 200) -> float:
    """Mean over ``specs`` of the median wall time of ``model.predict(spec)`` (s).

    The median of many calls after a warm-up is robust to the odd interruption; the mean
    over specs weighs step types as often as they occur.
    """
    medians = []
    for spec in specs:
        model.predict(spec)
        samples = []
        for _ in range(repeats):
            started = time.perf_counter()
            model.predict(spec)
            samples.append(time.perf_counter() - started)
        medians.append(statistics.median(samples))
    return float(np.mean(medians))


def evaluate_lolo(models: list[StepGenerator], folds: list[Fold], repeats: int = 200) -> dict:
    """Errors and generation time of fitted generators, one per fold, on the held-out steps.

    Parameters
    ----------
    models : ``models[i]`` fitted on ``folds[i].train``
    folds : from :func:`lolo_folds`
    repeats : timed calls of ``predict`` per held-out step

    Returns
    -------
    dict
        ``per_length``: per held-out length in mm, the pooled errors (:func:`summarise`),
        ``n_steps``, ``n_skipped`` and per-step errors; ``overall``: the same pooled over
        all folds (transitions count once per fold they are held out in);
        ``generation_time_s``: mean predict time per held-out step.
    """
    per_length, pooled, times = {}, {m: [] for m in METRICS}, []
    for model, fold in zip(models, folds):
        errors = step_errors(model, fold.heldout) if len(fold.heldout) else {m: np.empty(0) for m in METRICS}
        for m in METRICS:
            pooled[m].append(errors[m])
        per_length[str(length_mm(fold.length))] = {
            **(summarise(errors) if len(fold.heldout) else {}),
            "n_steps": len(fold.heldout),
            "n_skipped": len(fold.skipped),
            "steps": [
                {"step": spec.name, **{m: float(errors[m][k]) for m in METRICS}}
                for k, spec in enumerate(fold.heldout.specs)
            ],
        }
        times.extend([generation_time_s(model, [spec], repeats) for spec in fold.heldout.specs])
    pooled = {m: np.concatenate(v) for m, v in pooled.items()}
    return {
        "per_length": per_length,
        "overall": {
            **summarise(pooled),
            "n_steps": len(pooled["duration_error_s"]),
            "n_skipped": sum(len(f.skipped) for f in folds),
        },
        "generation_time_s": float(np.mean(times)),
    }
