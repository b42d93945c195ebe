"""M_opt's machinery: a walk of chained step OCPs, reusing a dataset's steps."""

import numpy as np
import pytest

from cocomopl.analysis.feasibility import check_motion
from cocomopl.dynamics import sole_placements
from cocomopl.gait import sequence_specs
from cocomopl.motion_file import read_motions
from cocomopl.ocp.chained_steps import solve_sequence

from conftest import SMALL, SMALL_LENGTH


@pytest.mark.slow
def test_a_chained_walk_is_one_consistent_motion_on_its_footsteps(robot, small_dataset):
    motions, attrs = read_motions(small_dataset)
    specs = sequence_specs([SMALL_LENGTH] * 3)  # start, cyclic, stop: left, right, left swing
    walk = solve_sequence(robot, specs, motions, settings=attrs["settings"])
    assert [s.name for s in walk.steps] == [s.name for s in specs]
    assert np.all(np.diff(walk.t) >= 0) and len(walk.step_starts) == 3
    report = check_motion(robot, walk, SMALL.friction)
    assert report["inverse_dynamics_residual"] < 1e-6  # also across the junctions
    assert report["zmp_margin"] > 0
    # every step starts where the one before ended: no jump in the configuration
    assert np.abs(np.diff(walk.q[:, :3], axis=0)).max() < 0.05
    # the walk ends with the feet side by side, three step lengths ahead
    soles = sole_placements(robot, walk.q[-1:])[0]
    assert soles[:, 0] == pytest.approx([3 * SMALL_LENGTH] * 2, abs=5e-3)


@pytest.mark.slow
def test_a_missing_transition_is_solved_for_the_robot_given_not_one_rebuilt_by_name(monkeypatch, tmp_path):
    """A robot from a description file whose name is no bundled robot: the transition the
    dataset lacks is solved with that very Robot object."""
    import dataclasses
    import json

    from cocomopl.data import BUNDLED_DATASET
    from cocomopl.motion import StepSpec
    from cocomopl.ocp import chained_steps
    from cocomopl.robot import Robot
    from cocomopl.robot.description import DESCRIPTIONS_DIR

    description = json.loads((DESCRIPTIONS_DIR / "talos.json").read_text()) | {"name": "my_talos"}
    (tmp_path / "my_talos.json").write_text(json.dumps(description))
    robot = Robot(str(tmp_path / "my_talos.json"))
    motions, attrs = read_motions(BUNDLED_DATASET)
    spec = StepSpec("transition", 0.25, 0.35)
    motions.pop(spec.name)
    used = []

    def solve_transition(robot_used, settings, right, *, cyclic_from, cyclic_to):
        used.append(robot_used)
        return dataclasses.replace(cyclic_from, steps=[right]), []

    monkeypatch.setattr(chained_steps, "solve_transition", solve_transition)
    motion = chained_steps.solve_step_motion(robot, spec, motions, settings=attrs["settings"])
    assert used == [robot] and motion.steps == [spec] and motions[spec.name] is motion
