"""How often do generated walks stay up?  50 random 9-step sequences, simulated in MuJoCo.

Each sequence draws its 9 step lengths uniformly from 150-400 mm (the training range),
the last repeating the one before it (a stop starts in its own gait), each within
``--max-change-mm`` of the one before (default 100 mm: the largest change between
consecutive steps in the paper's training set, 150 -> 250; the bundled set's transitions
change by 50 mm; 0 removes the limit), is generated with the bundled model (or ``--model``), placed in the
world (with the dynamics filter and the upper body's limit correction), checked as a plan
with the checks of ``cocomopl dataset check`` (inverse dynamics, ZMP margin, friction, limits),
and simulated with the stabilizer on, and with it off.  Goal (docs/results.md#goals): at
least 95 % walk without falling.

With ``--goals``, each walk goes to a random goal pose instead (within 1.5 m ahead, 0.6 m
behind or aside and 90 degrees, :func:`random_goal`): its footsteps are planned within the
bundled omnidirectional model's range (``cocomopl walk --to``), played as planned
(``cocomopl walk --to ... --no-reaim``), and it is also measured against the goal and walked
by the Kajita baseline on the same footsteps and timing.
With ``--feedforward``, each walk is also simulated without the stabilizer but with the
servos' torque feedforward from the plan (``cocomopl walk --no-stabilizer --feedforward``, ``--no-reaim`` for a goal).
With ``--reaim``, each walk is also simulated with footstep re-aiming, with and without the
stabilizer (``cocomopl walk --to ... [--no-stabilizer]``, which re-aims by default).

    python benchmarks/random_walks.py [--n 50] [--seed 0] [--max-change-mm 100] [--goals] [--feedforward]
        [--reaim] [--workers 2] [--contact-time-constant-s 0.01] [--reference-cutoff-hz 15] [--model MODEL] [--json]
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import multiprocessing as mp
import sys
import time

import numpy as np
from tqdm import tqdm

from cocomopl.analysis.feasibility import AT_LEAST
from cocomopl.data import BUNDLED_MODEL, BUNDLED_OMNI_MODEL
from cocomopl.errors import Error
from cocomopl.primitives.model_file import load_model
from cocomopl.sim.mujoco_model import CONTACT_TIME_CONSTANT, check_contact_time_constant
from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ, check_reference_cutoff

# per simulation of a walk: (stabilizer, torque feedforward, footstep re-aiming)
RUNS = {"stabilizer": (True, False, False), "no_stabilizer": (False, False, False),
        "feedforward": (False, True, False), "reaim": (True, False, True), "reaim_no_stabilizer": (False, False, True)}


def run_names(goals: bool, feedforward: bool, reaim: bool = False) -> tuple[str, ...]:
    """The simulations of each walk: the generated walk with and without the stabilizer,
    without it but with torque feedforward, re-aimed with and without it, the Kajita baseline
    (with the stabilizer)."""
    return (("stabilizer", "no_stabilizer") + (("feedforward",) if feedforward else ())
            + (("reaim", "reaim_no_stabilizer") if reaim else ()) + (("kajita",) if goals else ()))


def run_one(request: dict, contact_time_constant: float, model: str, reference_cutoff_hz: float,
            feedforward: bool = False, reaim: bool = False) -> dict:
    """One walk: ``request`` is ``{"lengths_mm": [...]}`` or ``{"goal": [x_m, y_m, yaw_deg]}``;
    a goal's walk is also measured against the goal, and the Kajita baseline walks its
    footsteps with the same timing (with the stabilizer); :func:`run_names`."""
    from cocomopl.analysis.feasibility import check_motion, tolerances, violations
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.pipeline import generate_walk, goal_errors, kajita_for, reaiming_for
    from cocomopl.requests import Goals, StraightSteps, WalkRequest
    from cocomopl.sim.mujoco_model import build_sim_model
    from cocomopl.sim.rollout import simulate

    goal = None
    if "goal" in request:
        x, y, yaw = request["goal"]
        goal = (x, y, math.radians(yaw))
        try:
            walk = generate_walk(WalkRequest(Goals([goal]), model=model))
        except Error as exc:
            return {**request, "unplanned": str(exc)}
    else:
        walk = generate_walk(WalkRequest(StraightSteps([x / 1000 for x in request["lengths_mm"]]), model=model))
    sim = build_sim_model(walk.robot, visuals=False, contact_time_constant=contact_time_constant)
    # the plan against the checks of `cocomopl dataset check`, with the OC data's friction
    checks = check_motion(walk.robot, walk.motion, OCPSettings().friction)
    out = {**request, "steps": len(walk.steps), "duration_s": walk.motion.duration, "plan_checks": checks,
           "plan_violations": violations(checks, tolerances(float(np.median(np.diff(walk.motion.t)))))}
    weight = walk.robot.mass * 9.81
    for name in run_names(goal is not None, feedforward, reaim):
        motion, (stabilizer, servo_feedforward, reaimed) = ((kajita_for(walk), (True, False, False)) if name == "kajita"
                                                            else (walk.motion, RUNS[name]))
        rollout = simulate(sim, motion, stabilizer=stabilizer, reference_cutoff_hz=reference_cutoff_hz,
                           feedforward=servo_feedforward, replanner=reaiming_for(walk) if reaimed else None)
        out[name] = {
            "fell": rollout.fell,
            "fall_time_s": rollout.fall_time,
            "peak_force_over_weight": float(rollout.measured.wrenches[..., 2].max() / weight),
            "distance_m": float(rollout.measured.q[-1, 0] - rollout.measured.q[0, 0]),
        }
        if goal is not None:
            errors = goal_errors(walk.robot, rollout.measured, [goal])
            out[name] |= {"final_position_error_m": errors.final_position_error_m,
                          "final_yaw_error_deg": errors.final_yaw_error_deg}
    return out


def random_lengths(rng: np.random.Generator, max_change: float, n: int = 9) -> list[float]:
    """Step lengths (mm) in 150-400, each within ``max_change`` of the previous (0: any)."""
    out = [float(np.round(rng.uniform(150, 400)))]
    while len(out) < n - 1:
        low, high = (150, 400) if max_change <= 0 else (max(150, out[-1] - max_change), min(400, out[-1] + max_change))
        out.append(float(np.round(rng.uniform(low, high))))
    return out + out[-1:]  # a stop repeats the length before it


def random_goal(rng: np.random.Generator) -> list[float]:
    """A goal pose [x_m, y_m, yaw_deg] within 1.5 m ahead, 0.6 m behind or aside and 90 deg."""
    return [float(np.round(rng.uniform(-0.6, 1.5), 3)), float(np.round(rng.uniform(-0.6, 0.6), 3)),
            float(np.round(rng.uniform(-90, 90), 1))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-change-mm", type=float, default=100.0)
    parser.add_argument("--goals", action="store_true",
                        help="omnidirectional walks instead: random goal poses, footsteps planned within the model's range")
    parser.add_argument("--feedforward", action="store_true",
                        help="also simulate each walk without the stabilizer but with the servos' torque feedforward")
    parser.add_argument("--reaim", action="store_true",
                        help="also simulate each walk with footstep re-aiming, with and without the stabilizer")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--contact-time-constant-s", type=float, default=CONTACT_TIME_CONSTANT,
                        help="sole-floor contact softness in s (default: %(default)s)")
    parser.add_argument("--reference-cutoff-hz", type=float, default=REFERENCE_CUTOFF_HZ,
                        help="low-pass of the reference joints in Hz, 0 for none (default: %(default)s)")
    parser.add_argument("--model", help="primitives model file (default: the bundled one, the omnidirectional one with --goals)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    args.model = args.model or str(BUNDLED_OMNI_MODEL if args.goals else BUNDLED_MODEL)
    try:
        check_contact_time_constant(args.contact_time_constant_s)
        check_reference_cutoff(args.reference_cutoff_hz)
        load_model(args.model)  # a missing or broken file fails here, not once per worker
    except Error as exc:
        parser.error(str(exc))
    rng = np.random.default_rng(args.seed)
    if args.goals:
        sequences = [{"goal": random_goal(rng)} for _ in range(args.n)]
    else:
        sequences = [{"lengths_mm": random_lengths(rng, args.max_change_mm)} for _ in range(args.n)]
    started = time.perf_counter()
    with mp.get_context("spawn").Pool(args.workers) as pool:
        results = list(tqdm(pool.imap(functools.partial(run_one, contact_time_constant=args.contact_time_constant_s, model=args.model,
                                                    reference_cutoff_hz=args.reference_cutoff_hz, feedforward=args.feedforward,
                                                    reaim=args.reaim),
                                  sequences), total=len(sequences), desc="random walks", file=sys.stderr))
    unplanned = [r for r in results if "unplanned" in r]
    results = [r for r in results if "unplanned" not in r]
    if not results:
        parser.error(f"no walk could be planned: {unplanned[0]['unplanned']}")
    summary = {"n": args.n, "seed": args.seed, "model": args.model, "max_change_mm": args.max_change_mm,
               "goals": args.goals, "feedforward": args.feedforward, "reaim": args.reaim, "unplanned": unplanned, "walks": len(results),
               "contact_time_constant_s": args.contact_time_constant_s, "reference_cutoff_hz": args.reference_cutoff_hz,
               "wall_time_s": time.perf_counter() - started}
    runs = run_names(args.goals, args.feedforward, args.reaim)
    for name in runs:
        walked = [not r[name]["fell"] for r in results]
        summary[name] = {
            "walked": int(sum(walked)),
            "walked_fraction": float(np.mean(walked)),
            "peak_force_over_weight_median": float(np.median([r[name]["peak_force_over_weight"] for r in results])),
        }
        if args.goals:
            stood = [r[name] for r in results if not r[name]["fell"]]
            summary[name] |= {f"{k}_max": float(max((s[k] for s in stood), default=float("nan")))
                              for k in ("final_position_error_m", "final_yaw_error_deg")}
    summary["plans_within_all_checks"] = int(sum(not r["plan_violations"] for r in results))
    summary["plan_violations"] = {
        name: int(sum(name in r["plan_violations"] for r in results)) for name in sorted({v for r in results for v in r["plan_violations"]})
    }
    summary["plan_worst"] = {
        name: float(np.min(values) if name in AT_LEAST else np.max(values))
        for name, values in ((k, [r["plan_checks"][k] for r in results]) for k in results[0]["plan_checks"])
    }
    summary["plan_failures"] = [
        {k: r[k] for k in ("lengths_mm", "goal") if k in r} | {name: r["plan_checks"][name] for name in r["plan_violations"]}
        for r in results if r["plan_violations"]
    ]
    summary["falls"] = [r for r in results if any(r[name]["fell"] for name in runs)]
    if args.json:
        print(json.dumps(summary))
    else:
        if unplanned:
            print(f"{len(unplanned)} goals the planner could not reach within the model's range: "
                  + "; ".join(str(r["goal"]) for r in unplanned))
        for name in runs:
            s = summary[name]
            print(f"{name:14s} walked {s['walked']}/{len(results)} ({100 * s['walked_fraction']:.0f} %), "
                  f"median peak force {s['peak_force_over_weight_median']:.2f} x weight"
                  + (f", ended within {100 * s['final_position_error_m_max']:.1f} cm and "
                     f"{s['final_yaw_error_deg_max']:.1f} deg of the goal" if args.goals else ""))
        print(f"plans within all {len(summary['plan_worst'])} checks of `cocomopl dataset check`: "
              f"{summary['plans_within_all_checks']}/{len(results)}; failed: {summary['plan_violations'] or 'none'}")
        for r in summary["falls"]:
            print("fell:", r.get("lengths_mm", r.get("goal")), {k: r[k]["fall_time_s"] for k in runs})
        print(f"{summary['wall_time_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
