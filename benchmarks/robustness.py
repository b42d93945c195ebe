"""How robust are the walks to a robot and a world that are not the model?

Each perturbation class is tried at two magnitudes, ``--trials`` times each, on four walks:
M_gen (the primitives), M_opt (chained OCPs), the Kajita baseline on M_gen's footsteps and
timing, and a random generated walk (9 straight steps, 150-400 mm, as
``benchmarks/random_walks.py`` draws them; a new one each trial).  Every rollout runs with the
stabilizer and the gains tuned for its walk's generator.  A trial succeeds if the robot does
not fall.  The classes and their magnitudes (:data:`CLASSES`):

* ``masses``: each link's mass and inertia ×(1 ± 10 %), ×(1 ± 20 %);
* ``com``: each link's centre of mass moved up to 1 cm, 2 cm per axis;
* ``joints``: friction loss up to 1 N m and damping up to 1 N m s/rad per joint; 2 and 5;
* ``servo_gains``: kp of legs, torso and arms each × a factor log-uniform in 0.8-1.25, 0.5-2;
* ``latency``: commands 5 ms, 10 ms late;
* ``floor_friction``: the floor's friction coefficient uniform in 0.5-1.0, 0.4-1.0;
* ``floor_tilt``: the floor tilted up to 1°, 2° about each horizontal axis;
* ``bumps``: boxes up to 0.5 cm, 1 cm high under the walk;
* ``push_sagittal``, ``push_lateral``: 40 N, 60 N for 0.1 s on the pelvis, forwards or
  backwards (left or right), at a random time of the walk.

``combined`` draws all of the issue's realistic magnitudes at once: masses ±10 %, servo
gains × 0.8-1.25, 5 ms latency, floor friction 0.5-1.0 and bumps up to 1 cm.

``max_lateral_push_n`` is the largest of the forces 20, 40, 60, ... 160 N (0.1 s, pelvis,
sideways) that M_gen survives when pushed at each of ``--push-phases`` times spread over its
walk, both directions; the survival rate at 60 N is reported too.

    python benchmarks/robustness.py [--trials 10] [--combined-trials 20] [--seed 0] [--workers 2] [--push-phases 10]
        [--classes masses,latency,...] [--robot talos] [--json]

``--robot`` runs another bundled robot's walks, from its bundled model and dataset: its M_gen
and M_opt, random lengths over TALOS's 150-400 mm scaled as its step lengths, and the pushes
scaled by its mass against TALOS's; the servos get the plan's torque feedforward where the
robot's description says so (G1).

Nothing here is tuned: the stabilizer's gains are those of the random-walk benchmark.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np
from random_walks import length_range_mm, random_lengths
from tqdm import tqdm

from cocomopl.errors import Error
from cocomopl.processes import spawn_pool
from cocomopl.robot import Robot
from cocomopl.sim.perturbations import Perturbation, Push
from cocomopl.sim.servos import GROUPS, ServoSettings

WALKS = ("M_gen", "M_opt", "Kajita", "random")
PUSH_STEP_N = 20.0
MAX_PUSH_N = 160.0

# class -> the two magnitudes: (label, world bounds, servo draw, push draw)
CLASSES = {
    "masses": [("±10 %", {"mass": 0.1}, None, None), ("±20 %", {"mass": 0.2}, None, None)],
    "com": [("1 cm", {"com_offset_m": 0.01}, None, None), ("2 cm", {"com_offset_m": 0.02}, None, None)],
    "joints": [("1 N m, 1 N m s/rad", {"joint_friction_nm": 1.0, "joint_damping": 1.0}, None, None),
               ("2 N m, 5 N m s/rad", {"joint_friction_nm": 2.0, "joint_damping": 5.0}, None, None)],
    "servo_gains": [("× 0.8-1.25", {}, {"gain": 1.25}, None), ("× 0.5-2", {}, {"gain": 2.0}, None)],
    "latency": [("5 ms", {}, {"latency_s": 0.005}, None), ("10 ms", {}, {"latency_s": 0.010}, None)],
    "floor_friction": [("0.5-1.0", {"floor_friction": (0.5, 1.0)}, None, None),
                       ("0.4-1.0", {"floor_friction": (0.4, 1.0)}, None, None)],
    "floor_tilt": [("1°", {"floor_tilt_deg": 1.0}, None, None), ("2°", {"floor_tilt_deg": 2.0}, None, None)],
    "bumps": [("0.5 cm", {"bump_m": 0.005}, None, None), ("1 cm", {"bump_m": 0.01}, None, None)],
    "push_sagittal": [("40 N", {}, None, (40.0, 0)), ("60 N", {}, None, (60.0, 0))],
    "push_lateral": [("40 N", {}, None, (40.0, 1)), ("60 N", {}, None, (60.0, 1))],
    "combined": [("realistic", {"mass": 0.1, "floor_friction": (0.5, 1.0), "bump_m": 0.01},
                  {"gain": 1.25, "latency_s": 0.005}, None)],
}


def servo_settings(draw: dict | None, rng: np.random.Generator) -> ServoSettings:
    """The servos of one trial: each group's kp × a factor log-uniform in [1/gain, gain], and the latency."""
    if not draw:
        return ServoSettings()
    gain = draw.get("gain")
    kp = {g: float(np.exp(rng.uniform(-np.log(gain), np.log(gain)))) for g in GROUPS} if gain else {}
    return ServoSettings(kp_scale=kp, latency_s=draw.get("latency_s", 0.0))


