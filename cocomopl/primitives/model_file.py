"""Model files: a fitted :class:`MovementPrimitives` as an NPZ archive, read without unpickling.

The archive holds every fitted array of the model, each named as its attribute without the
trailing ``_`` (``m`` for ``model.m_``), and one more, ``__metadata__``: a JSON
string with the format name and version, the model's settings and fit results, a SHA-256
checksum of the arrays and whatever the caller adds (command, versions, date, ...).

Reading checks all of it (:func:`_validate`): a checksum guards against damage, not against
a hand-edited file whose checksum was recomputed, and whatever prediction, synthesis or
``cocomopl model info`` would trip over later is refused here, in one line naming the file.

>>> save_model("model.npz", model, {"command": "cocomopl primitives fit ..."})
>>> model = load_model("model.npz")
>>> model_metadata("model.npz")["explained_variance"]
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from cocomopl.dataset.signals import PELVIS_NAMES, ZMP_NAMES
from cocomopl.errors import Error
from cocomopl.gait import OTHER_SIDE, phase_plan
from cocomopl.motion import STEP_KINDS, StepSpec
from cocomopl.motion_file import atomic_path
from cocomopl.primitives.checks import whole
from cocomopl.primitives.estimator import (
    PARAMETER_CHECKS,
    SIGNAL_GROUPS,
    MovementPrimitives,
    PredictedStep,
    signal_groups,
)
from cocomopl.primitives.training import (
    FOOTSTEP_PARAMETERS,
    STRAIGHT_PARAMETERS,
    TrainingSteps,
    learned_parts,
    with_step_lengths,
)
from cocomopl.robot.description import read_description

FORMAT = "cocomopl-model"
# 2: stops are learned in two parts, step types ``stop_<side>_part1`` and ``_part2``
# (version 1 had whole stops, which this version's prediction does not chain)
# 3: ``m_cov_start``, each primitive's posterior covariance with its start, which
# conditioning on a step's start needs, and ``eta_w``, the weight kernels' learned nuggets
# 4: ``c_w``, the weights' observation precisions, replace ``C``, the weight GPs' solves
# (signals x primitives x types x N x N: 440 MB for 118 steps a type), which prediction
# only read the precisions back from
FORMAT_VERSION = 4
METADATA_KEY = "__metadata__"
# what np.load and reading an archive member raise on a truncated, corrupt or foreign file
_UNREADABLE = (zipfile.BadZipFile, zlib.error, OSError, ValueError, EOFError, KeyError)

# The axes of the model's arrays, by letter: what each counts, for the error messages.
_AXES = {
    "S": "primitives",
    "T": "grid points",
    "I": "signals",
    "G": "step types",
    "N": "training steps per type at most",
    "P": "phases per type at most",
    "B": "phase boundaries per type at most",
    "Z": "step parameters (start and end length; with footsteps their widths and turns too)",
}
# Every fitted array of a model, by its attribute's name less the trailing ``_`` (prediction
# reads all but sigma, alpha_t and ell_t, which describe the fit): its dtype kind, its axes
# (letters of _AXES) and the sign its values must have: kernel amplitudes, widths and noise
# levels positive; distances and the duration amplitudes (0 where a type has fewer phases)
# at least zero; step lengths at least zero in a model of straight steps
# (``_check_step_parameters``).  ``m_var`` and ``m_cov_start`` have none: they are computed
# (co)variances, round-off may leave an entry slightly below zero, and prediction clips what
# it derives from them.
ARRAYS = {
    # MovementPrimitives.fit
    "tau": ("f", "T", None),
    "signal_names": ("U", "I", None),
    "unconditioned": ("b", "I", None),
    "types": ("U", "G", None),
    "lengths": ("f", "GNZ", None),
    "mask": ("f", "GN", None),
    "boundaries": ("f", "GB", None),
    # optimise._prediction_arrays
    "m": ("f", "ST", None),
    "m_var": ("f", "ST", None),
    "m_cov_start": ("f", "ST", None),
    "alpha_w": ("f", "IS", ">0"),
    "gamma_w": ("f", "IS", ">0"),
    "eta_w": ("f", "IS", ">0"),
    "chi": ("f", "ISG", None),
    "beta": ("f", "ISGN", None),
    "c_w": ("f", "IS", ">0"),
    "sigma": ("f", "I", ">0"),
    "alpha_t": ("f", "S", ">0"),
    "ell_t": ("f", "S", ">0"),
    # estimator._fit_durations
    "n_phases": ("iu", "G", None),
    "dur_mean": ("f", "GP", None),
    "dur_alpha": ("f", "GP", ">=0"),
    "dur_gamma": ("f", "GP", ">0"),
    "dur_beta": ("f", "GPN", None),
    "dur_K_inv": ("f", "GPNN", None),
    "support_radius": ("f", "G", ">=0"),
}
# The fitted arrays' names.  A file lacking any of them cannot predict.
REQUIRED = tuple(ARRAYS)
_KINDS = {"f": "floating-point numbers", "iu": "integers", "U": "unicode text", "b": "booleans"}
# What a model may predict for its own training steps.  s: walking phases last 0.1 to 1 s;
# a hand-edited duration GP predicting hours would have a walk sampled at millions of
# instants, and no robot walks phases of microseconds.  rad or m: joint angles and pelvis
# angles within a few radians, the ZMP within a metre of the pelvis; far beyond, the
# weights or primitives were edited (or overflow).
PHASE_DURATION_RANGE_S = (1e-3, 60.0)
SIGNAL_LIMIT = 100.0


class _Invalid(Exception):
    """A problem with a model file's content; :func:`_validate` names the file."""


