"""Model selection: the candidates are fitted from the smallest S up until the rule settles.

Two barely fitted candidates (2 and 3 primitives, 5 L-BFGS iterations) on the six cyclic
steps of 150-250 mm of the bundled dataset: the tests check the selection, not the models.
"""

import dataclasses
import inspect
import os

import pytest

from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL
from cocomopl.errors import Error
from cocomopl.primitives import DEFAULT_MAX_ITERATIONS, selection
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.model_file import model_metadata
from cocomopl.primitives.selection import EXPLAINED_ENOUGH, choose, select_model, settled
from cocomopl.primitives.training import TrainingSteps, load_training_steps


@pytest.fixture(scope="module")
def cyclic():
    steps = load_training_steps(BUNDLED_DATASET)
    return steps.subset(k for k, s in enumerate(steps.specs) if s.kind == "cyclic" and s.start_length <= 0.25)


@pytest.fixture(scope="module")
def selected(cyclic):
    return select_model(cyclic, n_primitives=(2, 3), kernels=("rbf",), max_iterations=5, workers=1)


@pytest.mark.slow
def test_every_candidate_is_fitted_and_the_rule_chooses(selected):
    best, rows = selected
    assert [(r["kernel"], r["n_primitives"]) for r in rows] == [("rbf", 2), ("rbf", 3)]
    winner = rows[choose(rows)]
    assert (best.kernel, best.n_primitives, best.bound_) == (winner["kernel"], winner["n_primitives"], winner["bound"])
    for r in rows:
        assert 1 <= r["iterations"] <= 5
        assert set(r["explained_variance"]) == {"joints", "zmp", "pelvis"}
        assert all(0 < v <= 1 for v in r["explained_variance"].values())


def _row(kernel: str, S: int, bound: float, explained: float) -> dict:
    return {"kernel": kernel, "n_primitives": S, "bound": bound,
            "explained_variance": {"joints": 1.0, "zmp": explained, "pelvis": 1.0}}


@pytest.mark.slow
def test_the_search_stops_at_the_first_size_that_explains_enough(cyclic, monkeypatch):
    monkeypatch.setattr(selection, "EXPLAINED_ENOUGH", 0.0)
    best, rows = select_model(cyclic, n_primitives=(3, 2, 4), kernels=("rbf", "matern32"), max_iterations=2, workers=2)
    assert sorted((r["kernel"], r["n_primitives"]) for r in rows) == [("matern32", 2), ("rbf", 2)]
    assert best.n_primitives == 2


def test_the_search_settles_where_the_bound_falls_or_a_size_explains_enough():
    low, high = EXPLAINED_ENOUGH - 1e-4, EXPLAINED_ENOUGH + 1e-4
    assert not settled([_row("rbf", 7, 1.0, low), _row("matern32", 7, 1.1, low)])
    assert settled([_row("rbf", 7, 1.0, low), _row("rbf", 11, 2.0, high)])
    assert settled([_row("rbf", 7, 2.0, low), _row("rbf", 11, 1.0, low)])
    # an earlier size explaining enough does not settle a later one (the bound rose through it)
    assert not settled([_row("rbf", 7, 1.0, high), _row("rbf", 11, 2.0, low)])


def test_a_bound_that_keeps_rising_leaves_the_choice_to_the_explained_variance():
    low, high = EXPLAINED_ENOUGH - 1e-4, EXPLAINED_ENOUGH + 1e-4
    rows = [_row("rbf", 7, 1.0, low), _row("rbf", 11, 2.0, high), _row("rbf", 15, 3.0, high),
            _row("matern32", 7, 1.1, low), _row("matern32", 11, 2.1, high), _row("matern32", 15, 3.1, high)]
    assert rows[choose(rows)]["kernel"] == "matern32" and rows[choose(rows)]["n_primitives"] == 11
    # no candidate explains enough: the largest S
    short = [_row("rbf", 7, 1.0, low), _row("rbf", 11, 2.0, low)]
    assert choose(short) == 1


def test_a_bound_that_turns_over_chooses_by_itself():
    rows = [_row("rbf", 7, 1.0, 1.0), _row("rbf", 11, 3.0, 1.0), _row("rbf", 15, 2.0, 1.0)]
    assert choose(rows) == 1


@pytest.mark.slow
def test_the_best_candidate_keeps_the_selection_settings_and_predicts(selected, cyclic):
    best, _ = selected
    assert best.max_iterations == 5 and not best.verbose
    step = best.predict(cyclic.specs[0])
    assert step.values.shape == (best.n_grid, len(cyclic.signal_names))


def test_an_impossible_candidate_is_refused_before_any_fit(cyclic):
    with pytest.raises(Error, match="500 primitives cannot exceed"):
        select_model(cyclic, n_primitives=(2, 500), kernels=("rbf",))
    with pytest.raises(Error, match="kernel must be one of rbf, matern32, matern52, not 'cubic'"):
        select_model(cyclic, n_primitives=(2,), kernels=("rbf", "cubic"))


def test_the_defaults_reproduce_the_bundled_model():
    default = inspect.signature(select_model).parameters["max_iterations"].default
    assert default == MovementPrimitives().max_iterations == DEFAULT_MAX_ITERATIONS
    bundled = model_metadata(BUNDLED_MODEL)
    assert (bundled["max_iterations"], bundled["n_grid"]) == (DEFAULT_MAX_ITERATIONS, MovementPrimitives().n_grid)


class _DiesInWorker(TrainingSteps):
    """Training steps whose copy in a worker process ends that process, as a crash in
    compiled code or the out-of-memory killer would."""

    def __reduce__(self):
        return os._exit, (1,)


def test_a_training_process_that_dies_is_an_error_not_a_hang(cyclic):
    steps = _DiesInWorker(*(getattr(cyclic, f.name) for f in dataclasses.fields(cyclic)))
    with pytest.raises(Error, match=r"a training process died .*run the same command again"):
        select_model(steps, n_primitives=(2,), kernels=("rbf",), max_iterations=2, workers=1)
