"""How often do generated walks stay up?  50 random 9-step sequences, simulated in MuJoCo.

Each sequence draws its 9 step lengths uniformly from 150-400 mm (the training range; for
another robot TALOS's range and ``--max-change-mm`` scaled by its leg length, G1: 110-290 mm),
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
With ``--footsteps``, each walk is ``--steps`` footsteps (default 12) drawn as a user may
write them: each footstep (length, width, turn) uniformly over the whole allowed range
(:func:`~cocomopl.dataset.design.allowed_footsteps`: backward and forward, inward and
outward, toe-in and toe-out), independently of the others, so that each step starts and ends
at independent footsteps; the first swing foot is drawn too.  Walk ``k`` of seed ``S`` is the
same whatever ``--n`` (its draw is seeded from ``S`` and ``k``).  The walk's footstep file
(docs/cli.md#footstep-files) is written and generated from as ``cocomopl walk
--footsteps FILE`` generates it, with the bundled omnidirectional model (or ``--model``); the
steps the model flags outside its training support are counted, not refused.
``--footstep-dir DIR`` keeps the files (``walk_K.csv``), to replay a walk that fell.

With ``--commands``, each walk follows a random script of velocity commands (``cocomopl
walk --commands FILE``, :func:`random_command_script`): over ``--script-s`` seconds (default 20)
a new command every 2 to 5 s, each a stop with probability 1/4, else each component drawn
uniformly over what the model's footsteps allow (``cocomopl.online.command_range``), and a
stop at the end; the walk is streamed by the online generator with the bundled
omnidirectional model (or ``--model``).

With ``--feedforward``, each walk is also simulated with the servos' torque feedforward from
the plan, without and with the stabilizer (``cocomopl walk [--no-stabilizer] --feedforward``,
``--no-reaim`` for a goal; G1's default is the latter).  The other runs are without it, whatever the
robot's default.
With ``--reaim``, each walk is also simulated with footstep re-aiming, with and without the
stabilizer (``cocomopl walk --to ... [--no-stabilizer]``, which re-aims by default).
``--dry-run`` prints the walks it would run (the footsteps and landings with ``--footsteps``)
and stops there.

Reports, per simulation, the walks standing and the median and largest peak vertical contact
force over the robot's weight; the steps the model flags out of its support, the walks the
dynamics filter warns about, and the plans within the checks of ``cocomopl dataset check``.
A figure is reported on a seed that nothing was tuned on.

    python benchmarks/random_walks.py [--n 50] [--seed 0] [--max-change-mm 100] [--goals | --footsteps [--steps 12] |
        --commands [--script-s 20]]
        [--feedforward] [--reaim] [--workers 2] [--contact-time-constant-s 0.01] [--reference-cutoff-hz 15]
        [--model MODEL] [--footstep-dir DIR] [--dry-run] [--json]
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from cocomopl.analysis.feasibility import AT_LEAST
from cocomopl.data import BUNDLED_MODEL, BUNDLED_OMNI_MODEL
from cocomopl.dataset.design import allowed_footsteps
from cocomopl.errors import Error
from cocomopl.motion import Footstep
from cocomopl.pipeline import FILTER_WARNING_M
from cocomopl.planning.footsteps import MAX_LANDINGS, footstep_specs, landings_of, write_landings
from cocomopl.primitives.model_file import METADATA_KEY, load_model, metadata_robot, model_robot
from cocomopl.processes import spawn_pool
from cocomopl.requests import FIRST_SWINGS
from cocomopl.robot import Robot
from cocomopl.sim.mujoco_model import CONTACT_TIME_CONSTANT, check_contact_time_constant
from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ, check_reference_cutoff

# per simulation of a walk: (stabilizer, torque feedforward, footstep re-aiming)
RUNS = {"stabilizer": (True, False, False), "no_stabilizer": (False, False, False),
        "feedforward": (False, True, False), "stabilizer_feedforward": (True, True, False),
        "reaim": (True, False, True), "reaim_no_stabilizer": (False, False, True)}
FOOTSTEP_WALK_STEPS = 12  # footsteps a --footsteps walk draws: start, 11 transitions, stop


def run_names(goals: bool, feedforward: bool, reaim: bool = False) -> tuple[str, ...]:
    """The simulations of each walk: the generated walk with and without the stabilizer,
    with torque feedforward without and with it, re-aimed with and without it, the Kajita baseline
    (with the stabilizer)."""
    return (("stabilizer", "no_stabilizer") + (("feedforward", "stabilizer_feedforward") if feedforward else ())
            + (("reaim", "reaim_no_stabilizer") if reaim else ()) + (("kajita",) if goals else ()))


def run_one(request: dict, contact_time_constant: float, model: str, reference_cutoff_hz: float,
            feedforward: bool = False, reaim: bool = False) -> dict:
    """One walk: ``request`` is ``{"lengths_mm": [...]}``, ``{"goal": [x_m, y_m, yaw_deg]}`` or
    ``{"footstep_file": path, ...}`` (:func:`random_footstep_walk`); a goal's walk is also
    measured against the goal, and the Kajita baseline walks its footsteps with the same
    timing (with the stabilizer); :func:`run_names`.  A walk that cannot be generated comes
    back with its error under ``unplanned``."""
    from cocomopl.analysis.feasibility import check_motion, tolerances, violations
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.pipeline import generate_walk, goal_errors, kajita_for, reaiming_for
    from cocomopl.planning.footsteps import read_landings
    from cocomopl.requests import Commands, Footsteps, Goals, StraightSteps, WalkRequest
    from cocomopl.sim.mujoco_model import build_sim_model
    from cocomopl.sim.rollout import simulate

    goal = None
    try:
        if "goal" in request:
            x, y, yaw = request["goal"]
            goal = (x, y, math.radians(yaw))
            path = Goals([goal])
        elif "footstep_file" in request:
            path = Footsteps(read_landings(request["footstep_file"]))  # as `cocomopl walk --footsteps FILE` reads it
        elif "commands" in request:
            path = Commands(tuple((t, f, s, math.radians(yaw)) for t, f, s, yaw in request["commands"]))
        else:
            path = StraightSteps([x / 1000 for x in request["lengths_mm"]])
        walk = generate_walk(WalkRequest(path, model=model))
    except Error as exc:
        return {**request, "unplanned": str(exc)}
    sim = build_sim_model(walk.robot, visuals=False, contact_time_constant=contact_time_constant)
    # the plan against the checks of `cocomopl dataset check`, with the OC data's friction
    checks = check_motion(walk.robot, walk.motion, OCPSettings().friction)
    out = {**request, "steps": len(walk.steps), "duration_s": walk.motion.duration, "plan_checks": checks,
           "plan_violations": violations(checks, tolerances(float(np.median(np.diff(walk.motion.t))))),
           "out_of_support": [s.spec.name for s in walk.steps if not s.in_support],
           "dynamics_filter_zmp_error_m": float(walk.motion.plan.plan_zmp_error_m)}
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


def random_lengths(rng: np.random.Generator, max_change: float, n: int = 9, lengths=(150.0, 400.0)) -> list[float]:
    """Step lengths (mm) within ``lengths`` (mm), each within ``max_change`` of the previous (0: any)."""
    shortest, longest = lengths
    out = [float(np.round(rng.uniform(shortest, longest)))]
    while len(out) < n - 1:
        low, high = lengths if max_change <= 0 else (max(shortest, out[-1] - max_change), min(longest, out[-1] + max_change))
        out.append(float(np.round(rng.uniform(low, high))))
    return out + out[-1:]  # a stop repeats the length before it


def length_range_mm(scale) -> tuple[float, float]:
    """TALOS's random step lengths, 150-400 mm, scaled as the robot's step lengths (``scale``:
    its :class:`~cocomopl.robot.scale.Scale`)."""
    return tuple(1000 * scale.length_m(x) for x in (0.15, 0.40))


def walk_seed(seed: int, walk: int) -> int:
    """The seed of walk ``walk``'s draw: one stream per (``seed``, walk), whatever the number of walks."""
    return int(np.random.SeedSequence([seed, walk]).generate_state(1)[0])


