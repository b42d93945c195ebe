"""Generation and placement per step, straight against omnidirectional, side by side.

M_gen with the robot's bundled straight model, and with its bundled omnidirectional model
(or ``--model``) the walk to (1.0 m, 0.5 m, 90 deg) and random footstep walks (``--walks``
walks of 12 footsteps, each drawn uniformly over the robot's allowed range, as
``random_walks.py --footsteps`` draws them, the first swing foot the left; seed ``--seed``):
generation (the primitives alone, caches built, median of 50 runs; of the random walks, the
median over the walks) and placement (world placement, dynamics filter, limits, inverse
dynamics) per step.  The robot is ``--robot`` (a bundled one), else the model's (TALOS for
the bundled model).

    python benchmarks/omni_speed.py [--robot g1] [--walks 10] [--seed 0] [--model MODEL.npz] [--json]
"""

import argparse
import json
import math
import sys
import time
import warnings

import numpy as np

from cocomopl.data import model_path
from cocomopl.dataset.design import allowed_footsteps
from cocomopl.errors import Error
from cocomopl.gait import m_gen, sequence_specs
from cocomopl.motion import Footstep
from cocomopl.planning.footsteps import footstep_specs
from cocomopl.planning.goal import plan_to_goal
from cocomopl.primitives.model_file import load_model, model_robot
from cocomopl.robot import Robot
from cocomopl.synthesis.step_chain import generate_steps
from cocomopl.synthesis.world import place_steps


def generation_s(model, specs) -> tuple[float, list]:
    """Median wall time of generating ``specs`` over 50 runs, after one that builds the caches, and the steps."""
    steps = generate_steps(model, specs)
    runs = []
    for _ in range(50):
        started = time.perf_counter()
        steps = generate_steps(model, specs)
        runs.append(time.perf_counter() - started)
    return float(np.median(runs)), steps


def measure(robot: Robot, model, specs_of) -> dict:
    specs = specs_of(model)
    generated, steps = generation_s(model, specs)
    started = time.perf_counter()
    place_steps(robot, steps, dt=0.025)
    placed = time.perf_counter() - started
    return {"steps": len(specs), "generation_us_per_step": 1e6 * generated / len(specs),
            "placement_s_per_step": placed / len(specs)}


def random_footstep_walks(robot: Robot, model, walks: int, seed: int) -> dict:
    per_step = []
    for walk in range(walks):
        footsteps = [Footstep(*map(float, f)) for f in allowed_footsteps(robot, 12, seed=seed + walk)]
        specs = footstep_specs(footsteps, "left")
        per_step.append(generation_s(model, specs)[0] / len(specs))
    return {"walks": walks, "steps": len(specs), "generation_us_per_step": 1e6 * float(np.median(per_step)),
            "generation_us_per_step_range": [1e6 * min(per_step), 1e6 * max(per_step)]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walks", type=int, default=10, help="random footstep walks (default: 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first random walk (default: 0)")
    parser.add_argument("--robot", metavar="NAME",
                        help="a bundled robot whose models are the defaults, talos or g1 (default: the model's robot)")
    parser.add_argument("--model", metavar="MODEL.npz",
                        help="omnidirectional model file (default: the robot's bundled one)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.walks < 1:
        parser.exit(2, f"omni_speed.py: error: --walks must be at least 1, got {args.walks}\n")
    warnings.simplefilter("ignore")
    try:
        omni = load_model(model_path(args.model, omni=True, robot=args.robot)).prepare()
        robot = model_robot(omni)
        if args.robot is not None and robot.name != args.robot:
            raise Error(f"{args.model} is a model of {robot.name}, not of {args.robot}")
        straight = load_model(model_path(robot=robot.name)).prepare()
    except Error as exc:
        parser.exit(2, f"omni_speed.py: error: {exc}\n")
    report = {
        "straight_m_gen": measure(robot, straight, lambda m: sequence_specs(list(m_gen(robot)))),
        "omni_goal_1_0.5_90": measure(robot, omni,
                                      lambda m: plan_to_goal(robot, (1.0, 0.5, math.radians(90)),
                                                             limits=m.footstep_range())),
        "omni_random_footsteps": random_footstep_walks(robot, omni, args.walks, args.seed),
    }
    if args.json:
        print(json.dumps(report))
    else:
        for label, r in report.items():
            placement = f", placement {r['placement_s_per_step']:.2f} s/step" if "placement_s_per_step" in r else ""
            walks = f"{r['walks']} walks of " if "walks" in r else ""
            print(f"{label}: {walks}{r['steps']} steps, generation median {r['generation_us_per_step']:.0f} us/step{placement}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
