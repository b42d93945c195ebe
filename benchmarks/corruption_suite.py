"""A hostile, careless user: how does ``cocomopl`` take corrupted files and absurd arguments?

Builds, in a temporary folder, corrupted copies of the bundled dataset and model and of a
small generated walk (``cocomopl generate``, M_gen), and runs the commands that read each
one, each in a fresh working folder with only its inputs.  A *case* is one command run on
one input.  The corruptions:

* motion files (the walk, and one motion of the dataset that is not its first): NaN or Inf
  at one sample of an array, arrays of the wrong shape or dtype, time that goes backwards,
  sample indices (impacts, step starts, phases) out of range or negative, missing arrays,
  missing or wrongly typed attributes, an unknown robot or joint names not the robot's;
* datasets: NaN in the training signals, signals of the wrong shape, no ``settings``, no
  motions, a motion file where a dataset is expected;
* models: arrays of the wrong shape or dtype or with NaN (the checksum recomputed, so the
  corruption gets past it), metadata of the wrong type or value;
* any file: truncated, empty, or text;
* arguments: non-ASCII digits, absurd sample spacing, step lengths or worker counts, an
  output that is the input, an over-long output name, an output in a read-only folder.

The motion corruptions are read by ``dataset check`` and, in turn, by ``plot`` or ``export``;
the other inputs by the commands listed with them (every reader of every input would take
well over the time budget: a run costs 2-10 s, most of it starting Python and cocomopl).

Each run is classified:

* ``clean``: refused as the CLI promises (docs/cli.md, "Exit status"): a non-zero exit, the
  last line of stderr starting with ``cocomopl: error:``, no traceback, and nothing written:
  no file or folder added to or removed from the working folder, the inputs unchanged.
* ``accepted``: exit 0 on an invalid input.
* ``traceback``: a Python traceback on stderr.
* ``wrote``: refused with the one-line error, but a file or folder was left behind or an
  input changed.
* ``timeout``: still running after the case's time limit (then killed).
* ``crash``: killed by a signal (e.g. a segmentation fault).
* ``clean`` too: ``dataset check`` failing a NaN or Inf by name (exit 1, ``FAIL:
  non_finite_values``), which is how that command reports them.
* ``unclear``: a non-zero exit without the one-line error (e.g. ``dataset check`` exit 1,
  reporting violations computed from the garbage instead of refusing the file).

A few cases are valid inputs (``expect`` "ok": controls that the harness and the rebuilt
files work) and pass when they exit 0; ``rejected`` is their failure.  Cases whose outcome
may be a refusal or a success (``expect`` "either": a documented value that is merely
extreme) pass with either a clean refusal or exit 0.

Every run gets at most ``MEMORY_LIMIT_BYTES`` of address space, so an absurd argument
cannot take the shared machine's memory (a refused allocation shows as a traceback).
``train`` runs with one candidate in one worker process (``--primitives 2 --kernels rbf
--workers 1 --max-iterations 1``).  ``simulate``, ``walk`` and ``reproduce`` are slow and
run on a handful of inputs only; ``--quick`` skips them.

Usage::

    python benchmarks/corruption_suite.py [--quick] [--json] [--out FILE.json] [--only TEXT] [--list] [--keep]

Run from anywhere; it uses the ``cocomopl`` importable by this Python (``PYTHONPATH``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

MEMORY_LIMIT_BYTES = 6 * 1024**3
DEFAULT_TIMEOUT_S = 300.0
SLOW_TIMEOUT_S = 240.0
# the dataset motion that is corrupted: not the first in any order, and one of M_opt's steps,
# so `reproduce --data` reuses it instead of solving an OCP
TARGET_MOTION = "transition_250_350_R"
FILE_NAMES = {"walk": "walk.h5", "dataset": "ds.h5", "model": "m.npz"}
# an existing folder that cannot be written: a chmod 555 one in the case's folder, or for
# root, who ignores permission bits, /proc (nothing can be created in it)
READONLY_ROOT = os.geteuid() == 0
READONLY_DIR = "/proc" if READONLY_ROOT else "readonly"
LONG_NAME = "x" * 250
FAILURE_CLASSES = ("accepted", "traceback", "wrote", "timeout", "crash", "unclear", "rejected")


# ============================================================================ corruptions
# A corruption edits a copy of a base file in place: ``corrupt(path)``.
Corrupt = Callable[[Path], None]


def _motion_group(f: h5py.File) -> h5py.Group:
    """The motion a corruption edits: a walk's only one, or ``TARGET_MOTION`` of a dataset."""
    names = list(f["motions"])
    return f["motions"][names[0] if len(names) == 1 else TARGET_MOTION]


