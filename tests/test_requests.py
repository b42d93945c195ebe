"""Walk requests that cannot be built wrong, and typed results whose JSON is the commands'."""

import dataclasses
import json
import math

import pytest

from cocomopl.analysis.metrics import WalkMetrics
from cocomopl.errors import Error
from cocomopl.planning.footsteps import Landing
from cocomopl.requests import Commands, Footsteps, Goals, Refinement, StraightSteps, WalkRequest
from cocomopl.results import GoalErrors, RefineReport, RefineSummary, SimulateReport, SimulationRecord

from conftest import run_cli


def test_a_goal_walk_reaims_by_default_and_any_other_walk_does_not():
    goal = Goals([(1.0, 0.5, math.radians(90))])
    assert WalkRequest(goal).replanner == "reaim"
    assert WalkRequest(goal, refinement=Refinement()).replanner == "none"
    assert WalkRequest(StraightSteps([0.25, 0.25])).replanner == "none"
    assert WalkRequest(Footsteps([Landing(0.0, 0.1, 0.0, "left")])).replanner == "none"
    assert WalkRequest(goal, replanner="recover").replanner == "recover"


@pytest.mark.parametrize("build, words", [
    (lambda: WalkRequest(Goals([(1, 0, 0)]), replanner="reaim", refinement=Refinement()), ["re-aiming", "--refine"]),
    (lambda: WalkRequest(Goals([(1, 0, 0)]), replanner="recover", refinement=Refinement()), ["recovery", "--refine"]),
    (lambda: WalkRequest(Goals([(1, 0, 0)]), replanner="twice"), ["replanner", "'twice'"]),
    (lambda: WalkRequest([0.25, 0.25]), ["StraightSteps, Footsteps, Goals or Commands", "list"]),
    (lambda: WalkRequest(StraightSteps([0.25, 0.25]), dt=0.5), ["--dt 0.5 s", "0.01 to 0.05"]),
    (lambda: StraightSteps([0.25, 0.25], first_swing="middle"), ["first swing", "'middle'"]),
    (lambda: Goals([]), ["goals"]),
    (lambda: Goals([(1.0, float("nan"), 0.0)]), ["three finite numbers"]),
    (lambda: Footsteps([]), ["at least one landing"]),
    (lambda: Commands([]), ["four finite numbers"]),
    (lambda: Commands([(0, 0.1, 0, 0), (0, 0, 0, 0)]), ["times must increase"]),
    (lambda: Commands([(0, 0.1, 0, 0)]), ["last command must be a stop"]),
    (lambda: WalkRequest(Commands([(0, 0.1, 0, 0), (2, 0, 0, 0)]), refinement=Refinement()), ["streamed", "--refine"]),
    (lambda: Refinement(warm_start="neighbour"), ["'neighbour'", "interpolated"]),
])
def test_options_that_exclude_each_other_cannot_be_built(build, words):
    with pytest.raises(Error) as refused:
        build()
    assert all(word in str(refused.value) for word in words), str(refused.value)


def test_a_request_names_its_inputs_bundled_by_kind():
    from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL, BUNDLED_OMNI_DATASET, BUNDLED_OMNI_MODEL

    assert WalkRequest(StraightSteps([0.25, 0.25])).inputs() == [BUNDLED_MODEL]
    refined = WalkRequest(Goals([(1, 0, 0)]), refinement=Refinement())
    assert refined.inputs() == [BUNDLED_OMNI_MODEL, BUNDLED_OMNI_DATASET]
    assert WalkRequest(StraightSteps([0.25, 0.25]), refinement=Refinement()).dataset_file() == BUNDLED_DATASET


def test_a_result_prints_its_fields_in_order_with_parts_spliced_and_absent_ones_left_out():
    summary = RefineSummary(steps=["start_250_L"], warm_start="interpolated", guess=["start_250_L"], iterations=[3],
                            converged=[True], fallback=[None], cost=[1.0], iterations_median=3, refine_s=1.5,
                            raw_cost_ratio=1.2, dataset="dataset.h5")
    report = RefineReport(output="r.h5", summary=summary)
    assert list(report.to_json()) == ["output", "steps", "warm_start", "guess", "iterations", "converged", "fallback",
                                      "cost", "iterations_median", "refine_s", "raw_cost_ratio", "dataset"]
    assert report.exit_code == 0 and report.to_table().endswith("wrote r.h5")
    record = SimulationRecord(stabilizer=True, stabilizer_gains=None, feedforward=False, sim_model=None, servos=None,
                              contact_time_constant_s=0.02, reference_cutoff_hz=20.0)
    names = [f.name for f in dataclasses.fields(WalkMetrics)]
    fell = SimulateReport(output="m.h5", simulation=record, metrics=WalkMetrics(**dict.fromkeys(names, 1.0) | {"fell": True}))
    assert list(fell.to_json()) == ["output", "stabilizer", "stabilizer_gains", "feedforward", "sim_model", "servos",
                                    "contact_time_constant_s", "reference_cutoff_hz", *names]
    assert fell.exit_code == 1
    assert "waypoints" not in GoalErrors(goal={"x_m": 1.0}).to_json()


@pytest.mark.slow
def test_generate_json_is_the_result_of_the_api(tmp_path):
    """The command prints the API's result as it is, footsteps of a goal walk included."""
    result = run_cli("generate", "--to", "-0.3,0.1,-20", "--json", "--out", str(tmp_path / "w.h5"))
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    assert list(payload)[:3] == ["output", "steps", "n_steps"] and payload["footsteps"] and "refine" not in payload
    assert payload["n_steps"] == len(payload["steps"])
