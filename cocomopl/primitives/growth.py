"""Where to grow a dataset: the step lengths at which the model knows least.

A step's signals are ``x_i(t) = sum_s W_is MP_s(t)``, and each weight ``W_is`` is a GP of the
step's lengths (eq. 5).  A GP's posterior variance depends on where its training inputs
lie, not on the values observed there, so the variance left at a candidate length can be
computed for training sets that do not exist yet: the trained lengths plus those already
picked.  That makes a greedy batch possible without solving anything: pick the candidate
of most variance left, add it to the inputs, pick again.

The score of a length ``L`` is the fraction of its prior variance each signal keeps,

    sum_s var_is(z) |MP_s|^2  /  sum_s alpha_is |MP_s|^2,

averaged over the signals and over the steps a new length adds to the training set (its
cyclic step ``(L, L)``, start ``(0, L)`` and stop ``(L, 0)``; a stop learned in parts
averages its parts): 0 where the model is certain, 1 where it has learned nothing.  With no
length added it is the model's own posterior variance (``tests/test_growth.py``).
"""

from __future__ import annotations

import numpy as np

from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives.estimator import SAME_LENGTHS_M2, MovementPrimitives
from cocomopl.primitives.training import step_lengths, step_type

GRID_M = 0.01  # candidate lengths lie on this grid, strictly between the trained ones
MAX_BUDGET = 20  # lengths one run adds: each brings 7 OCPs (three steps, four transitions)
# what a new length's warm-up walk starts from (cocomopl.jobs.grow_dataset); refinement's warm
# starts are another choice, cocomopl.ocp.settings.WARM_STARTS
GROWTH_WARM_STARTS = ("model", "neighbour")


def length_steps_of(length: float) -> list[StepSpec]:
    """The steps that a new training length adds and the score averages (left swing)."""
    return [StepSpec("cyclic", length, length), StepSpec("start", 0.0, length), StepSpec("stop", length, 0.0)]


def candidate_lengths(trained: list[float], exclude: list[float] = (), grid: float = GRID_M) -> list[float]:
    """Lengths on ``grid`` (m) strictly inside the trained range, none of them trained or in
    ``exclude`` (the held-out lengths)."""
    low, high = min(trained), max(trained)
    points = np.round(np.arange(np.ceil(low / grid) * grid, high + grid / 2, grid), 6)
    taken = np.array([*trained, *exclude])
    return [float(x) for x in points if low < x < high and not np.isclose(taken, x, atol=1e-6).any()]


def _kernel(d2: np.ndarray, alpha: np.ndarray, gamma: np.ndarray, nugget: np.ndarray) -> np.ndarray:
    """Eq. (5) with the nugget of steps of the same lengths, for all K weights: (K, *d2.shape)."""
    shape = (-1,) + (1,) * d2.ndim
    return alpha.reshape(shape) * np.exp(-gamma.reshape(shape) * d2) + nugget.reshape(shape) * (d2 < SAME_LENGTHS_M2)


def weight_variance(model: MovementPrimitives, type_: str, added: np.ndarray, *, z: np.ndarray) -> np.ndarray:
    """Posterior variance (I, S) of the weights of trajectory type ``type_`` at lengths ``z``
    (its step parameters), had the type's training inputs been the trained ones plus ``added`` (n, parameters).

    The model's weight posterior is a GP that observes each training step's weights with a
    noise of its own per (signal, primitive) (``Omega = (B^-1 + c I)^-1``); a new step is
    observed with the same noise ``1 / c``.
    """
    arrays = model.type_arrays(type_)
    alpha, gamma, nugget = arrays.alpha_w, arrays.gamma_w, arrays.nugget
    trained = arrays.lengths
    noise = 1.0 / model.c_w_.ravel()
    inputs = np.vstack([trained, added.reshape(-1, trained.shape[1])])
    K = _kernel(((inputs[:, None] - inputs[None]) ** 2).sum(-1), alpha, gamma, nugget)
    K += noise[:, None, None] * np.eye(len(inputs))
    b = _kernel(((inputs - z) ** 2).sum(-1), alpha, gamma, nugget)  # (K, n)
    var = alpha - np.einsum("kn,kn->k", b, np.linalg.solve(K, b[..., None])[..., 0])
    return np.maximum(var, 0.0).reshape(model.alpha_w_.shape)


def variance_left(model: MovementPrimitives, length: float, added: list[float]) -> float:
    """The score of ``length`` (see the module) given the lengths ``added`` to the trained ones."""
    energy = (model.m_**2).sum(axis=1)  # |MP_s|^2 over the grid, (S,)
    prior = model.alpha_w_ @ energy  # (I,)
    fractions, count = [], model.lengths_.shape[-1]
    for spec in length_steps_of(length):
        new_inputs = np.array([step_lengths(s, count) for L in added for s in length_steps_of(L) if s.kind == spec.kind])
        for type_ in model.trajectory_types(step_type(spec)):
            var = weight_variance(model, type_, new_inputs, z=step_lengths(spec, count))
            fractions.append(np.mean(var @ energy / prior))
    return float(np.mean(fractions))


def pick_uncertain(model: MovementPrimitives, trained: list[float], budget: int, *,
                   exclude: list[float] = ()) -> list[tuple[float, float]]:
    """The ``budget`` candidate lengths (m) of most variance left, picked greedily, each with
    its score when it was picked."""
    check_budget(budget, trained, exclude)
    candidates, picked = candidate_lengths(trained, exclude), []
    for _ in range(budget):
        added = [L for L, _ in picked]
        scores = {L: variance_left(model, L, added) for L in candidates if L not in added}
        best = max(scores, key=scores.get)
        picked.append((best, scores[best]))
    return picked


def pick_uniform(trained: list[float], budget: int, exclude: list[float] = ()) -> list[float]:
    """``budget`` lengths (m) spread evenly over the trained range, each the free candidate
    nearest its even spot: the baseline growth is compared with."""
    check_budget(budget, trained, exclude)
    low, high = min(trained), max(trained)
    free, picked = candidate_lengths(trained, exclude), []
    for k in range(1, budget + 1):
        spot = low + k * (high - low) / (budget + 1)
        best = min((L for L in free if L not in picked), key=lambda L: abs(L - spot))
        picked.append(best)
    return sorted(picked)


def check_budget(budget: int, trained: list[float], exclude: list[float] = ()) -> int:
    """``budget`` if it is a number of new lengths a run can add, else :class:`Error`."""
    room = len(candidate_lengths(trained, exclude))
    if not isinstance(budget, (int, np.integer)) or isinstance(budget, bool):
        raise Error(f"the budget must be a whole number of step lengths, not {budget!r}")
    if budget < 1:
        raise Error(f"the budget must be at least 1 step length, got {budget}")
    if budget > min(MAX_BUDGET, room):
        raise Error(f"a budget of {budget} lengths is more than one run adds (at most {min(MAX_BUDGET, room)}: "
                    f"{room} free {1000 * GRID_M:g} mm grid points in the trained range, {MAX_BUDGET} per run)")
    return int(budget)


__all__ = ["candidate_lengths", "check_budget", "pick_uncertain", "pick_uniform", "variance_left", "weight_variance"]
