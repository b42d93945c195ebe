"""The main job and the simulator from the command line: outputs, provenance, bad input.

``cocomopl reproduce`` is run and checked by tests/test_readme.py, as a README example."""

import json
import signal
import subprocess
import sys
import time

import h5py
import pytest

from cocomopl.cli import main
from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL
from cocomopl.motion_file import REPORT_MARKER, file_attrs, read_motion
from cocomopl.provenance import file_identity
from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ

from conftest import assert_one_line_error, run_cli


@pytest.fixture(scope="module")
def walk_report(tmp_path_factory):
    """The bundled model's 250 mm walk, in text mode, its folder given with a trailing slash."""
    out = tmp_path_factory.mktemp("walk") / "report"
    result = run_cli("walk", "--lengths-mm", "250,250", "--out", f"{out}/", "--no-video")
    return out, result


@pytest.mark.slow
def test_walk_writes_its_report(walk_report):
    out, result = walk_report
    assert result.returncode == 0, result.stderr  # the bundled model's walk stands
    payload = json.loads((out / "metrics.json").read_text())
    assert payload["fell"] is False and payload["steps"] == ["start_250_L", "stop_250_R"]
    assert payload["reference_cutoff_hz"] == REFERENCE_CUTOFF_HZ  # the reference is low-passed by default
    assert 0 < payload["peak_force_over_weight"] < 2 and payload["mean_torque"] > 0
    names = {p.name for p in out.iterdir()}
    assert {"motions.h5", "metrics.json", "walk.html", "zmp_comparison.png", "force_comparison.png",
            "knee_torque_comparison.png", "leg_joint_comparison.png"} <= names
    assert "walk.mp4" not in names  # --no-video
    assert not [n for n in names if n.startswith(".") and n != REPORT_MARKER]  # no temporary file left behind
    assert json.loads((out / REPORT_MARKER).read_text())["files"] == sorted(names - {REPORT_MARKER})
    assert [p.name for p in out.parent.iterdir()] == ["report"]  # nor a temporary folder beside it
    with h5py.File(out / "motions.h5") as f:
        assert set(f["motions"]) == {"generated", "simulated"}
    assert f"report in {out}/ (" in result.stdout and "//" not in result.stdout


@pytest.mark.slow
def test_walk_outputs_carry_their_provenance(walk_report, robot):
    out, _ = walk_report
    provenance = json.loads((out / "metrics.json").read_text())["provenance"]
    assert provenance["command"].startswith("cocomopl walk --lengths-mm 250,250")
    # the robot it walked, named and fingerprinted in the report as in its motions
    assert (provenance["robot"], provenance["robot_model"]) == (robot.name, robot.fingerprint)
    assert provenance["inputs"]["model"] == file_identity(BUNDLED_MODEL)  # a name and checksum, no path
    assert provenance["versions"]["cocomopl"] and provenance["created"]
    with h5py.File(out / "motions.h5") as f:
        attrs = file_attrs(f)
    assert attrs["command"] == provenance["command"] and attrs["inputs"] == provenance["inputs"]
    assert attrs["robot_model"] == provenance["robot_model"]


@pytest.mark.slow
def test_the_bundled_walk_is_not_flagged_and_a_tight_threshold_flags_it(monkeypatch):
    from cocomopl import pipeline
    from cocomopl.requests import StraightSteps, WalkRequest

    walk = pipeline.generate_walk(WalkRequest(StraightSteps([0.25, 0.25])))
    assert walk.motion.plan.plan_zmp_error_m < pipeline.FILTER_WARNING_M and walk.warnings == []
    monkeypatch.setattr(pipeline, "FILTER_WARNING_M", 0.0)  # every real walk leaves some error
    assert any("dynamics filter" in w for w in pipeline.generate_walk(WalkRequest(StraightSteps([0.25, 0.25]))).warnings)


@pytest.mark.slow
def test_simulate_a_motion_file_replacing_an_earlier_result(tmp_path):
    source = tmp_path / "generated.h5"
    assert run_cli("generate", "--lengths-mm", "250,250", "--out", str(source)).returncode == 0
    measured = tmp_path / "measured.h5"
    measured.write_text("an earlier result")
    result = run_cli("simulate", str(source), "--no-stabilizer", "--contact-time-constant-s", "0.02",
                     "--reference-cutoff-hz", "0", "--out", str(measured), "--json")
    assert result.returncode == 0, result.stderr
    assert f"cocomopl: warning: replacing {measured}" in result.stderr
    payload = json.loads(result.stdout)
    assert payload["stabilizer"] is False and payload["fell"] is False
    assert payload["reference_cutoff_hz"] == 0.0 == read_motion(measured).simulation.reference_cutoff_hz
    assert payload["contact_time_constant_s"] == 0.02 == read_motion(measured).simulation.contact_time_constant_s
    with h5py.File(measured) as f:
        assert file_attrs(f)["inputs"]["reference"] == file_identity(source)


