"""HDF5 files of motions: one schema for datasets, generated and measured motions.

Layout (``h5dump -n`` shows it)::

    /                       attrs: format="cocomopl", format_version, content ("dataset" or "part"; none for motion files),
                                   robot, producer, created, command, versions (JSON), inputs (JSON), ...
    /motions/<name>/        attrs: robot, joint_names (JSON), steps (JSON), meta (JSON)
        t (n,)  q (n, nq)  v (n, nv)  tau (n, nu)  wrenches (n, 2, 6)  contact (n, 2)
        zmp (n, 3)  impacts (m,)  step_starts (s,)  phase_kind (p,)  phase_first (p,)  phase_last (p,)
        signals/            values (n', 36), t (n',), phase_time (n',), names (36,)

Files are written to a temporary file beside the target and renamed, so a crash never
leaves a partial file; report folders likewise (:func:`report_folder`).  Where outputs may go
is checked before any work (:func:`check_output`): never over an input, a read-only file or a
folder of the user's.  Nothing is unpickled.
"""

from __future__ import annotations

import errno
import json
import os
import re
import secrets
import shutil
import tempfile
from contextlib import contextmanager, suppress
from pathlib import Path

import h5py
import numpy as np

from cocomopl.errors import Error
from cocomopl.motion import Motion, StepSpec
from cocomopl.validation import check_motion, check_settings, check_signals

FORMAT = "cocomopl"
FORMAT_VERSION = 1
_ARRAYS = ("t", "q", "v", "tau", "wrenches", "contact", "zmp", "impacts", "step_starts")


# ---------------------------------------------------------------------------- output places
# A temporary file or folder is ".<target name>.cocomopl-tmp-<pid>-<8 hex>[suffix]" beside its target: the pid
# lets a later run tell the leftovers of a killed writer (pid gone) from those of one still writing.
_TEMP_TAG = "cocomopl-tmp"
_TEMP = re.compile(rf"^\..*\.{_TEMP_TAG}-(\d+)-[0-9a-f]{{8}}")
# what a report folder writes last: it marks the folder as a report and lists the files the report wrote
REPORT_MARKER = ".cocomopl-report.json"


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


def writable_place(folder: Path, purpose: str) -> Path:
    """Make sure ``folder`` exists and can be written, or can be created where it is missing, without creating it
    (the writer does, when it writes: a refused or failed command leaves no empty folder); else :class:`Error`
    naming ``purpose``."""
    existing = Path(folder)
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise Error(f"cannot create {purpose}: {existing} is not a folder")
    try:  # a real probe: permission bits say nothing on read-only or virtual file systems
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        verb = "write to" if existing == Path(folder) else "create"
        raise Error(f"cannot {verb} {purpose}: {exc.strerror}") from None
    return folder


def check_output(path: str | Path, inputs=(), *, folder: bool = False, given: str | Path | None = None,
                 option: str = "--out") -> str | None:
    """Refuse, before any work, an output that must not be written, and say what it replaces.

    Parameters
    ----------
    path : the file (or with ``folder``, the report folder) a command will write
    inputs : the files the command reads (None entries are skipped); none may be replaced
    folder : ``path`` is a report folder, replaced as a whole (see :func:`report_folder`)
    given : the ``--out`` the user gave, for the messages (default: ``path``)
    option : the command-line option that names ``path``, for the messages

    Returns
    -------
    str or None
        "replacing PATH" or "replacing the report PATH" if it exists, else None.

    Raises
    ------
    Error
        if ``path`` would replace an input (the same file, symlinks, hard links and other
        spellings included, or a folder holding it), or is not what it would be replaced
        with: a read-only or special file, or a folder that is not a cocomopl report.
    """
    path = Path(path)
    for source in (Path(s) for s in inputs if s is not None):
        if _replaces(path, source):
            raise Error(f"{option} {Path(given or path)} would replace the input {source}")
    if not path.exists():
        return None
    return _replaced_report(path) if folder else _replaced_file(path)


def _replaces(out: Path, source: Path) -> bool:
    """Whether writing ``out`` destroys the existing file ``source``: it is ``out``, or lies in the folder ``out``."""
    if not source.exists():
        return False
    if out.exists() and os.path.samefile(out, source):
        return True
    return out.resolve() in source.resolve().parents


def _replaced_file(path: Path) -> str:
    """The note for an existing output file, or an :class:`Error` if it must not be replaced."""
    if not path.is_file():
        what = "a directory" if path.is_dir() else "not a regular file"
        raise Error(f"{path} is {what}, where a file is to be written; cocomopl replaces only files")
    # renaming over a file needs only its folder's permission: honour the file's own protection
    if not path.stat().st_mode & 0o222 or not os.access(path, os.W_OK):
        raise Error(f"{path} is read-only; cocomopl does not replace it")
    return f"replacing {path}"


