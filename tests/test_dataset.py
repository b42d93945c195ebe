"""Dataset generation: file contents, info, check, resume after a kill, and the Dask path."""

import json
import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

from cocomopl.cli import main
from cocomopl.dataset.plan import DEFAULT_LENGTHS_M, default_transitions, training_specs
from cocomopl.errors import Error
from cocomopl.gait import parse_transitions_mm
from cocomopl.motion import StepSpec
from cocomopl.motion_file import read_motions
from cocomopl.ocp.settings import OCPSettings

from conftest import SMALL, SMALL_LENGTH


def test_plan_has_the_papers_23_ocps_and_32_by_default():
    specs = training_specs((0.15, 0.25, 0.30, 0.35, 0.40))
    kinds = [s.kind for s in specs]
    assert len(specs) == 23
    assert (kinds.count("start"), kinds.count("cyclic"), kinds.count("transition"), kinds.count("stop")) == (5, 5, 8, 5)
    assert len(training_specs(DEFAULT_LENGTHS_M)) == 28
    specs = training_specs(DEFAULT_LENGTHS_M, default_transitions(DEFAULT_LENGTHS_M))
    assert len(specs) == 32
    assert {(s.start_length, s.end_length) for s in specs if s.kind == "transition"} >= {(0.25, 0.35), (0.35, 0.25)}


def test_default_transitions_keep_only_trained_lengths():
    assert default_transitions((0.15, 0.25, 0.30)) == ((0.15, 0.25),)
    assert default_transitions((0.20, 0.30)) == ()


def test_extra_transitions_parse_and_deduplicate():
    lengths = (0.15, 0.2, 0.25)
    assert parse_transitions_mm("250-150, 150-250", lengths) == ((0.15, 0.25),)
    assert len(training_specs(lengths, parse_transitions_mm("150-200", lengths))) == 3 * 3 + 2 * 2  # already neighbours


def test_gait_grids_give_each_gaits_two_footsteps_and_their_transitions_once(robot):
    from cocomopl.dataset.plan import DEFAULT_GAIT_GRID_TEXT, gait_footsteps, parse_gait_grid
    from cocomopl.motion import Footstep
    from cocomopl.planning.goal import turn_step_out

    grid = parse_gait_grid("300,150/100/0,12")
    assert grid == ((0.15, 0.3), (0.1,), (0.0, pytest.approx(np.radians(12))))
    footsteps, pairs = gait_footsteps(robot, [grid])
    # a gait leads with (length, width + d, turn) and trails with (length, d, -turn), where both
    # feet step out by d beyond 12 degrees only
    turn = grid[2][1]
    assert turn_step_out(turn) == turn_step_out(0.0) == 0.0 and 0.0 < turn_step_out(np.radians(-20)) < 0.015
    assert Footstep(0.3, 0.1, turn) in footsteps and Footstep(0.3, 0.0, -turn) in footsteps
    assert len(footsteps) == 8 and len(pairs) == 4
    # a second grid adds its gaits; a gait in both counts once
    more, more_pairs = gait_footsteps(robot, [grid, parse_gait_grid("400,150/100,0/0")])
    assert set(footsteps) < set(more) and len(more) == 8 + 2 and len(more_pairs) == 4 + 1  # (400, 0, 0), (400, 100, 0)
    assert gait_footsteps(robot, [parse_gait_grid(DEFAULT_GAIT_GRID_TEXT)])[0][0].length == -0.15


def test_a_transition_that_joins_both_consecutive_footsteps_and_a_gait_is_solved_once(robot):
    from cocomopl.dataset.plan import gait_footsteps, parse_gait_grid

    # the gait at 75 mm trails (75, 0, -6 deg) after leading (75, 40 mm, 6 deg): consecutive in
    # the sorted order too, where the pair comes the other way round
    footsteps, pairs = gait_footsteps(robot, [parse_gait_grid("75/40/6")])
    assert list(footsteps) == sorted(footsteps) and pairs == ((footsteps[1], footsteps[0]),)
    specs = training_specs(footsteps, pairs)
    assert len(specs) == len(set(specs)) == 2 * 3 + 2


@pytest.mark.parametrize("text, message", [
    ("150/100", "LENGTHS_MM/WIDTHS_MM/TURNS_DEG"), ("150,150/0/0", "repeat"), ("150/x/0", "not a number"),
])
def test_bad_gait_grids_are_refused(text, message):
    from cocomopl.dataset.plan import parse_gait_grid

    with pytest.raises(Error, match=message):
        parse_gait_grid(text)