def in_file(edit: Callable[[h5py.File], None]) -> Corrupt:
    """A corruption made by ``edit(file)`` on the HDF5 file opened for writing."""

    def corrupt(path: Path) -> None:
        with h5py.File(path, "r+") as f:
            edit(f)

    return corrupt


def in_motion(edit: Callable[[h5py.Group], None]) -> Corrupt:
    """A corruption made by ``edit(group)`` on the edited motion's group."""
    return in_file(lambda f: edit(_motion_group(f)))


def replaced(key: str, transform: Callable[[np.ndarray, h5py.Group], np.ndarray]) -> Corrupt:
    """The motion's array ``key`` (``signals/values`` for a nested one) replaced by
    ``transform(array, group)``."""

    def edit(group: h5py.Group) -> None:
        new = transform(group[key][()].copy(), group)
        del group[key]
        group.create_dataset(key, data=new)

    return in_motion(edit)


def deleted(key: str) -> Corrupt:
    """The motion's array ``key`` removed."""

    def edit(group: h5py.Group) -> None:
        del group[key]

    return in_motion(edit)


def _attr_edit(key: str, value) -> Callable:
    """An edit of an HDF5 object's attribute ``key``: set to ``value``, or removed if None."""

    def edit(node) -> None:
        if value is None:
            del node.attrs[key]
        else:
            node.attrs[key] = value

    return edit


def motion_attr(key: str, value) -> Corrupt:
    """The motion's attribute ``key`` set to ``value``, or removed if ``value`` is None."""
    return in_motion(_attr_edit(key, value))


def motion_steps(transform: Callable[[list], list]) -> Corrupt:
    """The motion's ``steps`` JSON replaced by ``transform(steps)`` (NaN written as JSON's ``NaN``)."""

    def edit(group: h5py.Group) -> None:
        group.attrs["steps"] = json.dumps(transform(json.loads(group.attrs["steps"])))

    return in_motion(edit)


def file_attr(key: str, value) -> Corrupt:
    """The file's attribute ``key`` set to ``value``, or removed if ``value`` is None."""
    return in_file(_attr_edit(key, value))


def both(*corruptions: Corrupt) -> Corrupt:
    """The corruptions one after the other."""

    def corrupt(path: Path) -> None:
        for c in corruptions:
            c(path)

    return corrupt


