"""Malformed files and options for every reading command: each ends in one line
``cocomopl: error: FILE: ...`` (or a FAIL of ``dataset check``), a non-zero exit, no
traceback, and nothing written.  The files are made here from the bundled ones."""

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from cocomopl.cli import main
from cocomopl.data import BUNDLED_DATASET
from cocomopl.motion_file import read_motion, write_motions

MOTION = "cyclic_250_L"


@pytest.fixture(scope="module")
def good_motion(tmp_path_factory) -> Path:
    """One solved step as a motion file: valid, small, fast to read."""
    path = tmp_path_factory.mktemp("good") / "motion.h5"
    write_motions(path, {MOTION: read_motion(BUNDLED_DATASET, MOTION)}, {"robot": "talos"})
    return path


def _edit(path: Path, group: str, key: str, value) -> None:
    """Replace (or, with None, delete) the array or attribute ``key`` of ``group``."""
    with h5py.File(path, "r+") as f:
        g = f[group]
        if key in g.attrs:
            del g.attrs[key]
            if value is not None:
                g.attrs[key] = value
            return
        del g[key]
        if value is not None:
            g.create_dataset(key, data=value)


def _with(array_key: str, change):
    """A corruption: ``change`` applied to a copy of the motion's array ``array_key``."""

    def corrupt(path: Path, group: str) -> None:
        with h5py.File(path, "r") as f:
            value = np.array(f[group][array_key])
        _edit(path, group, array_key, change(value))

    return corrupt


def _set(index, value):
    def change(a):
        a = a.astype(float) if a.dtype.kind != "f" else a
        a[index] = value
        return a

    return change


def _attribute(key: str, value):
    return lambda path, group: _edit(path, group, key, value)


MOTION_CORRUPTIONS = {
    "nan time": (_with("t", _set(5, np.nan)), "'t'"),
    "nan joint": (_with("q", _set((3, 12), np.nan)), "'q'"),
    "inf base": (_with("q", _set((3, 0), np.inf)), "'q'"),
    "nan velocity": (_with("v", _set((7, 9), np.nan)), "'v'"),
    "nan torque": (_with("tau", _set((7, 2), np.nan)), "'tau'"),
    "nan wrench": (_with("wrenches", _set((7, 0, 2), np.nan)), "'wrenches'"),
    "nan zmp under a pushing foot": (_with("zmp", _set((7, 0), np.nan)), "'zmp'"),
    "a joint column missing": (_with("q", lambda a: a[:, :-1]), "'q' has shape"),
    "torques transposed": (_with("tau", lambda a: a.T.copy()), "'tau' has shape"),
    "wrenches flattened": (_with("wrenches", lambda a: a.reshape(len(a), 12)), "'wrenches' has shape"),
    "joints as text": (_with("q", lambda a: a.astype("S8")), "'q'"),
    "contact not 0/1": (_with("contact", lambda a: a.astype(int) * 3), "'contact'"),
    "time going back": (_with("t", lambda a: a[::-1].copy()), "time"),
    "impact time not repeated": (_with("t", lambda a: np.linspace(0, a[-1], len(a))), "impact"),
    "impact out of range": (_with("impacts", lambda a: a + 1000), "impacts"),
    "negative step start": (_with("step_starts", lambda a: a - 5), "step_starts"),
    "phase beyond the end": (_with("phase_last", lambda a: a + 1000), "phase"),
    "velocities missing": (_attribute("v", None), "'v' is missing"),
    "steps missing": (_attribute("steps", None), "'steps'"),
    "steps of a bad kind": (_attribute("steps", json.dumps([{"kind": "jump", "start_length": 0.25,
                                                              "end_length": 0.25}])), "step"),
    "step length NaN": (_attribute("steps", '[{"kind": "cyclic", "start_length": NaN, "end_length": 0.25}]'), "length"),
    "joint names not JSON": (_attribute("joint_names", "leg_left_1_joint,"), "'joint_names'"),
    "joint names reversed": (lambda p, g: _edit(p, g, "joint_names", json.dumps(_names(p, g)[::-1])), "joint"),
    "robot a number": (_attribute("robot", 7), "robot"),
    "unknown robot": (lambda p, g: _rename_robot(p, g, "atlas"), "atlas"),
}


def _names(path: Path, group: str) -> list:
    with h5py.File(path, "r") as f:
        return json.loads(f[group].attrs["joint_names"])


def _rename_robot(path: Path, group: str, name: str) -> None:
    with h5py.File(path, "r+") as f:
        f[group].attrs["robot"] = name
        f.attrs["robot"] = name


def run(argv: list[str], capsys) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def assert_refused(code: int, err: str, *words: str) -> None:
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("cocomopl: error: "), err
    assert "Traceback" not in err and all(w in lines[0] for w in words), (words, err)


def contents(folder: Path) -> dict:
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


