"""HDF5 files of motions: one schema for datasets, generated and measured motions.

Layout (``h5dump -n`` shows it)::

    /                       attrs: format="cocomopl", format_version, content ("dataset" or "part"; none for motion files),
                                   robot, producer, created, command, versions (JSON), inputs (JSON), ...
    /motions/<name>/        attrs: robot, joint_names (JSON), steps (JSON), meta (JSON)
        t (n,)  q (n, nq)  v (n, nv)  tau (n, nu)  wrenches (n, 2, 6)  contact (n, 2)
        zmp (n, 3)  impacts (m,)  step_starts (s,)  phase_kind (p,)  phase_first (p,)  phase_last (p,)
        signals/            values (n', 36), t (n',), phase_time (n',), names (36,)

Files are written to a temporary file beside the target and renamed, so a crash never
leaves a partial file.  Nothing is unpickled.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from cocomopl.errors import Error
from cocomopl.motion import Motion, StepSpec

FORMAT = "cocomopl"
FORMAT_VERSION = 1
_ARRAYS = ("t", "q", "v", "tau", "wrenches", "contact", "zmp", "impacts", "step_starts")


def writable_folder(folder: Path, purpose: str) -> Path:
    """Create ``folder`` if needed and make sure it can be written, or raise :class:`Error`
    naming ``purpose`` (e.g. "output folder plots")."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise Error(f"cannot create {purpose}: {exc.strerror}") from None
    try:  # a real probe: permission bits say nothing on read-only or virtual file systems
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise Error(f"cannot write to {purpose}: {exc.strerror}") from None
    return folder


def output_file(path: str | Path, example_name: str) -> Path:
    """``path`` as an output file: an :class:`Error` if it is a directory (naming
    ``example_name`` as a file to give instead) or its folder cannot be written."""
    path = Path(path)
    if path.is_dir():
        raise Error(f"--out {path} is a directory; give a file path such as {path / example_name}")
    writable_folder(path.parent, f"the folder of --out {path}")
    return path


