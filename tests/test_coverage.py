"""Coverage of the step space by a model's training steps: distances in the model's inputs."""

import json

import numpy as np
import pytest

from cocomopl.cli import main
from cocomopl.data import BUNDLED_MODEL, BUNDLED_OMNI_MODEL
from cocomopl.errors import Error
from cocomopl.motion import STEP_KINDS, StepSpec
from cocomopl.primitives.coverage import coverage
from cocomopl.primitives.model_file import load_model
from cocomopl.primitives.training import with_step_lengths

pytestmark = pytest.mark.slow  # loads the bundled models (seconds each)

SMALL = {"footsteps": 40, "samples": 300}  # few collision checks: the suite stays fast


@pytest.fixture(scope="module")
def omni():
    return load_model(BUNDLED_OMNI_MODEL)


@pytest.fixture(scope="module")
def straight():
    return load_model(BUNDLED_MODEL)


def training_steps(model) -> list[StepSpec]:
    """Every left-swing training step of the model, rebuilt from its inputs."""
    out = []
    for kind in STEP_KINDS:
        g = model.types.index(model.trajectory_types(f"{kind}_left")[0])
        out += [with_step_lengths(StepSpec(kind, 0.0, 0.0), z) for z in model.lengths_[g][model.mask_[g] > 0]]
    return out


@pytest.mark.parametrize("name", ["straight", "omni"])
def test_training_steps_are_at_distance_zero(name, request):
    model = request.getfixturevalue(name)
    measured = coverage(model, steps=training_steps(model))
    assert measured.seed is None and [k.kind for k in measured.kinds] == list(STEP_KINDS)
    for k in measured.kinds:
        assert k.fill_distance <= 1e-12 and k.in_support == 1.0


def test_distances_and_support_are_those_predict_gives(omni):
    rng = np.random.default_rng(0)
    specs = [StepSpec("transition", *rng.uniform(-0.1, 0.35, 2), side, *rng.uniform(-0.05, 0.16, 2),
                      *rng.uniform(-0.4, 0.4, 2)) for side in ("left", "right") for _ in range(3)]
    specs += [StepSpec("start", 0.0, 0.3, "left", 0.0, 0.1, 0.0, 0.2), StepSpec("stop", 0.12, 0.0, "right", -0.04, 0.0, 0.3),
              StepSpec("cyclic", 0.2, 0.2, "left", 0.05, 0.05, -0.1, -0.1),
              StepSpec("transition", 0.9, -0.5, "left", 0.5, -0.3, 1.2, -1.2)]  # far beyond the range
    for spec in specs:
        step, (measured,) = omni.predict(spec), coverage(omni, steps=[spec]).kinds
        assert measured.fill_distance == pytest.approx(step.distance, abs=1e-12)
        assert measured.in_support == float(step.in_support)
    assert {s.in_support for s in omni.predict_many(specs)} == {True, False}  # both sides of the rule are met


def test_coverage_is_deterministic_for_a_seed(omni, robot):
    first, again, other = (coverage(omni, seed=seed, robot=robot, **SMALL) for seed in (3, 3, 4))
    assert first == again and first != other
    assert [k.kind for k in first.kinds] == list(STEP_KINDS) and first.parameters == 6
    assert first.kind("transition").steps == SMALL["samples"] and first.kind("start").steps == SMALL["footsteps"]
    for k in first.kinds:
        assert 0.0 <= k.in_support <= 1.0
        assert k.fill_distance >= k.p95 >= k.median >= 0.0 and k.support_radius > 0.0
    assert first.fill_distance == max(k.fill_distance for k in first.kinds)
    assert json.loads(json.dumps(first.to_json()))["kinds"]["cyclic"]["steps"] == SMALL["footsteps"]


def test_a_straight_model_is_measured_over_its_lengths(straight):
    measured = coverage(straight, samples=200, seed=1)
    assert [k.kind for k in measured.kinds] == list(STEP_KINDS)
    assert measured.parameters == 2 and measured.footsteps is None
    assert all(k.steps == 200 and 0.0 <= k.in_support <= 1.0 for k in measured.kinds)
    with pytest.raises(Error, match="turns or side-steps"):
        coverage(straight, steps=[StepSpec("cyclic", 0.2, 0.2, "left", 0.05, 0.05)])
    for bad in ({"samples": 0}, {"footsteps": 2.5}, {"steps": []}):
        with pytest.raises(Error):
            coverage(straight, **bad)


def test_model_info_reports_the_coverage(capsys):
    assert main(["model", "info", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)["coverage"]
    assert set(info["kinds"]) == set(STEP_KINDS) and info["parameters"] == 2
    assert info["fill_distance_m"] == max(k["fill_distance_m"] for k in info["kinds"].values())
    assert main(["model", "info"]) == 0
    text = capsys.readouterr().out
    assert "coverage" in text and all(f"  {kind} " in text for kind in STEP_KINDS)