def random_footstep_walk(robot: Robot, steps: int, *, seed: int, walk: int, folder: Path | None = None) -> dict:
    """Walk ``walk`` of ``seed``: ``steps`` footsteps (length, width, turn; m, m, rad) each
    drawn uniformly over the allowed range, independently, the first swing foot drawn too,
    and the world landings that make them (the last repeated for the stop, as a footstep
    file has it), written to ``folder``/walk_K.csv (``footstep_file``) if a folder is given."""
    rng = np.random.default_rng(walk_seed(seed, walk))
    footsteps = [Footstep(*map(float, f)) for f in allowed_footsteps(robot, steps, seed=int(rng.integers(2 ** 63)))]
    first_swing = FIRST_SWINGS[int(rng.integers(len(FIRST_SWINGS)))]
    landings = landings_of(robot, footstep_specs(footsteps, first_swing))
    out = {"walk": walk, "first_swing": first_swing, "footsteps": [list(f) for f in footsteps],
           "landings": [landing.as_dict() for landing in landings]}
    if folder is not None:
        out["footstep_file"] = str(Path(folder) / f"walk_{walk}.csv")
        write_landings(out["footstep_file"], landings)
    return out


def random_command_script(ranges: dict, duration_s: float, *, seed: int, walk: int) -> dict:
    """Walk ``walk`` of ``seed``: timed velocity commands ``[t_s, forward_m_s, sideways_m_s,
    yaw_rate_deg_s]`` over ``duration_s``, a new one every 2 to 5 s, each a stop with
    probability 1/4, else each component uniform over ``ranges`` (``command_range``), and a
    stop at ``duration_s``, as a command file has them."""
    rng = np.random.default_rng(walk_seed(seed, walk))
    commands, t = [], 0.0
    while t < duration_s:
        if commands and rng.random() < 0.25:
            values = [0.0, 0.0, 0.0]
        else:
            values = [float(np.round(rng.uniform(*ranges[key]), 4)) for key in ("forward", "sideways", "yaw_rate")]
        commands.append([round(t, 3), values[0], values[1], round(math.degrees(values[2]), 2)])
        t += float(rng.uniform(2.0, 5.0))
    commands.append([round(duration_s, 3), 0.0, 0.0, 0.0])
    return {"walk": walk, "commands": commands}


