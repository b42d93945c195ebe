"""Dataset generation, hardened: which saved parts a rerun reuses, what a run that cannot
succeed leaves behind, and the bounds of --dt and --workers.

The parts are the small dataset's steps, saved as a run saves them; only the run of no
converged OCP starts a worker process.  A wrong part in a whole run is in test_dataset.py's
Dask test, which solves a step anyway.
"""

from dataclasses import replace

import h5py
import numpy as np
import pytest

from cocomopl.cli import main
from cocomopl.dataset.generate import (
    check_dt,
    check_workers,
    finished_part,
    generate,
    job_executor,
    job_result,
    max_workers,
    part_attrs,
    write_part,
)
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.motion_file import read_motions, write_motions

from conftest import SMALL, SMALL_LENGTH

CYCLIC = StepSpec("cyclic", SMALL_LENGTH, SMALL_LENGTH)
START = StepSpec("start", 0.0, SMALL_LENGTH)
STOP = StepSpec("stop", SMALL_LENGTH, 0.0)


# each: how a part saved as cyclic_200_L.h5 is spoilt (its motions, its attributes), and words of the warning
def _copied_over(motions, attrs):
    return {START.name: motions[START.name]}, attrs


def _not_finite(motions, attrs):
    motions[CYCLIC.name].q[3, 7] = np.nan
    return {CYCLIC.name: motions[CYCLIC.name]}, attrs


def _other_settings(motions, attrs):
    return {CYCLIC.name: motions[CYCLIC.name]}, {**attrs, "settings": replace(SMALL, dt=0.04).as_dict()}


def _other_robot(motions, attrs):
    return {CYCLIC.name: motions[CYCLIC.name]}, {**attrs, "robot": "romeo"}


def _other_model(motions, attrs):
    return {CYCLIC.name: motions[CYCLIC.name]}, {**attrs, "robot_model": "0" * 16}


def _saved_by_an_older_version(motions, attrs):
    return {CYCLIC.name: motions[CYCLIC.name]}, {"content": "part", "settings": attrs["settings"]}


def _short_of_a_joint(motions, attrs):
    motion = motions[CYCLIC.name]
    motion.q = motion.q[:, :-1]
    return {CYCLIC.name: motion}, attrs


def _two_motions(motions, attrs):
    return {name: motions[name] for name in (CYCLIC.name, STOP.name)}, attrs


def _no_solver_statistics(motions, attrs):
    motion = motions[CYCLIC.name]
    motion.solution = None
    return {CYCLIC.name: motion}, attrs


SPOILT = {
    "copied over": (_copied_over, ["it holds start_200_L"]),
    "NaN": (_not_finite, ["array 'q' holds", "NaN"]),
    "settings": (_other_settings, ["other OCP settings", "dt 0.04, now 0.05"]),
    "robot": (_other_robot, ["robot 'romeo', not 'talos'"]),
    "robot model": (_other_model, ["another model of talos"]),
    "older version": (_saved_by_an_older_version, ["records no robot model"]),
    "shape": (_short_of_a_joint, ["array 'q' has shape"]),
    "two motions": (_two_motions, ["it holds 2 motions"]),
    "incomplete meta": (_no_solver_statistics, ["solver's statistics"]),
}


def _assert_warned(capsys, part, *words) -> None:
    """One warning line on stderr, naming ``part`` and each of ``words``."""
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"cocomopl: warning: not reusing {part}: "), lines
    for word in words:
        assert word in lines[0], lines[0]


@pytest.mark.slow
def test_a_sound_part_is_reused(tmp_path, small_dataset, robot, capsys):
    motions, _ = read_motions(small_dataset)
    write_part(tmp_path, CYCLIC, motions[CYCLIC.name], attrs=part_attrs(SMALL, robot))
    reused = finished_part(tmp_path / "cyclic_200_L.h5", CYCLIC, part_attrs(SMALL, robot), robot)
    np.testing.assert_array_equal(reused.q, motions[CYCLIC.name].q)
    assert capsys.readouterr().err == ""


@pytest.mark.slow
@pytest.mark.parametrize("case", SPOILT)
def test_a_part_that_is_not_its_step_is_solved_again(tmp_path, small_dataset, robot, capsys, case):
    """A part is reused only if it holds the one step its name stands for, solved with the
    same settings for the same robot, complete and finite; else it is deleted with a warning."""
    spoil, words = SPOILT[case]
    motions, _ = read_motions(small_dataset)
    part = tmp_path / "cyclic_200_L.h5"
    write_motions(part, *spoil(motions, part_attrs(SMALL, robot)))
    assert finished_part(part, CYCLIC, part_attrs(SMALL, robot), robot) is None
    _assert_warned(capsys, part, *words)
    assert not part.exists()


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["not HDF5", "no tau"])
def test_a_damaged_part_is_solved_again(tmp_path, small_dataset, robot, capsys, damage):
    motions, _ = read_motions(small_dataset)
    part = tmp_path / "cyclic_200_L.h5"
    write_part(tmp_path, CYCLIC, motions[CYCLIC.name], attrs=part_attrs(SMALL, robot))
    if damage == "not HDF5":  # as a kill during a copy leaves it
        part.write_bytes(b"not HDF5")
    else:
        with h5py.File(part, "r+") as f:
            del f[f"motions/{CYCLIC.name}/tau"]
    assert finished_part(part, CYCLIC, part_attrs(SMALL, robot), robot) is None
    _assert_warned(capsys, part, "not a readable HDF5" if damage == "not HDF5" else "array 'tau' is missing")
    assert not part.exists()