def push_at(draw: tuple | None, rng: np.random.Generator, window: tuple[float, float],
            mass_scale: float = 1.0) -> list[Push]:
    """One push of ``draw`` = (force N, axis 0 sagittal or 1 lateral), scaled by the robot's
    ``mass_scale``, random sign and time within ``window`` (s)."""
    if draw is None:
        return []
    force, axis = draw
    vector = [0.0, 0.0]
    vector[axis] = float(force * mass_scale * rng.choice([-1.0, 1.0]))
    return [Push(float(rng.uniform(*window)), tuple(vector))]


_WORKER: dict = {}


def _start_worker(walks: dict) -> None:
    from cocomopl.pipeline import SimSettings, servo_feedforward
    from cocomopl.sim.mujoco_model import build_sim_model

    robot = Robot(next(iter(walks.values())).robot)
    _WORKER.update(walks=walks, sim=build_sim_model(robot, visuals=False), robot=robot,
                   feedforward=servo_feedforward(SimSettings(), robot))


def run_trial(task: dict) -> dict:
    """One rollout: ``task`` names the walk (or carries a random walk's lengths), the class,
    the magnitude and the trial's seed."""
    from cocomopl.pipeline import generate_walk
    from cocomopl.requests import StraightSteps, WalkRequest
    from cocomopl.sim.perturbations import perturbed
    from cocomopl.sim.rollout import simulate

    sim, robot = _WORKER["sim"], _WORKER["robot"]
    if task["walk"] == "random":
        motion = generate_walk(WalkRequest(StraightSteps([x / 1000 for x in task["lengths_mm"]]), robot=robot.name)).motion
    else:
        motion = _WORKER["walks"][task["walk"]]
    rng = np.random.default_rng(task["seed"])
    _, bounds, servo_draw, push_draw = CLASSES[task["class"]][task["magnitude"]]
    world = Perturbation(**bounds).draw(rng, sim.mj.nbody, sim.mj.nv)
    servos = servo_settings(servo_draw, rng)
    pushes = task.get("pushes") or push_at(push_draw, rng, (0.5, motion.duration - 0.5), robot.scale.mass)
    rollout = simulate(perturbed(sim, world), motion, stabilizer=True, servos=servos, pushes=pushes,
                       feedforward=_WORKER["feedforward"])
    return {**{k: v for k, v in task.items() if k != "pushes"}, "fell": rollout.fell,
            "pushes": [[p.time_s, *p.force_n] for p in pushes]}


def prepare_walks(robot: str) -> dict:
    """M_gen, M_opt and the Kajita walk of the paper's experiment (``cocomopl reproduce
    --robot ROBOT``'s)."""
    from cocomopl.data import dataset_path
    from cocomopl.gait import m_opt, sequence_specs
    from cocomopl.motion_file import read_motions
    from cocomopl.ocp.chained_steps import solve_sequence
    from cocomopl.pipeline import generate_walk, kajita_for
    from cocomopl.requests import StraightSteps, WalkRequest

    walk = generate_walk(WalkRequest(StraightSteps(), robot=robot))
    dataset, attrs = read_motions(dataset_path(robot=robot), dataset=True)
    m_opt = solve_sequence(walk.robot, sequence_specs(list(m_opt(walk.robot))), dataset, settings=attrs["settings"])
    return {"M_gen": walk.motion, "M_opt": m_opt, "Kajita": kajita_for(walk)}


def tasks_for(classes: list[str], trials: int, combined_trials: int, seed: int, scale) -> list[dict]:
    """Every rollout of the class trials, each with its own seed (and random walk: TALOS's
    lengths and change between steps, scaled by the robot's ``scale``)."""
    rng = np.random.default_rng(seed)
    lengths, change = length_range_mm(scale), 100.0 * scale.length
    out = []
    for name in classes:
        for magnitude in range(len(CLASSES[name])):
            for trial in range(combined_trials if name == "combined" else trials):
                walk_lengths = random_lengths(rng, change, lengths=lengths)
                trial_seed = int(rng.integers(2**31))
                for walk in WALKS:
                    task = {"class": name, "magnitude": magnitude, "trial": trial, "walk": walk, "seed": trial_seed}
                    out.append(task | ({"lengths_mm": walk_lengths} if walk == "random" else {}))
    return out


