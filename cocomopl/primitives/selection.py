"""Model selection: fit every (number of primitives, kernel) candidate and choose one.

The paper keeps the candidate with the largest free energy (eq. 6).  On noise-free OC data
the bound does not turn over: every added primitive shrinks the residual noise, and the
largest S tried always wins (with EM, 1.08e6 nats at S = 7 up to 2.05e6 at 31).  So the
bound chooses only if it turns over within the candidates; otherwise the smallest S that
explains ``EXPLAINED_ENOUGH`` of every signal group is chosen, the paper's criterion in
effect, and among the kernels at that S the largest bound.
"""

from __future__ import annotations

import itertools
import multiprocessing
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed

from tqdm import tqdm

from cocomopl.primitives import DEFAULT_KERNELS, DEFAULT_MAX_ITERATIONS, DEFAULT_PRIMITIVES
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.training import TrainingSteps

EXPLAINED_ENOUGH = 0.999  # explained variance each signal group needs (joints, ZMP, pelvis)


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


def _candidates(
    base: MovementPrimitives, n_primitives: Iterable[int], kernels: Iterable[str]
) -> list[MovementPrimitives]:
    """Unfitted copies of ``base``, one per (kernel, number of primitives), its other parameters kept."""
    return [
        MovementPrimitives(**base.get_params()).set_params(n_primitives=s, kernel=k)
        for k, s in itertools.product(kernels, n_primitives)
    ]


def select_model(
    steps: TrainingSteps,
    n_primitives: Iterable[int] = DEFAULT_PRIMITIVES,
    kernels: Iterable[str] = DEFAULT_KERNELS,
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    workers: int = 1,
    progress: bool = False,
) -> tuple[MovementPrimitives, list[dict]]:
    """Fit all candidates (in ``workers`` processes) and return the best model and the table.

    Parameters
    ----------
    steps : the training steps
    n_primitives, kernels : the candidates are all their combinations
    max_iterations : the most EM rounds of each fit
    workers : processes to fit in.  They are spawned, not forked: a forked JAX runtime can hang
    progress : show a bar of the candidates fitted on stderr.  The candidates' own per-iteration
        progress (``verbose``) stays off: bars from parallel processes would overwrite each other

    Returns
    -------
    best : the candidate with the largest bound
    rows : :func:`summary_row` of every candidate, ordered by kernel and number of primitives

    Raises
    ------
    Error
        If a candidate cannot be fitted to ``steps``, before any is fitted.
    """
    models = _candidates(MovementPrimitives(max_iterations=max_iterations), n_primitives, kernels)
    for model in models:
        model.validate(steps)
    fitted = []
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        # the largest first, so that the two processes finish together
        futures = [pool.submit(model.fit, steps) for model in sorted(models, key=lambda m: -m.n_primitives)]
        for future in tqdm(as_completed(futures), total=len(futures), desc="fitting", unit="model", disable=not progress):
            fitted.append(future.result())
    fitted.sort(key=lambda m: (m.kernel, m.n_primitives))
    rows = [summary_row(m) for m in fitted]
    return fitted[choose(rows)], rows


def choose(rows: list[dict]) -> int:
    """The index of the chosen candidate among :func:`summary_row` rows (module docstring):
    the largest bound if some kernel's bound falls as S grows, else the smallest S whose
    every signal group reaches ``EXPLAINED_ENOUGH`` (the largest S if none does), its best
    kernel by the bound."""
    def bound_of(i: int) -> float:
        return rows[i]["bound"]

    by_kernel = {}
    for i in sorted(range(len(rows)), key=lambda i: rows[i]["n_primitives"]):
        by_kernel.setdefault(rows[i]["kernel"], []).append(i)
    if any(bound_of(b) < bound_of(a) for ids in by_kernel.values() for a, b in itertools.pairwise(ids)):
        return max(range(len(rows)), key=bound_of)
    enough = [i for i, row in enumerate(rows) if min(row["explained_variance"].values()) >= EXPLAINED_ENOUGH]
    S = min((rows[i]["n_primitives"] for i in enough), default=max(row["n_primitives"] for row in rows))
    return max((i for i, row in enumerate(rows) if row["n_primitives"] == S), key=bound_of)