def pushing_sample(group: h5py.Group, n: int) -> int:
    """A sample near the middle of an array of ``n`` samples at which a foot pushes on the
    ground and that is no impact, so a NaN ZMP there is not the legal "no foot pushes" NaN."""
    candidates = np.arange(2, n - 2)
    if "wrenches" in group and len(group["wrenches"]) == n:
        fz = group["wrenches"][()][:, :, 2].sum(axis=1)
        impacts = set(group["impacts"][()].tolist()) if "impacts" in group else set()
        candidates = [k for k in candidates if fz[k] > 10 and k not in impacts and k - 1 not in impacts]
    return int(min(candidates, key=lambda k: abs(k - n // 2)))


def at_sample(key: str, value: float) -> Corrupt:
    """``value`` (NaN, Inf) at one sample of array ``key``: the sample's largest element."""

    def transform(a: np.ndarray, group: h5py.Group) -> np.ndarray:
        a = a.astype(float)
        k = pushing_sample(group, len(a))
        if a.ndim == 1:
            a[k] = value
        else:
            row = a[k]  # a view
            row.flat[int(np.argmax(np.abs(row)))] = value
        return a

    return replaced(key, transform)


def index_set(key: str, position: int, value: Callable[[int], int]) -> Corrupt:
    """Entry ``position`` of the index array ``key`` set to ``value(n)``, n the motion's samples."""

    def transform(a: np.ndarray, group: h5py.Group) -> np.ndarray:
        a[position] = value(len(group["t"]))
        return a

    return replaced(key, transform)


def decreasing_time(t: np.ndarray, group: h5py.Group) -> np.ndarray:
    """Time that jumps back 0.1 s at one sample (not an impact's legal repeat)."""
    t[pushing_sample(group, len(t))] -= 0.1
    return t


def truncated(path: Path) -> None:
    """The first half of the file's bytes."""
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def emptied(path: Path) -> None:
    """An empty file."""
    path.write_bytes(b"")


def text(path: Path) -> None:
    """A text file of the same name."""
    path.write_text("time,q\n0.0,1.0\nthis is not HDF5 nor NPZ\n")


def in_model(edit: Callable[[dict, dict], None]) -> Corrupt:
    """A model corruption made by ``edit(arrays, metadata)``; the checksum is then
    recomputed (``model_file.checksum``), so the corruption reaches the checks behind it."""
    def corrupt(path: Path) -> None:
        from cocomopl.primitives.model_file import METADATA_KEY, checksum

        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        meta = json.loads(arrays.pop(METADATA_KEY).item())
        edit(arrays, meta)
        meta["checksum"] = checksum(arrays)
        with open(path, "wb") as f:
            np.savez(f, **arrays, **{METADATA_KEY: np.array(json.dumps(meta))})

    return corrupt


def model_array(name: str, transform: Callable[[np.ndarray], np.ndarray]) -> Corrupt:
    """The model array ``name`` replaced by ``transform(array)``."""

    def edit(arrays: dict, meta: dict) -> None:
        arrays[name] = transform(arrays[name].copy())

    return in_model(edit)


def model_meta(key: str, value) -> Corrupt:
    """The model metadata's ``key`` set to ``value``."""

    def edit(arrays: dict, meta: dict) -> None:
        meta[key] = value

    return in_model(edit)


def first_nan(a: np.ndarray, value: float = np.nan) -> np.ndarray:
    """``value`` at the middle element of an array."""
    a = a.astype(float)
    a.flat[a.size // 2] = value
    return a


def unchanged(path: Path) -> None:
    """No corruption (a control)."""


# ============================================================================ inputs and commands
@dataclass(frozen=True)
class Input:
    """A file placed in a case's working folder: a copy of base ``walk``, ``dataset`` or
    ``model``, corrupted by ``corrupt``; ``name`` identifies it (and its cached build)."""

    name: str
    base: str
    corrupt: Corrupt = unchanged

    @property
    def file(self) -> str:
        return FILE_NAMES[self.base]


@dataclass(frozen=True)
class Command:
    """A ``cocomopl`` command line reading a file: ``args(file)``."""

    label: str
    args: Callable[[str], list[str]]
    slow: bool = False
    timeout: float = DEFAULT_TIMEOUT_S


TRAIN_ARGS = ["--primitives", "2", "--kernels", "rbf", "--max-iterations", "1", "--workers", "1"]

CHECK = Command("dataset check", lambda f: ["dataset", "check", f])
INFO = Command("dataset info", lambda f: ["dataset", "info", f])
PLOT = Command("plot", lambda f: ["plot", f, "--out", "plots"])
EXPORT = Command("export", lambda f: ["export", f, "--format", "csv", "--out", "out"])
PLOT_TARGET = Command("plot", lambda f: ["plot", f, "--motion", TARGET_MOTION, "--out", "plots"])
EXPORT_TARGET = Command("export", lambda f: ["export", f, "--motion", TARGET_MOTION, "--format", "csv", "--out", "out"])
TRAIN = Command("train", lambda f: ["train", f, "--out", "model.npz", *TRAIN_ARGS])
MODEL_INFO = Command("model info", lambda f: ["model", "info", f])
GENERATE = Command("generate", lambda f: ["generate", "--model", f, "--out", "gen.h5"])
SIMULATE = Command("simulate", lambda f: ["simulate", f, "--out", "sim.h5"], slow=True, timeout=SLOW_TIMEOUT_S)
WALK = Command("walk", lambda f: ["walk", "--model", f, "--out", "report", "--no-video"], slow=True,
               timeout=SLOW_TIMEOUT_S)
REPRODUCE_DATA = Command("reproduce --data", lambda f: ["reproduce", "--data", f, "--out", "report"], slow=True,
                         timeout=SLOW_TIMEOUT_S)
REPRODUCE_MODEL = Command("reproduce --model", lambda f: ["reproduce", "--model", f, "--out", "report"], slow=True,
                          timeout=SLOW_TIMEOUT_S)

MOTION_CONSUMERS = (PLOT, EXPORT)
DATASET_READERS = (CHECK, INFO, PLOT_TARGET, EXPORT_TARGET)
MODEL_READERS = (MODEL_INFO, GENERATE)


@dataclass(frozen=True)
class Case:
    """One run: ``cocomopl argv`` in a fresh folder holding ``inputs``.

    ``expect``: "error" (an invalid input, to be refused cleanly), "ok" (a valid one, to
    succeed) or "either".  ``kind`` groups cases in the summary.
    """

    name: str
    kind: str
    argv: tuple[str, ...]
    inputs: tuple[Input, ...] = ()
    slow: bool = False
    timeout: float = DEFAULT_TIMEOUT_S
    expect: str = "error"


def cases_of(kind: str, source: Input, commands: tuple[Command, ...], expect: str = "error") -> list[Case]:
    """One case per command reading ``source``."""
    return [Case(f"{source.name} | {c.label}", kind, tuple(c.args(source.file)), (source,), c.slow, c.timeout, expect)
            for c in commands]


# ---------------------------------------------------------------------------- the suite
NAN, INF = float("nan"), float("inf")


def motion_corruptions() -> list[tuple[str, str, Corrupt, tuple[Command, ...]]]:
    """(kind, name, corruption, extra commands) of the walk: each is also read by
    ``MOTION_READERS``; the extra commands are the slow ones, on a handful."""
    return [
        *[("nan", f"{key}.nan", at_sample(key, NAN), (SIMULATE,) if key == "q" else ())
          for key in ("t", "q", "v", "tau", "wrenches", "zmp")],
        *[("inf", f"{key}.inf", at_sample(key, INF), (SIMULATE,) if key == "wrenches" else ())
          for key in ("q", "wrenches")],
        ("shape", "q.drop-column", replaced("q", lambda a, g: a[:, :-1]), (SIMULATE,)),
        ("shape", "tau.extra-dim", replaced("tau", lambda a, g: a[:, :, None]), ()),
        ("shape", "t.one-short", replaced("t", lambda a, g: a[:-1]), ()),
        ("dtype", "q.strings", replaced("q", lambda a, g: a.astype("S24")), ()),
        ("dtype", "q.ints", replaced("q", lambda a, g: np.round(a).astype(np.int64)), ()),
        ("dtype", "impacts.fractional", replaced("impacts", lambda a, g: a + 0.5), ()),
        ("time", "t.decreasing", replaced("t", decreasing_time), (SIMULATE,)),
        ("time", "t.constant", replaced("t", lambda a, g: np.zeros_like(a)), ()),
        ("index", "impacts.out-of-range", index_set("impacts", -1, lambda n: n + 5), ()),
        ("index", "impacts.negative", index_set("impacts", 0, lambda n: -3), ()),
        ("index", "step_starts.out-of-range", index_set("step_starts", -1, lambda n: n + 5), ()),
        ("index", "phase_last.out-of-range", index_set("phase_last", -1, lambda n: n + 10), ()),
        ("index", "phase_first.negative", index_set("phase_first", -1, lambda n: -5), ()),
        ("missing", "zmp.missing", deleted("zmp"), ()),
        ("attrs", "robot.number", motion_attr("robot", 42), ()),
        ("attrs", "joint_names.not-json", motion_attr("joint_names", "leg_left_1_joint, leg_left_2_joint"), ()),
        ("attrs", "steps.bad-kind", motion_steps(lambda s: [{**s[0], "kind": "hop"}, *s[1:]]), ()),
        ("attrs", "steps.nan-length", motion_steps(lambda s: [*s[:-1], {**s[-1], "start_length": NAN}]), ()),
        ("attrs", "steps.one-fewer", motion_steps(lambda s: s[:-1]), ()),
        ("attrs", "file-robot.number", file_attr("robot", 42), ()),
        ("robot", "robot.unknown", both(motion_attr("robot", "asimo"), file_attr("robot", "asimo")), ()),
        ("robot", "robot.romeo", both(motion_attr("robot", "romeo"), file_attr("robot", "romeo")), (SIMULATE,)),
        ("robot", "joint_names.foreign", in_motion(_rename_first_joint), ()),
        ("file", "truncated", truncated, ()),
        ("file", "empty", emptied, ()),
        ("file", "text", text, ()),
    ]


def _rename_first_joint(group: h5py.Group) -> None:
    names = json.loads(group.attrs["joint_names"])
    group.attrs["joint_names"] = json.dumps(["left_knee_of_another_robot", *names[1:]])


def motion_cases() -> list[Case]:
    """The walk, corrupted, read by ``dataset check`` and, in turn, by ``plot`` or
    ``export`` (to keep the run short), and by the slow commands given."""
    return [case for i, (kind, name, corrupt, slow) in enumerate(motion_corruptions())
            for case in cases_of(kind, Input(f"walk:{name}", "walk", corrupt), (CHECK, MOTION_CONSUMERS[i % 2], *slow))]


def dataset_cases() -> list[Case]:
    """The bundled dataset, corrupted in one motion that is not its first, or as a whole."""
    table = [
        ("nan", "q.nan", at_sample("q", NAN), (*DATASET_READERS, REPRODUCE_DATA)),
        ("inf", "tau.inf", at_sample("tau", INF), (CHECK, EXPORT_TARGET)),
        ("nan", "signals.nan", at_sample("signals/values", NAN), (INFO, TRAIN)),
        ("shape", "signals.drop-column", replaced("signals/values", lambda a, g: a[:, :-1]), (TRAIN,)),
        ("time", "signals.phase_time-reversed", replaced("signals/phase_time", lambda a, g: a[::-1]), (TRAIN,)),
        ("index", "impacts.out-of-range", index_set("impacts", -1, lambda n: n + 5), (CHECK, PLOT_TARGET)),
        ("missing", "no-settings", file_attr("settings", None), (INFO, REPRODUCE_DATA)),
        ("missing", "no-motions", in_file(_delete_motions), (INFO, TRAIN)),
        ("file", "truncated", truncated, (CHECK,)),
    ]
    return [case for kind, name, corrupt, commands in table
            for case in cases_of(kind, Input(f"dataset:{name}", "dataset", corrupt), commands)]


def _delete_motions(f: h5py.File) -> None:
    for name in list(f["motions"]):
        del f["motions"][name]


def model_cases() -> list[Case]:
    """The bundled model, corrupted (checksum recomputed), read by ``model info`` and ``generate``."""
    table = [
        ("model-array", "m.nan", model_array("m", first_nan), (GENERATE, WALK)),
        ("model-array", "beta.inf", model_array("beta", lambda a: first_nan(a, INF)), (GENERATE,)),
        ("model-array", "alpha_w.drop-column", model_array("alpha_w", lambda a: a[:, :-1]), (GENERATE,)),
        ("model-array", "m.transposed", model_array("m", lambda a: a.T), (GENERATE,)),
        ("model-array", "sigma.strings", model_array("sigma", lambda a: a.astype(str)), (GENERATE,)),
        ("model-array", "n_phases.fractional", model_array("n_phases", lambda a: a + 0.5), (GENERATE,)),
        ("model-meta", "n_primitives.string", model_meta("n_primitives", "eleven"), MODEL_READERS),
        ("model-meta", "n_primitives.negative", model_meta("n_primitives", -3), (*MODEL_READERS, REPRODUCE_MODEL)),
        ("model-meta", "n_primitives.mismatch", model_meta("n_primitives", 4), (GENERATE, WALK)),
        ("model-meta", "kernel.unknown", model_meta("kernel", "cubic"), MODEL_READERS),
        ("model-meta", "explained_variance.list", model_meta("explained_variance", [0.9, 0.9]), (MODEL_INFO,)),
        ("file", "truncated", truncated, (GENERATE,)),
        ("file", "empty", emptied, (MODEL_INFO,)),
        ("file", "text", text, (GENERATE,)),
    ]
    return [case for kind, name, corrupt, commands in table
            for case in cases_of(kind, Input(f"model:{name}", "model", corrupt), commands)]


WALK_IN, DATASET_IN, MODEL_IN = Input("walk", "walk"), Input("dataset", "dataset"), Input("model", "model")


def foreign_file_cases() -> list[Case]:
    """A file of one kind where another is expected."""
    return [
        Case("walk as dataset | dataset info", "foreign", ("dataset", "info", "walk.h5"), (WALK_IN,)),
        Case("walk as dataset | train", "foreign", ("train", "walk.h5", "--out", "model.npz", *TRAIN_ARGS), (WALK_IN,)),
        Case("walk as dataset | reproduce --data", "foreign", ("reproduce", "--data", "walk.h5", "--out", "report"),
             (WALK_IN,), slow=True, timeout=SLOW_TIMEOUT_S),
        Case("dataset as model | generate", "foreign", ("generate", "--model", "ds.h5", "--out", "gen.h5"), (DATASET_IN,)),
        Case("model as motion | plot", "foreign", ("plot", "m.npz", "--out", "plots"), (MODEL_IN,)),
    ]


def argument_cases() -> list[Case]:
    """Absurd option values and output paths, on valid inputs."""
    return [
        Case("non-ASCII digits | generate --lengths-mm", "args", ("generate", "--lengths-mm", "١٥٠,١٥٠", "--out", "g.h5")),
        Case("dt 1e-9 | generate --dt", "args", ("generate", "--dt", "1e-9", "--out", "g.h5"), timeout=20),
        Case("799 mm steps | generate --lengths-mm", "args", ("generate", "--lengths-mm", "799,799", "--out", "g.h5"),
             timeout=30, expect="either"),
        Case("100000 workers | train --workers", "args",
             ("train", "ds.h5", "--out", "model.npz", *TRAIN_ARGS[:-2], "--workers", "100000"), (DATASET_IN,),
             expect="either"),
        Case("out is the input | train", "out-path", ("train", "ds.h5", "--out", "ds.h5", *TRAIN_ARGS), (DATASET_IN,)),
        Case("out is the input | simulate", "out-path", ("simulate", "walk.h5", "--out", "walk.h5"), (WALK_IN,),
             slow=True, timeout=SLOW_TIMEOUT_S),
        Case("out is the input | generate", "out-path", ("generate", "--model", "m.npz", "--out", "m.npz"), (MODEL_IN,)),
        Case("out is the input | plot", "out-path", ("plot", "walk.h5", "--out", "walk.h5"), (WALK_IN,)),
        # 253 characters fit a file system's 255 (the temporary name must be made to fit too): either outcome;
        # 300 do not
        Case("250-char name | generate --out", "out-path", ("generate", "--out", f"{LONG_NAME}.h5"), expect="either"),
        Case("300-char name | generate --out", "out-path", ("generate", "--out", f"{LONG_NAME}{'y' * 50}.h5")),
        Case("250-char name | export --out", "out-path", ("export", "walk.h5", "--format", "csv", "--out", LONG_NAME),
             (WALK_IN,)),
        Case("read-only folder | generate --out", "out-path", ("generate", "--out", f"{READONLY_DIR}/g.h5")),
        Case("read-only folder | export --out", "out-path",
             ("export", "walk.h5", "--format", "csv", "--out", f"{READONLY_DIR}/walk"), (WALK_IN,)),
        Case("read-only folder | plot --out", "out-path", ("plot", "walk.h5", "--out", f"{READONLY_DIR}/plots"), (WALK_IN,)),
    ]


def control_cases() -> list[Case]:
    """Valid inputs that must pass: the harness and the rebuilt model file work."""
    return [
        Case("control: walk | dataset check", "control", ("dataset", "check", "walk.h5"), (WALK_IN,), expect="ok"),
        Case("control: model re-saved | model info", "control", ("model", "info", "m.npz"),
             (Input("model:resaved", "model", in_model(lambda arrays, meta: None)),), expect="ok"),
    ]


def all_cases() -> list[Case]:
    return [*control_cases(), *motion_cases(), *dataset_cases(), *model_cases(), *foreign_file_cases(),
            *argument_cases()]


# ============================================================================ running
class Builder:
    """Makes the base files once and each corrupted input once, in ``root``."""

    def __init__(self, root: Path):
        self.root = root
        self.bases: dict[str, Path] = {}

    def base(self, name: str) -> Path:
        if name not in self.bases:
            self.bases[name] = self._make_base(name)
        return self.bases[name]

    def _make_base(self, name: str) -> Path:
        from cocomopl.data import dataset_path, model_path

        folder = self.root / "bases"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / FILE_NAMES[name]
        if name == "walk":
            progress("generating the walk (cocomopl generate) ...")
            done = subprocess.run([sys.executable, "-m", "cocomopl", "generate", "--out", str(path)], cwd=folder,
                                  env=child_env(), capture_output=True, text=True, check=False)
            if done.returncode != 0:
                raise SystemExit(f"cannot generate the walk:\n{done.stderr}")
        else:
            shutil.copyfile(dataset_path(None) if name == "dataset" else model_path(None), path)
        return path

    def build(self, source: Input) -> Path:
        """The input's file, built on first use."""
        path = self.root / "inputs" / source.name.replace(":", "_").replace("/", "_") / source.file
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(self.base(source.base), path)
            source.corrupt(path)
        return path


def child_env() -> dict:
    return {**os.environ, "MUJOCO_GL": "egl"}


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def snapshot(folder: Path) -> dict[str, str]:
    """Every file (by SHA-256) and folder under ``folder``, by relative path."""
    out = {}
    for path in sorted(folder.rglob("*")):
        rel = str(path.relative_to(folder))
        out[rel] = "<dir>" if path.is_dir() else hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def run_command(argv: tuple[str, ...], cwd: Path, timeout: float) -> tuple[int | None, str, str, float]:
    """Run ``cocomopl argv``: (exit status or None on timeout, stdout, stderr, seconds)."""
    started = time.perf_counter()
    # the suite runs no threads, so preexec_fn is safe here
    proc = subprocess.Popen(
        [sys.executable, "-m", "cocomopl", *argv], cwd=cwd, env=child_env(), stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace", start_new_session=True,
        preexec_fn=_limit_memory,
    )
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
        status = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the command and any worker it spawned
        stdout, stderr = proc.communicate()
        status = None
    return status, stdout, stderr, time.perf_counter() - started


def last_line(stderr: str) -> str:
    """The last non-empty line of stderr, progress bars' carriage returns resolved."""
    lines = [line.split("\r")[-1].strip() for line in stderr.splitlines()]
    lines = [line for line in lines if line]
    return lines[-1] if lines else ""


def classify(case: Case, status: int | None, stdout: str, stderr: str, wrote: bool) -> str:
    """``clean`` or ``ok`` for a pass, else the failure class (see the module's docstring)."""
    if status is None:
        return "timeout"
    if "Traceback" in stderr:
        return "traceback"
    if status < 0:
        return "crash"
    if status == 0:
        return "accepted" if case.expect == "error" else "ok"
    if case.expect == "ok":
        return "rejected"
    if status == 1 and case.argv[:2] == ("dataset", "check") and "FAIL: non_finite_values" in stdout:
        return "wrote" if wrote else "clean"  # the check's own verdict on NaN and Inf (docs/cli.md, dataset check)
    if not last_line(stderr).startswith("cocomopl: error:"):
        return "unclear"
    return "wrote" if wrote else "clean"


def _make_writable(folder: Path) -> None:
    for path in [folder, *folder.rglob("*")]:
        if path.is_dir() and not path.is_symlink():
            path.chmod(0o755)


def run_case(case: Case, builder: Builder, folder: Path) -> dict:
    """Run one case in the fresh ``folder`` and return its record."""
    folder.mkdir(parents=True)
    for source in case.inputs:
        shutil.copyfile(builder.build(source), folder / source.file)
    if not READONLY_ROOT and any(READONLY_DIR in a for a in case.argv):
        (folder / READONLY_DIR).mkdir(mode=0o555)
    before = snapshot(folder)
    status, stdout, stderr, seconds = run_command(case.argv, folder, case.timeout)
    after = snapshot(folder)
    changed = sorted(p for p in set(before) | set(after) if before.get(p) != after.get(p))
    _make_writable(folder)
    shutil.rmtree(folder, ignore_errors=True)
    subcommand = " ".join(case.argv[:2] if case.argv[0] in ("dataset", "model") else case.argv[:1])
    return {"case": case.name, "kind": case.kind, "subcommand": subcommand, "expect": case.expect,
            "command": "cocomopl " + " ".join(case.argv),
            "class": classify(case, status, stdout, stderr, bool(changed)), "exit": status, "seconds": round(seconds, 1),
            "last_stderr": last_line(stderr)[:300], "changed": changed[:10]}


def progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# ============================================================================ report
def _pass_fail(results: list[dict], key: Callable[[dict], str]) -> dict[str, dict[str, int]]:
    """Passed and failed cases by ``key(record)``."""
    out: dict[str, dict[str, int]] = {}
    for r in results:
        counts = out.setdefault(key(r), {"pass": 0, "fail": 0})
        counts["pass" if r["class"] in ("clean", "ok") else "fail"] += 1
    return out


def summary(results: list[dict], quick: bool, wall: float) -> dict:
    failing = [r for r in results if r["class"] not in ("clean", "ok")]
    return {
        "cases": len(results),
        "clean": sum(r["class"] == "clean" for r in results),
        "ok": sum(r["class"] == "ok" for r in results),
        "failures": dict(Counter(r["class"] for r in failing).most_common()),
        "by_kind": _pass_fail(results, lambda r: r["kind"]),
        "failing": [{k: r[k] for k in ("case", "class", "exit", "command", "last_stderr", "changed")} for r in failing],
        "quick": quick,
        "by_command": _pass_fail(results, lambda r: r["subcommand"]),
        "readonly_folder": READONLY_DIR + (" (running as root: /proc, not a chmod 555 folder)" if READONLY_ROOT else ""),
        "memory_limit_bytes": MEMORY_LIMIT_BYTES,
        "wall_time_s": round(wall, 1),
        "results": results,
    }


def table(report: dict) -> str:
    lines = [f"{'result':10s} {'exit':>5s} {'s':>6s}  case  ->  last line of stderr"]
    for r in report["results"]:
        exit_ = "-" if r["exit"] is None else str(r["exit"])
        lines.append(f"{r['class']:10s} {exit_:>5s} {r['seconds']:6.1f}  {r['case']}  ->  {r['last_stderr'][:110]}")
    failures = ", ".join(f"{k} {v}" for k, v in report["failures"].items()) or "none"
    lines.append(f"\n{report['cases']} cases: {report['clean']} clean refusals, {report['ok']} valid inputs passed; "
                 f"failures: {failures} ({report['wall_time_s']:.0f} s{', --quick' if report['quick'] else ''})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="skip the simulate, walk and reproduce cases")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    parser.add_argument("--out", metavar="FILE.json", help="also write the JSON report to this file")
    parser.add_argument("--only", metavar="TEXT", help="run only the cases whose name contains TEXT")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder (its path goes to stderr)")
    args = parser.parse_args(argv)

    cases = [c for c in all_cases() if not (args.quick and c.slow) and (not args.only or args.only in c.name)]
    if args.list:
        print("\n".join(f"{c.kind:12s} {c.name:48s} cocomopl {' '.join(c.argv)}" for c in cases))
        return 0
    root = Path(tempfile.mkdtemp(prefix="cocomopl-corruption-"))
    builder, results, started = Builder(root), [], time.perf_counter()
    try:
        for i, case in enumerate(cases, 1):
            record = run_case(case, builder, root / "cases" / str(i))
            results.append(record)
            progress(f"[{i}/{len(cases)} {time.perf_counter() - started:5.0f} s] {record['class']:9s} "
                     f"{record['seconds']:5.1f} s  {case.name}  ->  {record['last_stderr'][:100]}")
    finally:
        if args.keep:
            progress(f"kept {root}")
        else:
            _make_writable(root)
            shutil.rmtree(root, ignore_errors=True)
    report = summary(results, args.quick, time.perf_counter() - started)
    if args.out:
        Path(args.out).write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps(report) if args.json else table(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