def _replaced_report(folder: Path) -> str | None:
    """The note for an existing report folder, or an :class:`Error` unless it is empty or a cocomopl report holding
    only what the report wrote (so no file of the user's is ever deleted)."""
    if not folder.is_dir():
        raise Error(f"--out {folder} is a file, not a folder")
    here = Path.cwd()
    if folder.resolve() in (here, *here.parents):  # renamed away, it would leave the shell in a deleted folder
        raise Error(f"--out {folder} is the current folder or holds it; give a folder inside it")
    entries = {name for name in os.listdir(folder) if not _TEMP.match(name)}
    if not entries:
        return None
    listed = _report_files(folder)
    if listed is None:
        raise Error(f"--out {folder} is not empty and not a cocomopl report (it holds {min(entries)}); "
                    "give a new or empty folder")
    foreign = sorted(entries - listed - {REPORT_MARKER})
    if foreign:
        raise Error(f"--out {folder} is a cocomopl report but also holds {foreign[0]}, which the report did not "
                    "write; move it out or give another folder")
    return f"replacing the report {folder}"


def _report_files(folder: Path) -> set[str] | None:
    """The file names a report folder's marker lists, or None if it has no readable marker."""
    try:
        marker = json.loads((folder / REPORT_MARKER).read_text())
        return set(marker["files"]) if marker.get("format") == "cocomopl report" else None
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def output_file(path: str | Path, example_name: str, *, inputs=(), beside: tuple[str, ...] = (),
                option: str = "--out") -> Path:
    """``path`` as an output file, checked by :func:`check_output` against ``inputs``, with the files of suffixes
    ``beside`` written next to it (``train``'s ".png"), before any work: an :class:`Error` if it is a directory
    (naming ``example_name`` as a file to give instead), may not be replaced, or its folder cannot be written.
    ``option`` names the command-line option that gave ``path`` in the messages."""
    path = Path(path)
    if path.is_dir():
        raise Error(f"{option} {path} is a directory; give a file path such as {path / example_name}")
    for target in (path, *(path.with_suffix(suffix) for suffix in beside)):
        check_output(target, inputs, given=path, option=option)
    writable_place(path.parent, f"the folder of {option} {path}")
    return path


@contextmanager
def report_folder(folder: str | Path, inputs=()):
    """Yield a temporary folder in which to write the report ``folder``; it replaces ``folder`` when the block succeeds.

    The folder is built beside ``folder`` under a temporary name, marked with :data:`REPORT_MARKER` (listing its
    files) and renamed into place, so a run that fails, is interrupted or killed leaves the old report or the new
    one, never a mix, and no empty folder.  An existing ``folder`` is replaced only if :func:`check_output` allows
    it (empty, or a report holding only its own files); that and ``inputs`` are checked on entry, before any work.
    Replacing renames the old report to a temporary name, the new one into place, then deletes the old one: a
    kill between the two renames (microseconds) leaves both under temporary names and no ``folder``.
    """
    folder = Path(folder)
    check_output(folder, inputs, folder=True)
    place = folder.resolve() if folder.is_symlink() else folder  # a link to a report stays a link
    made = [p for p in (place.parent, *place.parent.parents) if not p.exists()]  # deepest first
    work = None
    try:
        writable_folder(place.parent, f"the folder of --out {folder}")
        remove_stale_temps(place.parent)
        work = temp_name(place)
        work.mkdir()
        with _named_as(work, folder, unnamed=False):
            yield work
            files = sorted(p.name for p in work.iterdir() if not _TEMP.match(p.name))
            (work / REPORT_MARKER).write_text(json.dumps({"format": "cocomopl report", "files": files}) + "\n")
            _swap_in(work, place)
    except BaseException:
        if work is not None:
            shutil.rmtree(work, ignore_errors=True)
        for parent in made:  # the folders made for it, if they stayed empty
            try:
                parent.rmdir()
            except OSError:
                break
        raise


def _swap_in(new: Path, place: Path) -> None:
    """Rename the folder ``new`` to ``place``, replacing the folder there (a folder cannot be renamed over a non-empty
    one: the old one is renamed aside first, put back if the second rename fails, and deleted last)."""
    if not place.exists():
        os.rename(new, place)
        return
    _replaced_report(place)  # again: the user may have put a file there during the run
    old = temp_name(place, ".old")
    os.rename(place, old)
    try:
        os.rename(new, place)
    except BaseException:
        os.rename(old, place)
        raise
    shutil.rmtree(old, ignore_errors=True)


