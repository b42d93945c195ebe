"""Model selection: fit the (number of primitives, kernel) candidates and choose one.

The paper keeps the candidate with the largest free energy (eq. 6).  On noise-free OC data
the bound does not turn over: every added primitive shrinks the residual noise, and the
largest S tried always wins (with EM, 1.08e6 nats at S = 7 up to 2.05e6 at 31).  So the
bound chooses only if it turns over within the candidates; otherwise the smallest S that
explains ``EXPLAINED_ENOUGH`` of every signal group is chosen, the paper's criterion in
effect, and among the kernels at that S the largest bound.

The candidates are fitted from the smallest S up, and the search stops at the first S that
settles the choice: where every group is explained enough, or where the bound has fallen.
A larger S could then only be chosen by a bound that turns over after rising through it,
which it does not on this data; and the largest candidates take longest (the 15-primitive
fits of a 464-step dataset: 370-410 s each, of 2413 s for all nine).
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
import threading
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from tqdm import tqdm

from cocomopl.errors import Error
from cocomopl.primitives import DEFAULT_KERNELS, DEFAULT_MAX_ITERATIONS, DEFAULT_PRIMITIVES, DEFAULT_WIDTHS
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.training import TrainingSteps
from cocomopl.processes import exit_with_parent

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
    *,
    max_iterations: int = DEFAULT_MAX_ITERATIONS,
    n_widths: int = DEFAULT_WIDTHS,
    workers: int = 1,
    progress: bool = False,
) -> tuple[MovementPrimitives, list[dict]]:
    """Fit the candidates (in ``workers`` processes) from the smallest S up until the choice is
    settled (:func:`settled`), and return the best model and the table.

    Parameters
    ----------
    steps : the training steps
    n_primitives, kernels : the candidates are all their combinations
    max_iterations : the most EM rounds of each fit
    n_widths : the candidate widths of the weight kernels (:class:`MovementPrimitives`)
    workers : processes to fit in.  They are spawned, not forked: a forked JAX runtime can hang.
        Candidates still fitting when the choice is settled are stopped
    progress : show a bar of the candidates fitted on stderr.  The candidates' own per-iteration
        progress (``verbose``) stays off: bars from parallel processes would overwrite each other

    Returns
    -------
    best : the candidate the rule chooses (:func:`choose`)
    rows : :func:`summary_row` of every candidate fitted, ordered by kernel and number of primitives

    Raises
    ------
    Error
        If a candidate cannot be fitted to ``steps``, before any is fitted, or if a worker
        process dies.
    """
    models = _candidates(MovementPrimitives(max_iterations=max_iterations, n_widths=n_widths), n_primitives, kernels)
    for model in models:
        model.validate(steps)
    sizes = sorted({model.n_primitives for model in models})
    fitted: list[MovementPrimitives] = []
    bar = tqdm(total=len(models), desc="fitting", unit="model", disable=not progress)
    others = set(multiprocessing.active_children())
    pool = ProcessPoolExecutor(workers, multiprocessing.get_context("spawn"), initializer=_start_worker,
                               initargs=(os.getpid(),))
    try:
        pending = {S: [pool.submit(model.fit, steps) for model in models if model.n_primitives == S] for S in sizes}
        for S in sizes:
            for future in pending[S]:
                fitted.append(_fitted(future))
                bar.update()
            if settled([summary_row(m) for m in fitted]):
                break
    finally:
        # the fits still running when the choice is settled are stopped, not waited for
        pool.shutdown(wait=False, cancel_futures=True)
        for process in set(multiprocessing.active_children()) - others:
            process.terminate()
        bar.total = len(fitted)
        bar.close()
    fitted.sort(key=lambda m: (m.kernel, m.n_primitives))
    rows = [summary_row(m) for m in fitted]
    return fitted[choose(rows)], rows


def _fitted(future) -> MovementPrimitives:
    """A candidate's fit; a worker that died is an :class:`Error`, not a traceback or a hang."""
    try:
        return future.result()
    except BrokenProcessPool:
        raise Error("a training process died (a crash in compiled code, or out of memory): "
                    "run the same command again") from None


def _start_worker(parent: int) -> None:
    """Give a worker's progress bars a thread lock, not tqdm's default process lock: a worker
    stopped mid-fit would leave that lock's semaphores behind, and Python warns about them.
    And end the worker with its parent (:func:`~cocomopl.processes.exit_with_parent`)."""
    tqdm.set_lock(threading.RLock())
    exit_with_parent(parent)


def settled(rows: list[dict]) -> bool:
    """Whether the candidates of :func:`summary_row` ``rows``, fitted from the smallest S up,
    settle the choice (module docstring): some kernel's bound fell as S grew, or a candidate
    of the largest S fitted explains enough of every signal group."""
    largest = max(row["n_primitives"] for row in rows)
    enough = any(row["n_primitives"] == largest and min(row["explained_variance"].values()) >= EXPLAINED_ENOUGH
                 for row in rows)
    return enough or _bound_falls(rows)


def _bound_falls(rows: list[dict]) -> bool:
    """Whether some kernel's bound falls as S grows."""
    by_kernel: dict[str, list[dict]] = {}
    for row in sorted(rows, key=lambda row: row["n_primitives"]):
        by_kernel.setdefault(row["kernel"], []).append(row)
    return any(b["bound"] < a["bound"] for kernel_rows in by_kernel.values() for a, b in itertools.pairwise(kernel_rows))


def choose(rows: list[dict]) -> int:
    """The index of the chosen candidate among :func:`summary_row` rows (module docstring):
    the largest bound if some kernel's bound falls as S grows, else the smallest S whose
    every signal group reaches ``EXPLAINED_ENOUGH`` (the largest S if none does), its best
    kernel by the bound."""
    def bound_of(i: int) -> float:
        return rows[i]["bound"]

    if _bound_falls(rows):
        return max(range(len(rows)), key=bound_of)
    enough = [i for i, row in enumerate(rows) if min(row["explained_variance"].values()) >= EXPLAINED_ENOUGH]
    S = min((rows[i]["n_primitives"] for i in enough), default=max(row["n_primitives"] for row in rows))
    return max((i for i, row in enumerate(rows) if row["n_primitives"] == S), key=bound_of)
