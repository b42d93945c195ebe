"""A summary of a dataset file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cocomopl.errors import Error, plural
from cocomopl.motion import Footstep
from cocomopl.motion_file import read_motions


def dataset_info(path: str | Path) -> dict:
    """Counts, convergence, timings and provenance of a dataset (read and checked by
    :func:`cocomopl.motion_file.read_motions`)."""
    motions, attrs = read_motions(path, dataset=True, signals=True)
    names = sorted(motions)
    n_signals = {len(attrs["signals"][n]["names"]) for n in names}
    durations = {n: float(motions[n].t[-1]) for n in names}
    solutions = [motions[n].solution for n in names]
    try:
        solver = [s.solver for s in solutions if not s.mirrored]
        solve_times = [float(s["solve_time_s"]) for s in solver]
        iterations = [float(s["iterations"]) for s in solver]
        converged = all(bool(s["converged"]) for s in solver)
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise Error(f"{path}: a motion's solver statistics are incomplete ({type(exc).__name__}: {exc})") from None
    signals = n_signals.pop() if len(n_signals) == 1 else None
    lengths = _attribute(path, attrs, "lengths_m", list, [])
    footsteps = _attribute(path, attrs, "footsteps_m_rad", list, [])
    if not all(isinstance(f, list) and len(f) == 3 and all(isinstance(x, (int, float)) for x in f) for f in footsteps):
        raise Error(f"{path}: attribute 'footsteps_m_rad' must hold [length, width, turn] triples of numbers")
    continuity = _attribute(path, attrs, "continuity", dict, {})
    _attribute(path, attrs, "ocps", list, [])
    _attribute(path, attrs, "failed", dict, {})
    _attribute(path, attrs, "wall_time_s", (int, float, type(None)), None)
    if not all(isinstance(x, (int, float)) for x in [*lengths, *continuity.values()]):
        raise Error(f"{path}: attributes 'lengths_m' and 'continuity' must hold numbers")
    return {
        "file": str(path),
        "robot": attrs.get("robot"),
        "lengths_mm": [round(1000 * L) for L in lengths],
        "footsteps": [Footstep(*f).label for f in footsteps],
        "ocps": len(attrs.get("ocps", [])),
        "motions": len(names),
        "signals": signals,
        "trajectories": len(names) * (signals or 0),
        "all_converged": bool(attrs.get("all_converged")) and converged,
        "failed": attrs.get("failed", {}),
        "mean_solve_time_s": float(np.mean(solve_times)) if solver else None,
        "total_solve_time_s": float(np.sum(solve_times)) if solver else None,
        "wall_time_s": attrs.get("wall_time_s"),
        "mean_iterations": float(np.mean(iterations)) if solver else None,
        "max_continuity_error": max(continuity.values()) if continuity else None,
        # generation measures the solved steps' junctions only; `dataset check` adds their mirror images
        "solved_step_junctions": len(continuity),
        "duration_s": {"min": min(durations.values()), "max": max(durations.values())} if durations else None,
        "created": attrs.get("created"),
        "command": attrs.get("command"),
        "versions": attrs.get("versions"),
        "settings": attrs.get("settings"),
        "motion_names": names,
    }


def _attribute(path, attrs: dict, key: str, kind, default):
    """A dataset attribute that must be of ``kind`` if present; an :class:`Error` otherwise."""
    value = attrs.get(key, default)
    if not isinstance(value, kind) or isinstance(value, bool):
        raise Error(f"{path}: attribute {key!r} is {type(value).__name__}, not the {key} a dataset holds")
    return value


def format_info(info: dict) -> str:
    rows = [
        ("file", info["file"]),
        ("robot", info["robot"]),
        ("step lengths (mm)", ", ".join(map(str, info["lengths_mm"]))),
        *([("footsteps (mm, mm, deg)", ", ".join(info["footsteps"]))] if info["footsteps"] else []),
        ("OCPs solved / motions", f"{info['ocps']} / {info['motions']} (with mirror images)"),
        ("signals per motion", info["signals"]),
        ("training trajectories", info["trajectories"]),
        ("all converged", info["all_converged"]),
        ("mean solve time (s)", f"{info['mean_solve_time_s']:.2f}" if info["mean_solve_time_s"] else "-"),
        ("wall time (s)", f"{info['wall_time_s']:.1f}" if info["wall_time_s"] else "-"),
        ("max continuity error", f"{info['max_continuity_error']:.2e} over "
         f"{plural(info['solved_step_junctions'], 'step junction')} of the solved steps (without mirror images)"
         if info["max_continuity_error"] is not None else "-"),
        ("created", info["created"]),
        ("command", info["command"]),
    ]
    if info["failed"]:
        rows.append(("NOT CONVERGED", ", ".join(info["failed"])))
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{k:{width}s}  {v}" for k, v in rows)
