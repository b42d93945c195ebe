"""Growing a dataset: where the model is unsure, the baseline's even spread, the model's walk as
a warm start, steps of the grown dataset kept as they were, and bad input."""

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL, BUNDLED_OMNI_MODEL
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives.estimator import SAME_LENGTHS_M2, VARIANCE_FLOOR, weight_posterior
from cocomopl.primitives.growth import (
    candidate_lengths,
    check_budget,
    pick_uncertain,
    pick_uniform,
    variance_left,
    weight_variance,
)
from cocomopl.primitives.model_file import load_model
from cocomopl.primitives.training import step_lengths

from conftest import SMALL, SMALL_LENGTH, assert_one_line_error, run_cli

TRAINED = [0.15, 0.2, 0.25, 0.3, 0.35, 0.4]


@pytest.fixture(scope="module")
def model():
    return load_model(BUNDLED_MODEL).prepare()


@pytest.fixture(scope="module")
def omni_model():
    return load_model(BUNDLED_OMNI_MODEL).prepare()


def direct_weight_variance(model, type_, z):
    """The weight GPs' posterior variance (before the floor), by dense solves of the model's
    weight kernels: ``alpha - b^T C b`` with ``C = (alpha (E + eta I) + I / c)^-1``."""
    c = model.type_arrays(type_)
    n = len(c.lengths)
    D = ((c.lengths[:, None] - c.lengths[None]) ** 2).sum(axis=-1)
    eta, precision = model.eta_w_.ravel(), model.c_w_.ravel()
    B = c.alpha_w[:, None, None] * (np.exp(-np.multiply.outer(c.gamma_w, D)) + eta[:, None, None] * np.eye(n))
    C = np.linalg.inv(B + np.eye(n) / precision[:, None, None])
    d2 = ((c.lengths - z) ** 2).sum(axis=1)
    b = c.alpha_w[:, None] * np.exp(-np.multiply.outer(c.gamma_w, d2)) + np.multiply.outer(c.nugget, d2 < SAME_LENGTHS_M2)
    return np.maximum(c.alpha_w - np.einsum("kn,knm,km->k", b, C, b), 0.0)


@pytest.mark.parametrize("spec", [StepSpec("cyclic", 0.175, 0.175), StepSpec("start", 0.0, 0.33),
                                  StepSpec("transition", 0.22, 0.27)])
def test_with_nothing_added_the_variance_is_the_models_own(model, spec):
    type_ = f"{spec.kind}_left"
    z = step_lengths(spec)
    prior = model.type_arrays(type_).alpha_w
    ours = weight_variance(model, type_, np.zeros((0, 2)), z=z).ravel()
    # as fractions of the prior: the variance left is a difference of nearly equal numbers
    np.testing.assert_allclose(ours / prior, direct_weight_variance(model, type_, z) / prior, atol=1e-6)


@pytest.mark.parametrize("spec", [StepSpec("cyclic", 0.175, 0.175), StepSpec("transition", 0.25, 0.3),
                                  StepSpec("stop", 0.4, 0.0)])
def test_the_predictions_eigenbasis_variance_is_the_direct_solves(model, spec):
    """Prediction takes ``b^T C b`` in an eigenbasis (``estimator._weight_solves``), at a new
    step and at a trained one, where the nugget counts."""
    assert_eigenbasis_variance_is_direct(model, spec, atol=1e-8)


@pytest.mark.parametrize("spec", [StepSpec("transition", 0.3, 0.1, end_width=0.12, end_turn=-0.3),
                                  StepSpec("transition", -0.1, 0.25, start_width=-0.03, start_turn=0.2)])
def test_single_precision_eigenbases_keep_the_variance_within_its_floor(omni_model, spec):
    """The step-space model's transitions (278 training steps) keep their eigenbases in single
    precision: the variance stays within the floor every new step's variance is given."""
    assert omni_model.type_arrays("transition_left").solves.basis.dtype == np.float32
    assert_eigenbasis_variance_is_direct(omni_model, spec, atol=VARIANCE_FLOOR)


