"""Benchmark of the OC training-data stage.

Reports, in one run on this machine:

* per-OCP solve time and iterations of a dataset (default: the bundled one, as recorded
  when it was generated), and its whole wall time;
* optionally (``--regenerate``) the wall time of generating the whole dataset afresh;
* for reference, a cyclic TALOS step built with Crocoddyl's own ``SimpleBipedGaitProblem``
  beside cocomopl's cyclic step of the same length, both solved here.

Usage::

    python benchmarks/bench_ocp.py [DATASET] [--regenerate] [--length-mm 250] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import cocomopl  # noqa: F401  (sets one OpenMP thread per process before Crocoddyl loads)


def dataset_table(path: Path) -> dict:
    from cocomopl.motion_file import read_motions

    motions, attrs = read_motions(path)
    rows = []
    for name, motion in sorted(motions.items()):
        if motion.solution.mirrored:
            continue
        solver = motion.solution.solver
        rows.append(
            {
                "ocp": name,
                "solve_time_s": solver["solve_time_s"],
                "iterations": solver["iterations"],
                "attempts": len(solver.get("attempts", [])),
                "cost": solver["cost"],
            }
        )
    return {"file": str(path), "wall_time_s": attrs.get("wall_time_s"), "workers": attrs.get("workers"), "ocps": rows}


def squared_torque_integral(t: np.ndarray, tau: np.ndarray) -> float:
    return float((tau[:-1] ** 2).sum(axis=1) @ np.diff(t))


def crocoddyl_reference(length: float, dt: float, ds_knots: int, ss_knots: int) -> dict:
    """Crocoddyl's example biped problem (TALOS, two steps of the given foot travel)."""
    import crocoddyl
    from crocoddyl.utils.biped import SimpleBipedGaitProblem

    from cocomopl.robot import Robot

    robot = Robot("talos")
    model = robot.model.copy()
    model.referenceConfigurations["half_sitting"] = robot.q_ref
    gait = SimpleBipedGaitProblem(model, "right_sole_link", "left_sole_link")
    x0 = np.concatenate([robot.q_ref, np.zeros(model.nv)])
    problem = gait.createWalkingProblem(x0, 2 * length, 0.05, dt, ss_knots, ds_knots)
    solver = crocoddyl.SolverFDDP(problem)
    xs = [x0] * (problem.T + 1)
    us = problem.quasiStatic([x0] * problem.T)
    start = time.perf_counter()
    solver.solve(xs, us, 200, False)
    elapsed = time.perf_counter() - start
    us = np.array([u for u in solver.us if len(u) == robot.nu])
    return {
        "name": "crocoddyl SimpleBipedGaitProblem (2 steps, CoM and swing foot tracked)",
        "knots": problem.T,
        "solve_time_s": elapsed,
        "iterations": int(solver.iter),
        "squared_torque_integral": float((us**2).sum() * dt),
    }


def cocomopl_cyclic(length: float) -> dict:
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.ocp.solve import solve_length, to_motion
    from cocomopl.robot import Robot

    robot = Robot("talos")
    settings = OCPSettings(ss_search_step=0.0)
    start = time.perf_counter()
    solutions, _info = solve_length(robot, length, settings, kinds=("cyclic",))
    total = time.perf_counter() - start
    solution = solutions["cyclic"]
    motion = to_motion(robot, solution, settings)
    return {
        "name": "cocomopl cyclic step (1 step, torque-optimal, periodic)",
        "knots": len(solution.us),
        "solve_time_s": solution.stats["solve_time_s"],
        "iterations": solution.stats["iterations"],
        "with_warm_up_walk_s": total,
        "squared_torque_integral": squared_torque_integral(motion.t, motion.tau),
    }


def regenerate() -> float:
    from cocomopl.dataset.generate import generate
    from cocomopl.dataset.plan import DEFAULT_LENGTHS_M

    with tempfile.TemporaryDirectory() as tmp:
        summary = generate(Path(tmp) / "bench.h5", DEFAULT_LENGTHS_M, command="benchmarks/bench_ocp.py --regenerate")
    return summary["wall_time_s"]


def main() -> int:
    from cocomopl.data import BUNDLED_DATASET

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dataset", nargs="?", default=str(BUNDLED_DATASET))
    parser.add_argument("--regenerate", action="store_true", help="also time a fresh generation of the 28 OCPs")
    parser.add_argument("--length-mm", type=float, default=250.0, help="step length of the side-by-side comparison")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    report = {"dataset": dataset_table(Path(args.dataset))}
    if args.regenerate:
        report["regenerated_wall_time_s"] = regenerate()
    length = args.length_mm / 1000
    ours = cocomopl_cyclic(length)
    from cocomopl.ocp.settings import OCPSettings

    s = OCPSettings()
    report["side_by_side"] = [
        ours,
        crocoddyl_reference(length, s.dt, round(s.ds_duration / s.dt), round(s.ss_duration / s.dt)),
    ]
    if args.json:
        print(json.dumps(report))
        return 0
    table = report["dataset"]
    print(f"dataset {table['file']}: wall time {table['wall_time_s']:.1f} s with {table['workers']} workers")
    print(f"{'OCP':24s} {'solve (s)':>9s} {'iterations':>10s} {'attempts':>8s}")
    for row in table["ocps"]:
        print(f"{row['ocp']:24s} {row['solve_time_s']:9.2f} {row['iterations']:10d} {row['attempts']:8d}")
    if "regenerated_wall_time_s" in report:
        print(f"regenerated the whole dataset here in {report['regenerated_wall_time_s']:.1f} s")
    print(f"\nside by side, step length {args.length_mm:g} mm:")
    print(f"{'problem':72s} {'knots':>5s} {'solve (s)':>9s} {'iter':>5s} {'int tau^2 dt':>12s}")
    for row in report["side_by_side"]:
        print(
            f"{row['name']:72s} {row['knots']:5d} {row['solve_time_s']:9.2f} {row['iterations']:5d} "
            f"{row['squared_torque_integral']:12.0f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
