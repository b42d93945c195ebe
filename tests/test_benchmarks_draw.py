"""``benchmarks/random_walks.py --footsteps`` draws its walks as a user may write them: every
footstep over the whole allowed range, each parameter of either sign, each step's start and end
footsteps independent, and each walk's footstep file reads back, as ``cocomopl walk --footsteps``
reads it, to the footsteps drawn.  Run through the benchmark's command line (``--dry-run``: the
walks are drawn and written, not generated)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cocomopl.gait import FOOTSTEP_RANGE, check_footstep
from cocomopl.planning.footsteps import landing_footsteps, read_landings

pytestmark = pytest.mark.slow  # the benchmark runs in a new process

BENCHMARK = Path(__file__).parents[1] / "benchmarks" / "random_walks.py"
PARAMETERS = ("length", "width", "turn")


def dry_run(*args: str) -> dict:
    result = subprocess.run([sys.executable, str(BENCHMARK), "--footsteps", "--dry-run", "--json", *args],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


@pytest.fixture(scope="module")
def drawn(tmp_path_factory) -> dict:
    """20 walks of 10 footsteps, seed 0, their footstep files kept."""
    folder = tmp_path_factory.mktemp("footsteps")
    return dry_run("--n", "20", "--steps", "10", "--seed", "0", "--footstep-dir", str(folder))


def footsteps_of(walks: list[dict]) -> np.ndarray:
    return np.array([w["footsteps"] for w in walks])  # (walks, steps, 3): length, width (m), turn (rad)


def test_every_parameter_takes_either_sign_over_its_whole_range(drawn):
    footsteps = footsteps_of(drawn["walks"]).reshape(-1, 3)
    assert len(footsteps) == 200
    for k, name in enumerate(PARAMETERS):
        low, high = FOOTSTEP_RANGE[name]
        values = footsteps[:, k]
        assert (values < 0).sum() >= 10 and (values > 0).sum() >= 10, name
        assert low <= values.min() < low + 0.2 * (high - low), name
        assert high - 0.2 * (high - low) < values.max() <= high, name


def test_every_footstep_is_allowed_for_the_foot_that_takes_it(robot, drawn):
    for walk in drawn["walks"]:
        assert walk["landings"][0]["side"] == walk["first_swing"]
        for footstep, landing in zip(walk["footsteps"], walk["landings"]):
            check_footstep(robot, landing["side"], tuple(footstep))


def test_the_footstep_files_read_back_to_the_footsteps_drawn(robot, drawn):
    for walk in drawn["walks"]:
        read = landing_footsteps(robot, read_landings(walk["footstep_file"]))
        # the stop repeats the last footstep, as a footstep file has it
        np.testing.assert_allclose(np.array(read), np.array([*walk["footsteps"], walk["footsteps"][-1]]), atol=2e-6)


def test_a_steps_start_and_end_footsteps_are_independent(drawn):
    footsteps = footsteps_of(drawn["walks"])
    starts, ends = footsteps[:, :-1].reshape(-1, 3), footsteps[:, 1:].reshape(-1, 3)  # the 180 transitions
    for k, name in enumerate(PARAMETERS):
        assert abs(np.corrcoef(starts[:, k], ends[:, k])[0, 1]) < 0.3, name
        assert (np.sign(starts[:, k]) * np.sign(ends[:, k]) < 0).sum() >= 10, f"{name} seldom changes sign"
    assert np.abs(ends[:, 0] - starts[:, 0]).max() > 0.3  # no limit on the change from step to step
    assert {w["first_swing"] for w in drawn["walks"]} == {"left", "right"}


def test_walks_differ_between_walks_and_seeds(drawn):
    other = dry_run("--n", "2", "--steps", "10", "--seed", "1")
    first = footsteps_of(drawn["walks"])
    assert not np.allclose(first[0], first[1])
    assert not np.allclose(first[:2], footsteps_of(other["walks"]))