def checksum(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 hex digest of the arrays' names, dtypes, shapes and bytes, in sorted name order.

    Dtype and shape are hashed too, so a reinterpreted or reshaped array does not pass.
    """
    digest = hashlib.sha256()
    for name in sorted(arrays):
        if name == METADATA_KEY:
            continue
        a = np.asarray(arrays[name])
        header = json.dumps([name, a.dtype.str, list(a.shape)])
        digest.update(header.encode() + b"\0")
        digest.update(np.ascontiguousarray(a).tobytes())
    return digest.hexdigest()


def _json_default(value):
    # caller metadata may carry NumPy scalars or arrays (e.g. a selection table)
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    raise TypeError(f"metadata value {value!r} of type {type(value).__name__} cannot be written as JSON")


def model_arrays(model: MovementPrimitives) -> dict[str, np.ndarray]:
    """The arrays a model file holds of ``model``: every fitted array, by its name in the file.

    Raises
    ------
    Error
        If the model is not fitted, or lacks a fitted array.
    """
    missing = [name for name in REQUIRED if not hasattr(model, f"{name}_")]
    if len(missing) == len(REQUIRED):
        raise Error("the model is not fitted")
    if missing:
        raise Error(f"the model lacks the fitted arrays {', '.join(f'{name}_' for name in missing)}")
    return {name: np.asarray(getattr(model, f"{name}_")) for name in REQUIRED}


def save_model(path: str | Path, model: MovementPrimitives, metadata: dict) -> None:
    """Write a fitted model and ``metadata`` to an NPZ file, atomically.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder is created if needed.  ``.npz`` is not appended.
    model : MovementPrimitives
        A fitted model.
    metadata : dict
        JSON-able extra metadata (command, versions, date, ...).  The model's own entries
        (format, checksum, settings, fit results) take precedence over keys of the same name.
    """
    path = Path(path)
    try:
        arrays = model_arrays(model)
    except Error as exc:
        raise Error(f"cannot save {path}: {exc}") from None
    pickled = [name for name, a in arrays.items() if a.dtype.hasobject]
    if pickled:  # NPZ would pickle them, and load_model refuses pickles
        raise Error(f"cannot save {path}: arrays {', '.join(pickled)} hold Python objects")
    meta = {
        **metadata,
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "checksum": checksum(arrays),
        "n_primitives": int(model.n_primitives),
        "kernel": str(model.kernel),
        "n_grid": int(model.n_grid),
        "max_iterations": int(model.max_iterations),
        "n_widths": int(model.n_widths),
        "bound": float(model.bound_),
        "n_iter": int(model.n_iter_),
        "fit_time_s": float(model.fit_time_s_),
        "explained_variance": {str(k): float(v) for k, v in model.explained_variance_.items()},
    }
    text = json.dumps(meta, default=_json_default)
    try:
        # np.savez appends ".npz" to a file name that lacks it: write through a file object
        # so the temporary file is exactly the one atomic_path renames.  Compressed: the
        # per-type arrays are padded to the largest type (a model of footsteps, whose
        # transitions outnumber its other steps three to one, is 125 MB raw and 10 MB so)
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays, **{METADATA_KEY: np.array(text)})
    except OSError as exc:
        raise Error(f"cannot write model file {path}: {exc.strerror or exc}") from None


def _read(path: str | Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Metadata and arrays of a model file, checked; every problem raises :class:`Error`."""
    path = Path(path)
    if not path.exists():
        raise Error(f"{path}: model file not found")
    if path.is_dir():
        raise Error(f"{path}: a directory, not a cocomopl model file")
    unreadable = f"{path}: not a readable NPZ file (truncated, corrupt or another format)"
    try:
        data = np.load(path, allow_pickle=False)
    except PermissionError:
        raise Error(f"{path}: cannot read it, permission denied") from None
    except _UNREADABLE:
        raise Error(unreadable) from None
    if not isinstance(data, np.lib.npyio.NpzFile):  # a bare .npy array
        raise Error(f"{path}: not a cocomopl model file")
    with data:
        try:
            if METADATA_KEY not in data.files:
                raise Error(f"{path}: not a cocomopl model file")
            # every array is read, for the metadata alone too: the checksum covers them all
            arrays = {name: data[name] for name in data.files}
        except _UNREADABLE:
            raise Error(unreadable) from None
    raw = arrays.pop(METADATA_KEY)
    try:
        meta = json.loads(raw.item()) if raw.shape == () and raw.dtype.kind == "U" else None
    except (json.JSONDecodeError, RecursionError):  # RecursionError: JSON nested thousands deep
        meta = None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise Error(f"{path}: not a cocomopl model file")
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise Error(
            f"{path}: format version {_shown(version)}; this cocomopl reads version {FORMAT_VERSION} "
            "(train the model again with cocomopl train)"
        )
    if meta.get("checksum") != checksum(arrays):
        raise Error(f"{path}: corrupted, checksum mismatch")
    _validate(path, meta, arrays)
    return meta, arrays


def _validate(path: Path, meta: dict, arrays: dict[str, np.ndarray]) -> None:
    """Raise :class:`Error` ``"PATH: what is wrong"`` unless the metadata and the arrays are
    complete, well typed and consistent with each other."""
    # a recorded description stands for the robot: its name need not be a bundled one
    fields = {**_METADATA, "robot": (False, _text)} if "robot_description" in meta else _METADATA
    try:
        _check_fields(meta, fields, "metadata")
        _check_arrays(meta, arrays)
    except _Invalid as exc:
        raise Error(f"{path}: {exc}") from None


# ---------------------------------------------------------------------------- metadata
def _shown(value) -> str:
    """A metadata value as JSON, cut short: messages stay one line."""
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _is_real(value) -> bool:
    try:  # a JSON integer of 400 digits overflows a float
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    except OverflowError:
        return False


def _real(least: float | None = None) -> Callable:
    def check(value):
        if _is_real(value) and (least is None or value >= least):
            return None
        return "a finite number" + ("" if least is None else f" >= {least:g}")

    return check


def _text(value) -> str | None:
    return None if isinstance(value, str) else "a string"


def _object(value) -> str | None:
    return None if isinstance(value, dict) else "an object"


def _scores(value) -> str | None:
    """Explained variance per signal group, as ``model info`` shows it."""
    ok = isinstance(value, dict) and set(value) == set(SIGNAL_GROUPS) and all(map(_is_real, value.values()))
    return None if ok else f"finite numbers for {', '.join(SIGNAL_GROUPS)}"


def _robot(value) -> str | None:
    """A robot cocomopl can load: a bundled name or a description file.  Only the description
    is read: building the robot's model takes a second, and synthesis does it anyway."""
    if not isinstance(value, str):
        return "a robot name"
    try:
        read_description(value)
    except (Error, OSError, ValueError) as exc:  # OSError, ValueError: a name no path can have
        raise _Invalid(f"metadata 'robot': {exc}") from None
    return None


def _dataset(value) -> str | None:
    if not isinstance(value, dict):
        return "an object"
    _check_fields(value, _DATASET, "metadata 'dataset'")
    return None


def _selection(value) -> str | None:
    """The model-selection table, one object per candidate, as ``model info --verbose`` shows it."""
    if not isinstance(value, list):
        return "a list of objects"
    for k, row in enumerate(value):
        if not isinstance(row, dict):
            raise _Invalid(f"metadata 'selection' row {k + 1} is {_shown(row)}, expected an object")
        _check_fields(row, _SELECTION_ROW, f"metadata 'selection' row {k + 1}")
    return None


# The entries cocomopl reads (load_model, model info, synthesis): whether required, and a
# check returning what a wrong value should have been (None when right).  A check of a
# nested object raises for its own entries.  Other entries are the caller's and pass.
_METADATA = {
    # the estimator's parameters, by its own rules
    "n_primitives": (True, PARAMETER_CHECKS["n_primitives"]),
    "kernel": (True, PARAMETER_CHECKS["kernel"]),
    "n_grid": (True, PARAMETER_CHECKS["n_grid"]),
    "max_iterations": (False, PARAMETER_CHECKS["max_iterations"]),  # the estimator's default stands in
    "n_widths": (False, PARAMETER_CHECKS["n_widths"]),  # and here: files before it were trained with the default
    "bound": (True, _real()),
    "n_iter": (True, whole(0)),
    "fit_time_s": (True, _real(0.0)),
    "explained_variance": (True, _scores),
    "robot": (False, _robot),  # synthesis defaults to DEFAULT_ROBOT
    "robot_description": (False, _object),  # a robot that is not bundled: its description
    "dataset": (False, _dataset),
    "selection": (False, _selection),
    "command": (False, _text),
    "created": (False, _text),
    "versions": (False, _object),
    "training_wall_time_s": (False, _real(0.0)),
}
_DATASET = {
    "name": (False, _text),
    "path": (False, _text),
    "sha256": (False, _text),
    "created": (False, _text),
    "robot": (False, _text),
    "steps": (False, whole(1)),
}
_SELECTION_ROW = {
    "n_primitives": (True, PARAMETER_CHECKS["n_primitives"]),
    "kernel": (True, PARAMETER_CHECKS["kernel"]),
    "bound": (True, _real()),
    "explained_variance": (True, _scores),
    "iterations": (True, whole(0)),
    "fit_time_s": (False, _real(0.0)),
}


def _check_fields(record: dict, fields: dict, where: str) -> None:
    """Raise :class:`_Invalid` for the first entry of ``fields`` that ``record`` lacks or
    holds wrong; ``where`` names ``record`` in the message."""
    for key, (required, check) in fields.items():
        if key not in record:
            if required:
                raise _Invalid(f"{where} lacks {key!r}")
            continue
        expected = check(record[key])
        if expected:
            raise _Invalid(f"{where} {key!r} is {_shown(record[key])}, expected {expected}")


# ---------------------------------------------------------------------------- arrays
def _check_arrays(meta: dict, arrays: dict[str, np.ndarray]) -> None:
    """Presence, dtypes, shapes and values of the arrays; ``meta`` is already checked."""
    missing = [name for name in REQUIRED if name not in arrays]
    if missing:
        raise _Invalid(f"lacks the model arrays {', '.join(missing)}")
    for name, (kinds, axes, _) in ARRAYS.items():
        _check_kind_and_ndim(name, arrays[name], kinds, axes)
    names = [str(n) for n in arrays["signal_names"]]
    types = [str(t) for t in arrays["types"]]
    _check_signal_names(names)
    phases = _check_types(types)
    sizes = {
        "S": meta["n_primitives"],
        "T": meta["n_grid"],
        "I": len(names),
        "G": len(types),
        "N": arrays["mask"].shape[1],
        "P": max(phases),
        "B": max(phases) + 1,
        "Z": _parameter_count(arrays["lengths"]),
    }
    for name, (_, axes, sign) in ARRAYS.items():
        _check_shape(name, arrays[name], axes, sizes)
        _check_values(name, arrays[name], sign)
    _check_step_parameters(arrays["lengths"])
    _check_grid(arrays["tau"])
    _check_unconditioned(arrays["unconditioned"], names)
    counts = _check_mask(arrays["mask"], types)
    _check_phases(arrays, types, phases)
    _check_dataset_steps(meta, types, counts)
    _check_predictions(_model(meta, arrays), types, counts)


def _check_kind_and_ndim(name: str, a: np.ndarray, kinds: str, axes: str) -> None:
    if a.dtype.kind not in kinds:
        raise _Invalid(f"array {name!r} has dtype {a.dtype}, expected {_KINDS[kinds]}")
    if a.ndim != len(axes):
        counted = ", ".join(_AXES[axis] for axis in axes)
        raise _Invalid(f"array {name!r} has shape {a.shape}, expected {len(axes)} dimensions ({counted})")


def _parameter_count(lengths: np.ndarray) -> int:
    """How many step parameters the model takes: :data:`STRAIGHT_PARAMETERS` or :data:`FOOTSTEP_PARAMETERS`."""
    count = lengths.shape[-1]
    if count not in (STRAIGHT_PARAMETERS, FOOTSTEP_PARAMETERS):
        raise _Invalid(f"array 'lengths' holds {count} step parameters, expected {STRAIGHT_PARAMETERS} (start and end "
                       f"length) or {FOOTSTEP_PARAMETERS} (and their widths and turns)")
    return count


def _check_step_parameters(lengths: np.ndarray) -> None:
    """Straight steps go forward: a model of them has no negative length."""
    if lengths.shape[-1] == STRAIGHT_PARAMETERS:
        _check_values("lengths", lengths, ">=0")


def _check_shape(name: str, a: np.ndarray, axes: str, sizes: dict[str, int]) -> None:
    expected = tuple(sizes[axis] for axis in axes)
    if a.shape != expected:
        counts = [f"{sizes[axis]} {_AXES[axis]}" for axis in dict.fromkeys(axes)]  # each axis once, in order
        listed = counts[0] if len(counts) == 1 else f"{', '.join(counts[:-1])} and {counts[-1]}"
        raise _Invalid(f"array {name!r} has shape {a.shape}, expected {expected} for {listed}")


def _check_values(name: str, a: np.ndarray, sign: str | None) -> None:
    """Finite numbers of the required sign.  The phase boundaries are padded with NaN past
    each type's phases: :func:`_check_phases` checks the ones in use."""
    if a.dtype.kind != "f" or name == "boundaries":
        return
    bad = ~np.isfinite(a)
    if bad.any():
        raise _Invalid(f"array {name!r} holds {a[bad][0]} at {_index(bad)}, expected finite numbers")
    if sign is not None:
        bad = a <= 0 if sign == ">0" else a < 0
        if bad.any():
            expected = "positive" if sign == ">0" else "non-negative"
            raise _Invalid(f"array {name!r} holds {a[bad][0]:g} at {_index(bad)}, expected {expected} values")


def _index(bad: np.ndarray) -> tuple[int, ...]:
    """The index of the first True of ``bad``, as a tuple of ints."""
    return tuple(int(i) for i in np.argwhere(bad)[0])


def _check_signal_names(names: list[str]) -> None:
    """The signals synthesis expects, by position: joint angles, then the ZMP, then the
    pelvis orientation (dataset.signals.signal_names).  Whether the joints are the robot's
    is not checked: that needs its model built, which synthesis does."""
    tail = ZMP_NAMES + PELVIS_NAMES
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise _Invalid(f"array 'signal_names' repeats {repeated[0]!r}")
    if len(names) <= len(tail) or names[-len(tail) :] != tail:
        raise _Invalid(f"array 'signal_names' must end with {', '.join(tail)}, after at least one joint")
    joints = signal_groups(names)["joints"]
    if len(joints) != len(names) - len(tail):
        raise _Invalid("array 'signal_names' names a ZMP or pelvis signal among the joints")


class _Trajectory(NamedTuple):
    """A trajectory type a model can learn: a step type, or one part of a step learned in parts."""

    spec: StepSpec  # of a step of its kind and swing side (the lengths are placeholders)
    phases: int
    first: bool  # whether it starts its step: a whole step, or the first part


@functools.cache
def _trajectories() -> dict[str, _Trajectory]:
    """Every trajectory type a model can learn, by name.

    Training cuts (:func:`learned_parts`) one step of each kind and swing side, with its
    phase plan, as it cuts real ones: a stop in two parts, the others whole.
    """
    specs = [StepSpec(kind, 0.2, 0.2, side) for kind in STEP_KINDS for side in OTHER_SIDE]
    plans = [len(phase_plan(spec)) for spec in specs]
    steps = TrainingSteps(
        specs,
        [np.zeros((p + 1, 1)) for p in plans],
        [np.arange(p + 1.0) for p in plans],
        [np.ones(p) for p in plans],
        ["signal"],
        {},
    )
    parts, types = learned_parts(steps)
    firsts = [k == 0 or parts.specs[k] != parts.specs[k - 1] for k in range(len(types))]
    return {t: _Trajectory(s, len(d), f) for t, s, d, f in zip(types, parts.specs, parts.durations, firsts)}


def _check_types(types: list[str]) -> list[int]:
    """Known, distinct trajectory types, a step learned in parts with all of them; returns
    each type's number of phases."""
    known = _trajectories()
    if not types:
        raise _Invalid("array 'types' is empty: the model has no step type")
    for t in types:
        if t not in known:
            raise _Invalid(f"array 'types' holds {t!r}, not a step type; expected some of {', '.join(known)}")
        if types.count(t) > 1:
            raise _Invalid(f"array 'types' repeats {t!r}")
    for t in types:  # prediction chains the parts of a step: without one, the step has too few phases
        lacking = [p for p, other in known.items() if other.spec == known[t].spec and p not in types]
        if lacking:
            raise _Invalid(f"array 'types' holds {t!r} but not {lacking[0]!r}")
    return [known[t].phases for t in types]


def _check_grid(tau: np.ndarray) -> None:
    # prediction fits splines through the grid: knots must rise, and span the step
    if tau[0] != 0.0 or tau[-1] != 1.0 or not np.all(np.diff(tau) > 0):
        raise _Invalid("array 'tau' must rise strictly from 0 to 1")


def _check_unconditioned(unconditioned: np.ndarray, names: list[str]) -> None:
    # the ZMP jumps at touchdown, so prediction does not condition it on the previous step
    if not np.array_equal(unconditioned, [n in ZMP_NAMES for n in names]):
        raise _Invalid(f"array 'unconditioned' must mark the signals {', '.join(ZMP_NAMES)} and no other")


def _check_mask(mask: np.ndarray, types: list[str]) -> np.ndarray:
    """Per type, ones for its training steps then zeros (prediction slices the first
    ``mask.sum()``), at least one step; returns the counts."""
    counts = mask.sum(axis=1).astype(int)
    expected = np.arange(mask.shape[1]) < counts[:, None]
    for g, t in enumerate(types):
        if counts[g] < 1 or not np.array_equal(mask[g], expected[g]):
            raise _Invalid(f"array 'mask' row {g} ({t}) must be 1 for at least one training step, then 0")
    return counts


def _check_phases(arrays: dict[str, np.ndarray], types: list[str], phases: list[int]) -> None:
    """Each type's phase count, as its phase plan has, and its phase boundaries: rising
    strictly from 0 to 1, for splines per phase."""
    for g, (t, p) in enumerate(zip(types, phases)):
        if arrays["n_phases"][g] != p:
            raise _Invalid(f"array 'n_phases' gives {t} {arrays['n_phases'][g]} phases, expected {p}")
        b = arrays["boundaries"][g, : p + 1]
        if not (np.all(np.isfinite(b)) and b[0] == 0.0 and b[-1] == 1.0 and np.all(np.diff(b) > 0)):
            raise _Invalid(f"array 'boundaries' row {g} ({t}) must rise strictly from 0 to 1 over its {p + 1} values")


def _check_dataset_steps(meta: dict, types: list[str], counts: np.ndarray) -> None:
    """The recorded number of training steps is that of the learned trajectories, a step
    learned in parts counted once (by its first part)."""
    steps = (meta.get("dataset") or {}).get("steps")
    if steps is None:
        return
    learned = sum(int(c) for t, c in zip(types, counts) if _trajectories()[t].first)
    if learned != steps:
        raise _Invalid(f"metadata 'dataset' 'steps' is {steps}, but the arrays hold {learned} training steps")


def _check_predictions(model: MovementPrimitives, types: list[str], counts: np.ndarray) -> None:
    """Predict every training step as a walk does: a start step from rest, any other step
    conditioned on a start (its own predicted start, where the step before it would end);
    finite signals within SIGNAL_LIMIT and phase durations within PHASE_DURATION_RANGE_S.

    Values that pass every check above may still be absurd together (weights that overflow,
    a duration GP predicting hours, primitives that vanish where a step is conditioned on its
    start); prediction itself is the judge, rather than a second copy of its formulas.  A
    start step is not conditioned: every one begins in the same posture, so its start has
    almost no variance, and conditioning it on another step's end, which no walk does, can
    be off by orders of magnitude in a correctly fitted model.
    """
    specs = [with_step_lengths(_trajectories()[t].spec, z)
             for g, t in enumerate(types) if _trajectories()[t].first  # predicted with the first part
             for z in model.lengths_[g, : counts[g]]]
    # what overflows is refused by the checks; a step's values are computed when first read
    with np.errstate(all="ignore"):
        for spec, step in zip(specs, model.predict_many(specs)):  # together: a few products, not one per step
            if spec.kind != "start":
                _check_predicted(step, model.signal_names)
                step = step.conditioned_on(step.values[0])
            _check_predicted(step, model.signal_names)


def _check_predicted(step: PredictedStep, signal_names: list[str]) -> None:
    """Raise :class:`_Invalid` for a non-finite or implausible signal or phase duration of ``step``."""
    bad = ~(np.abs(step.values) <= SIGNAL_LIMIT)  # NaN too
    if bad.any():
        k, i = _index(bad)
        raise _Invalid(
            f"the model predicts {step.values[k, i]:.3g} for signal {signal_names[i]} of its training step "
            f"{step.spec.name}, expected at most {SIGNAL_LIMIT:g} (rad or m): its weights or primitives are wrong"
        )
    low, high = PHASE_DURATION_RANGE_S
    bad = ~((step.durations >= low) & (step.durations <= high))
    if bad.any():
        (p,) = _index(bad)
        raise _Invalid(
            f"the model predicts {step.durations[p]:.3g} s for phase {p} of its training step {step.spec.name}, "
            f"expected {low:g} to {high:g} s: its duration GP arrays dur_* are wrong"
        )


def _model(meta: dict, arrays: dict[str, np.ndarray]) -> MovementPrimitives:
    """The fitted model of a file's checked metadata and arrays."""
    model = MovementPrimitives(
        n_primitives=meta["n_primitives"],
        kernel=meta["kernel"],
        n_grid=meta["n_grid"],
        **{key: meta[key] for key in ("max_iterations", "n_widths") if key in meta},
    )
    for name in REQUIRED:
        setattr(model, f"{name}_", arrays[name])
    model.bound_ = float(meta["bound"])
    model.n_iter_ = meta["n_iter"]
    model.fit_time_s_ = float(meta["fit_time_s"])
    model.explained_variance_ = {k: float(v) for k, v in meta["explained_variance"].items()}
    model.metadata_ = meta
    return model


def load_model(path: str | Path) -> MovementPrimitives:
    """Read a model written by :func:`save_model`.

    Returns
    -------
    MovementPrimitives
        Fitted: every fitted attribute is set (the arrays of the file, ``bound_``, ``n_iter_``,
        ``fit_time_s_``, ``explained_variance_``), and ``metadata_`` holds the decoded metadata.
    """
    return _model(*_read(path))


def model_metadata(path: str | Path) -> dict:
    """The decoded metadata of a model file, after the same checks as :func:`load_model`."""
    return _read(path)[0]


def model_robot(model):
    """The robot a loaded model is for, from its metadata (:func:`metadata_robot`)."""
    return metadata_robot(getattr(model, "metadata_", None) or {})


def metadata_robot(meta: dict):
    """The robot a model's metadata ``meta`` names: its recorded description if it has one (a
    robot that is not bundled), else its bundled name (default TALOS); an :class:`Error` if
    the robot's fingerprint differs from the one the model recorded."""
    from cocomopl.motion_file import check_robot_model, load_robot
    from cocomopl.robot import DEFAULT_ROBOT

    described = meta.get("robot_description")
    robot = load_robot(meta.get("robot") or DEFAULT_ROBOT, None if described is None else json.dumps(described, sort_keys=True))
    check_robot_model(meta.get("robot_model"), robot, "the model")
    return robot
