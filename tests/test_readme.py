"""The README's examples run, so none of them can go stale.

Every line that starts with ``cocomopl`` in a ```bash block of README.md runs, in order, in
one fresh folder (later lines read the files earlier ones wrote), and must exit 0; a line
with ``--json`` must print one JSON object.  The ```python block runs too, in the same
folder.  The examples that take minutes are shrunk, each by one rule of ``SHRINK``:

* ``cocomopl dataset generate``: one step length, 200 mm (its start, cyclic and stop
  steps), on 50 ms knots without the knee bend and load transfer (as tests/conftest.py's
  small dataset);
* ``cocomopl train``: one candidate, 3 primitives and the RBF kernel, 2 iterations;
* the Python block: ``max_iterations=2`` for the fit.

Everything else runs exactly as written.
"""

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).parents[1] / "README.md"

SHRINK = {
    ("dataset", "generate"): ["--lengths-mm", "200", "--dt", "0.05", "--load-transfer-weight", "0",
                              "--min-knee-flexion-rad", "0"],
    ("train",): ["--primitives", "3", "--kernels", "rbf", "--max-iterations", "2"],
}
PYTHON_SHRINK = (r"max_iterations=\d+", "max_iterations=2")


def blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", README.read_text(), flags=re.M | re.S)


def commands() -> list[list[str]]:
    """The README's ``cocomopl`` command lines, as argument lists (comments dropped)."""
    lines = [line for block in blocks("bash") for line in block.splitlines() if line.startswith("cocomopl ")
             or line.strip() == "cocomopl"]
    return [shlex.split(line, comments=True) for line in lines]


def shrunk(args: list[str]) -> list[str]:
    """``args`` with the shrink rule of its command applied (later options win in argparse)."""
    for prefix, extra in SHRINK.items():
        if tuple(args[1 : 1 + len(prefix)]) == prefix:
            return args + extra
    return args


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("readme")


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[1])}
    return subprocess.run(args, capture_output=True, text=True, cwd=cwd, env=env, timeout=600)


def test_the_readme_has_examples():
    assert len(commands()) >= 10 and blocks("python")


@pytest.mark.slow
@pytest.mark.parametrize("args", commands(), ids=lambda a: " ".join(a[:4]))
def test_command_example_runs(args, folder):
    result = run([sys.executable, "-m", "cocomopl", *shrunk(args)[1:]], folder)
    assert result.returncode == 0, f"{shlex.join(args)} exited {result.returncode}: {result.stderr[-2000:]}"
    if "--json" in args:
        assert isinstance(json.loads(result.stdout), dict)


@pytest.mark.slow
def test_python_example_runs(folder):
    code = re.sub(*PYTHON_SHRINK, "\n".join(blocks("python")))
    result = run([sys.executable, "-c", code], folder)
    assert result.returncode == 0, result.stderr[-2000:]
