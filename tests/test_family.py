"""The family check: probe lengths, the bracketing trained steps, the errors it reports, bad input.

The steps of 200 mm in the bundled dataset play the probes, the other lengths the trained
steps around them, so no OCP is solved here.
"""

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives.family import GROUPS, bracket, family_errors, probe_lengths, signal_group_indices
from cocomopl.primitives.model_file import load_model
from cocomopl.primitives.training import load_training_steps

from conftest import assert_one_line_error, run_cli

PROBE = 0.2


@pytest.fixture(scope="module")
def split():
    steps = load_training_steps(BUNDLED_DATASET)
    at_probe = [k for k, s in enumerate(steps.specs) if PROBE in (s.start_length, s.end_length)]
    probes = steps.subset([k for k in at_probe if steps.specs[k].kind in ("cyclic", "start", "stop")])
    trained = steps.subset([k for k in range(len(steps)) if k not in at_probe])
    return steps, probes, trained


def test_probe_lengths_are_the_midpoints():
    assert probe_lengths([0.25, 0.15, 0.2, 0.2]) == [0.175, 0.225]


@pytest.mark.parametrize(("spec", "below", "above"), [
    (StepSpec("cyclic", 0.2, 0.2), StepSpec("cyclic", 0.15, 0.15), StepSpec("cyclic", 0.25, 0.25)),
    (StepSpec("start", 0.0, 0.2), StepSpec("start", 0.0, 0.15), StepSpec("start", 0.0, 0.25)),
    (StepSpec("stop", 0.2, 0.0, "right"), StepSpec("stop", 0.15, 0.0, "right"), StepSpec("stop", 0.25, 0.0, "right")),
])
def test_a_probe_is_bracketed_by_its_kind_and_side_at_the_nearest_lengths(split, spec, below, above):
    _, _, trained = split
    lower, upper, weight = bracket(spec, trained)
    assert (trained.specs[lower], trained.specs[upper]) == (below, above)
    assert weight == pytest.approx(0.5)


def test_a_probe_outside_the_trained_lengths_is_refused(split):
    _, _, trained = split
    with pytest.raises(Error, match="not between two trained steps"):
        bracket(StepSpec("cyclic", 0.45, 0.45), trained)


def test_the_bundled_model_reproduces_steps_it_was_trained_on_within_its_fit(robot, split):
    steps, probes, trained = split
    model = load_model(BUNDLED_MODEL).prepare()  # trained on every step, the probes too
    errors = family_errors(model, probes, trained, groups=signal_group_indices(robot, steps.signal_names))
    assert set(errors["all"]["model"]) == set(GROUPS)
    assert len(errors["steps"]) == len(probes)
    for group in GROUPS:
        assert np.isfinite(errors["all"]["linear"][group]) and errors["all"]["linear"][group] > 0
        # its explained variance is 99.94 % or more in every group: a few mrad (mm), far
        # below the 0.1 rad of a step on another solution branch
        assert errors["all"]["model"][group] < 0.01, group


def test_joint_groups_split_the_joints(robot, split):
    steps, _, _ = split
    groups = signal_group_indices(robot, steps.signal_names)
    joints = np.concatenate([groups["legs"], groups["torso"], groups["arms"]])
    assert sorted(joints) == list(range(robot.nu))
    assert all(steps.signal_names[i].startswith("arm") for i in groups["arms"])


@pytest.mark.slow
@pytest.mark.parametrize("lengths", ["150", "100", "175,450"])
def test_probe_lengths_off_the_trained_range_get_one_line(lengths):
    assert_one_line_error(run_cli("dataset", "family", "--lengths-mm", lengths), "between")


@pytest.mark.slow
def test_a_probes_file_that_cannot_be_written_gets_one_line_naming_its_option(tmp_path):
    result = run_cli("dataset", "family", "--lengths-mm", "175", "--probes-out", str(tmp_path))
    assert_one_line_error(result, "--probes-out", "is a directory")
    assert list(tmp_path.iterdir()) == []
