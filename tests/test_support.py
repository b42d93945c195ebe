"""The model's training support: the planner plans only steps inside it, and every walk's steps
(step lengths, footstep files) are checked against it, a step outside warned about by name or,
with --strict, refused.

The out-of-support steps are found from the model when the test runs, so the tests hold for
whichever bundled model ships."""

from __future__ import annotations

import itertools
import math
import re
import warnings
from collections.abc import Iterator

import numpy as np
import pytest

from cocomopl.data import BUNDLED_MODEL, BUNDLED_OMNI_MODEL, model_path
from cocomopl.errors import Error
from cocomopl.gait import FOOTSTEP_RANGE, check_footstep
from cocomopl.motion import Footstep
from cocomopl.pipeline import generate_walk, plan_in_support
from cocomopl.planning import goal as goal_planner
from cocomopl.planning.footsteps import footstep_specs, landings_of, read_landings, walk_specs, write_landings
from cocomopl.primitives.model_file import load_model
from cocomopl.requests import Footsteps, WalkRequest
from cocomopl.robot import Robot
from cocomopl.synthesis.step_chain import OutOfSupportWarning, generate_steps, outside_support

from conftest import assert_one_line_error, run_cli


def _allowed(robot, footstep: Footstep) -> bool:
    try:
        for side in ("left", "right"):
            check_footstep(robot, side, footstep)
    except Error:
        return False
    return True


def _walks(robot, straight: bool) -> Iterator[list[list[Footstep]]]:
    """Footstep walks to search for a step outside a model's support, in two groups: one
    footstep (a start and a stop) for each footstep of a grid over the robot's range, then a
    transition between two of them."""
    axes = [np.linspace(lo, hi, 5) for lo, hi in FOOTSTEP_RANGE.values()]
    if straight:  # a straight model: its shortest steps lie furthest from its trained lengths
        axes = [np.linspace(0.02, 0.14, 7), [0.0], [0.0]]
    grid = [Footstep(*(round(float(v), 4) for v in values)) for values in itertools.product(*axes)]
    grid = [f for f in grid if _allowed(robot, f)]
    yield [[f] for f in grid]
    yield [[a, b] for a, b in itertools.permutations(grid[::3], 2)]


@pytest.fixture(scope="module")
def omni_model():
    return load_model(BUNDLED_OMNI_MODEL).prepare()


@pytest.fixture(scope="module")
def outside(robot, omni_model, tmp_path_factory):
    """A footstep file whose walk has a step outside its model's support: the bundled
    omnidirectional model's if some allowed walk has one, else the straight model's (trained on
    150-400 mm: far shorter steps lie outside).  Returns the model file, the footstep file, the
    model and the walk's steps as the model predicts them."""
    for model_file, straight in ((BUNDLED_OMNI_MODEL, False), (BUNDLED_MODEL, True)):
        model = omni_model if model_file == BUNDLED_OMNI_MODEL else load_model(model_file).prepare()
        for group in _walks(robot, straight):
            walks = [footstep_specs(footsteps, "left") for footsteps in group]
            predicted = model.predict_many([spec for walk in walks for spec in walk])
            for walk, end in zip(walks, np.cumsum([len(walk) for walk in walks])):
                if not all(step.in_support for step in predicted[end - len(walk):end]):
                    path = tmp_path_factory.mktemp("support") / "footsteps.csv"
                    write_landings(path, landings_of(robot, walk))
                    # the walk as the file gives it (to a micrometre)
                    return model_file, path, model, model.predict_many(walk_specs(robot, read_landings(path)))
    raise AssertionError("neither bundled model has a step outside its support on the grid")


def _named(model, steps) -> list[tuple[str, str]]:
    """Per step outside the support: the words its warning must hold (its number and name, and
    its distance against the support radius)."""
    return [(f"step {number} ({step.spec.name}): ", outside_support(model, step))
            for number, step in enumerate(steps, start=1) if not step.in_support]


@pytest.mark.slow  # loads the bundled models
def test_outside_support_says_the_distance_and_the_radius(outside):
    _, _, model, steps = outside
    step = next(step for step in steps if not step.in_support)
    distance, radius = (float(x) for x in re.findall(r"(\d+) mm", outside_support(model, step)))
    assert distance == round(1000 * step.distance) and distance >= radius


@pytest.mark.slow  # loads the bundled models
def test_each_step_outside_gets_one_warning_naming_it(robot, outside):
    _, path, model, steps = outside
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        generate_steps(model, walk_specs(robot, read_landings(path)))
    said = [str(w.message) for w in caught if issubclass(w.category, OutOfSupportWarning)]
    expected = _named(model, steps)
    assert len(said) == len(expected)
    for message, (name, distance) in zip(said, expected):
        assert message.startswith(name) and distance in message and "rad" in message
    with pytest.raises(Error, match=re.escape(f"refused (--strict): {expected[0][0]}")):
        generate_steps(model, walk_specs(robot, read_landings(path)), strict=True)


