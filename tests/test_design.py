"""The step-space design: footsteps and pairs spread over every step the footstep range allows."""

import math
import subprocess
import sys

import numpy as np
import pytest

from cocomopl.dataset.design import (
    allowed_footsteps,
    farthest_points,
    is_allowed,
    nearest_neighbour_path,
    parse_step_space,
    step_space_design,
    transition_points,
)
from cocomopl.dataset.generate import generate, reusable_steps
from cocomopl.dataset.plan import training_specs
from cocomopl.errors import Error
from cocomopl.gait import FOOTSTEP_METRIC, FOOTSTEP_RANGE
from cocomopl.jobs import check_dataset_file
from cocomopl.motion import Footstep
from cocomopl.motion_file import read_motions
from cocomopl.provenance import file_identity
from cocomopl.robot import Robot

from conftest import SMALL, SMALL_LENGTH, TURNED, run_cli

FEW = 256  # Sobol candidates: the bundled design's 2048 take 10 s to check


@pytest.fixture(scope="module")
def robot():
    return Robot("talos")


@pytest.fixture(scope="module")
def design(robot):
    return step_space_design(robot, footsteps=16, pairs=30, candidates=FEW)


def test_every_footstep_is_allowed_and_both_signs_are_covered(robot, design):
    assert len(design.footsteps) == 16 and len(set(design.footsteps)) == 16
    assert all(is_allowed(robot, f) for f in design.footsteps)
    values = np.array(design.footsteps)
    for column in range(3):
        assert values[:, column].min() < 0 < values[:, column].max()


def test_maximin_reaches_the_corners_of_the_range(design):
    values = np.array(design.footsteps)
    for column, key in enumerate(("length", "width", "turn")):
        low, high = FOOTSTEP_RANGE[key]
        assert values[:, column].min() == pytest.approx(low, abs=1e-3)
        assert values[:, column].max() == pytest.approx(high, abs=1e-3)


def test_pairs_are_distinct_and_join_designed_footsteps(design):
    unordered = {frozenset(pair) for pair in design.pairs}
    consecutive = {frozenset(pair) for pair in zip(design.footsteps, design.footsteps[1:])}
    assert len(unordered) == len(design.pairs) == 30
    assert not unordered & consecutive
    assert all(a in design.footsteps and b in design.footsteps and a != b for a, b in design.pairs)


def test_a_larger_design_keeps_a_smaller_one(robot, design):
    """Farthest-point picks are greedy, so a larger design reuses every OCP of a smaller one."""
    larger = step_space_design(robot, footsteps=16, pairs=45, candidates=FEW)
    assert larger.footsteps == design.footsteps
    assert {frozenset(p) for p in design.pairs} <= {frozenset(p) for p in larger.pairs}
    more = step_space_design(robot, footsteps=20, pairs=0, candidates=FEW)
    assert set(design.footsteps) <= set(more.footsteps)


def test_the_training_specs_solve_each_pair_both_ways(design):
    specs = training_specs(design.footsteps, design.pairs)
    kinds = [s.kind for s in specs]
    assert kinds.count("cyclic") == kinds.count("start") == kinds.count("stop") == 16
    assert kinds.count("transition") == 2 * (15 + 30)


def test_maximin_fills_the_step_space_better_than_random_draws(robot, design):
    """The largest gap from an allowed transition to the design's transitions, against a
    random design of the same size."""
    drawn = allowed_footsteps(robot, 600, seed=99) * FOOTSTEP_METRIC
    steps = np.hstack([drawn[:300], drawn[300:]])

    def fill(d):
        points = transition_points(list(zip(d.footsteps, d.footsteps[1:])) + list(d.pairs))
        return max(np.linalg.norm(points - step, axis=1).min() for step in steps)

    random = step_space_design(robot, footsteps=16, pairs=30, sampling="random", seed=5)
    assert fill(design) < fill(random)


def test_random_designs_are_seeded(robot):
    a = step_space_design(robot, footsteps=6, pairs=4, sampling="random", seed=3)
    b = step_space_design(robot, footsteps=6, pairs=4, sampling="random", seed=3)
    c = step_space_design(robot, footsteps=6, pairs=4, sampling="random", seed=4)
    assert a == b and a.footsteps != c.footsteps
    assert a.record == {"design": {"sampling": "random", "seed": 3, "footsteps": 6, "pairs": 4}}


