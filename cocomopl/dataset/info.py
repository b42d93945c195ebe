"""A summary of a dataset file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cocomopl.errors import Error
from cocomopl.motion_file import file_attrs, open_checked


def dataset_info(path: str | Path) -> dict:
    """Counts, convergence, timings and provenance of a dataset."""
    with open_checked(path) as f:
        attrs = file_attrs(f)
        if attrs.get("content") != "dataset":
            raise Error(f"{path} is a cocomopl motion file, not a dataset")
        names = sorted(f["motions"])
        try:
            n_signals = {int(f["motions"][n]["signals"]["values"].shape[1]) for n in names}
            durations = {n: float(f["motions"][n]["t"][-1]) for n in names}
            stats = [json.loads(f["motions"][n].attrs["meta"]) for n in names]
        except (KeyError, ValueError, OSError) as exc:
            raise Error(f"{path} is damaged: {exc}") from None
    signals = n_signals.pop() if len(n_signals) == 1 else None
    solver = [s["solver"] for s in stats if not s.get("mirrored")]
    continuity = attrs.get("continuity", {})
    return {
        "file": str(path),
        "robot": attrs.get("robot"),
        "lengths_mm": [round(1000 * L) for L in attrs.get("lengths_m", [])],
        "ocps": len(attrs.get("ocps", [])),
        "motions": len(names),
        "signals": signals,
        "trajectories": len(names) * (signals or 0),
        "all_converged": bool(attrs.get("all_converged")) and all(s["converged"] for s in solver),
        "failed": attrs.get("failed", {}),
        "mean_solve_time_s": float(np.mean([s["solve_time_s"] for s in solver])) if solver else None,
        "total_solve_time_s": float(np.sum([s["solve_time_s"] for s in solver])) if solver else None,
        "wall_time_s": attrs.get("wall_time_s"),
        "mean_iterations": float(np.mean([s["iterations"] for s in solver])) if solver else None,
        "max_continuity_error": max(continuity.values()) if continuity else None,
        "junctions": len(continuity),
        "duration_s": {"min": min(durations.values()), "max": max(durations.values())} if durations else None,
        "created": attrs.get("created"),
        "command": attrs.get("command"),
        "versions": attrs.get("versions"),
        "settings": attrs.get("settings"),
        "motion_names": names,
    }


def format_info(info: dict) -> str:
    rows = [
        ("file", info["file"]),
        ("robot", info["robot"]),
        ("step lengths (mm)", ", ".join(map(str, info["lengths_mm"]))),
        ("OCPs solved / motions", f"{info['ocps']} / {info['motions']} (with mirror images)"),
        ("signals per motion", info["signals"]),
        ("training trajectories", info["trajectories"]),
        ("all converged", info["all_converged"]),
        ("mean solve time (s)", f"{info['mean_solve_time_s']:.2f}" if info["mean_solve_time_s"] else "-"),
        ("wall time (s)", f"{info['wall_time_s']:.1f}" if info["wall_time_s"] else "-"),
        ("max continuity error", f"{info['max_continuity_error']:.2e} over {info['junctions']} junctions"
         if info["max_continuity_error"] is not None else "-"),
        ("created", info["created"]),
        ("command", info["command"]),
    ]
    if info["failed"]:
        rows.append(("NOT CONVERGED", ", ".join(info["failed"])))
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{k:{width}s}  {v}" for k, v in rows)
