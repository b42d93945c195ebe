"""Where outputs go: no command replaces its input, report folders are written as a unit,
a killed writer's temporary files are recognised and cleaned, and the system's refusals
(a full disk, a read-only place, a name too long) are one line.

The commands run in this process (``cocomopl.cli.main``), so the refusals, which come before
any work, take a fraction of a second."""

import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.figure
import pytest

from cocomopl.cli import main
from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.motion_file import (
    REPORT_MARKER,
    atomic_path,
    os_error_message,
    read_motion,
    remove_stale_temps,
    report_folder,
    write_json,
    write_motions,
)


@pytest.fixture(scope="module")
def step_file(tmp_path_factory) -> Path:
    """A motion file of one bundled OC step."""
    path = tmp_path_factory.mktemp("inputs") / "step.h5"
    write_motions(path, {"step": read_motion(BUNDLED_DATASET, "cyclic_250_L")}, {"robot": "talos"})
    return path


def cocomopl(capsys, *args) -> tuple[int, str]:
    """``cocomopl ARGS`` in this process: the exit status and stderr."""
    status = main([str(a) for a in args])
    return status, capsys.readouterr().err


def assert_error_line(status: int, stderr: str, text: str) -> None:
    """Exit 2 and stderr exactly one ``cocomopl: error:`` line containing ``text``."""
    assert status == 2, stderr
    assert stderr.count("\n") == 1 and stderr.startswith("cocomopl: error: "), stderr
    assert text in stderr, stderr


def snapshot(folder: Path) -> dict[str, bytes | str]:
    """Every entry below ``folder``: a file's bytes, a link's target, a folder's marker."""
    out = {}
    for path in sorted(folder.rglob("*")):
        key = str(path.relative_to(folder))
        out[key] = os.readlink(path) if path.is_symlink() else "<dir>" if path.is_dir() else path.read_bytes()
    return out


