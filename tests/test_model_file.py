"""Model files: exact round trip, atomic writes, no unpickling, one clear error per bad file.

Bad files are made from the bundled model (no training): damaged, foreign or other-version
files, and hand-edited ones whose checksum was recomputed, so that only the checks of
content refuse them.
"""

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET, model_path
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.primitives import model_file
from cocomopl.primitives.estimator import MovementPrimitives, PredictedStep
from cocomopl.primitives.model_file import (
    FORMAT_VERSION,
    REQUIRED,
    checksum,
    load_model,
    model_arrays,
    model_metadata,
    save_model,
)

from conftest import assert_one_line_error, run_cli

DATASET = BUNDLED_DATASET
SPEC = StepSpec("cyclic", 0.25, 0.25, "left")
# the selection table as train writes it, with NumPy scalars, which are written as JSON numbers
METADATA = {
    "command": "pytest",
    "versions": {"numpy": np.__version__},
    "selection": [{"n_primitives": np.int64(3), "kernel": "rbf", "bound": np.float64(12.5), "iterations": 30,
                   "explained_variance": {"joints": np.float64(0.9), "zmp": 0.8, "pelvis": 0.7}}],
}


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


@pytest.fixture(scope="module")
def bundled() -> tuple[dict, dict]:
    """The bundled model's arrays and metadata, read once."""
    with np.load(model_path(None), allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    return arrays, json.loads(arrays.pop(model_file.METADATA_KEY).item())


def write(out: Path, arrays: dict, metadata_text: str) -> Path:
    with open(out, "wb") as f:
        np.savez(f, **arrays, __metadata__=np.array(metadata_text))
    return out


def edited(bundled, out: Path, change, fix_checksum: bool = True) -> Path:
    """The bundled model with ``change(arrays, metadata)`` made to copies of them, written to
    ``out`` with the checksum recomputed (by hand-editing, as it were), or the old one kept."""
    arrays = {name: a.copy() for name, a in bundled[0].items()}
    meta = copy.deepcopy(bundled[1])
    change(arrays, meta)
    if fix_checksum:
        meta["checksum"] = checksum(arrays)
    return write(out, arrays, json.dumps(meta))


def test_the_file_holds_every_fitted_array(model):
    fitted = {name[:-1] for name, value in vars(model).items() if name.endswith("_") and isinstance(value, np.ndarray)}
    assert set(REQUIRED) == fitted
    assert len(REQUIRED) == len(set(REQUIRED))


def test_round_trip(model, saved):
    loaded = load_model(saved)
    for name, value in model_arrays(model).items():
        assert isinstance(getattr(loaded, f"{name}_"), np.ndarray), name
        assert getattr(loaded, f"{name}_").dtype == value.dtype, name
        np.testing.assert_array_equal(getattr(loaded, f"{name}_"), value, err_msg=name)
    assert loaded.signal_names_.dtype.kind == "U"
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
    assert meta["checksum"] == model_file.checksum(model_arrays(model))
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

    monkeypatch.setattr(model_file.np, "savez_compressed", interrupted)
    with pytest.raises(KeyboardInterrupt):
        save_model(saved, model, {})
    assert [p.name for p in saved.parent.iterdir()] == [saved.name]
    assert saved.read_bytes() == old


def test_unfitted_model_is_not_saved(tmp_path):
    with pytest.raises(Error, match="not fitted"):
        save_model(tmp_path / "model.npz", MovementPrimitives(), {})
    assert list(tmp_path.iterdir()) == []


def assert_refused(path: Path, *words: str) -> None:
    """Both readers refuse ``path`` with one line ``PATH: ...`` naming every one of ``words``."""
    for read in (load_model, model_metadata):
        with pytest.raises(Error) as info:
            read(path)
        message = str(info.value)
        assert "\n" not in message
        assert message.startswith(f"{path}: "), message
        for word in words:
            assert word in message, message


# ---------------------------------------------------------------------------- damaged or foreign files
def _truncated(bundled, out: Path) -> Path:
    data = model_path(None).read_bytes()
    out.write_bytes(data[: len(data) // 2])
    return out


def _random_bytes(bundled, out: Path) -> Path:
    out.write_bytes(np.random.default_rng(0).bytes(4096))
    return out


def _foreign_npz(bundled, out: Path) -> Path:
    with open(out, "wb") as f:
        np.savez(f, x=np.arange(3))
    return out


def _npy(bundled, out: Path) -> Path:
    with open(out, "wb") as f:
        np.save(f, np.arange(3))
    return out


def _other_format(bundled, out: Path) -> Path:
    return edited(bundled, out, lambda arrays, meta: meta.update(format="something-else"))


def _metadata_text(text: str):
    """A maker of the bundled arrays with ``text`` as the metadata string."""
    return lambda bundled, out: write(out, bundled[0], text)


def _wrong_version(bundled, out: Path) -> Path:
    return edited(bundled, out, lambda arrays, meta: meta.update(format_version=FORMAT_VERSION - 1))


def _tampered(bundled, out: Path) -> Path:
    return edited(bundled, out, lambda arrays, meta: arrays.update(chi=arrays["chi"] + 1.0), fix_checksum=False)


# id: (maker of the file or None for none, words of the message)
BAD_FILES = {
    "missing": (None, ["model file not found"]),
    "directory": ("dir", ["a directory, not a cocomopl model file"]),
    "truncated": (_truncated, ["not a readable NPZ file"]),
    "random_bytes": (_random_bytes, ["not a readable NPZ file"]),
    "foreign_npz": (_foreign_npz, ["not a cocomopl model file"]),
    "npy": (_npy, ["not a cocomopl model file"]),
    "other_format": (_other_format, ["not a cocomopl model file"]),
    "metadata_not_json": (_metadata_text("{not json"), ["not a cocomopl model file"]),
    # json.loads recurses: this raises RecursionError, not a decoding error
    "metadata_nested_deeply": (_metadata_text("[" * 100_000 + "]" * 100_000), ["not a cocomopl model file"]),
    "wrong_version": (_wrong_version, [f"format version {FORMAT_VERSION - 1};", f"reads version {FORMAT_VERSION}",
                                       "cocomopl train"]),
    "tampered": (_tampered, ["corrupted, checksum mismatch"]),
}


@pytest.mark.parametrize("make, words", BAD_FILES.values(), ids=BAD_FILES.keys())
def test_bad_files(bundled, tmp_path, make, words):
    path = tmp_path / "bad.npz"
    if make == "dir":
        path.mkdir()
    elif make is not None:
        make(bundled, path)
    assert_refused(path, *words)


# ---------------------------------------------------------------------------- hand-edited content
def replace(name: str, new):
    """An edit: array ``name`` becomes ``new(array)``."""
    return lambda arrays, meta: arrays.update({name: new(arrays[name])})


def assign(name: str, index, value):
    """An edit: ``array[index] = value`` in array ``name``."""

    def change(arrays, meta):
        arrays[name][index] = value

    return change


def both(first, second):
    """An edit: ``first``, then ``second``."""
    return lambda arrays, meta: (first(arrays, meta), second(arrays, meta))


def set_meta(key: str, value):
    return lambda arrays, meta: meta.update({key: value})


def drop_type(type_: str):
    """An edit: the step type ``type_`` removed from every array with a step-type axis."""

    def change(arrays, meta):
        g = list(arrays["types"]).index(type_)
        for name, (_, axes, _) in model_file.ARRAYS.items():
            if "G" in axes:
                arrays[name] = np.delete(arrays[name], g, axis=axes.index("G"))

    return change


def swap_signals(i: int, j: int):
    def change(arrays, meta):
        names = arrays["signal_names"]
        names[[i, j]] = names[[j, i]]

    return change


# id: (edit, words of the message).  The bundled model has 11 primitives, 100 grid points,
# 36 signals (30 joints, then the ZMP and the pelvis angles) and 10 step types, the first
# cyclic_left with training steps of 150 mm and up.
EDITS = {
    "missing_array": (lambda arrays, meta: arrays.pop("dur_K_inv"), ["lacks the model arrays dur_K_inv"]),
    "wrong_shape": (replace("chi", lambda a: a[:, :, :3]),
                    ["array 'chi' has shape (36, 11, 3), expected (36, 11, 10)",
                     "for 36 signals, 11 primitives and 10 step types"]),
    "wrong_ndim": (replace("m", lambda a: a[None]),
                   ["array 'm' has shape (1, 11, 100), expected 2 dimensions (primitives, grid points)"]),
    "floats_as_integers": (replace("tau", lambda a: a.astype(np.int64)),
                           ["array 'tau' has dtype int64, expected floating-point numbers"]),
    "counts_as_floats": (replace("n_phases", lambda a: a.astype(float)),
                         ["array 'n_phases' has dtype float64, expected integers"]),
    "names_as_bytes": (replace("signal_names", lambda a: a.astype(bytes)),
                       ["array 'signal_names' has dtype |S17, expected unicode text"]),
    "flags_as_floats": (replace("unconditioned", lambda a: a.astype(float)),
                        ["array 'unconditioned' has dtype float64, expected booleans"]),
    "nan": (assign("beta", (0, 0, 0, 0), np.nan), ["array 'beta' holds nan at (0, 0, 0, 0), expected finite numbers"]),
    "inf": (assign("dur_K_inv", (1, 0, 2, 2), -np.inf), ["array 'dur_K_inv' holds -inf at (1, 0, 2, 2)"]),
    "primitives_in_metadata": (set_meta("n_primitives", 15),
                               ["array 'm' has shape (11, 100), expected (15, 100)",
                                "for 15 primitives and 100 grid points"]),
    "primitives_in_one_array": (replace("alpha_t", lambda a: a[:-1]),
                                ["array 'alpha_t' has shape (10,), expected (11,) for 11 primitives"]),
    "grid_in_metadata": (set_meta("n_grid", 50), ["array 'tau' has shape (100,), expected (50,) for 50 grid points"]),
    "negative_length_scale": (assign("ell_t", 3, -0.1), ["array 'ell_t' holds -0.1 at (3,), expected positive values"]),
    "zero_kernel_variance": (assign("alpha_w", (2, 1), 0.0), ["array 'alpha_w' holds 0 at (2, 1), expected positive"]),
    "negative_distance": (assign("support_radius", 4, -1.0), ["array 'support_radius' holds -1", "non-negative"]),
    "four_step_parameters": (replace("lengths", lambda a: np.zeros((*a.shape[:2], 4))),
                             ["array 'lengths' holds 4 step parameters, expected 2 (start and end length) or 6"]),
    "backward_straight_step": (assign("lengths", (0, 0, 0), -0.15), ["array 'lengths' holds -0.15", "non-negative"]),
    "unknown_kernel": (set_meta("kernel", "cubic"),
                       ["metadata 'kernel' is", '"cubic", expected one of rbf, matern32, matern52']),
    "count_as_text": (set_meta("n_primitives", "11"),
                      ["metadata 'n_primitives' is", '"11", expected a whole number >= 1']),
    "count_as_boolean": (set_meta("n_iter", True), ["metadata 'n_iter' is true, expected a whole number >= 0"]),
    "one_grid_point": (set_meta("n_grid", 1), ["metadata 'n_grid' is 1, expected a whole number >= 2"]),
    "nan_bound": (set_meta("bound", float("nan")), ["metadata 'bound' is NaN, expected a finite number"]),
    "missing_metadata": (lambda arrays, meta: meta.pop("bound"), ["metadata lacks 'bound'"]),
    "signal_group_scores": (lambda arrays, meta: meta["explained_variance"].pop("zmp"),
                            ["metadata 'explained_variance' is", "expected finite numbers for joints, zmp, pelvis"]),
    "unknown_robot": (set_meta("robot", "nao"), ["metadata 'robot': unknown robot 'nao'"]),
    "robot_as_number": (set_meta("robot", 3), ["metadata 'robot' is 3, expected a robot name"]),
    "selection_row": (lambda arrays, meta: meta["selection"][1].update(iterations="many"),
                      ["metadata 'selection' row 2 'iterations' is", '"many", expected a whole number >= 0']),
    "dataset_as_text": (set_meta("dataset", "bundled"), ["metadata 'dataset' is", '"bundled", expected an object']),
    "dataset_steps": (lambda arrays, meta: meta["dataset"].update(steps=63),
                      ["metadata 'dataset' 'steps' is 63, but the arrays hold 64 training steps"]),
    "signal_order": (swap_signals(0, 30), ["array 'signal_names' must end with zmp_x, zmp_y, zmp_z, pelvis_roll"]),
    "unconditioned_joint": (assign("unconditioned", 0, True),
                            ["array 'unconditioned' must mark the signals zmp_x, zmp_y, zmp_z and no other"]),
    "unknown_type": (assign("types", 0, "hop_left"), ["array 'types' holds 'hop_left', not a step type"]),
    "stop_without_its_second_part": (drop_type("stop_left_part2"),
                                     ["array 'types' holds 'stop_left_part1' but not 'stop_left_part2'"]),
    "phase_count": (assign("n_phases", 0, 3), ["array 'n_phases' gives cyclic_left 3 phases, expected 2"]),
    "phase_boundaries": (assign("boundaries", (0, 1), 1.5),
                         ["array 'boundaries' row 0 (cyclic_left) must rise strictly from 0 to 1 over its 3 values"]),
    "mask_gap": (assign("mask", (0, 0), 0.0), ["array 'mask' row 0 (cyclic_left) must be 1 for at least one"]),
    "grid_reversed": (replace("tau", lambda a: a[::-1].copy()), ["array 'tau' must rise strictly from 0 to 1"]),
    "duration_of_hours": (assign("dur_mean", (0, 1), 10.0),
                          ["the model predicts 2.2e+04 s for phase 1 of its training step cyclic_150_L",
                           "expected 0.001 to 60 s"]),
    "huge_weights": (replace("chi", lambda a: a * 1e6), ["the model predicts", "of its training step cyclic_150_L",
                                                         "expected at most 100 (rad or m)"]),
    # primitives that are zero and certain at the start: a conditioned start is 0 / 0
    "primitives_vanish_at_start": (both(assign("m", (slice(None), 0), 0.0), assign("m_cov_start", (slice(None), 0), 0.0)),
                                   ["the model predicts nan for signal"]),
}


@pytest.mark.parametrize("edit, words", EDITS.values(), ids=EDITS.keys())
def test_hand_edited_files(bundled, tmp_path, edit, words):
    path = edited(bundled, tmp_path / "bad.npz", edit)
    assert_refused(path, *words)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["duration_of_hours"])  # the other edits are refused in-process above
def test_cli_refuses_hand_edited_files(bundled, tmp_path, case):
    bad = edited(bundled, tmp_path / "bad.npz", EDITS[case][0])
    for args in (["model", "info", str(bad)], ["generate", "--model", str(bad), "--out", str(tmp_path / "x.h5")]):
        result = run_cli(*args, cwd=tmp_path)
        assert result.returncode == 2, result.stderr
        assert result.stderr.startswith(f"cocomopl: error: {bad}: "), result.stderr
        assert_one_line_error(result, *EDITS[case][1])
    assert [p.name for p in tmp_path.iterdir()] == ["bad.npz"]


def test_bundled_model_passes(bundled):
    model = load_model(model_path(None))
    assert model.n_primitives == bundled[1]["n_primitives"] and model.metadata_["robot"] == "talos"
    assert np.all(np.isfinite(model.predict(StepSpec("stop", 0.25, 0.0, "right")).values))
    # the loaded model holds the file's arrays as they are (benchmarks/bench_primitives.py times the read)
    assert checksum(model_arrays(model)) == bundled[1]["checksum"]


def test_sound_edits_pass(bundled, tmp_path):
    """Edits that keep the model sound pass: the checks are of content, not of bytes."""

    def change(arrays, meta):
        meta.update(command="by hand", extra={"note": [1, 2]})
        arrays["chi"] += 1e-3  # a millimetre or milliradian on every signal
        arrays["dur_mean"][0] += 0.1

    path = edited(bundled, tmp_path / "edited.npz", change)
    model = load_model(path)
    assert model.metadata_["command"] == "by hand" and model.metadata_["extra"] == {"note": [1, 2]}


def test_the_reading_check_predicts_start_steps_from_rest_as_a_walk_does(monkeypatch):
    """A start step's start has almost no variance (every one begins in the same posture):
    conditioned on another step's end, which no walk does, a model fitted on three lengths
    predicted 103 rad and was refused although it explains 99.99 % of its data."""
    predicted, conditioned = [], []
    predict_many, conditioned_on = MovementPrimitives.predict_many, PredictedStep.conditioned_on

    def recording_predictions(self, specs):
        predicted.extend(spec.kind for spec in specs)
        return predict_many(self, specs)

    def recording_conditions(self, start):
        conditioned.append(self.spec.kind)
        return conditioned_on(self, start)

    monkeypatch.setattr(MovementPrimitives, "predict_many", recording_predictions)
    monkeypatch.setattr(PredictedStep, "conditioned_on", recording_conditions)
    load_model(model_path(None))
    assert set(predicted) == {"start", "cyclic", "transition", "stop"}
    assert set(conditioned) == {"cyclic", "transition", "stop"}


def test_a_model_of_a_robot_of_ones_own_carries_its_description(model, tmp_path):
    """Without a recorded description a robot name must be a bundled one; with it, the model
    rebuilds the robot from the file alone."""
    from cocomopl.primitives.model_file import model_robot
    from cocomopl.robot import Robot

    with pytest.raises(Error, match="metadata 'robot': unknown robot 'mybot'"):
        save_model(tmp_path / "nameless.npz", model, {"robot": "mybot"})
        load_model(tmp_path / "nameless.npz")
    described = {**Robot("talos").description, "name": "mybot"}
    save_model(tmp_path / "mybot.npz", model, {"robot": "mybot", "robot_description": described})
    robot = model_robot(load_model(tmp_path / "mybot.npz"))
    assert robot.name == "mybot" and robot.joint_names == Robot("talos").joint_names


@pytest.mark.slow  # the benchmark runs in a new process
def test_the_random_walks_benchmark_takes_a_model_of_ones_own_robot(model, tmp_path):
    """``benchmarks/random_walks.py`` builds the robot from the model, its recorded
    description included: a robot that is not bundled draws its walks in its own range."""
    import subprocess
    import sys

    from cocomopl.robot import Robot

    described = {**Robot("talos").description, "name": "mybot"}
    save_model(tmp_path / "mybot.npz", model, {"robot": "mybot", "robot_description": described})
    benchmark = Path(__file__).parents[1] / "benchmarks" / "random_walks.py"
    result = subprocess.run([sys.executable, str(benchmark), "--model", str(tmp_path / "mybot.npz"), "--n", "3",
                             "--dry-run", "--json"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    lengths = np.array([walk["lengths_mm"] for walk in json.loads(result.stdout)["walks"]])
    assert lengths.shape == (3, 9) and lengths.min() >= 150 and lengths.max() <= 400  # TALOS's range: mybot is TALOS