@pytest.mark.slow
@pytest.mark.parametrize(
    "args, words",
    [
        (("walk", "--lengths-mm", "250,300"), ["must repeat"]),
        (("walk", "--lengths-mm", "250,abc"), ["not a number"]),
        (("walk", "--lengths-mm", "250"), ["at least two"]),
        (("walk", "--lengths-mm", "0.15,0.25,0.25"), ["millimetres", "150 mm"]),
        (("walk", "--model", "missing.npz"), ["not found", "missing.npz"]),
        (("walk", "--robot", "romeo"), ["no bundled romeo model", "romeo_model.npz"]),
        (("walk", "--robot", "g1", "--model", str(BUNDLED_MODEL)), ["a model of robot 'talos', not 'g1'"]),
        (("simulate", "missing.h5"), ["not found"]),
        (("walk", "--contact-time-constant-s", "0.001"), ["contact time constant", "0.002"]),
        (("simulate", "missing.h5", "--contact-time-constant-s", "nan"), ["positive finite"]),
        (("walk", "--reference-cutoff-hz", "600"), ["reference cut-off 600 Hz", "500 Hz"]),
        (("simulate", "missing.h5", "--reference-cutoff-hz", "-1"), ["reference cut-off -1 Hz"]),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, words):
    out = tmp_path / "report"
    extra = ("--out", str(out)) if args[0] == "walk" else ("--out", str(tmp_path / "m.h5"))
    result = run_cli(*args, *extra, cwd=tmp_path)
    assert_one_line_error(result, *words)
    assert result.stderr.startswith("cocomopl: error: ")
    assert list(tmp_path.iterdir()) == []  # not the report, not a temporary folder


@pytest.mark.slow
def test_foreign_motion_file_and_unwritable_folder(tmp_path):
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = [1, 2, 3]
    assert_one_line_error(run_cli("simulate", str(foreign), "--out", str(tmp_path / "m.h5")), "not a cocomopl motion file")
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert_one_line_error(run_cli("walk", "--lengths-mm", "250,250", "--out", str(blocker / "report")), "cannot")


@pytest.mark.slow
def test_interrupting_walk_leaves_no_report(tmp_path):
    out = tmp_path / "report"
    process = start_walk(out)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert "cocomopl: interrupted" in stderr and "Traceback" not in stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_killed_walk_leaves_the_old_report_and_the_next_run_cleans_up(tmp_path):
    out = tmp_path / "report"
    assert main(["plot", str(BUNDLED_DATASET), "--motion", "cyclic_250_L", "--out", str(out)]) == 0
    old = {p.name: p.read_bytes() for p in out.iterdir()}
    process = start_walk(out)
    process.kill()  # SIGKILL: no chance to clean up
    process.communicate(timeout=120)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == old  # the old report, not a mix
    (stale,) = [p for p in tmp_path.iterdir() if p != out]
    assert stale.name.startswith(f".report.cocomopl-tmp-{process.pid}-")  # recognisable as the killed run's
    assert main(["plot", str(BUNDLED_DATASET), "--motion", "cyclic_250_L", "--out", str(tmp_path / "plots")]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plots", "report"]


def start_walk(out) -> subprocess.Popen:
    """``cocomopl walk --out OUT`` in a new process, once it has started to build its report.

    The process gets Ctrl-C's handling as from a shell: a test worker may ignore SIGINT (some
    suite runs' did, after tests that start process pools), a child inherits that, and the walk
    would run to its end."""
    as_from_a_shell = ("import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
                       "sys.argv = ['cocomopl', *sys.argv[1:]]; runpy.run_module('cocomopl', run_name='__main__')")
    process = subprocess.Popen([sys.executable, "-c", as_from_a_shell, "walk", "--out", str(out), "--no-video"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while process.poll() is None and time.monotonic() < deadline:
        if any(p.name.startswith(f".{out.name}.cocomopl-tmp-") for p in out.parent.iterdir()):
            return process
        time.sleep(0.02)
    pytest.fail(f"walk did not start a report: {process.communicate()}")
