"""The README's examples run, so none of them can go stale.

Every line that starts with ``cocomopl`` in a ```bash block of README.md runs, in order, in
one fresh folder (later lines read the files earlier ones wrote), and must exit 0; a line
with ``--json`` runs in a new interpreter, as a user runs it, and must print one JSON object
on its standard output; the other lines run through the command's entry point in the test's
process (``conftest.run_cli``), and the ```python block in a new interpreter.  The examples
that take minutes are shrunk or skipped:

* ``cocomopl dataset generate`` is skipped: the bundled dataset, which the same command made
  with the default lengths, is copied to its ``--out`` for the lines after it.  The command
  itself is run by tests/test_dataset.py (killed and resumed) and tests/test_cli_errors.py
  (bad input);
* ``cocomopl train`` (``SHRINK``): one candidate, 3 primitives and the RBF kernel, 2
  iterations;
* the Python block (``PYTHON_SHRINK``): 3 primitives and 2 iterations for the fit.

Everything else runs exactly as written; ``cocomopl reproduce``'s report is also checked
against the project's claims on the bundled data.
"""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from cocomopl.data import BUNDLED_DATASET

from conftest import run_cli

README = Path(__file__).parents[1] / "README.md"

SHRINK = {("train",): ["--primitives", "3", "--kernels", "rbf", "--max-iterations", "2"]}
PYTHON_SHRINK = {r"n_primitives=\d+": "n_primitives=3", r"max_iterations=\d+": "max_iterations=2"}


def blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", README.read_text(), flags=re.MULTILINE | re.DOTALL)


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
    if args[1:3] == ["dataset", "generate"]:
        out = folder / args[args.index("--out") + 1]
        out.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(BUNDLED_DATASET, out)
        return
    # a line with --json in a process of its own: all it prints, compiled code's too, must be
    # one JSON object; the others through the entry point in this process, sparing seconds of imports
    if "--json" in args:
        result = run([sys.executable, "-m", "cocomopl", *shrunk(args)[1:]], folder)
    else:
        result = run_cli(*shrunk(args)[1:], cwd=folder)
    assert result.returncode == 0, f"{shlex.join(args)} exited {result.returncode}: {result.stderr[-2000:]}"
    if "--json" in args:
        payload = json.loads(result.stdout)
        assert isinstance(payload, dict)
        if args[1] == "reproduce":
            check_reproduce_report(payload, folder / "cocomopl-reproduce")


@pytest.mark.slow
def test_python_example_runs(folder):
    code = "\n".join(blocks("python"))
    for pattern, replacement in PYTHON_SHRINK.items():
        code = re.sub(pattern, replacement, code)
    result = run([sys.executable, "-c", code], folder)
    assert result.returncode == 0, result.stderr[-2000:]


def check_reproduce_report(payload: dict, out: Path) -> None:
    """``cocomopl reproduce``'s report and the project's claims on the bundled data."""
    assert payload == json.loads((out / "table1.json").read_text())
    table = payload["table1_mean_torque"]
    start, end = payload["window_s"]
    for method in ("OC", "MP", "refined", "Kajita"):
        figures = payload["metrics"][method]
        assert table[f"{method} simulated"] == figures["mean_torque"] > 0
        assert not figures["fell"]  # the bundled M_gen, refined M_gen, M_opt and Kajita walks stand
        assert figures["duration_s"] == pytest.approx(end - start, abs=0.01)  # one window for every walk
        assert figures["stabilizer_gains"]["ankle_damping"] > 0
        assert 0 < figures["knee_angle_min_rad"] <= figures["knee_angle_mean_rad"] <= figures["knee_angle_max_rad"]
        assert 0.5 < figures["com_height_min_m"] <= figures["com_height_mean_m"] <= figures["com_height_max_m"] < 1.2
        per_sole = figures["planned"]["force_variation_over_weight"]
        # |d(F_left + F_right)| <= |dF_left| + |dF_right|: the sum varies at most twice the larger sole
        assert 0 < figures["planned"]["total_force_variation_over_weight"] <= 2 * per_sole
    # docs/results.md: MP within 5 % of OC's simulated torque and below Kajita's
    assert abs(payload["mp_vs_oc_simulated_mean_torque_difference"]) < 0.05
    assert payload["mp_vs_kajita"]["mean_torque"]["lower"] == "MP"
    # every refined step converged from its default warm start, the dataset's solved steps around
    # it, and the refined plan costs less torque than the generated one
    assert all(payload["refine"]["converged"])
    assert payload["refine"]["warm_start"] == "interpolated"
    # each from solved steps of its kind, a cyclic step counting as a transition to its own length
    def family(name: str) -> str:
        kind = name.split("_")[0]
        return "transition" if kind == "cyclic" else kind

    guessed = [{family(corner) for corner in guess.split("+")} for guess in payload["refine"]["guess"]]
    assert guessed == [{family(step)} for step in payload["refine"]["steps"]]
    assert payload["refine"]["raw_cost_ratio"] > 1
    # the two-stage baseline: the second stage takes out most of the cart-table's error
    kajita = payload["kajita"]
    assert kajita["variant"] == "two-stage" and kajita["second_stage"] and kajita["pelvis_drop_searched"]
    assert kajita["zmp_reference_rms_m"] < 0.2 * kajita["first_stage_zmp_reference_rms_m"]
    # the bundled dataset holds every step of M_opt: none is solved again
    assert payload["m_opt_steps"] == 9 and payload["m_opt_solved_now"] == []
    assert payload["provenance"]["inputs"]["dataset"]["name"] == "dataset.h5"
    with h5py.File(out / "motions.h5") as f:
        assert set(f["motions"]) == {f"{m}_{kind}" for m in ("MP", "refined", "OC", "Kajita") for kind in ("planned", "simulated")}
    assert {"zmp_comparison.png", "force_comparison.png", "knee_torque_comparison.png"} <= {p.name for p in out.iterdir()}