@contextmanager
def atomic_path(path: Path, suffix: str = ".tmp"):
    """Yield a temporary path beside ``path`` that replaces it only if the block succeeds.

    ``suffix`` ends the temporary name, for writers that choose their format by it.  Leftovers of writers that were
    killed are removed first (:func:`remove_stale_temps`); an :class:`OSError` about the temporary file names
    ``path`` instead."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temps(path.parent)
    tmp = temp_name(path, suffix)
    # O_EXCL: never another's file; mode 0666 less the umask, as for any result file (mkstemp's is 0600)
    os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
    try:
        with _named_as(tmp, path, unnamed=True):
            yield tmp
            os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def temp_name(path: Path, suffix: str = "") -> Path:
    """A new temporary name beside ``path``, with this process's pid, within the file system's name length (the
    target's name is shortened as needed: a 250-character name gets a temporary name too)."""
    tag = f".{_TEMP_TAG}-{os.getpid()}-{secrets.token_hex(4)}{suffix}"
    room = _name_max(path.parent) - len(os.fsencode(f".{tag}"))
    base = path.name
    while base and len(os.fsencode(base)) > room:
        base = base[:-1]
    return path.with_name(f".{base}{tag}")


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) the file system of ``folder`` takes; POSIX's usual 255 if it does not say."""
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        return 255