def random_goal(rng: np.random.Generator) -> list[float]:
    """A goal pose [x_m, y_m, yaw_deg] within 1.5 m ahead, 0.6 m behind or aside and 90 deg."""
    return [float(np.round(rng.uniform(-0.6, 1.5), 3)), float(np.round(rng.uniform(-0.6, 0.6), 3)),
            float(np.round(rng.uniform(-90, 90), 1))]


def file_robot(path: str) -> Robot:
    """The robot a model file is for, from its metadata alone
    (:func:`~cocomopl.primitives.model_file.metadata_robot`): the arrays' checks take
    seconds, and the run itself makes them (:func:`~cocomopl.primitives.model_file.load_model`)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(data[METADATA_KEY].item())
    except (OSError, KeyError, ValueError, AttributeError) as exc:
        raise Error(f"{path}: not a readable cocomopl model file ({exc.__class__.__name__})") from None
    return metadata_robot(meta)


def label(result: dict) -> str:
    """A walk as a reader finds it again: its lengths, its goal, or its index and footstep file."""
    if "walk" in result:
        return f"walk {result['walk']}" + (f" ({result['footstep_file']})" if "footstep_file" in result else "")
    return str(result.get("lengths_mm", result.get("goal")))


def footstep_signs(walks: list[dict]) -> dict:
    """How many drawn footsteps take each parameter below, at and above zero."""
    drawn = np.array([f for w in walks for f in w["footsteps"]]).reshape(-1, 3)
    return {name: {"negative": int((drawn[:, k] < 0).sum()), "zero": int((drawn[:, k] == 0).sum()),
                   "positive": int((drawn[:, k] > 0).sum())} for k, name in enumerate(("length", "width", "turn"))}


def summarise(args: argparse.Namespace, sequences: list[dict], results: list[dict], unplanned: list[dict],
              wall_time_s: float) -> dict:
    """The figures of a run: per simulation the walks standing and the peak contact forces,
    the steps out of the model's support and the plans within the checks of `dataset check`."""
    summary = {"n": args.n, "seed": args.seed, "model": args.model, "max_change_mm": args.max_change_mm,
               "goals": args.goals, "footsteps": args.footsteps, "commands": args.commands, "feedforward": args.feedforward,
               "reaim": args.reaim,
               "unplanned": unplanned, "walks": len(results),
               "contact_time_constant_s": args.contact_time_constant_s, "reference_cutoff_hz": args.reference_cutoff_hz,
               "wall_time_s": wall_time_s}
    if args.footsteps:
        summary |= {"steps_per_walk": args.steps, "footstep_signs": footstep_signs(sequences)}
    runs = run_names(args.goals, args.feedforward, args.reaim)
    for name in runs:
        walked = [not r[name]["fell"] for r in results]
        peaks = [r[name]["peak_force_over_weight"] for r in results]
        summary[name] = {
            "walked": int(sum(walked)),
            "walked_fraction": float(np.mean(walked)),
            "peak_force_over_weight_median": float(np.median(peaks)),
            "peak_force_over_weight_max": float(np.max(peaks)),
        }
        if args.goals:
            stood = [r[name] for r in results if not r[name]["fell"]]
            summary[name] |= {f"{k}_max": float(max((s[k] for s in stood), default=float("nan")))
                              for k in ("final_position_error_m", "final_yaw_error_deg")}
    summary["steps"] = int(sum(r["steps"] for r in results))
    summary["steps_out_of_support"] = int(sum(len(r["out_of_support"]) for r in results))
    summary["walks_out_of_support"] = int(sum(bool(r["out_of_support"]) for r in results))
    summary["walks_filter_warned"] = int(sum(r["dynamics_filter_zmp_error_m"] > FILTER_WARNING_M for r in results))
    summary["plans_within_all_checks"] = int(sum(not r["plan_violations"] for r in results))
    summary["plan_violations"] = {
        name: int(sum(name in r["plan_violations"] for r in results)) for name in sorted({v for r in results for v in r["plan_violations"]})
    }
    summary["plan_worst"] = {
        name: float(np.min(values) if name in AT_LEAST else np.max(values))
        for name, values in ((k, [r["plan_checks"][k] for r in results]) for k in results[0]["plan_checks"])
    }
    summary["plan_failures"] = [
        {k: r[k] for k in ("lengths_mm", "goal", "walk", "footstep_file", "commands") if k in r}
        | {name: r["plan_checks"][name] for name in r["plan_violations"]}
        for r in results if r["plan_violations"]
    ]
    summary["falls"] = [r for r in results if any(r[name]["fell"] for name in runs)]
    return summary