def assert_eigenbasis_variance_is_direct(model, spec, *, atol):
    type_ = model.trajectory_types(f"{spec.kind}_left")[0]
    c = model.type_arrays(type_)
    z = step_lengths(spec, c.lengths.shape[1])
    _, (variance,) = weight_posterior(c, ((c.lengths - z) ** 2).sum(axis=1)[None])
    prior = c.alpha_w
    np.testing.assert_allclose(np.maximum(variance, 0.0) / prior, direct_weight_variance(model, type_, z) / prior, atol=atol)


def test_adding_a_length_leaves_no_variance_more_anywhere_and_least_there(model):
    grid = candidate_lengths(TRAINED)
    before = np.array([variance_left(model, L, []) for L in grid])
    after = np.array([variance_left(model, L, [0.27]) for L in grid])
    assert np.all(after <= before + 1e-12)
    # what is left there is the step's own variation about the smooth function (nugget and noise)
    assert after[grid.index(0.27)] < 0.05 * before[grid.index(0.27)]
    assert np.argmin(after) == grid.index(0.27)


def test_candidates_lie_on_the_grid_inside_the_range_off_trained_and_held_out_lengths():
    grid = candidate_lengths(TRAINED, exclude=[0.17, 0.175])
    assert grid[0] == pytest.approx(0.16) and grid[-1] == pytest.approx(0.39)
    assert not any(np.isclose(grid, x).any() for x in [*TRAINED, 0.17])
    assert np.allclose(np.round(np.array(grid) / 0.01), np.array(grid) / 0.01)


def test_the_first_pick_is_where_the_model_is_least_certain(model):
    grid = candidate_lengths(TRAINED)
    scores = [variance_left(model, L, []) for L in grid]
    (first, score), = pick_uncertain(model, TRAINED, 1)
    assert first == grid[int(np.argmax(scores))] and score == pytest.approx(max(scores))
    # and the second is where the most is left once the first is known
    (_, _), (second, _) = pick_uncertain(model, TRAINED, 2)
    left = {L: variance_left(model, L, [first]) for L in grid if first != L}
    assert second == max(left, key=left.get)


def test_greedy_picks_are_distinct_and_each_no_more_certain_than_the_next(model):
    picks = pick_uncertain(model, TRAINED, 4)
    lengths, scores = zip(*picks)
    assert len(set(lengths)) == 4
    # the variance only falls as lengths are added, so each pick's score bounds the next one's
    assert np.all(np.diff(scores) <= 1e-12)
    assert picks == pick_uncertain(model, TRAINED, 4)


def test_the_uniform_baseline_spreads_its_lengths_evenly():
    assert pick_uniform(TRAINED, 2) == pytest.approx([0.23, 0.32])
    assert pick_uniform(TRAINED, 2, exclude=[0.23]) == pytest.approx([0.24, 0.32])


@pytest.mark.parametrize(("budget", "words"), [(0, "at least 1"), (-2, "at least 1"), (21, "at most 20"),
                                               (1.5, "whole number"), (True, "whole number")])
def test_a_budget_it_cannot_spend_is_refused(budget, words):
    with pytest.raises(Error, match=words):
        check_budget(budget, TRAINED)


@pytest.mark.slow
def test_the_models_walk_lies_on_the_warm_up_walks_knots_from_rest_to_its_footsteps(robot):
    import pinocchio as pin

    from cocomopl.gait import foot_separation
    from cocomopl.ocp.problems import landing_point, state_count
    from cocomopl.ocp.refine import walk_guess, warm_start
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.ocp.solve import warm_up_plan
    from cocomopl.pipeline import generate_walk
    from cocomopl.requests import StraightSteps, WalkRequest

    settings, length = OCPSettings(), 0.23
    plan = warm_up_plan(robot, length, settings)
    xs, us = warm_start(robot, walk_guess(robot, generate_walk(WalkRequest(StraightSteps([length] * 4))).motion), plan.phases, x0=plan.x0,
                        dt=settings.dt)
    assert len(xs) == state_count(plan.phases) and len(us) == len(xs) - 1
    np.testing.assert_array_equal(xs[0], plan.x0)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, xs[-1][: robot.model.nq])
    end, separation = landing_point(plan.phases)[0], foot_separation(robot)
    for side, y in (("right", 0.0), ("left", separation)):  # a stop ends with the feet side by side
        np.testing.assert_allclose(data.oMf[robot.foot_frames[side]].translation[:2], [end, y], atol=0.01, err_msg=side)


