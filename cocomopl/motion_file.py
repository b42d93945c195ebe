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
from cocomopl.validation import check_motion, check_settings, check_signals

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


def _dataset(group: h5py.Group, key: str) -> np.ndarray:
    """The array ``key`` of ``group``; an :class:`Error` if it is missing or not an array."""
    item = group.get(key)
    if not isinstance(item, h5py.Dataset):
        raise Error(f"array {key!r} is missing")
    if item.dtype.kind not in "biuf" and key != "phase_kind" and key != "names":
        raise Error(f"array {key!r} holds {item.dtype} values, not numbers")
    return item[()]


def _json_attribute(group: h5py.Group, key: str):
    """The JSON attribute ``key`` of ``group``, decoded; an :class:`Error` if missing or not JSON."""
    value = group.attrs.get(key)
    if isinstance(value, bytes):
        value = value.decode(errors="replace")
    if not isinstance(value, str):
        raise Error(f"attribute {key!r} is missing or not text")
    try:
        return json.loads(value)
    except json.JSONDecodeError:
        raise Error(f"attribute {key!r} is not valid JSON") from None


def _steps(group: h5py.Group) -> list[StepSpec]:
    steps = _json_attribute(group, "steps")
    if not isinstance(steps, list) or not all(isinstance(s, dict) for s in steps):
        raise Error("attribute 'steps' is not a list of step objects")
    try:
        return [StepSpec(**s) for s in steps]
    except (TypeError, ValueError) as exc:
        raise Error(f"attribute 'steps' holds a bad step: {exc}") from None


def _phases(group: h5py.Group) -> list[tuple[str, int, int]]:
    kinds, first, last = (_dataset(group, f"phase_{key}") for key in ("kind", "first", "last"))
    if not (kinds.ndim == first.ndim == last.ndim == 1 and len(kinds) == len(first) == len(last)):
        raise Error("arrays 'phase_kind', 'phase_first' and 'phase_last' are not three lists of one length")
    if first.dtype.kind not in "iu" or last.dtype.kind not in "iu" or kinds.dtype.kind != "S":
        raise Error("phases are not (kind, first sample, last sample) triples")
    return [(k.decode(errors="replace"), int(a), int(b)) for k, a, b in zip(kinds, first, last)]


def read_motion_group(group: h5py.Group, robot=None, finite: bool = True) -> Motion:
    """Read a motion written by :func:`write_motion_group` and check it with
    :func:`cocomopl.validation.check_motion` (against ``robot`` if given; NaN and Inf are
    refused unless ``finite`` is False).  Every problem is an :class:`Error`."""
    arrays = {key: _dataset(group, key) for key in _ARRAYS}
    contact = arrays["contact"]
    if contact.dtype.kind in "iu" and np.isin(contact, (0, 1)).all():
        arrays["contact"] = contact.astype(bool)
    robot_name = group.attrs.get("robot")
    motion = Motion(
        phases=_phases(group),
        steps=_steps(group),
        joint_names=_json_attribute(group, "joint_names"),
        robot=robot_name.decode(errors="replace") if isinstance(robot_name, bytes) else robot_name,
        meta=_json_attribute(group, "meta"),
        **arrays,
    )
    check_motion(motion, robot, finite)
    return motion


def read_signals(group: h5py.Group, n_signals: int | None = None, finite: bool = True) -> dict:
    """The training signals of a dataset motion (``values``, ``t``, ``phase_time``, ``names``), checked."""
    signals = group.get("signals")
    if not isinstance(signals, h5py.Group):
        raise Error("it has no training signals (regenerate it with 'cocomopl dataset generate')")
    out = {key: _dataset(signals, key) for key in ("values", "t", "phase_time", "names")}
    if out["names"].ndim != 1 or out["names"].dtype.kind not in "SU":
        raise Error("signals/names is not a list of names")
    out["names"] = [n.decode(errors="replace") if isinstance(n, bytes) else str(n) for n in out["names"]]
    check_signals(out, n_signals, finite)
    return out


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
    if f.attrs.get("format") != FORMAT or not isinstance(f.get("motions"), h5py.Group):
        f.close()
        raise Error(f"{path}: an HDF5 file but not a cocomopl motion file")
    version = f.attrs.get("format_version")
    if not (isinstance(version, (int, np.integer)) and version == FORMAT_VERSION):
        f.close()
        raise Error(f"{path}: format version {version!r}; this cocomopl reads version {FORMAT_VERSION}")
    if not all(isinstance(group, h5py.Group) for group in f["motions"].values()):
        f.close()
        raise Error(f"{path}: its motions are not all HDF5 groups")
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