def test_a_gait_out_of_range_is_refused_naming_it(robot):
    from cocomopl.dataset.plan import gait_footsteps, parse_gait_grid

    # the gaits step out at turns (test_planning), so none in range collides: 25 degrees at 0 mm
    # is taken, 30 and a 160 mm side step at 25 degrees are not
    gait_footsteps(robot, [parse_gait_grid("0/0/25")])
    with pytest.raises(Error, match=r"gait \(0 mm, 0 mm, 30 deg\).*turn 30 deg is outside"):
        gait_footsteps(robot, [parse_gait_grid("150/100/0"), parse_gait_grid("0/0/30")])
    with pytest.raises(Error, match=r"gait \(150 mm, 160 mm, 25 deg\).*width 175 mm is outside"):
        gait_footsteps(robot, [parse_gait_grid("150/160/25")])


@pytest.mark.parametrize(
    "text, message",
    [("150-300", "300 mm is not one of the training lengths"), ("150", "joined by '-'"),
     ("150-150", "cyclic step"), ("150-x", "not a number")],
)
def test_extra_transitions_errors(text, message):
    with pytest.raises(Error, match=message):
        parse_transitions_mm(text, (0.15, 0.25))


@pytest.mark.slow
def test_info_json(small_dataset, capsys):
    assert main(["dataset", "info", str(small_dataset), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["motions"] == 6
    assert info["signals"] == 36
    assert info["trajectories"] == 6 * 36
    assert info["all_converged"] is True
    assert info["mean_solve_time_s"] > 0
    assert info["command"] == "pytest"
    assert info["versions"]["pin"] == "4.0.0"


@pytest.mark.slow
def test_check_passes_and_reports_worst_values(small_dataset, capsys):
    assert main(["dataset", "check", str(small_dataset), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] is True
    for key in ("inverse_dynamics_residual", "zmp_margin", "torque_ratio", "continuity"):
        assert key in report["worst"]


@pytest.mark.slow
def test_check_fails_on_a_tampered_motion(small_dataset, tmp_path, capsys):
    """Torques that no longer produce the motion are caught by inverse dynamics."""
    bad = tmp_path / "bad.h5"
    bad.write_bytes(small_dataset.read_bytes())
    with h5py.File(bad, "r+") as f:
        f["motions/cyclic_200_L/tau"][5, 3] += 10.0
    assert main(["dataset", "check", str(bad), "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert "inverse_dynamics_residual" in report["failures"]


@pytest.mark.slow
def test_resume_after_kill_recomputes_nothing_finished(tmp_path, small_dataset, robot):
    """A run killed (SIGKILL) while it solves leaves the steps saved before it untouched and
    writes no dataset; the same run again reuses them and solves only the rest.  The saved
    steps are the small dataset's cyclic and stop steps, as a killed earlier run leaves them.
    The first run is killed once it has submitted the start step's OCP (its pool's ``submit``
    says so), and it cannot save a part before the kill (its ``write_part`` waits forever)."""
    from cocomopl.dataset.generate import part_attrs, write_part

    out = tmp_path / "resume.h5"
    parts = tmp_path / "resume.h5.parts"
    parts.mkdir()
    solved, _ = read_motions(small_dataset)
    names = [f"{kind}_{SMALL_LENGTH * 1000:g}_L" for kind in ("cyclic", "stop")]
    for name in names:
        write_part(parts, solved[name].steps[0], solved[name], attrs=part_attrs(SMALL, robot))
    saved = {p.name: p.stat().st_mtime_ns for p in parts.glob("*.h5")}
    # the small dataset's settings (its phase durations are no CLI options), as the CLI calls it
    script = ("import json, sys, threading; from cocomopl.dataset import generate as g; from cocomopl.ocp.settings "
              "import OCPSettings\n"
              "submit = g.cf.ProcessPoolExecutor.submit\n"
              "def submitted(*args, **kwargs):\n    future = submit(*args, **kwargs)\n"
              "    print('an OCP submitted', file=sys.stderr, flush=True)\n    return future\n"
              "if sys.argv[4:] == ['hold']:\n    g.cf.ProcessPoolExecutor.submit = submitted\n"
              "    g.write_part = lambda *args, **kwargs: threading.Event().wait()\n"
              "print(json.dumps(g.generate(sys.argv[1], (float(sys.argv[2]),), settings=OCPSettings("
              "**json.loads(sys.argv[3])), workers=1, command='cocomopl dataset generate (test)')))")
    cmd = [sys.executable, "-c", script, str(out), str(SMALL_LENGTH), json.dumps(SMALL.as_dict())]
    proc = subprocess.Popen([*cmd, "hold"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    progress = b""
    while b"an OCP submitted" not in progress:
        chunk = os.read(proc.stderr.fileno(), 4096)
        assert chunk, "the first run ended before it submitted an OCP: " + progress.decode(errors="replace")
        progress += chunk
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not out.exists()
    assert {p.name: p.stat().st_mtime_ns for p in parts.glob("*.h5")} == saved  # untouched, nothing half-written
    result = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert (summary["reused"], summary["solved"], summary["failed"]) == (2, 1, [])
    # progress names each OCP as it finishes, on stderr, so stdout stays one JSON object
    assert f"solved start_{SMALL_LENGTH * 1000:g}_L in" in result.stderr and "elapsed" in result.stderr
    motions, attrs = read_motions(out)
    assert len(motions) == 6 and attrs["command"].startswith("cocomopl dataset generate")
    for name in names:  # the saved steps, reused as they were
        np.testing.assert_array_equal(motions[name].q, solved[name].q)


@pytest.mark.slow
def test_dask_cluster_path(tmp_path, small_dataset, robot, capsys):
    """The OCPs run on a Dask cluster.  The small dataset's cyclic and stop steps are left
    as parts of an interrupted run, and its cyclic step copied over the start step's part:
    that part is not reused, the cluster solves only the start step, and the dataset holds
    every step under its own name (a reused copy would leave one out)."""
    distributed = pytest.importorskip("dask.distributed")
    from cocomopl.dataset.generate import generate, part_attrs, write_part

    out = tmp_path / "dask.h5"
    parts = tmp_path / "dask.h5.parts"
    solved, _ = read_motions(small_dataset)
    cyclic, stop = (solved[f"{kind}_{SMALL_LENGTH * 1000:g}_L"] for kind in ("cyclic", "stop"))
    for spec, motion in ((cyclic.steps[0], cyclic), (stop.steps[0], stop), (StepSpec("start", 0.0, SMALL_LENGTH), cyclic)):
        write_part(parts, spec, motion, attrs=part_attrs(SMALL, robot))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        summary = generate(out, (SMALL_LENGTH,), settings=SMALL, scheduler=cluster.scheduler_address, progress=False)
    assert f"cocomopl: warning: not reusing {parts / 'start_200_L.h5'}: it holds cyclic_200_L\n" in capsys.readouterr().err
    assert (summary["failed"], summary["reused"], summary["solved"]) == ([], 2, 1)
    motions, attrs = read_motions(out)
    assert sorted(motions) == sorted(solved) and all(motion.name == name for name, motion in motions.items())
    assert attrs["scheduler"] == cluster.scheduler_address


def test_generate_help_states_the_default_settings(capsys):
    with pytest.raises(SystemExit):
        main(["dataset", "generate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    defaults = OCPSettings()
    assert f"(default: {defaults.max_iterations})" in text
    assert f"(default: {defaults.w_load_transfer:g};" in text
    assert f"(default: {defaults.min_knee_flexion:g};" in text


@pytest.mark.slow
def test_bundled_dataset_is_complete_and_passes_the_check(capsys):
    """The dataset that ships in the package: made by the project's command with the default
    training set (32 OCPs, 64 motions with their mirror images), every check passing."""
    assert main(["dataset", "info", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    motions = 2 * len(training_specs(DEFAULT_LENGTHS_M, default_transitions(DEFAULT_LENGTHS_M)))
    assert (info["motions"], info["signals"], info["trajectories"]) == (motions, 36, 36 * motions) == (64, 36, 2304)
    assert info["all_converged"] is True
    assert info["command"].startswith("cocomopl dataset generate")
    assert info["versions"]["crocoddyl"] == "3.2.1" and info["created"]
    # solved with the default settings, so plain `cocomopl dataset generate` makes it again;
    # the sole gap added since then acts on turning steps only, which it has none of; the upper
    # body's velocity weight added since then reads as the legs' weight it had
    assert OCPSettings.from_saved(info["settings"]) == OCPSettings()
    assert set(OCPSettings().as_dict()) - set(info["settings"]) == {"sole_gap", "w_sole_gap", "w_upper_velocity"}
    assert main(["dataset", "check", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["ok"] is True
