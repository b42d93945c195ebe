"""Refinement: primitives as warm starts of the step OCPs, against the OCPs' own initial guess.

Over M_gen and ``--n`` random 9-step sequences (drawn as in ``random_walks.py``, seed
``--seed``), every step of the generated walk is refined (``cocomopl.ocp.refine``) and the
same OCP -- same start, same end target, same settings and stopping test -- is solved again
from the dataset's own initial guess (feet on their paths by inverse kinematics: "cold").
Per step: iterations, wall time and final cost, warm and cold, and whether each converged.

    python benchmarks/bench_refine.py [--n 20] [--seed 5] [--workers 2] [--warm-start nearest|generated] [--json]

Each step is warm-started as ``cocomopl refine`` does by default, from the dataset's solved
steps around it, interpolated (``cocomopl.ocp.refine.guess_states``), and its first step at
the first knot is solved exactly (``cocomopl.ocp.first_knot``). ``--warm-start nearest``
starts it from the nearest solved step; ``--warm-start generated`` from the generated step,
with box-FDDP's own first step, as the cold solves take. The cold solves are the same in
every run.

Seed 5 is used by no other benchmark.  Keys: ``iterations_median``, ``iterations_p95``,
``cold_iterations_median``, ``cost_ratio_to_cold_median``, ``cost_ratio_to_cold_max``
(refined cost over cold cost, per step), ``speedup_median`` (the cold solver's wall time over
the warm one's, per step), ``speedup_with_guess_median`` (the same with building each guess's
states counted), ``speedup_whole_step_median`` (the same over whole steps: the problem, its
controls and the acceptance checks, which warm and cold share, counted too), ``success_rate`` (refined steps converged and accepted by the dataset's checks),
``fallback_steps`` (those the warm start left unaccepted, solved again from the cold guess;
their iterations and time count both solves), ``cold_success_rate``,
``raw_cost_ratio_median`` (per walk: the generated walk's ∫Στ²dt as placed over the refined
one's) and ``m_gen`` (the same for M_gen alone).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from functools import partial

import numpy as np
from random_walks import random_lengths
from tqdm import tqdm

from cocomopl.gait import M_GEN_MM
from cocomopl.ocp.settings import DEFAULT_WARM_START, WARM_STARTS
from cocomopl.processes import spawn_pool

SEED = 5


def run_one(lengths_mm: list[float], warm_start_from: str = DEFAULT_WARM_START) -> dict:
    from cocomopl.data import BUNDLED_DATASET
    from cocomopl.motion_file import read_motions
    from cocomopl.ocp.refine import cold_solve, torque_cost
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.pipeline import generate_walk, refine
    from cocomopl.requests import Refinement, StraightSteps, WalkRequest

    walk = generate_walk(WalkRequest(StraightSteps([x / 1000 for x in lengths_mm])))
    refined, summary = refine(walk.motion, Refinement(warm_start=warm_start_from))
    _, attrs = read_motions(BUNDLED_DATASET, dataset=True)
    settings = OCPSettings.from_saved(attrs["settings"])
    rows = []
    # the cold solves see the same plans: each step starts where the refined step before it ended
    for plan, warm in zip(refined.plans, refined.steps):
        cold = cold_solve(walk.robot, plan, settings)
        rows.append({"step": warm["step"], "iterations": warm["iterations"], "converged": warm["converged"],
                     "fallback": warm["fallback"],
                     "cost": warm["cost"], "solve_s": warm["solve_time_s"], "guess_s": warm["guess_s"],
                     "step_s": warm["step_s"],
                     "cold_iterations": cold.stats["iterations"], "cold_converged": cold.stats["converged"],
                     "cold_cost": cold.stats["cost"], "cold_solve_s": cold.stats["solve_time_s"],
                     "cold_guess_s": cold.stats["guess_s"], "cold_step_s": cold.stats["step_s"]})
    return {"lengths_mm": lengths_mm, "raw_cost_ratio": summary.raw_cost_ratio,
            "refined_torque_cost": torque_cost(refined.motion), "steps": rows}


def summarise(walks: list[dict]) -> dict:
    steps = [row for w in walks for row in w["steps"]]
    warm = np.array([r["iterations"] for r in steps])
    ratio = np.array([r["cost"] / r["cold_cost"] for r in steps])
    speedup = np.array([r["cold_solve_s"] / r["solve_s"] for r in steps])
    return {
        "n_walks": len(walks),
        "n_steps": len(steps),
        "iterations_median": float(np.median(warm)),
        "iterations_p95": float(np.percentile(warm, 95)),
        "cold_iterations_median": float(np.median([r["cold_iterations"] for r in steps])),
        "cold_iterations_p95": float(np.percentile([r["cold_iterations"] for r in steps], 95)),
        "cost_ratio_to_cold_median": float(np.median(ratio)),
        "cost_ratio_to_cold_max": float(ratio.max()),
        "cost_ratio_to_cold_min": float(ratio.min()),
        "speedup_median": float(np.median(speedup)),
        "speedup_with_guess_median": float(np.median([(r["cold_guess_s"] + r["cold_solve_s"]) / (r["guess_s"] + r["solve_s"])
                                                      for r in steps])),
        "speedup_whole_step_median": float(np.median([r["cold_step_s"] / r["step_s"] for r in steps])),
        "success_rate": float(np.mean([r["converged"] for r in steps])),
        "fallback_steps": int(sum(r["fallback"] for r in steps)),
        "cold_success_rate": float(np.mean([r["cold_converged"] for r in steps])),
        "raw_cost_ratio_median": float(np.median([w["raw_cost_ratio"] for w in walks])),
        "raw_cost_ratio_max": float(np.max([w["raw_cost_ratio"] for w in walks])),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20, help="random sequences besides M_gen (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--warm-start", default=DEFAULT_WARM_START, choices=WARM_STARTS,
                        help="what each step's OCP starts from (default: %(default)s)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    sequences = [[float(x) for x in M_GEN_MM.split(",")]] + [random_lengths(rng, 100.0) for _ in range(args.n)]
    started = time.perf_counter()
    with spawn_pool(args.workers) as pool:
        walks = list(tqdm(pool.imap(partial(run_one, warm_start_from=args.warm_start), sequences), total=len(sequences),
                          desc="walks refined", file=sys.stderr))
    summary = {**summarise(walks), "m_gen": summarise(walks[:1]), "seed": args.seed, "warm_start": args.warm_start,
               "wall_time_s": time.perf_counter() - started, "walks": walks}
    if args.json:
        print(json.dumps(summary))
    else:
        for key, value in summary.items():
            if not isinstance(value, (list, dict)):
                print(f"{key:28s} {value:.4g}" if isinstance(value, float) else f"{key:28s} {value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