def remove_stale_temps(folder: Path) -> list[Path]:
    """Remove the temporary files and folders in ``folder`` whose writer has ended (killed, so it could not
    clean up), and return them.  A temporary of a live process is never touched; nor is one whose pid a new process
    has taken since (kept, harmless).  Best effort: what cannot be removed stays for a later run."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _TEMP.match(entry.name)
        if match is None or _alive(int(match[1])):
            continue
        try:
            shutil.rmtree(entry.path) if entry.is_dir(follow_symlinks=False) else os.unlink(entry.path)
        except OSError:
            continue
        removed.append(Path(entry.path))
    return removed


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (signal 0 tests for it without sending anything)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's
        return True
    except (OverflowError, ValueError):
        return False
    return True


@contextmanager
def _named_as(temp: Path, final: Path, unnamed: bool):
    """Re-raise an :class:`OSError` about ``temp`` (or a path in it) as one about ``final`` (the matching path in it):
    users know the file they asked for, not its temporary name.  With ``unnamed``, a system error naming no file
    (h5py's) is taken to be about ``final`` too."""
    try:
        yield
    except OSError as exc:
        name = _renamed(exc, temp, final, unnamed)
        if name is None:
            raise
        raise OSError(exc.errno, _strerror(exc), str(name)) from exc


def _renamed(exc: OSError, temp: Path, final: Path, unnamed: bool) -> Path | None:
    if exc.filename is None:
        return final if unnamed and exc.errno in errno.errorcode else None
    try:
        return final / Path(os.fsdecode(exc.filename)).relative_to(temp)
    except (TypeError, ValueError):
        return None


def _strerror(exc: OSError) -> str:
    """The system's message for ``exc``'s error number; h5py's own messages span lines and name temporary files."""
    if exc.errno in errno.errorcode:
        return os.strerror(exc.errno)
    return exc.strerror or str(exc) or type(exc).__name__


def os_error_message(exc: OSError) -> str:
    """One line for an operating-system error: ``<path>: <strerror>`` (the CLI's ``cocomopl: error: ...``)."""
    text = _strerror(exc)
    if exc.filename is not None:
        text = f"{os.fsdecode(exc.filename) if isinstance(exc.filename, bytes) else exc.filename}: {text}"
    return " ".join(text.splitlines())


def write_json(path: Path, payload: dict) -> Path:
    """Write ``payload`` as indented JSON, atomically."""
    with atomic_path(Path(path)) as tmp:
        tmp.write_text(json.dumps(payload, indent=2, default=float) + "\n")
    return Path(path)


_COMPRESSED_SIZE = 256  # arrays of at least this many values are stored compressed: a dataset's bulk


def _write_array(group: h5py.Group, key: str, data) -> None:
    """``data`` as the dataset ``key`` of ``group``, the large arrays compressed losslessly
    (shuffle and gzip: solver output in float64 takes about 13 % less space)."""
    data = np.asarray(data)
    compressed = {"compression": "gzip", "compression_opts": 4, "shuffle": True} if data.size >= _COMPRESSED_SIZE else {}
    group.create_dataset(key, data=data, **compressed)


def write_motion_group(group: h5py.Group, motion: Motion, signals: dict | None = None) -> None:
    """Write one motion (and optionally its training signals) into an HDF5 group."""
    for key in _ARRAYS:
        _write_array(group, key, getattr(motion, key))
    group.create_dataset("phase_kind", data=np.array([p[0] for p in motion.phases], dtype="S8"))
    group.create_dataset("phase_first", data=np.array([p[1] for p in motion.phases], dtype=int))
    group.create_dataset("phase_last", data=np.array([p[2] for p in motion.phases], dtype=int))
    group.attrs["robot"] = motion.robot
    group.attrs["joint_names"] = json.dumps(list(motion.joint_names))
    group.attrs["steps"] = json.dumps([s.as_dict() for s in motion.steps])
    group.attrs["meta"] = json.dumps(motion.meta_json())
    if signals is not None:
        sig = group.create_group("signals")
        for key, value in signals.items():
            if key == "names":
                sig.create_dataset("names", data=np.array(value, dtype="S32"))
            else:
                _write_array(sig, key, value)


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
    meta = _json_attribute(group, "meta")
    motion = Motion(
        phases=_phases(group),
        steps=_steps(group),
        joint_names=_json_attribute(group, "joint_names"),
        robot=robot_name.decode(errors="replace") if isinstance(robot_name, bytes) else robot_name,
        **(Motion.split_meta(meta) if isinstance(meta, dict) else {"meta": meta}),
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


def write_motions(path: str | Path, motions: dict[str, Motion], attrs: dict, *, signals: dict | None = None) -> None:
    """Write motions (by name) and file-level metadata atomically."""
    path = Path(path)
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        for key, value in attrs.items():
            f.attrs[key] = value if isinstance(value, str) else json.dumps(value)
        described = _robot_description(motions.values())
        if described is not None:
            f.attrs["robot_description"] = described
        fingerprint = _robot_fingerprint(motions.values())
        if fingerprint is not None and "robot_model" not in attrs:
            f.attrs["robot_model"] = fingerprint
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
            with suppress(json.JSONDecodeError):
                value = json.loads(value)
        out[key] = value
    return out


def _robot_description(motions) -> str | None:
    """The JSON description of the robot of ``motions`` if it was built in this process and is
    not the bundled description of its name (which the name gives enough): a robot of one's
    own, or a bundled robot's description copied and changed under the same name."""
    from cocomopl.robot.description import available_robots, built_description, read_description

    names = {motion.robot for motion in motions}
    name = names.pop() if len(names) == 1 else None
    described = None if name is None else built_description(name)
    if described is None or (name in available_robots() and described == read_description(name)):
        return None
    return json.dumps(described, sort_keys=True)


def _robot_fingerprint(motions) -> str | None:
    """The fingerprint of the robot of ``motions`` (:attr:`~cocomopl.robot.Robot.fingerprint`)
    if they share one and it was built in this process."""
    from cocomopl.robot.description import built_fingerprint

    names = {motion.robot for motion in motions}
    return built_fingerprint(names.pop()) if len(names) == 1 else None


def check_robot_model(recorded, robot, what: str = "it") -> None:
    """An :class:`Error` if ``recorded``, the fingerprint a file or model records (None for
    one made before files recorded it), is not ``robot``'s: it was made for another model of
    the robot (another description, URDF or joints under the same name)."""
    if recorded is not None and recorded != robot.fingerprint:
        raise Error(f"{what} was made for another model of {robot.name} (its description, URDF or joints differ "
                    "from the one loaded here)")


def load_robot(name: str, description: str | None = None):
    """The robot a file names, loaded once per process, from the description the file
    records if it does (a robot of the user's own), else by its bundled name; an
    :class:`Error` if it cannot be."""
    from cocomopl.robot import Robot

    if description is None:
        if name not in _ROBOTS:
            _ROBOTS[name] = Robot(name)
        return _ROBOTS[name]
    if description not in _ROBOTS:
        try:
            recorded = json.loads(description)
        except json.JSONDecodeError as exc:
            raise Error(f"its robot description is not JSON ({exc})") from None
        _ROBOTS[description] = Robot(recorded)
    _ROBOTS[name] = _ROBOTS[description]  # what the file's readers load by name next
    return _ROBOTS[description]


_ROBOTS: dict = {}


def _recorded_description(f: h5py.File) -> str | None:
    value = f.attrs.get("robot_description")
    return value.decode(errors="replace") if isinstance(value, bytes) else value


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


def read_motions(path: str | Path, *, finite: bool = True, dataset: bool = False, signals: bool = False,
                 robot=None) -> tuple[dict[str, Motion], dict]:
    """All motions of a file, by name, and its metadata, every one checked against ``robot``
    or, by default, the robot the file names, which must load (see :func:`read_motion_group`).

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
            robot = robot or load_robot(_file_robot(f, names), _recorded_description(f))
            check_robot_model(attrs.get("robot_model"), robot)
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
            robot = load_robot(_file_robot(f, [name]), _recorded_description(f))
            check_robot_model(file_attrs(f).get("robot_model"), robot, "the file")
            return read_motion_group(f["motions"][name], robot)
        except Error as exc:
            raise Error(f"{path}: motion {name}: {exc}") from None
        except (KeyError, ValueError, TypeError, OSError) as exc:
            raise Error(f"{path}: motion {name}: damaged ({type(exc).__name__}: {exc})") from None
