"""Checks of what a file holds, before anything computes with it.

A motion, dataset or model file can be truncated, edited by hand or written by another
program.  Each reader calls these checks once, so a wrong file is refused with one line
naming what is wrong instead of failing somewhere deep in a solver, a plot or an export.
The functions raise :class:`~cocomopl.errors.Error` with a message that does not name the
file; the readers prefix it.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from cocomopl.errors import Error
from cocomopl.gait import FOOTSTEP_RANGE, MAX_LENGTH_M, RANGE_ROUNDING, footstep_range, within_range
from cocomopl.motion import Motion

PHASE_KINDS = ("ds", "ss")
QUATERNION_TOLERANCE = 1e-3  # |norm - 1| of the base orientation; solvers and MuJoCo keep it near 1e-12
NO_PUSH_FORCE = 1e-6  # N: the ZMP is undefined (NaN) where the soles push less than this in all


def read_csv_table(path: str | Path, columns: tuple[str, ...], *, what: str) -> list[tuple[int, list[str]]]:
    """The rows of a CSV file with the header ``columns``, as (row number from 1, its cells
    stripped), blank lines left out.

    Raises
    ------
    Error
        One line naming the file (a ``what`` file) and the row: a missing or unreadable
        file, another header, a row with a missing or extra value, no rows.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise Error(f"{path}: no such {what} file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise Error(f"{path}: cannot read it as a UTF-8 text file ({error.__class__.__name__})") from None
    rows = [row for row in csv.reader(text.splitlines()) if any(cell.strip() for cell in row)]
    if not rows or tuple(cell.strip() for cell in rows[0]) != columns:
        raise Error(f"{path}: the first line must be the header {','.join(columns)}")
    out = []
    for row, cells in enumerate(rows[1:], start=2):
        if len(cells) != len(columns):
            raise Error(f"{path}: row {row} has {len(cells)} values, expected {len(columns)} ({','.join(columns)})")
        out.append((row, [cell.strip() for cell in cells]))
    if not out:
        raise Error(f"{path}: no rows after the header")
    return out


def require(condition: bool, message: str) -> None:
    """Raise :class:`Error` with ``message`` unless ``condition``."""
    if not condition:
        raise Error(message)


def check_array(name: str, value: np.ndarray, kind: str, *, shape: tuple) -> np.ndarray:
    """``value`` if its dtype kind is one of ``kind`` ("f" float, "i" integer, "b" bool) and
    its shape matches ``shape`` (None matches any length); else :class:`Error`."""
    value = np.asarray(value)
    kinds = {"f": "floating-point numbers", "i": "whole numbers", "b": "booleans", "fi": "numbers", "bi": "0/1 flags"}
    require(value.dtype.kind in kind.replace("i", "iu"), f"array {name!r} holds {value.dtype} values, not {kinds[kind]}")
    expected = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
    require(
        value.ndim == len(shape) and all(s is None or s == v for s, v in zip(shape, value.shape)),
        f"array {name!r} has shape {value.shape}, expected {expected}",
    )
    return value


def check_finite(name: str, value: np.ndarray) -> None:
    """:class:`Error` naming the first NaN or Inf in ``value``, if any."""
    bad = ~np.isfinite(value)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise Error(f"array {name!r} holds {int(bad.sum())} NaN or infinite value(s), the first {value[index]} at {index}")


def check_indices(name: str, value: np.ndarray, n: int, *, increasing: bool = True) -> None:
    """``value`` are sample indices in ``0 .. n-1``, strictly increasing if ``increasing``."""
    if value.size:
        require(value.min() >= 0 and value.max() < n, f"{name} {value.tolist()} are not all sample indices 0..{n - 1}")
    if increasing:
        require(bool(np.all(np.diff(value) > 0)), f"{name} {value.tolist()} are not strictly increasing")


def check_steps(steps: list, limits: dict[str, tuple[float, float]] = FOOTSTEP_RANGE) -> None:
    """Every step's lengths are numbers of metres within reach, backward steps as far as
    ``limits`` go (a robot's :func:`~cocomopl.gait.footstep_range`, by default TALOS's
    ``FOOTSTEP_RANGE``), and its widths and turns within them (give or take
    ``RANGE_ROUNDING``, as :func:`~cocomopl.gait.check_footstep` takes them)."""
    require(len(steps) >= 1, "the motion has no steps")
    low = limits["length"][0]
    for spec in steps:
        for length in (spec.start_length, spec.end_length):
            require(
                isinstance(length, (int, float)) and not isinstance(length, bool) and math.isfinite(length)
                and low - RANGE_ROUNDING["length"] <= length <= MAX_LENGTH_M,
                f"step {spec.kind} has length {length!r}, not a number of metres in {low:g}..{MAX_LENGTH_M:g}",
            )
        for key in ("width", "turn"):
            lo, hi = limits[key]
            for value in (getattr(spec, f"start_{key}"), getattr(spec, f"end_{key}")):
                require(within_range(key, value, limits), f"step {spec.name} has a {key} of {value:g}, outside {lo:g}..{hi:g}")


def check_time(t: np.ndarray, impacts: np.ndarray) -> None:
    """Time increases strictly, except that a touchdown repeats its time once (pre- and post-impact)."""
    require(len(t) >= 2, f"the motion has {len(t)} sample(s); at least 2 are needed")
    check_indices("impacts", impacts, len(t) - 1)
    step = np.diff(t)
    repeated = np.zeros(len(step), dtype=bool)
    repeated[impacts] = True
    bad = np.flatnonzero(np.where(repeated, step != 0.0, step <= 0.0))
    if bad.size:
        k = int(bad[0])
        what = "an impact whose time is not repeated" if repeated[k] else "time that does not increase"
        raise Error(f"samples {k} and {k + 1} (t = {t[k]:.6g}, {t[k + 1]:.6g} s) have {what}")


def check_motion(motion: Motion, robot=None, finite: bool = True) -> None:
    """Refuse a motion that is not a well-formed motion (for ``robot``, if given).

    Checks the kinds and shapes of every array against each other and the robot, strictly
    increasing time (repeated at impacts only), the indices (impacts, step starts, phases)
    in range, the attributes' types, the steps within the robot's footstep range (TALOS's
    without a robot), a unit base quaternion and, unless ``finite`` is False, that no value
    is NaN or infinite (the ZMP may be NaN where no sole pushes).
    """
    require(isinstance(motion.robot, str) and motion.robot != "", "attribute 'robot' is not a robot name")
    require(isinstance(motion.meta, dict), "attribute 'meta' is not a JSON object")
    names = motion.joint_names
    require(isinstance(names, list) and all(isinstance(x, str) for x in names), "joint_names is not a list of names")
    nu = len(names)
    t = check_array("t", motion.t, "f", shape=(None,))
    n = len(t)
    shapes = {"q": (n, 7 + nu), "v": (n, 6 + nu), "tau": (n, nu), "wrenches": (n, 2, 6), "zmp": (n, 3)}
    arrays = {key: check_array(key, getattr(motion, key), "f", shape=shape) for key, shape in shapes.items()}
    check_array("contact", motion.contact, "b", shape=(n, 2))
    impacts = check_array("impacts", motion.impacts, "i", shape=(None,))
    starts = check_array("step_starts", motion.step_starts, "i", shape=(len(motion.steps),))
    if robot is not None:
        require(motion.robot == robot.name, f"the motion is for robot {motion.robot!r}, not {robot.name!r}")
        require(names == list(robot.joint_names), f"its joint names are not {robot.name}'s {nu}-joint order")
    if finite:
        check_finite("t", t)
        for key, value in arrays.items():
            if key == "zmp":  # undefined, NaN, where no sole pushes: only there
                pushing = motion.wrenches[:, :, 2].sum(axis=1) > NO_PUSH_FORCE
                check_finite("zmp", value[pushing])
                require(not np.isinf(value).any(), "array 'zmp' holds infinite values")
            else:
                check_finite(key, value)
        norm = np.linalg.norm(arrays["q"][:, 3:7], axis=1)
        k = int(np.argmax(np.abs(norm - 1.0)))
        require(abs(norm[k] - 1.0) <= QUATERNION_TOLERANCE, f"the base quaternion at sample {k} has norm {norm[k]:.6g}, not 1")
    check_indices("impacts", impacts, n - 1)
    if np.isfinite(t).all():  # a NaN time is reported by the finiteness check (or the dataset check)
        check_time(t, impacts)
    check_steps(motion.steps, FOOTSTEP_RANGE if robot is None else footstep_range(robot))
    check_indices("step_starts", starts, n)
    require(starts[0] == 0, f"step_starts begin at {int(starts[0])}, not 0")
    for kind, first, last in motion.phases:
        require(kind in PHASE_KINDS, f"phase kind {kind!r} is not one of {', '.join(PHASE_KINDS)}")
        require(0 <= first <= last < n, f"phase ({kind}, {first}, {last}) is not a sample range within 0..{n - 1}")


def check_signals(signals: dict, n_signals: int | None = None, finite: bool = True) -> int:
    """Refuse training signals that are not ``values`` (n, I), ``t`` and ``phase_time`` (n,)
    increasing, ``names`` (I,); returns I.  ``n_signals``: the I of the other motions."""
    values = check_array("signals/values", signals["values"], "f", shape=(None, n_signals))
    n, count = values.shape
    t = check_array("signals/t", signals["t"], "f", shape=(n,))
    phase_time = check_array("signals/phase_time", signals["phase_time"], "f", shape=(n,))
    require(len(signals["names"]) == count, f"signals/names has {len(signals['names'])} names for {count} signals")
    if finite:
        for key, value in (("signals/values", values), ("signals/t", t), ("signals/phase_time", phase_time)):
            check_finite(key, value)
    require(n >= 2 and bool(np.all(np.diff(t) > 0)), "signals/t does not increase strictly")
    require(bool(np.all(np.diff(phase_time) >= 0)) and phase_time[0] == 0 and phase_time[-1] >= 1,
            "signals/phase_time does not run from 0 up to the number of phases")
    return count


def check_settings(settings) -> dict:
    """A dataset's OCP settings: a JSON object whose ``dt`` and ``friction`` are positive numbers."""
    require(isinstance(settings, dict), "attribute 'settings' is missing or not a JSON object (is this a dataset?)")
    for key in ("dt", "friction"):
        value = settings.get(key)
        require(isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0,
                f"settings {key!r} is {value!r}, not a positive number")
    return settings
