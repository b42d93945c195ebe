"""``cocomopl robot bootstrap``: a robot's description to a walking report, resumable.

The whole chain solves 32 OCPs (about 14 minutes for the G1 on 2 cores), so the test here
resumes it from a folder that already holds the G1's dataset and model, as a rerun after
Ctrl-C would: those stages are kept, the check and the walk run.
"""

import json
import shutil

import pytest

from cocomopl.bootstrap import PROJECTED_WORKERS, dataset_projection
from cocomopl.data import dataset_path, model_path
from cocomopl.dataset.generate import TimeLeft

from conftest import assert_one_line_error, run_cli


@pytest.mark.slow
def test_a_rerun_keeps_the_finished_stages_and_walks_the_robot(tmp_path):
    out = tmp_path / "g1"
    out.mkdir()
    shutil.copy(dataset_path(robot="g1"), out / "dataset.h5")
    shutil.copy(model_path(robot="g1"), out / "model.npz")
    result = run_cli("robot", "bootstrap", "g1", "--out", str(out), "--no-video", "--json")
    assert result.returncode == 0, result.stderr
    assert "[4/4] walk" in result.stderr  # progress goes on with --json, on stderr
    report = json.loads(result.stdout)
    assert report["robot"] == "g1" and report["check"] is True
    assert [(s["stage"], s["status"]) for s in report["stages"]] == [
        ("dataset", "kept"), ("check", "run"), ("train", "kept"), ("walk", "run")]
    assert report["walk"]["fell"] is False and report["walk"]["steps"][0].startswith("start")
    assert (out / "walk" / "metrics.json").exists() and (out / "walk" / "motions.h5").exists()
    assert report["dataset_projection_s"] is None  # the bundled set records no phase times


def test_a_folder_holding_another_robots_dataset_is_refused(tmp_path):
    (tmp_path / "dataset.h5").write_bytes(dataset_path().read_bytes())  # TALOS's
    assert_one_line_error(run_cli("robot", "bootstrap", "g1", "--out", str(tmp_path)),
                          "is not a dataset of the robot 'g1'")
    assert_one_line_error(run_cli("robot", "bootstrap", "talos", "--out", str(tmp_path / "dataset.h5")),
                          "dataset.h5")
    assert_one_line_error(run_cli("robot", "bootstrap", "nobody", "--out", str(tmp_path / "x")), "nobody")
    assert not (tmp_path / "x").exists()


def test_a_dataset_of_other_lengths_is_refused_not_replaced(tmp_path, small_dataset):
    shutil.copy(small_dataset, tmp_path / "dataset.h5")
    before = (tmp_path / "dataset.h5").read_bytes()
    assert_one_line_error(run_cli("robot", "bootstrap", "talos", "--out", str(tmp_path)),
                          "other lengths or OCP settings")
    assert (tmp_path / "dataset.h5").read_bytes() == before


def test_the_projection_holds_the_measured_sweeps_and_shares_the_transitions(small_dataset):
    from cocomopl.motion_file import file_attrs, open_checked

    with open_checked(small_dataset) as f:
        phases = file_attrs(f)["phase_wall_time_s"]
    projection = dataset_projection(small_dataset)
    assert phases["lengths"] > 0 and phases["transitions"] >= 0
    # one length: no transitions, so more workers gain nothing over the sweeps' chain
    assert list(projection) == list(PROJECTED_WORKERS)
    assert all(seconds == pytest.approx(phases["lengths"] + phases["transitions"] * 2 / n)
               for n, seconds in projection.items())


def test_the_time_left_takes_the_sweeps_pace_then_the_transitions_own():
    left = TimeLeft(transitions=5, workers=2)
    assert left.seconds() is None  # nothing to estimate from
    left.started -= 10.0
    left.lengths_done(1, 4)
    # 10 s for a quarter of the sweeps: 30 s more; a job of 2 x 10 s (two sweeps side by side),
    # a quarter of it per transition, 5 transitions on 2 workers: 3 rounds of 5 s
    assert left.seconds() == pytest.approx(30.0 + 3 * 5.0, rel=0.01)
    left.lengths_done(4, 4)
    left.started -= 6.0  # the transitions' phase: 6 s
    left.transition_done()
    left.transition_done()
    assert left.seconds() == pytest.approx(3 * 6.0 / 2, rel=0.01)  # 3 left at 3 s each, as measured
    assert TimeLeft(transitions=3, workers=None).seconds() is None  # a cluster of unknown size