@pytest.mark.slow  # generates and places a walk
def test_a_footstep_walk_carries_its_warnings(robot, outside):
    model_file, path, model, steps = outside
    walk = generate_walk(WalkRequest(Footsteps(read_landings(path)), model=model_file))
    expected = _named(model, steps)
    named = [w for w in walk.warnings if "from the nearest training step" in w]
    assert [w.split(": ")[0] + ": " for w in named] == [name for name, _ in expected]
    with pytest.raises(Error, match=re.escape(expected[0][0])):
        generate_walk(WalkRequest(Footsteps(read_landings(path)), model=model_file, strict=True))


@pytest.mark.slow  # runs the command line
def test_generate_warns_about_a_footstep_file_and_strict_refuses_it(outside, tmp_path):
    model_file, path, model, steps = outside
    expected = _named(model, steps)
    out = tmp_path / "walk.h5"
    result = run_cli("generate", "--model", str(model_file), "--footsteps", str(path), "--out", str(out))
    assert result.returncode == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if "from the nearest training step" in line]
    assert len(warned) == len(expected)
    for line, (name, distance) in zip(warned, expected):
        assert line.startswith(f"cocomopl: warning: {name}") and distance in line
    refused_out = tmp_path / "refused.h5"
    refused = run_cli("generate", "--model", str(model_file), "--footsteps", str(path), "--out", str(refused_out),
                      "--strict")
    assert refused.returncode == 2
    assert_one_line_error(refused, "cocomopl: error: refused (--strict)", *expected[0])
    assert not refused_out.exists()


@pytest.mark.slow  # plans six walks
@pytest.mark.parametrize("x, y, yaw_deg", [(0.8, 0.3, 30), (-0.4, -0.2, -30), (-0.3, 0.4, -90), (0.3, -0.6, -45),
                                           (-0.6, 0.0, 0), (0.0, -0.4, 0)])
def test_the_planner_plans_steps_inside_the_support(robot, omni_model, x, y, yaw_deg):
    specs = plan_in_support(robot, omni_model, [(x, y, math.radians(yaw_deg))])
    assert all(step.in_support for step in omni_model.predict_many(specs))


@pytest.mark.slow  # plans three walks on G1's bundled omnidirectional model
@pytest.mark.parametrize("x, y, yaw_deg", [(1.0, 0.5, 90), (-0.5, 0.0, 0), (0.0, -0.4, 0)])
def test_g1s_planner_plans_steps_inside_its_own_models_support(x, y, yaw_deg):
    """G1's footsteps are its own (a range scaled to its legs): its bundled model is the one
    the plans are held to, and every planned step is inside that model's support."""
    g1 = Robot("g1")
    model = load_model(model_path(omni=True, robot="g1")).prepare()
    specs = plan_in_support(g1, model, [(x, y, math.radians(yaw_deg))])
    assert all(_allowed(g1, spec.end_footstep) for spec in specs if spec.kind != "stop")
    assert all(step.in_support for step in model.predict_many(specs))


@pytest.mark.slow  # loads the bundled omnidirectional model
def test_a_goal_no_plan_in_the_support_reaches_is_refused(robot, monkeypatch):
    """A model that trusts its training steps only (support radius 0): every plan in its range
    has a step outside its support, so the goal is refused, naming it and the nearest plan's
    step; there is no --strict for it to depend on."""
    monkeypatch.setattr(goal_planner, "MAX_LANDINGS", 6)  # every plan is refused: try few
    model = load_model(BUNDLED_OMNI_MODEL)
    model.support_radius_ = np.zeros_like(model.support_radius_)
    model.prepare()
    with pytest.raises(Error) as refused:
        plan_in_support(robot, model, [(0.53, 0.07, math.radians(17.0))])
    message = str(refused.value)
    assert "\n" not in message
    assert message.startswith("no walk within the model's support reaches the goal (0.53 m, 0.07 m, 17 deg): ")
    assert re.search(r"the nearest plan in its footstep range has step \d+ \([^)]+\) \d+ mm from the nearest "
                     r"training step of its type, support radius 0 mm$", message), message
    with pytest.raises(Error, match=r"reaches goal 1 of 2 \(0.53 m, 0.07 m, 17 deg\): "):
        plan_in_support(robot, model, [(0.53, 0.07, math.radians(17.0)), (1.0, 0.3, math.radians(20.0))])