@pytest.mark.parametrize("kind", sorted(MOTION_CORRUPTIONS))
def test_a_corrupted_motion_file_is_refused_by_every_reading_command(kind, good_motion, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.h5"
    shutil.copy(good_motion, bad)
    corrupt, word = MOTION_CORRUPTIONS[kind]
    corrupt(bad, f"motions/{MOTION}")
    before = contents(tmp_path)
    commands = (
        ["plot", str(bad), "--out", "plots"],
        ["export", str(bad), "--format", "csv", "--out", "out/walk"],
        ["simulate", str(bad), "--out", "sim.h5"],
    )
    for argv in commands:
        code, out, err = run(argv, capsys)
        assert_refused(code, err, "bad.h5", word)
        assert out == "" and contents(tmp_path) == before, argv
    code, out, err = run(["dataset", "check", str(bad)], capsys)
    if kind.startswith(("nan", "inf")):  # read, and failed by the check
        assert code == 1 and "FAIL: non_finite_values" in out, out + err
    else:
        assert_refused(code, err, "bad.h5", word)


@pytest.mark.parametrize("content", [b"", b"not an HDF5 file\n", b"\x89HDF\r\n\x1a\n" + bytes(100)])
def test_empty_text_and_truncated_files_are_refused(content, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.h5"
    bad.write_bytes(content)
    for argv in (["dataset", "info", str(bad)], ["dataset", "check", str(bad)], ["plot", str(bad)],
                 ["export", str(bad), "--format", "csv", "--out", "w"], ["reproduce", "--data", str(bad)],
                 ["train", str(bad), "--out", "m.npz"]):
        code, _out, err = run(argv, capsys)
        assert_refused(code, err, "bad.h5")
    assert [p.name for p in tmp_path.iterdir()] == ["bad.h5"]


@pytest.fixture(scope="module")
def dataset_copy(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("dataset") / "dataset.h5"
    shutil.copy(BUNDLED_DATASET, path)
    return path


def _last_motion(path: Path) -> str:
    with h5py.File(path, "r") as f:
        return max(f["motions"])


@pytest.mark.slow
@pytest.mark.parametrize("where", ["signals/values", "q"])
def test_dataset_check_fails_a_nan_that_is_not_in_the_first_motion(where, dataset_copy, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(dataset_copy, bad)
    name = _last_motion(bad)
    with h5py.File(bad, "r+") as f:
        f[f"motions/{name}/{where}"][3, 2] = np.nan
    code, out, err = run(["dataset", "check", str(bad), "--json"], capsys)
    report = json.loads(out)
    assert code == 1 and not report["ok"] and report["failures"] == ["non_finite_values"]
    assert report["worst_in"]["non_finite_values"] == name
    # and the commands that learn from or compare with it refuse it
    code, out, err = run(["train", str(bad), "--out", str(tmp_path / "m.npz"), "--primitives", "2"], capsys)
    assert_refused(code, err, "bad.h5", name)
    code, _, err = run(["reproduce", "--data", str(bad), "--out", str(tmp_path / "r")], capsys)
    assert_refused(code, err, "bad.h5")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.h5"]


@pytest.mark.slow
def test_a_dataset_whose_motion_is_fine_but_fails_the_check_is_refused_by_reproduce(dataset_copy, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(dataset_copy, bad)
    with h5py.File(bad, "r+") as f:
        f[f"motions/{_last_motion(bad)}/tau"][5, 3] *= 3.0  # inverse dynamics no longer agrees
    code, _, err = run(["reproduce", "--data", str(bad), "--out", str(tmp_path / "r")], capsys)
    assert_refused(code, err, "bad.h5", "dataset check")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.h5"]


def test_a_motion_file_is_not_a_dataset(good_motion, tmp_path, capsys):
    for argv in (["reproduce", "--data", str(good_motion), "--out", str(tmp_path / "r")],
                 ["dataset", "info", str(good_motion)], ["train", str(good_motion), "--out", str(tmp_path / "m.npz")]):
        code, _out, err = run(argv, capsys)
        assert_refused(code, err, "motion.h5", "not an OC dataset")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("key, value", [("settings", None), ("settings", json.dumps({"dt": "fast"})),
                                        ("lengths_m", json.dumps(["a"])), ("continuity", json.dumps([1]))])
def test_a_dataset_with_wrong_attributes_is_refused(key, value, dataset_copy, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(dataset_copy, bad)
    with h5py.File(bad, "r+") as f:
        del f.attrs[key]
        if value is not None:
            f.attrs[key] = value
    code, _, err = run(["dataset", "info", str(bad)], capsys)
    assert_refused(code, err, "bad.h5")


@pytest.mark.slow
@pytest.mark.parametrize("argv, words", [
    (["generate", "--lengths-mm", "١٥٠,١٥٠"], ["ASCII"]),
    (["generate", "--dt", "1e-9"], ["--dt", "0.01"]),
    (["generate", "--dt", "0.001"], ["--dt"]),
    (["generate", "--lengths-mm", "799,799"], ["799", "reach"]),
    (["walk", "--lengths-mm", "650,650", "--no-video"], ["650", "reach"]),
    (["train", "--workers", "١"], ["ASCII"]),
    (["train", "--primitives", "٣"], ["whole numbers"]),
])
def test_options_out_of_range_are_refused_before_any_work(argv, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    assert_refused(code, capsys.readouterr().err, *words)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("setting", ["friction", "dt"])
def test_a_null_setting_is_refused_by_dataset_check_in_one_line(setting, dataset_copy, tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    shutil.copy(dataset_copy, bad)
    with h5py.File(bad, "r+") as f:
        settings = json.loads(f.attrs["settings"])
        f.attrs["settings"] = json.dumps(settings | {setting: None})
    code, _, err = run(["dataset", "check", str(bad)], capsys)
    assert_refused(code, err, "bad.h5", f"setting '{setting}'", "None", "not a number")
