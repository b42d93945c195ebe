"""The main job and the simulator from the command line: outputs, JSON, bad input."""

import json

import h5py
import pytest

from cocomopl.motion_file import read_motion
from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ

from test_cli_errors import assert_one_line_error, run_cli


@pytest.fixture(scope="module")
def walk_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk") / "report"
    result = run_cli("walk", "--lengths-mm", "250,250", "--out", str(out), "--no-video", "--json")
    return out, result


def test_walk_writes_its_report_and_one_json_object(walk_report):
    out, result = walk_report
    assert result.returncode in (0, 1), result.stderr  # 1 means it fell, reported in the JSON
    payload = json.loads(result.stdout)
    for key in ("fell", "peak_force_over_weight", "max_force_rate", "mean_torque", "zmp_rms_error", "duration_s"):
        assert key in payload
    assert payload["steps"] == ["start_250_L", "stop_250_R"]
    assert payload["reference_cutoff_hz"] == REFERENCE_CUTOFF_HZ  # the reference is low-passed by default
    assert (result.returncode == 1) == payload["fell"]
    names = {p.name for p in out.iterdir()}
    assert {"motions.h5", "metrics.json", "walk.html", "zmp_comparison.png", "force_comparison.png",
            "knee_torque_comparison.png", "leg_joint_comparison.png"} <= names
    assert "walk.mp4" not in names  # --no-video
    assert json.loads((out / "metrics.json").read_text())["mean_torque"] == payload["mean_torque"]
    with h5py.File(out / "motions.h5") as f:
        assert set(f["motions"]) == {"generated", "simulated"}
    assert not [n for n in names if n.startswith(".")]  # no temporary file left behind


def test_walk_flags_a_walk_the_dynamics_filter_left_inconsistent(walk_report):
    from cocomopl.pipeline import FILTER_WARNING_M

    _, result = walk_report
    payload = json.loads(result.stdout)
    error = payload["dynamics_filter_zmp_error_m"]
    assert 0 <= error < 1
    flagged = any("dynamics filter" in w for w in payload["warnings"])
    assert flagged == (error > FILTER_WARNING_M)
    assert flagged == ("dynamics filter" in result.stderr)  # and the human sees it too


def test_simulate_a_motion_file(walk_report, tmp_path):
    out, _ = walk_report
    # the generated motion of the report, alone in a file, then simulated without stabilizer
    source = tmp_path / "generated.h5"
    assert run_cli("generate", "--lengths-mm", "250,250", "--out", str(source)).returncode == 0
    measured = tmp_path / "measured.h5"
    result = run_cli("simulate", str(source), "--no-stabilizer", "--contact-time-constant-s", "0.02",
                     "--reference-cutoff-hz", "0", "--out", str(measured), "--json")
    payload = json.loads(result.stdout)
    assert payload["stabilizer"] is False and measured.exists()
    assert payload["reference_cutoff_hz"] == 0.0 == read_motion(measured).meta["reference_cutoff_hz"]
    assert payload["contact_time_constant_s"] == 0.02 == read_motion(measured).meta["contact_time_constant_s"]
    assert (result.returncode == 1) == payload["fell"]


@pytest.mark.parametrize(
    "args, words",
    [
        (("walk", "--lengths-mm", "250,300"), ["must repeat"]),
        (("walk", "--lengths-mm", "250,abc"), ["not a number"]),
        (("walk", "--lengths-mm", "250"), ["at least two"]),
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
    assert_one_line_error(run_cli(*args, *extra, cwd=tmp_path), *words)
    assert not out.exists() and not (tmp_path / "m.h5").exists()


def test_foreign_motion_file_and_unwritable_folder(tmp_path):
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = [1, 2, 3]
    assert_one_line_error(run_cli("simulate", str(foreign), "--out", str(tmp_path / "m.h5")), "not a cocomopl motion file")
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert_one_line_error(run_cli("walk", "--lengths-mm", "250,250", "--out", str(blocker / "report")), "cannot")


def test_reproduce_gives_table_one_and_its_figures(tmp_path):
    out = tmp_path / "repro"
    result = run_cli("reproduce", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)
    assert payload == json.loads((out / "table1.json").read_text())
    table = payload["table1_mean_torque"]
    for method in ("OC", "MP", "Kajita"):
        assert table[f"{method} simulated"] == payload["metrics"][method]["mean_torque"] > 0
        assert not payload["metrics"][method]["fell"]  # the bundled M_gen, M_opt and Kajita walks stand
        per_sole = payload["planned_force_variation_over_weight"][method]
        # |d(F_left + F_right)| <= |dF_left| + |dF_right|: the sum varies at most twice the larger sole
        assert 0 < payload["planned_total_force_variation_over_weight"][method] <= 2 * per_sole
    assert payload["mp_vs_oc_simulated_mean_torque_difference"] == pytest.approx(table["MP simulated"] / table["OC simulated"] - 1)
    mp, kajita = (payload["metrics"][m]["force_variation_over_weight"] for m in ("MP", "Kajita"))
    assert payload["mp_smoother_than_kajita"] == (mp < kajita)
    with h5py.File(out / "motions.h5") as f:
        assert set(f["motions"]) == {f"{m}_{kind}" for m in ("MP", "OC", "Kajita") for kind in ("planned", "simulated")}
    assert {"zmp_comparison.png", "force_comparison.png", "knee_torque_comparison.png"} <= {p.name for p in out.iterdir()}
