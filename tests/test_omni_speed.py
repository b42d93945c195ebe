"""``benchmarks/omni_speed.py`` refuses what a user can get wrong in one line, exit 2."""

import subprocess
import sys
from pathlib import Path

import pytest

from cocomopl.data import BUNDLED_OMNI_MODEL

from conftest import assert_one_line_error

pytestmark = pytest.mark.slow  # the benchmark runs in a new process

BENCHMARK = Path(__file__).parents[1] / "benchmarks" / "omni_speed.py"


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCHMARK), *args], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("content, words", [(None, ["missing.npz", "not found"]),
                                            (b"not a model", ["junk.npz", "not a readable"])])
def test_a_model_that_is_not_one_is_refused(tmp_path, content, words):
    path = tmp_path / ("missing.npz" if content is None else "junk.npz")
    if content is not None:
        path.write_bytes(content)
    result = run("--model", str(path), "--json")
    assert_one_line_error(result, *words)
    assert result.returncode == 2 and result.stdout == ""


def test_no_walks_is_refused():
    result = run("--walks", "0")
    assert_one_line_error(result, "--walks")
    assert result.returncode == 2


@pytest.mark.parametrize("args, words", [(["--robot", "nobody"], ["nobody", "no bundled"]),
                                         (["--robot", "g1", "--model", str(BUNDLED_OMNI_MODEL)],
                                          ["talos", "not of g1"])])
def test_a_robot_without_models_or_not_the_models_is_refused(args, words):
    result = run(*args, "--json")
    assert_one_line_error(result, *words)
    assert result.returncode == 2 and result.stdout == ""