def test_allowed_footsteps_are_uniform_over_the_allowed_range(robot):
    drawn = allowed_footsteps(robot, 400, seed=1)
    assert all(is_allowed(robot, f) for f in drawn[:50])
    for column, key in enumerate(("length", "width", "turn")):
        low, high = FOOTSTEP_RANGE[key]
        assert low <= drawn[:, column].min() and drawn[:, column].max() <= high
        assert (drawn[:, column] < 0).mean() > 0.1 and (drawn[:, column] > 0).mean() > 0.1


def test_farthest_points_on_a_line_halve_the_gaps():
    points = np.linspace(0.0, 1.0, 101)[:, None]
    assert sorted(float(points[i, 0]) for i in farthest_points(points, 3, 0)) == [0.0, 0.5, 1.0]


def test_straight_lengths_are_swept_in_increasing_order():
    assert nearest_neighbour_path([0.3, 0.15, 0.25, 0.2]) == [Footstep(x) for x in (0.15, 0.2, 0.25, 0.3)]


@pytest.mark.parametrize("text", ["40", "40/x", "1/5", "4/-1", "4/5/6", ""])
def test_bad_step_spaces_are_refused(text):
    with pytest.raises(Error, match="step space"):
        parse_step_space(text)


@pytest.mark.slow  # starts the command line
def test_the_command_line_refuses_a_bad_step_space(tmp_path):
    out = tmp_path / "d.h5"
    run = subprocess.run([sys.executable, "-m", "cocomopl", "dataset", "generate", "--step-space=3/x", "--out", str(out)],
                         capture_output=True, text=True)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.strip().splitlines()[-1].startswith("cocomopl: error:") and "step space" in run.stderr
    assert not out.exists()


def test_rounding_keeps_names_exact(design):
    for f in design.footsteps:
        assert round(f.length * 1000) == pytest.approx(f.length * 1000, abs=1e-9)
        assert round(math.degrees(f.turn), 1) == pytest.approx(math.degrees(f.turn), abs=1e-9)


@pytest.mark.slow  # shares the small and turning datasets (about 2 minutes on 2 cores), then solves 2 OCPs
def test_a_pair_of_unrelated_footsteps_is_solved_both_ways_and_passes_the_checks(robot, small_dataset, turning_dataset,
                                                                                  tmp_path):
    """A design joins footsteps of no common gait: a straight one and one turned 15 degrees,
    each solved before (the tests' shared sets), here joined by their two transitions."""
    known = {}
    for path in (small_dataset, turning_dataset):
        motions, _ = read_motions(path, dataset=True)
        known |= {m.steps[0]: m for m in motions.values() if m.steps[0].swing_side == "left"}
    straight, design = Footstep(SMALL_LENGTH), {"design": {"sampling": "test", "seed": 0, "footsteps": 2, "pairs": 1}}
    out = tmp_path / "pair.h5"
    summary = generate(out, (straight, TURNED), ((straight, TURNED),), settings=SMALL, workers=2, known=known,
                       command="pytest", progress=False, record=design)
    assert summary["failed"] == [] and summary["solved"] == 2 and summary["reused"] == 6
    motions, attrs = read_motions(out, dataset=True)
    assert attrs["design"] == design["design"]
    assert sum(name.startswith("transition_") for name in motions) == 4  # both ways, and mirrored
    report = check_dataset_file(out)
    assert report.ok, report.failures


@pytest.mark.slow  # shares the small dataset
def test_a_run_reuses_a_datasets_steps_and_solves_none_again(robot, small_dataset, tmp_path):
    known = reusable_steps(small_dataset, SMALL, robot)
    assert {spec.swing_side for spec in known} == {"left"}
    out = tmp_path / "again.h5"
    record = {"reused_from": [file_identity(small_dataset)]}  # as generate_dataset(reuse=...) records it
    summary = generate(out, (SMALL_LENGTH,), settings=SMALL, workers=1, known=known, command="pytest", progress=False,
                       record=record)
    assert summary["solved"] == 0 and summary["reused"] == len(known) and summary["failed"] == []
    again, attrs = read_motions(out, dataset=True)
    assert attrs["reused_from"] == record["reused_from"]
    before, _ = read_motions(small_dataset, dataset=True)
    assert sorted(again) == sorted(before)
    for name, motion in before.items():
        np.testing.assert_array_equal(again[name].q, motion.q)


@pytest.mark.slow  # shares the small dataset
def test_reusing_a_dataset_of_other_settings_is_refused_in_one_line(small_dataset, tmp_path):
    out = tmp_path / "d.h5"
    result = run_cli("dataset", "generate", "--lengths-mm", "200", "--reuse", str(small_dataset), "--out", str(out))
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and f"cannot reuse {small_dataset}: it was solved with other OCP settings" in lines[0]
    assert not out.exists() and not out.with_name(out.name + ".parts").exists()