@pytest.mark.slow
def test_no_converged_ocp_writes_nothing(tmp_path):
    """Knots longer than the phases: no OCP converges, and the run refuses to write a
    dataset of no motion; a file already there stays, and no working folder is left."""
    out = tmp_path / "d.h5"
    out.write_bytes(b"an earlier dataset")
    with pytest.raises(Error, match=r"no OCP converged with these settings \(dt 1 s.*; nothing written"):
        generate(out, (SMALL_LENGTH,), settings=replace(SMALL, dt=1.0, max_iterations=1), workers=1, progress=False)
    assert out.read_bytes() == b"an earlier dataset"
    assert list(tmp_path.iterdir()) == [out]


@pytest.mark.slow
@pytest.mark.parametrize("saved", [False, True], ids=["nothing saved", "two parts saved"])
@pytest.mark.parametrize("stop", [KeyboardInterrupt, RuntimeError], ids=["interrupted", "failed"])
def test_an_interrupted_run_keeps_its_parts_but_no_empty_folder(tmp_path, small_dataset, robot, monkeypatch, saved, stop):
    """The run stops as it submits its first OCP (Ctrl-C, or a failure)."""
    import concurrent.futures as cf

    def interrupt(*args, **kwargs):
        raise stop

    monkeypatch.setattr(cf.ProcessPoolExecutor, "submit", interrupt)
    out, parts = tmp_path / "d.h5", tmp_path / "d.h5.parts"
    if saved:
        solved, _ = read_motions(small_dataset)
        for spec in (CYCLIC, STOP):
            write_part(parts, spec, solved[spec.name], attrs=part_attrs(SMALL, robot))
    before = {p.name: p.stat().st_mtime_ns for p in parts.glob("*")}
    with pytest.raises(stop):
        generate(out, (SMALL_LENGTH,), settings=SMALL, workers=1, progress=False)
    assert not out.exists()
    assert parts.exists() == saved
    assert {p.name: p.stat().st_mtime_ns for p in parts.glob("*")} == before


@pytest.mark.slow
def test_an_unreachable_scheduler_leaves_nothing(tmp_path, monkeypatch, capsys):
    pytest.importorskip("dask.distributed")
    from cocomopl.dataset import generate as module

    monkeypatch.setattr(module, "SCHEDULER_TIMEOUT_S", 0.5)
    assert main(["dataset", "generate", "--lengths-mm", "200", "--scheduler", "tcp://127.0.0.1:1",
                 "--out", str(tmp_path / "d.h5")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cocomopl: error: cannot reach the Dask scheduler at tcp://127.0.0.1:1")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "option, words",
    [(["--dt", "0.1"], ["--dt", "0.005..0.05 s", "3 knots"]), (["--dt", "0.001"], ["--dt", "0.005..0.05 s"]),
     (["--workers", str(max_workers() + 1)], ["--workers", f"at most {max_workers()}"])],
)
def test_dt_and_workers_out_of_range_are_refused_at_parse_time(tmp_path, capsys, option, words):
    with pytest.raises(SystemExit) as exit_:
        main(["dataset", "generate", *option, "--out", str(tmp_path / "d.h5")])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cocomopl: error: argument ")
    for word in words:
        assert word in lines[0], lines[0]
    assert list(tmp_path.iterdir()) == []


def test_the_bounds_themselves_are_accepted(tmp_path):
    assert check_dt(0.005) == 0.005 and check_dt(0.05) == 0.05
    assert check_workers(max_workers()) == max_workers()
    with pytest.raises(Error, match="per core"):  # the Python API too
        generate(tmp_path / "d.h5", (SMALL_LENGTH,), settings=SMALL, workers=max_workers() + 1, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_a_solver_process_that_dies_is_an_error_not_a_traceback():
    """A worker killed in compiled code (a C++ exception's terminate, the out-of-memory killer)."""
    import os

    with job_executor(1, None) as executor, pytest.raises(Error, match=r"a solver process died .*run the same "
                                                                        "command again to resume"):
        job_result(executor.submit(os._exit, 1))


@pytest.mark.slow  # a local cluster started, its worker killed and restarted: 10-20 s
def test_a_dask_worker_that_dies_is_an_error_not_a_traceback():
    """On a cluster, a job whose worker dies more often than Dask retries it (here: at once)."""
    import os

    import dask

    distributed = pytest.importorskip("dask.distributed")
    with (dask.config.set({"distributed.scheduler.allowed-failures": 0}),
          distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
          job_executor(1, cluster.scheduler_address) as executor,
          pytest.raises(Error, match=r"a solver process died .*run the same command again to resume")):
        job_result(executor.submit(os._exit, 1))


@pytest.mark.parametrize("option, expected", [([], 0.1), (["--upper-velocity-weight", "1.5"], 1.5)])
def test_the_upper_velocity_weight_option_reaches_the_ocp_settings(tmp_path, monkeypatch, capsys, option, expected):
    from cocomopl.dataset import generate as module

    solved_with = []

    def no_solving(*args, settings, **kwargs):
        solved_with.append(settings)
        raise Error("stopped before solving")

    monkeypatch.setattr(module, "generate", no_solving)
    assert main(["dataset", "generate", "--lengths-mm", "200", *option, "--out", str(tmp_path / "d.h5")]) == 2
    assert "stopped before solving" in capsys.readouterr().err
    (settings,) = solved_with
    assert settings.w_upper_velocity == expected
    assert settings.w_velocity == 0.1  # the legs keep theirs