def push_tasks(duration: float, phases: int, mass_scale: float = 1.0) -> list[dict]:
    """M_gen pushed sideways at ``phases`` times over its walk, both ways, at each force of the
    ladder (TALOS's forces; ``force_n`` scaled by the robot's ``mass_scale`` when it pushes)."""
    times = np.linspace(0.5, duration - 0.5, phases)
    return [{"class": "push_lateral", "magnitude": 0, "trial": k, "walk": "M_gen", "seed": 0, "force_n": force,
             "pushes": [Push(float(t), (0.0, sign * force * mass_scale))]}
            for force in np.arange(PUSH_STEP_N, MAX_PUSH_N + 1, PUSH_STEP_N)
            for k, t in enumerate(times) for sign in (1.0, -1.0)]


def summarise(results: list[dict], classes: list[str]) -> dict:
    out = {}
    for name in classes:
        for magnitude, (label, *_) in enumerate(CLASSES[name]):
            rows = [r for r in results if r["class"] == name and r["magnitude"] == magnitude]
            key = name if name == "combined" else f"{name} {label}"
            out[key] = {"n": len(rows), "success_rate": float(np.mean([not r["fell"] for r in rows])),
                        "by_walk": {w: float(np.mean([not r["fell"] for r in rows if r["walk"] == w])) for w in WALKS}}
    return out


def largest_push(results: list[dict]) -> tuple[float, dict]:
    """The largest force of the ladder that M_gen survives at every phase and direction, and the survival rate per force."""
    rates = {}
    for force in sorted({r["force_n"] for r in results}):
        rates[force] = float(np.mean([not r["fell"] for r in results if r["force_n"] == force]))
    survived = 0.0
    for force, rate in rates.items():
        if rate < 1.0:
            break
        survived = force
    return survived, rates


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10, help="trials per class and magnitude (default: %(default)s)")
    parser.add_argument("--combined-trials", type=int, default=20,
                        help="trials of the combined class, whose rate has a goal (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--push-phases", type=int, default=10, help="times of M_gen's walk it is pushed at (default: %(default)s)")
    parser.add_argument("--classes", default=",".join(CLASSES), help="comma list of classes (default: all)")
    parser.add_argument("--robot", default="talos", help="a bundled robot (default: %(default)s)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    classes = [c.strip() for c in args.classes.split(",") if c.strip()]
    unknown = [c for c in classes if c not in CLASSES]
    if unknown or min(args.trials, args.combined_trials, args.workers) < 1 or args.push_phases < 0:
        parser.error(f"unknown classes {unknown}; choose from {','.join(CLASSES)}" if unknown
                     else "--trials, --combined-trials and --workers must be at least 1, --push-phases at least 0")
    started = time.perf_counter()
    try:
        walks = prepare_walks(args.robot)
    except Error as exc:
        parser.error(str(exc))
    scale = Robot(args.robot).scale  # TALOS's: 1 exactly, so its draws are as they were
    tasks = tasks_for(classes, args.trials, args.combined_trials, args.seed, scale)
    pushes = push_tasks(walks["M_gen"].duration, args.push_phases, scale.mass) if args.push_phases else []
    with spawn_pool(args.workers, _start_worker, (walks,)) as pool:
        results = list(tqdm(pool.imap_unordered(run_trial, tasks + pushes), total=len(tasks) + len(pushes),
                            desc="rollouts", file=sys.stderr))
    push_rows = [r for r in results if "force_n" in r]
    results = [r for r in results if "force_n" not in r]
    by_class = summarise(results, classes)
    summary = {"robot": args.robot, "trials": args.trials, "seed": args.seed, "classes": by_class,
               "combined_success_rate": by_class.get("combined", {}).get("by_walk", {}).get("random")}
    if push_rows:
        summary["max_lateral_push_n"], rates = largest_push(push_rows)
        summary["lateral_push_survival_by_force_n"] = {f"{k:g}": v for k, v in rates.items()}
        summary["push_phases"] = args.push_phases
    summary["wall_time_s"] = time.perf_counter() - started
    if args.json:
        print(json.dumps(summary))
        return 0
    print(f"{'class':34s} {'n':>4s} " + " ".join(f"{w:>7s}" for w in WALKS))
    for key, row in by_class.items():
        print(f"{key:34s} {row['n']:4d} " + " ".join(f"{100 * row['by_walk'][w]:6.0f}%" for w in WALKS))
    if push_rows:
        print(f"largest lateral push (0.1 s) M_gen survives at all {args.push_phases} phases, both ways: "
              f"{summary['max_lateral_push_n']:g} N")
    print(f"{summary['wall_time_s']:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