@contextmanager
def report_folder(folder: str | Path):
    """Yield ``folder`` for a report, created if needed; if the block fails or is
    interrupted, remove what it added (the folder itself if it made it), so a failed run
    leaves nothing behind."""
    folder = Path(folder)
    existed = folder.exists()
    before = set(folder.iterdir()) if existed and folder.is_dir() else set()
    writable_folder(folder, f"output folder {folder}")
    try:
        yield folder
    except BaseException:
        if not existed:
            shutil.rmtree(folder, ignore_errors=True)
        else:
            for added in set(folder.iterdir()) - before:
                shutil.rmtree(added) if added.is_dir() else added.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_path(path: Path, suffix: str = ".tmp"):
    """Yield a temporary path beside ``path`` that replaces it only if the block succeeds.

    ``suffix`` ends the temporary name, for writers that choose their format by it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(name, 0o666 & ~umask)  # mkstemp makes 0600; a result file is an ordinary file
    tmp = Path(name)
    try:
        yield tmp
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


def write_json(path: Path, payload: dict) -> Path:
    """Write ``payload`` as indented JSON, atomically."""
    with atomic_path(Path(path)) as tmp:
        tmp.write_text(json.dumps(payload, indent=2, default=float) + "\n")
    return Path(path)


def write_motion_group(group: h5py.Group, motion: Motion, signals: dict | None = None) -> None:
    """Write one motion (and optionally its training signals) into an HDF5 group."""
    for key in _ARRAYS:
        group.create_dataset(key, data=np.asarray(getattr(motion, key)))
    group.create_dataset("phase_kind", data=np.array([p[0] for p in motion.phases], dtype="S8"))
    group.create_dataset("phase_first", data=np.array([p[1] for p in motion.phases], dtype=int))
    group.create_dataset("phase_last", data=np.array([p[2] for p in motion.phases], dtype=int))
    group.attrs["robot"] = motion.robot
    group.attrs["joint_names"] = json.dumps(list(motion.joint_names))
    group.attrs["steps"] = json.dumps([vars(s) for s in motion.steps])
    group.attrs["meta"] = json.dumps(motion.meta)
    if signals is not None:
        sig = group.create_group("signals")
        for key, value in signals.items():
            if key == "names":
                sig.create_dataset("names", data=np.array(value, dtype="S32"))
            else:
                sig.create_dataset(key, data=np.asarray(value))


def read_motion_group(group: h5py.Group) -> Motion:
    """Read a motion written by :func:`write_motion_group`."""
    arrays = {key: np.array(group[key]) for key in _ARRAYS}
    arrays["contact"] = arrays["contact"].astype(bool)
    phases = [
        (k.decode(), int(a), int(b))
        for k, a, b in zip(group["phase_kind"][()], group["phase_first"][()], group["phase_last"][()])
    ]
    return Motion(
        phases=phases,
        steps=[StepSpec(**s) for s in json.loads(group.attrs["steps"])],
        joint_names=json.loads(group.attrs["joint_names"]),
        robot=str(group.attrs["robot"]),
        meta=json.loads(group.attrs["meta"]),
        **arrays,
    )


def write_motions(path: str | Path, motions: dict[str, Motion], attrs: dict, signals: dict | None = None) -> None:
    """Write motions (by name) and file-level metadata atomically."""
    path = Path(path)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        for key, value in attrs.items():
            f.attrs[key] = value if isinstance(value, str) else json.dumps(value)
        group = f.create_group("motions")
        for name, motion in motions.items():
            write_motion_group(group.create_group(name), motion, None if signals is None else signals.get(name))


def open_checked(path: str | Path) -> h5py.File:
    """Open a cocomopl HDF5 file for reading, with a clear error for anything else."""
    path = Path(path)
    if not path.exists():
        raise Error(f"file not found: {path}")
    if path.is_dir():
        raise Error(f"{path} is a directory, not a cocomopl HDF5 file")
    try:
        f = h5py.File(path, "r")
    except OSError:
        raise Error(f"{path} is not a readable HDF5 file (truncated, corrupt or another format)") from None
    if f.attrs.get("format") != FORMAT or "motions" not in f:
        f.close()
        raise Error(f"{path} is an HDF5 file but not a cocomopl motion file")
    version = int(f.attrs.get("format_version", -1))
    if version != FORMAT_VERSION:
        f.close()
        raise Error(f"{path} has format version {version}; this cocomopl reads version {FORMAT_VERSION}")
    return f


def file_attrs(f: h5py.File) -> dict:
    """File-level metadata, JSON values decoded."""
    out = {}
    for key, value in f.attrs.items():
        if isinstance(value, bytes):
            value = value.decode()
        if isinstance(value, str):
            try:
                value = json.loads(value)
            except json.JSONDecodeError:
                pass
        out[key] = value
    return out


def read_motions(path: str | Path) -> tuple[dict[str, Motion], dict]:
    """All motions of a file, by name, and its metadata."""
    with open_checked(path) as f:
        try:
            motions = {name: read_motion_group(group) for name, group in f["motions"].items()}
        except (KeyError, ValueError, TypeError, OSError) as exc:
            raise Error(f"{path} is damaged: {exc}") from None
        return motions, file_attrs(f)


def read_motion(path: str | Path, name: str | None = None) -> Motion:
    """One motion of a file: ``name``, or the only one."""
    with open_checked(path) as f:
        names = list(f["motions"])
        if name is None:
            if len(names) != 1:
                raise Error(f"{path} holds {len(names)} motions; name one of: {', '.join(names)}")
            name = names[0]
        if name not in names:
            raise Error(f"{path} has no motion {name!r}; it has: {', '.join(names)}")
        try:
            return read_motion_group(f["motions"][name])
        except (KeyError, ValueError, TypeError, OSError) as exc:
            raise Error(f"{path} is damaged: {exc}") from None