def print_summary(args: argparse.Namespace, summary: dict, unplanned: list[dict]) -> None:
    runs = run_names(args.goals, args.feedforward, args.reaim)
    walks = summary["walks"]
    if args.footsteps:
        signs = summary["footstep_signs"]
        print(f"{walks} walks of {args.steps} footsteps drawn over the allowed range (seed {args.seed}); drawn "
              + ", ".join(f"{name} {c['negative']} < 0 / {c['positive']} > 0" for name, c in signs.items()))
    if unplanned:
        print(f"{len(unplanned)} walks could not be generated: " + "; ".join(f"{label(r)}: {r['unplanned']}" for r in unplanned))
    for name in runs:
        s = summary[name]
        print(f"{name:19s} walked {s['walked']}/{walks} ({100 * s['walked_fraction']:.0f} %), "
              f"peak force median {s['peak_force_over_weight_median']:.2f}, max {s['peak_force_over_weight_max']:.2f} x weight"
              + (f", ended within {100 * s['final_position_error_m_max']:.1f} cm and "
                 f"{s['final_yaw_error_deg_max']:.1f} deg of the goal" if args.goals else ""))
    print(f"steps out of the model's support: {summary['steps_out_of_support']}/{summary['steps']} "
          f"(in {summary['walks_out_of_support']} walks); the dynamics filter warned on {summary['walks_filter_warned']} walks")
    print(f"plans within all {len(summary['plan_worst'])} checks of `cocomopl dataset check`: "
          f"{summary['plans_within_all_checks']}/{walks}; failed: {summary['plan_violations'] or 'none'}")
    for r in summary["falls"]:
        print("fell:", label(r), {k: r[k]["fall_time_s"] for k in runs})
    print(f"{summary['wall_time_s']:.0f} s")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-change-mm", type=float, default=100.0)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--goals", action="store_true",
                      help="omnidirectional walks instead: random goal poses, footsteps planned within the model's range")
    mode.add_argument("--footsteps", action="store_true",
                      help="omnidirectional walks instead: footsteps drawn independently over the whole allowed range")
    mode.add_argument("--commands", action="store_true",
                      help="omnidirectional walks instead: random scripts of velocity commands, streamed online")
    parser.add_argument("--script-s", type=float, help="seconds of commands per walk with --commands (default: 20)")
    parser.add_argument("--steps", type=int, help=f"footsteps per walk with --footsteps (default: {FOOTSTEP_WALK_STEPS})")
    parser.add_argument("--footstep-dir", type=Path, metavar="DIR",
                        help="with --footsteps, keep each walk's footstep file there (walk_K.csv; default: a temporary folder)")
    parser.add_argument("--feedforward", action="store_true",
                        help="also simulate each walk with the servos' torque feedforward, without and with the stabilizer")
    parser.add_argument("--reaim", action="store_true",
                        help="also simulate each walk with footstep re-aiming, with and without the stabilizer")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--contact-time-constant-s", type=float, default=CONTACT_TIME_CONSTANT,
                        help="sole-floor contact softness in s (default: %(default)s)")
    parser.add_argument("--reference-cutoff-hz", type=float, default=REFERENCE_CUTOFF_HZ,
                        help="low-pass of the reference joints in Hz, 0 for none (default: %(default)s)")
    parser.add_argument("--model", help="primitives model file (default: the bundled one, the omnidirectional one with "
                                        "--goals or --footsteps)")
    parser.add_argument("--dry-run", action="store_true", help="print the walks that would run, and stop")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    args.model = args.model or str(BUNDLED_OMNI_MODEL if args.goals or args.footsteps or args.commands else BUNDLED_MODEL)
    if args.n < 1 or args.workers < 1:
        parser.error("--n and --workers are at least 1")
    for given, option in ((args.steps, "--steps"), (args.footstep_dir, "--footstep-dir")):
        if given is not None and not args.footsteps:
            parser.error(f"{option} is used only with --footsteps")
    if args.script_s is not None and not args.commands:
        parser.error("--script-s is used only with --commands")
    if args.reaim and args.commands:
        parser.error("--reaim replans whole walks: it is not used with --commands")
    args.script_s = 20.0 if args.script_s is None else args.script_s
    if not 1.0 <= args.script_s <= 600.0:
        parser.error(f"--script-s {args.script_s:g} is outside 1..600 s")
    args.steps = FOOTSTEP_WALK_STEPS if args.steps is None else args.steps
    if not 1 <= args.steps < MAX_LANDINGS:
        parser.error(f"--steps {args.steps} is outside 1..{MAX_LANDINGS - 1}")
    try:
        check_contact_time_constant(args.contact_time_constant_s)
        check_reference_cutoff(args.reference_cutoff_hz)
        # a missing or broken file fails here, not once per worker; a dry run reads only the robot
        robot = file_robot(args.model) if args.dry_run else model_robot(load_model(args.model))
        if args.footsteps and args.footstep_dir is not None:
            args.footstep_dir.mkdir(parents=True, exist_ok=True)
    except (Error, OSError) as exc:
        parser.error(str(exc))
    with tempfile.TemporaryDirectory(prefix="random_walks_") as scratch:
        rng = np.random.default_rng(args.seed)
        if args.goals:
            sequences = [{"goal": random_goal(rng)} for _ in range(args.n)]
        elif args.footsteps:
            # the walks are generated from their files; a dry run writes only those it is asked to keep
            folder = args.footstep_dir or (None if args.dry_run else Path(scratch))
            sequences = [random_footstep_walk(robot, args.steps, seed=args.seed, walk=k, folder=folder)
                         for k in range(args.n)]
        elif args.commands:
            from cocomopl.online import command_range, step_period

            model = load_model(args.model)
            ranges = command_range(period=step_period(model), limits=model.footstep_range())
            sequences = [random_command_script(ranges, args.script_s, seed=args.seed, walk=k) for k in range(args.n)]
        else:
            scale = robot.scale  # TALOS's range and change, scaled to the model's robot
            lengths = length_range_mm(scale)
            args.max_change_mm *= scale.length
            sequences = [{"lengths_mm": random_lengths(rng, args.max_change_mm, lengths=lengths)} for _ in range(args.n)]
        if args.dry_run:
            if args.json:
                print(json.dumps({"seed": args.seed, "model": args.model, "walks": sequences}))
            else:
                for sequence in sequences:
                    print(json.dumps(sequence))
            return 0
        started = time.perf_counter()
        with spawn_pool(args.workers) as pool:
            results = list(tqdm(pool.imap(functools.partial(run_one, contact_time_constant=args.contact_time_constant_s,
                                                            model=args.model, reference_cutoff_hz=args.reference_cutoff_hz,
                                                            feedforward=args.feedforward, reaim=args.reaim),
                                          sequences), total=len(sequences), desc="random walks", file=sys.stderr))
        wall_time_s = time.perf_counter() - started
    if args.footstep_dir is None:  # the temporary files are gone: a walk is found again by its index
        for r in results:
            r.pop("footstep_file", None)
    unplanned = [r for r in results if "unplanned" in r]
    results = [r for r in results if "unplanned" not in r]
    if not results:
        parser.error(f"no walk could be generated: {unplanned[0]['unplanned']}")
    summary = summarise(args, sequences, results, unplanned, wall_time_s)
    if args.json:
        print(json.dumps(summary))
    else:
        print_summary(args, summary, unplanned)
    return 0


if __name__ == "__main__":
    sys.exit(main())
