"""``benchmarks/stabilizer_tuning.py`` on any bundled robot: its tuning sequences scaled onto
the robot's own dataset, and a robot it cannot tune refused in one line."""

import itertools
import subprocess
import sys
from pathlib import Path

import pytest

from cocomopl.data import dataset_path
from cocomopl.motion_file import read_motions
from cocomopl.robot import Robot

from conftest import assert_one_line_error

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
from stabilizer_tuning import TUNING, scaled_mm

BENCHMARK = Path(__file__).parents[1] / "benchmarks" / "stabilizer_tuning.py"


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_the_scaled_sequences_step_only_between_the_robots_trained_lengths(name):
    """The OC walks of a sequence chain the dataset's own steps: every length is a trained
    one, and each change of length is one the dataset holds a transition for."""
    robot = Robot(name)
    dataset, _ = read_motions(dataset_path(robot=name), dataset=True)
    kinds = {(spec.kind, round(spec.start_length, 3), round(spec.end_length, 3))
             for motion in dataset.values() for spec in motion.steps}
    for talos_mm in TUNING.values():
        mm = scaled_mm(robot, talos_mm)
        assert name != "talos" or mm == talos_mm
        for a, b in itertools.pairwise(mm):
            kind = "cyclic" if a == b else "transition"
            assert (kind, a / 1000, b / 1000) in kinds, (name, a, b)


@pytest.mark.parametrize("robot, words", [("nobody", ["nobody", "unknown robot"]),
                                          ("romeo", ["romeo", "no bundled"])])
def test_a_robot_without_bundled_data_is_refused(robot, words):
    result = subprocess.run([sys.executable, str(BENCHMARK), "--robot", robot, "--json"], capture_output=True,
                            text=True, timeout=120)
    assert_one_line_error(result, *words)
    assert result.returncode == 2 and result.stdout == ""
