"""Model files: exact round trip, atomic writes, no unpickling, one clear error per bad file."""

import json
from pathlib import Path

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives import model_file
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.model_file import (
    FORMAT_VERSION,
    REQUIRED,
    load_model,
    model_metadata,
    save_model,
)

DATASET = BUNDLED_DATASET
SPEC = StepSpec("cyclic", 0.25, 0.25, "left")
METADATA = {"command": "pytest", "versions": {"numpy": np.__version__}, "selection": [[3, "rbf", 0.9]]}


@pytest.fixture(scope="module")
def model() -> MovementPrimitives:
    from cocomopl.primitives.training import load_training_steps

    steps = load_training_steps(DATASET)
    keep = [k for k, spec in enumerate(steps.specs) if spec.kind in ("cyclic", "transition")]
    return MovementPrimitives(n_primitives=3, kernel="rbf", n_grid=30, max_iterations=30).fit(steps.subset(keep))


@pytest.fixture
def saved(model, tmp_path) -> Path:
    path = tmp_path / "model.npz"
    save_model(path, model, METADATA)
    return path


def resave(path: Path, out: Path, change_arrays=None, change_meta=None) -> Path:
    """Copy a model file, changing its arrays and/or metadata but not the stored checksum."""
    with np.load(path, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    meta = json.loads(arrays.pop(model_file.METADATA_KEY).item())
    if change_arrays:
        change_arrays(arrays)
    if change_meta:
        change_meta(meta)
    with open(out, "wb") as f:
        np.savez(f, **arrays, __metadata__=np.array(json.dumps(meta)))
    return out


def test_required_matches_fitted_state(model):
    assert set(REQUIRED) == set(model.state_)
    assert len(REQUIRED) == len(set(REQUIRED))


def test_round_trip(model, saved):
    loaded = load_model(saved)
    assert set(loaded.state_) == set(model.state_)
    for name, value in model.state_.items():
        assert isinstance(loaded.state_[name], np.ndarray), name
        assert loaded.state_[name].dtype == np.asarray(value).dtype, name
        np.testing.assert_array_equal(loaded.state_[name], value, err_msg=name)
    assert loaded.state_["signal_names"].dtype.kind == "U"
    for attr in ("n_primitives", "kernel", "n_grid", "max_iterations", "bound_", "n_iter_", "fit_time_s_",
                 "explained_variance_"):
        assert getattr(loaded, attr) == getattr(model, attr), attr
    before, after = model.predict(SPEC), loaded.predict(SPEC)
    np.testing.assert_array_equal(after.values, before.values)
    np.testing.assert_array_equal(after.durations, before.durations)
    start = before.values[-1]
    np.testing.assert_array_equal(loaded.predict(SPEC, start).values, model.predict(SPEC, start).values)
    assert loaded.metadata_["command"] == "pytest"


def test_metadata(model, saved):
    meta = model_metadata(saved)
    assert meta["format"] == "cocomopl-model" and meta["format_version"] == FORMAT_VERSION
    assert meta["checksum"] == model_file.checksum(model.state_)
    assert (meta["n_primitives"], meta["kernel"], meta["n_grid"]) == (3, "rbf", 30)
    assert meta["bound"] == model.bound_ and meta["n_iter"] == model.n_iter_
    assert meta["explained_variance"] == model.explained_variance_
    for key, value in METADATA.items():
        assert meta[key] == value


def test_loads_without_pickle(saved):
    with np.load(saved, allow_pickle=False) as data:
        assert set(data.files) == {*REQUIRED, "__metadata__"}
        for name in data.files:
            assert not data[name].dtype.hasobject, name


@pytest.mark.parametrize("name", ["model.npz", "model.bin", "model"])
def test_no_temp_files_and_exact_name(model, tmp_path, name):
    save_model(tmp_path / name, model, {})
    save_model(tmp_path / name, model, {})  # overwriting too
    assert [p.name for p in tmp_path.iterdir()] == [name]
    load_model(tmp_path / name)


def test_failed_save_leaves_no_file(model, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(Error, match="cannot write model file"):
        save_model(blocker / "model.npz", model, {})
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_interrupted_save_keeps_old_file(model, saved, monkeypatch):
    old = saved.read_bytes()

    def interrupted(file, **arrays):
        file.write(b"PK\x03\x04 half an archive")
        raise KeyboardInterrupt

    monkeypatch.setattr(model_file.np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        save_model(saved, model, {})
    assert [p.name for p in saved.parent.iterdir()] == [saved.name]
    assert saved.read_bytes() == old


def test_unfitted_model_is_not_saved(tmp_path):
    with pytest.raises(Error, match="not fitted"):
        save_model(tmp_path / "model.npz", MovementPrimitives(), {})
    assert list(tmp_path.iterdir()) == []


def _truncated(saved: Path, out: Path) -> Path:
    data = saved.read_bytes()
    out.write_bytes(data[: len(data) // 2])
    return out


def _random_bytes(saved: Path, out: Path) -> Path:
    out.write_bytes(np.random.default_rng(0).bytes(4096))
    return out


def _foreign_npz(saved: Path, out: Path) -> Path:
    with open(out, "wb") as f:
        np.savez(f, x=np.arange(3))
    return out


def _npy(saved: Path, out: Path) -> Path:
    with open(out, "wb") as f:
        np.save(f, np.arange(3))
    return out


def _other_format(saved: Path, out: Path) -> Path:
    return resave(saved, out, change_meta=lambda meta: meta.update(format="something-else"))


def _bad_metadata_json(saved: Path, out: Path) -> Path:
    with np.load(saved, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["__metadata__"] = np.array("{not json")
    with open(out, "wb") as f:
        np.savez(f, **arrays)
    return out


def _wrong_version(saved: Path, out: Path) -> Path:
    return resave(saved, out, change_meta=lambda meta: meta.update(format_version=FORMAT_VERSION - 1))


def _tampered(saved: Path, out: Path) -> Path:
    def change(arrays):
        arrays["chi"] = arrays["chi"] + 1.0

    return resave(saved, out, change_arrays=change)


def _missing_array(saved: Path, out: Path) -> Path:
    def change(arrays):
        del arrays["dur_K_inv"]

    def fix_checksum(meta):
        with np.load(saved, allow_pickle=False) as data:
            kept = {name: data[name] for name in data.files if name not in ("dur_K_inv", "__metadata__")}
        meta["checksum"] = model_file.checksum(kept)

    return resave(saved, out, change_arrays=change, change_meta=fix_checksum)


def _missing_metadata_entry(saved: Path, out: Path) -> Path:
    return resave(saved, out, change_meta=lambda meta: meta.pop("bound"))


@pytest.mark.parametrize(
    "make, words",
    [
        (None, ["model file not found"]),
        ("dir", ["is a directory"]),
        (_truncated, ["not a readable NPZ file"]),
        (_random_bytes, ["not a readable NPZ file"]),
        (_foreign_npz, ["not a cocomopl model file"]),
        (_npy, ["not a cocomopl model file"]),
        (_other_format, ["not a cocomopl model file"]),
        (_bad_metadata_json, ["not a cocomopl model file"]),
        (_wrong_version, [f"has format version {FORMAT_VERSION - 1}; this cocomopl reads version {FORMAT_VERSION}", "cocomopl train"]),
        (_tampered, ["is corrupted: checksum mismatch"]),
        (_missing_array, ["lacks the model arrays dur_K_inv"]),
        (_missing_metadata_entry, ["incomplete or invalid metadata", "bound"]),
    ],
)
def test_bad_files(saved, make, words):
    path = saved.parent / "bad.npz"
    if make == "dir":
        path.mkdir()
    elif make is not None:
        make(saved, path)
    readers = [load_model] if make is _missing_metadata_entry else [load_model, model_metadata]
    for read in readers:
        with pytest.raises(Error) as info:
            read(path)
        message = str(info.value)
        assert "\n" not in message
        assert str(path) in message
        for word in words:
            assert word in message