def dead_pid() -> int:
    """The pid of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", ""])
    child.wait()
    return child.pid


def fake_report(folder: Path, **files: str) -> Path:
    """A report folder as :func:`report_folder` leaves it, holding ``files`` (name: text)."""
    with report_folder(folder) as work:
        for name, text in files.items():
            (work / name).write_text(text)
    return folder


# ---------------------------------------------------------------------------- 1. inputs are never replaced
@pytest.mark.parametrize(
    "args, message",
    [
        (("train", "walk.h5", "--out", "./walk.h5"), "--out walk.h5 would replace the input walk.h5"),
        (("train", "walk.png", "--out", "walk.npz"), "--out walk.npz would replace the input walk.png"),
        (("simulate", "walk.h5", "--out", "link.h5"), "--out link.h5 would replace the input walk.h5"),
        (("simulate", "walk.h5", "--out", "hard.h5"), "--out hard.h5 would replace the input walk.h5"),
        (("generate", "--model", "m.npz", "--out", "./m.npz"), "--out m.npz would replace the input m.npz"),
        (("export", "walk.h5", "--format", "csv", "--out", "link"), "--out link would replace the input walk.h5"),
        (("reproduce", "--data", "report/motions.h5", "--out", "report"),
         "--out report would replace the input report/motions.h5"),
        (("walk", "--model", "report/m.npz", "--out", "report/"), "--out report would replace the input report/m.npz"),
        (("plot", "report/motions.h5", "--out", "./report"), "--out report would replace the input report/motions.h5"),
        (("plot", "walk.h5", "--out", "linked-report"), "--out linked-report would replace the input walk.h5"),
        (("export-model", "--robot", "robot.json", "--out", "robot.json"),
         "--out robot.json would replace the input robot.json"),
    ],
    ids=lambda x: " ".join(x[:1]) if isinstance(x, tuple) else None,
)
def test_no_command_replaces_its_input(step_file, tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    shutil.copy(step_file, "walk.h5")
    shutil.copy(step_file, "walk.png")  # train's plot beside --out walk.npz
    os.symlink("walk.h5", "link.h5")
    os.symlink("walk.h5", "link.csv")  # export's walk.csv of --out link
    os.link("walk.h5", "hard.h5")
    Path("m.npz").write_bytes(b"a model")
    Path("robot.json").write_text("{}")
    fake_report(Path("report"), **{"motions.h5": "", "m.npz": ""})
    shutil.copy(step_file, "report/motions.h5")
    os.symlink(tmp_path, "linked-report")  # a folder holding the input, through a link
    before = snapshot(tmp_path)
    assert_error_line(*cocomopl(capsys, *args), message)
    assert snapshot(tmp_path) == before  # refused before anything was written


def test_train_refuses_what_it_could_not_write_before_training(tmp_path, monkeypatch, capsys):
    from cocomopl.primitives import selection

    monkeypatch.setattr(selection, "select_model", lambda *a, **k: pytest.fail("trained before checking --out"))
    read_only = tmp_path / "kept.npz"
    read_only.write_text("a model of the user's")
    read_only.chmod(0o444)
    assert_error_line(*cocomopl(capsys, "train", BUNDLED_DATASET, "--out", read_only), f"{read_only} is read-only")
    (tmp_path / "model.png").mkdir()
    assert_error_line(*cocomopl(capsys, "train", BUNDLED_DATASET, "--out", tmp_path / "model.npz"),
                      f"{tmp_path / 'model.png'} is a directory")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.npz", "model.png"]


# ---------------------------------------------------------------------------- 2. report folders as a unit
def test_a_report_is_built_aside_and_renamed_into_place(tmp_path):
    target = tmp_path / "report"
    with report_folder(target) as work:
        assert work.parent == tmp_path and work.name.startswith(".report.cocomopl-tmp-")
        assert not target.exists()  # nothing at the target until the report is complete
        (work / "a.png").write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]
    assert json.loads((target / REPORT_MARKER).read_text()) == {"format": "cocomopl report", "files": ["a.png"]}


def test_replacing_a_report_leaves_no_file_of_the_old_one(tmp_path):
    target = fake_report(tmp_path / "report", **{"old.png": "old", "motions.h5": "old"})
    with report_folder(target) as work:
        (work / "motions.h5").write_text("new")
    assert sorted(p.name for p in target.iterdir()) == [REPORT_MARKER, "motions.h5"]
    assert (target / "motions.h5").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]  # the old one is gone, not set aside


@pytest.mark.parametrize("failure", [KeyboardInterrupt, RuntimeError])
def test_a_failed_report_leaves_the_old_one_or_nothing(tmp_path, failure):
    old = fake_report(tmp_path / "old", **{"motions.h5": "old"})
    before = snapshot(tmp_path)
    with pytest.raises(failure), report_folder(old) as work:
        (work / "motions.h5").write_text("half")
        raise failure
    with pytest.raises(failure), report_folder(tmp_path / "new" / "deeper" / "report") as work:
        (work / "motions.h5").write_text("half")
        raise failure
    assert snapshot(tmp_path) == before  # the old report as it was; no new folder, not even its parents


def test_an_empty_folder_is_replaced_and_a_foreign_one_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    with report_folder(tmp_path / "empty") as work:
        (work / "a.png").write_text("")
    assert (tmp_path / "empty" / "a.png").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("the user's")
    with pytest.raises(Error, match=r"not empty and not a cocomopl report .it holds notes.txt"), report_folder(mine):
        pytest.fail("entered")
    report = fake_report(tmp_path / "report", **{"a.png": ""})
    (report / "notes.txt").write_text("added by the user")
    with pytest.raises(Error, match=r"also holds notes.txt"), report_folder(report):
        pytest.fail("entered")
    assert (mine / "notes.txt").read_text() == "the user's" and (report / "notes.txt").exists()
    assert not [p for p in tmp_path.iterdir() if "cocomopl-tmp" in p.name]


def test_a_report_replaced_through_a_link_stays_linked(tmp_path):
    real = fake_report(tmp_path / "real", **{"a.png": "old"})
    (tmp_path / "link").symlink_to(real)
    with report_folder(tmp_path / "link") as work:
        (work / "a.png").write_text("new")
    assert (tmp_path / "link").is_symlink() and (real / "a.png").read_text() == "new"


def test_the_current_folder_and_a_file_are_refused_as_report_folders(tmp_path, monkeypatch, step_file, capsys):
    monkeypatch.chdir(tmp_path)
    assert_error_line(*cocomopl(capsys, "plot", step_file, "--out", "."), "--out . is the current folder")
    Path("a-file").write_text("")
    assert_error_line(*cocomopl(capsys, "plot", step_file, "--out", "a-file"), "--out a-file is a file, not a folder")
    assert sorted(os.listdir()) == ["a-file"]


@pytest.mark.slow
def test_plot_replaces_its_report_and_says_so(step_file, tmp_path, capsys):
    out = tmp_path / "plots"
    assert cocomopl(capsys, "plot", step_file, "--out", out) == (0, "")
    assert cocomopl(capsys, "plot", step_file, "--out", out) == (0, f"cocomopl: warning: replacing the report {out}\n")
    listed = json.loads((out / REPORT_MARKER).read_text())["files"]
    assert listed == ["contact_forces.png", "joint_angles.png", "torques.png", "zmp.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plots"]


# ---------------------------------------------------------------------------- 3. what a killed writer leaves
def test_stale_temporaries_are_removed_and_live_ones_kept(tmp_path):
    dead = dead_pid()
    stale = [tmp_path / f".walk.h5.cocomopl-tmp-{dead}-0123abcd.tmp",
             tmp_path / f".report.cocomopl-tmp-{dead}-89abcdef"]
    live = [tmp_path / f".walk.h5.cocomopl-tmp-{os.getpid()}-0123abcd.tmp",
            tmp_path / ".walk.h5.cocomopl-tmp-1-00000000"]  # pid 1 never ends
    mine = [tmp_path / f".walk.h5.{dead}.tmp", tmp_path / f"walk.h5.cocomopl-tmp-{dead}-0123abcd"]  # not our pattern
    stale[1].mkdir()
    (stale[1] / "motions.h5").write_text("half")
    for path in [stale[0], *live, *mine]:
        path.write_text("")
    with atomic_path(tmp_path / "walk.h5") as tmp:  # a run writing into the folder cleans it
        tmp.write_text("new")
    assert sorted(tmp_path.iterdir()) == sorted([*live, *mine, tmp_path / "walk.h5"])
    assert remove_stale_temps(tmp_path) == []


def test_temporary_names_fit_a_long_file_name(tmp_path):
    name = "w" * 246 + ".h5"  # 249 characters: ".NAME.cocomopl-tmp-PID-RANDOM" would be too long
    with atomic_path(tmp_path / name) as tmp:
        assert len(os.fsencode(tmp.name)) <= 255 and tmp.parent == tmp_path
        tmp.write_text("written")
    assert (tmp_path / name).read_text() == "written"
    with report_folder(tmp_path / ("r" * 250)) as work:
        assert len(work.name) <= 255
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "r" * 250])


def test_a_name_beyond_the_limit_is_one_line(step_file, tmp_path, capsys):
    for args in (("plot", step_file, "--out", tmp_path / ("p" * 300)),
                 ("simulate", step_file, "--out", tmp_path / ("s" * 300 + ".h5"))):
        assert_error_line(*cocomopl(capsys, *args), f"{args[-1]}: File name too long")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------- 4. the system's refusals
@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EROFS, errno.EACCES])
def test_a_system_error_mid_report_is_one_line_and_leaves_nothing(step_file, tmp_path, monkeypatch, capsys, code):
    def refused(figure, path, **options):
        Path(path).write_bytes(b"\x89PNG half")
        raise OSError(code, os.strerror(code), str(path))

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", refused)
    status, stderr = cocomopl(capsys, "plot", step_file, "--out", tmp_path / "plots")
    # named by the file asked for, not by its temporary name
    expected = f"cocomopl: error: {tmp_path / 'plots' / 'joint_angles.png'}: {os.strerror(code)}"
    assert_error_line(status, stderr, expected)
    assert list(tmp_path.iterdir()) == []


def test_a_system_error_in_a_file_names_the_file(tmp_path, monkeypatch):
    target = tmp_path / "metrics.json"

    def full(self, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OSError) as raised:
        write_json(target, {"a": 1})
    assert os_error_message(raised.value) == f"{target}: No space left on device"
    assert list(tmp_path.iterdir()) == []


def test_an_unnamed_system_error_is_about_the_file_written(tmp_path):
    """h5py's errors name no file and span lines: the user gets the target and the system's words."""
    target = tmp_path / "motions.h5"
    with pytest.raises(OSError) as raised, atomic_path(target) as tmp:
        tmp.write_bytes(b"half")
        raise OSError(errno.EFBIG, "Can't write data (file write failed: time = ...\n, errno = 27, ...)")
    assert os_error_message(raised.value) == f"{target}: File too large"
    assert list(tmp_path.iterdir()) == []


def test_a_bug_keeps_its_traceback(step_file, tmp_path, monkeypatch):
    from cocomopl.analysis import plots

    monkeypatch.setattr(plots, "plot_joint_angles", lambda *a: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        main(["plot", str(step_file), "--out", str(tmp_path / "plots")])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_refused_export_warns_of_no_replacement_and_a_done_one_does(step_file, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("walk.csv").write_text("an earlier export")
    # refused after the outputs were checked: the motion is not the robot's
    assert_error_line(*cocomopl(capsys, "export", step_file, "--format", "csv", "--out", "walk", "--robot", "romeo"),
                      "the motion is for robot 'talos', not 'romeo'")
    assert Path("walk.csv").read_text() == "an earlier export"
    assert cocomopl(capsys, "export", step_file, "--format", "csv", "--out", "walk", "--force") == (
        0, "cocomopl: warning: replacing walk.csv\n")
    assert Path("walk.csv").read_text() != "an earlier export"