def load_robot(name: str):
    """The robot a file names, loaded once per process; an :class:`Error` if it cannot be."""
    from cocomopl.robot import Robot

    if name not in _ROBOTS:
        _ROBOTS[name] = Robot(name)
    return _ROBOTS[name]


_ROBOTS: dict = {}


def _file_robot(f: h5py.File, names: list[str]) -> str:
    """The one robot a file's motions are for (its metadata's, which they must all share)."""
    robots = {f["motions"][n].attrs.get("robot") for n in names}
    if "robot" in f.attrs:
        robots.add(f.attrs["robot"])
    robots = {r.decode(errors="replace") if isinstance(r, bytes) else r for r in robots}
    if len(robots) != 1 or not all(isinstance(r, str) and r for r in robots):
        raise Error(f"its motions name {len(robots)} robots ({', '.join(sorted(map(str, robots)))}); expected one")
    return robots.pop()


def is_dataset(path: str | Path) -> bool:
    """Whether a file is an OC dataset, whose motions carry training signals."""
    with open_checked(path) as f:
        return f.attrs.get("content") == "dataset"


def read_motions(path: str | Path, finite: bool = True, dataset: bool = False,
                 signals: bool = False) -> tuple[dict[str, Motion], dict]:
    """All motions of a file, by name, and its metadata, every one checked against the robot
    the file names (see :func:`read_motion_group`).

    ``dataset``: the file must be an OC dataset (content "dataset", with its OCP settings).
    ``signals``: also read each motion's training signals, as ``attrs["signals"][name]``.
    A problem is an :class:`Error` ``"PATH: what is wrong"``.
    """
    with open_checked(path) as f:
        try:
            attrs = file_attrs(f)
            if dataset:
                if attrs.get("content") != "dataset":
                    raise Error("it is a cocomopl motion file, not an OC dataset (from 'cocomopl dataset generate')")
                check_settings(attrs.get("settings"))
            names = list(f["motions"])
            if not names:
                raise Error("it holds no motions")
            robot = load_robot(_file_robot(f, names))
            motions, found = {}, {}
            for name in names:
                try:
                    motions[name] = read_motion_group(f["motions"][name], robot, finite)
                    if signals:
                        found[name] = read_signals(f["motions"][name], None, finite)
                except Error as exc:
                    raise Error(f"motion {name}: {exc}") from None
            if signals:
                counts = {len(s["names"]) for s in found.values()}
                if len(counts) != 1:
                    raise Error(f"its motions have different numbers of training signals ({sorted(counts)})")
                attrs["signals"] = found
        except Error as exc:
            raise Error(f"{path}: {exc}") from None
        except (KeyError, ValueError, TypeError, OSError) as exc:
            raise Error(f"{path}: damaged ({type(exc).__name__}: {exc})") from None
        return motions, attrs


def read_motion(path: str | Path, name: str | None = None) -> Motion:
    """One motion of a file: ``name``, or the only one; checked as by :func:`read_motions`."""
    with open_checked(path) as f:
        names = list(f["motions"])
        if name is None:
            if len(names) != 1:
                raise Error(f"{path} holds {len(names)} motions; name one of: {', '.join(names)}")
            name = names[0]
        if name not in names:
            raise Error(f"{path} has no motion {name!r}; it has: {', '.join(names)}")
        try:
            robot = load_robot(_file_robot(f, [name]))
            return read_motion_group(f["motions"][name], robot)
        except Error as exc:
            raise Error(f"{path}: motion {name}: {exc}") from None
        except (KeyError, ValueError, TypeError, OSError) as exc:
            raise Error(f"{path}: motion {name}: damaged ({type(exc).__name__}: {exc})") from None
