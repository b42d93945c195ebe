"""Approximate Bayesian model comparison: fit every (number of primitives, kernel) candidate
and keep the one with the largest free energy (eq. 6), as the paper does."""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor, as_completed

from tqdm import tqdm

from cocomopl.primitives import DEFAULT_KERNELS, DEFAULT_PRIMITIVES
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.training import TrainingSteps


def _fit(steps: TrainingSteps, n_primitives: int, kernel: str, max_iterations: int) -> MovementPrimitives:
    return MovementPrimitives(n_primitives, kernel, max_iterations=max_iterations).fit(steps)


def summary_row(model: MovementPrimitives) -> dict:
    """One line of the model-comparison table."""
    return {
        "n_primitives": model.n_primitives,
        "kernel": model.kernel,
        "bound": model.bound_,
        "explained_variance": model.explained_variance_,
        "iterations": model.n_iter_,
        "fit_time_s": model.fit_time_s_,
    }


def select_model(
    steps: TrainingSteps,
    n_primitives=DEFAULT_PRIMITIVES,
    kernels=DEFAULT_KERNELS,
    max_iterations: int = 150,
    workers: int = 1,
    progress: bool = False,
) -> tuple[MovementPrimitives, list[dict]]:
    """Fit all candidates (in ``workers`` processes) and return the best model and the table.

    Processes are spawned, not forked: a forked JAX runtime can hang.
    """
    candidates = [(s, k) for k in kernels for s in n_primitives]
    for s, k in candidates:  # refuse impossible settings before any process starts
        MovementPrimitives(s, k, max_iterations=max_iterations).validate(steps)
    models = []
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [pool.submit(_fit, steps, s, k, max_iterations) for s, k in candidates]
        for future in tqdm(as_completed(futures), total=len(futures), desc="fitting", unit="model", disable=not progress):
            models.append(future.result())
    models.sort(key=lambda m: (m.kernel, m.n_primitives))
    best = max(models, key=lambda m: m.bound_)
    return best, [summary_row(m) for m in models]
