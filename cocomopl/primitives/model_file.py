"""Model files: a fitted :class:`MovementPrimitives` as an NPZ archive, read without unpickling.

The archive holds every array of ``model.state_`` and one more, ``__metadata__``: a JSON
string with the format name and version, the model's settings and fit results, a SHA-256
checksum of the arrays and whatever the caller adds (command, versions, date, ...).

>>> save_model("model.npz", model, {"command": "cocomopl primitives fit ..."})
>>> model = load_model("model.npz")
>>> model_metadata("model.npz")["explained_variance"]
"""

from __future__ import annotations

import hashlib
import json
import zipfile
import zlib
from pathlib import Path

import numpy as np

from cocomopl.errors import Error
from cocomopl.motion_file import atomic_path
from cocomopl.primitives.estimator import MovementPrimitives

FORMAT = "cocomopl-model"
# 2: stops are learned in two parts, step types ``stop_<side>_part1`` and ``_part2``
# (version 1 had whole stops, which this version's prediction does not chain)
FORMAT_VERSION = 2
METADATA_KEY = "__metadata__"
# what np.load and reading an archive member raise on a truncated, corrupt or foreign file
_UNREADABLE = (zipfile.BadZipFile, zlib.error, OSError, ValueError, EOFError, KeyError)
# The keys of a fitted model's ``state_``: MovementPrimitives.fit, optimise._prediction_arrays
# and model._fit_durations.  A file lacking any of them cannot predict.
REQUIRED = (
    # MovementPrimitives.fit
    "tau", "signal_names", "unconditioned", "types", "lengths", "mask", "boundaries",
    # optimise._prediction_arrays
    "m", "m_var", "alpha_w", "gamma_w", "chi", "beta", "C", "sigma", "alpha_t", "ell_t",
    # model._fit_durations
    "n_phases", "dur_mean", "dur_alpha", "dur_gamma", "dur_beta", "dur_K_inv", "support_radius",
)  # fmt: skip


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
    if not hasattr(model, "state_"):
        raise Error(f"cannot save {path}: the model is not fitted")
    arrays = {name: np.asarray(value) for name, value in model.state_.items()}
    missing = [name for name in REQUIRED if name not in arrays]
    if missing:
        raise Error(f"cannot save {path}: the model's state lacks {', '.join(missing)}")
    if METADATA_KEY in arrays:
        raise Error(f"cannot save {path}: the model's state has an array named {METADATA_KEY}")
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
        "bound": float(model.bound_),
        "n_iter": int(model.n_iter_),
        "fit_time_s": float(model.fit_time_s_),
        "explained_variance": {str(k): float(v) for k, v in model.explained_variance_.items()},
    }
    text = json.dumps(meta, default=_json_default)
    try:
        # np.savez appends ".npz" to a file name that lacks it: write through a file object
        # so the temporary file is exactly the one atomic_path renames
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, **arrays, **{METADATA_KEY: np.array(text)})
    except OSError as exc:
        raise Error(f"cannot write model file {path}: {exc.strerror or exc}") from None


def _read(path: str | Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Metadata and arrays of a model file, checked; every problem raises :class:`Error`."""
    path = Path(path)
    if not path.exists():
        raise Error(f"model file not found: {path}")
    if path.is_dir():
        raise Error(f"{path} is a directory, not a cocomopl model file")
    unreadable = f"{path} is not a readable NPZ file (truncated, corrupt or another format)"
    try:
        data = np.load(path, allow_pickle=False)
    except PermissionError:
        raise Error(f"cannot read {path}: permission denied") from None
    except _UNREADABLE:
        raise Error(unreadable) from None
    if not isinstance(data, np.lib.npyio.NpzFile):  # a bare .npy array
        raise Error(f"{path} is not a cocomopl model file")
    with data:
        try:
            if METADATA_KEY not in data.files:
                raise Error(f"{path} is not a cocomopl model file")
            # every array is read, for the metadata alone too: the checksum covers them all
            arrays = {name: data[name] for name in data.files}
        except _UNREADABLE:
            raise Error(unreadable) from None
    raw = arrays.pop(METADATA_KEY)
    try:
        meta = json.loads(raw.item()) if raw.shape == () and raw.dtype.kind == "U" else None
    except json.JSONDecodeError:
        meta = None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise Error(f"{path} is not a cocomopl model file")
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise Error(
            f"{path} has format version {version}; this cocomopl reads version {FORMAT_VERSION} "
            "(train the model again with cocomopl train)"
        )
    if meta.get("checksum") != checksum(arrays):
        raise Error(f"{path} is corrupted: checksum mismatch")
    missing = [name for name in REQUIRED if name not in arrays]
    if missing:
        raise Error(f"{path} lacks the model arrays {', '.join(missing)}")
    return meta, arrays


def load_model(path: str | Path) -> MovementPrimitives:
    """Read a model written by :func:`save_model`.

    Returns
    -------
    MovementPrimitives
        Fitted: ``state_``, ``bound_``, ``n_iter_``, ``fit_time_s_`` and
        ``explained_variance_`` are set, and ``metadata_`` holds the decoded metadata.
    """
    meta, arrays = _read(path)
    try:
        model = MovementPrimitives(
            n_primitives=int(meta["n_primitives"]),
            kernel=str(meta["kernel"]),
            n_grid=int(meta["n_grid"]),
            **({"max_iterations": int(meta["max_iterations"])} if "max_iterations" in meta else {}),
        )
        model.bound_ = float(meta["bound"])
        model.n_iter_ = int(meta["n_iter"])
        model.fit_time_s_ = float(meta["fit_time_s"])
        model.explained_variance_ = {str(k): float(v) for k, v in meta["explained_variance"].items()}
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise Error(f"{path} has incomplete or invalid metadata ({type(exc).__name__}: {exc})") from None
    model.state_ = arrays
    model.metadata_ = meta
    return model


def model_metadata(path: str | Path) -> dict:
    """The decoded metadata of a model file, after the same checks as :func:`load_model`."""
    return _read(path)[0]