@pytest.mark.slow
def test_steps_known_from_the_dataset_being_grown_are_not_solved_again(small_dataset, tmp_path):
    from cocomopl.dataset.generate import generate
    from cocomopl.motion_file import read_motions

    motions, _ = read_motions(small_dataset, dataset=True)
    known = {m.steps[0]: m for m in motions.values() if m.steps[0].swing_side == "left"}
    summary = generate(tmp_path / "again.h5", (SMALL_LENGTH,), settings=SMALL, workers=1, progress=False, known=known,
                       record={"grown": {"picked_mm": []}})
    assert summary["solved"] == 0 and summary["failed"] == []
    again, attrs = read_motions(tmp_path / "again.h5", dataset=True)
    assert sorted(again) == sorted(motions) and attrs["grown"] == {"picked_mm": []}
    for name, motion in motions.items():
        np.testing.assert_array_equal(again[name].q, motion.q)


@pytest.mark.slow
@pytest.mark.parametrize("budget", ["0", "1000000"])
def test_a_bad_budget_gets_one_line_and_writes_nothing(tmp_path, budget):
    out = tmp_path / "grown.h5"
    assert_one_line_error(run_cli("dataset", "grow", "--budget", budget, "--out", str(out)), "budget")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_held_out_steps_that_are_not_probes_are_refused(tmp_path):
    out = tmp_path / "grown.h5"
    result = run_cli("dataset", "grow", "--budget", "1", "--held-out", str(BUNDLED_DATASET), "--out", str(out))
    assert_one_line_error(result, "held-out steps")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_missing_model_file_is_refused(small_dataset, tmp_path):
    out = tmp_path / "grown.h5"
    result = run_cli("dataset", "grow", str(small_dataset), "--model", str(tmp_path / "missing.npz"), "--budget", "1",
                     "--out", str(out))
    assert_one_line_error(result, "missing.npz")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_model_of_another_robot_is_refused_before_any_solving(tmp_path):
    from cocomopl.primitives.model_file import save_model

    other = tmp_path / "other.npz"
    model = load_model(BUNDLED_MODEL)
    save_model(other, model, {**model.metadata_, "robot": "romeo"})
    out = tmp_path / "grown.h5"
    assert_one_line_error(run_cli("dataset", "grow", "--model", str(other), "--budget", "1", "--out", str(out)),
                          "not trained on")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.npz"]


@pytest.mark.slow
def test_the_neighbours_oc_walk_lies_on_the_warm_up_walks_knots(robot, small_dataset):
    """Continuation's guess: the dataset's start, cyclic and stop steps of a trained length,
    chained, mapped onto the knots of the warm-up walk of a new length."""
    import pinocchio as pin

    from cocomopl.jobs import neighbour_walk
    from cocomopl.motion_file import read_motions
    from cocomopl.ocp.problems import landing_point, state_count
    from cocomopl.ocp.solve import warm_up_plan

    motions, attrs = read_motions(small_dataset, dataset=True)
    xs, us = neighbour_walk(robot, motions, attrs["settings"], neighbour=SMALL_LENGTH, length=SMALL_LENGTH, settings=SMALL)
    plan = warm_up_plan(robot, SMALL_LENGTH, SMALL)
    assert len(xs) == state_count(plan.phases) and len(us) == len(xs) - 1
    np.testing.assert_array_equal(xs[0], plan.x0)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, xs[-1][: robot.model.nq])
    # the same length: the chained OC steps end exactly where the warm-up walk must
    end = landing_point(plan.phases)[0]
    np.testing.assert_allclose(data.oMf[robot.foot_frames["right"]].translation[:2], [end, 0.0], atol=1e-3)


def test_an_unknown_warm_start_is_refused():
    from cocomopl.jobs import grow_dataset

    with pytest.raises(Error, match="warm start must be one of model, neighbour"):
        grow_dataset("never.h5", budget=1, warm_start="kinematic")
