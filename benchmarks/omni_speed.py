"""Generation and placement per step, straight against omnidirectional, side by side.

M_gen with the bundled straight model and the walk to (1.0 m, 0.5 m, 90 deg) with
the bundled omnidirectional model: generation (the primitives alone, caches built, median of
50 runs) and placement (world placement, dynamics filter, limits, inverse dynamics) per step.

    python benchmarks/omni_speed.py [--json]
"""

import argparse
import json
import math
import sys
import time
import warnings

import numpy as np

from cocomopl.data import BUNDLED_MODEL, BUNDLED_OMNI_MODEL
from cocomopl.gait import M_GEN, sequence_specs
from cocomopl.planning.goal import plan_to_goal
from cocomopl.primitives.model_file import load_model
from cocomopl.robot import Robot
from cocomopl.synthesis.step_chain import generate_steps
from cocomopl.synthesis.world import place_steps


def measure(robot: Robot, path, specs_of) -> dict:
    model = load_model(path).prepare()
    specs = specs_of(model)
    generate_steps(model, specs)  # caches built
    runs = []
    for _ in range(50):
        started = time.perf_counter()
        steps = generate_steps(model, specs)
        runs.append(time.perf_counter() - started)
    started = time.perf_counter()
    place_steps(robot, steps, dt=0.025)
    placed = time.perf_counter() - started
    return {"steps": len(specs), "generation_us_per_step": 1e6 * float(np.median(runs)) / len(specs),
            "placement_s_per_step": placed / len(specs)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    robot = Robot("talos")
    report = {
        "straight_m_gen": measure(robot, BUNDLED_MODEL, lambda m: sequence_specs(list(M_GEN))),
        "omni_goal_1_0.5_90": measure(robot, BUNDLED_OMNI_MODEL,
                                      lambda m: plan_to_goal(robot, (1.0, 0.5, math.radians(90)),
                                                             limits=m.footstep_range())),
    }
    if args.json:
        print(json.dumps(report))
    else:
        for label, r in report.items():
            print(f"{label}: {r['steps']} steps, generation median {r['generation_us_per_step']:.0f} us/step, "
                  f"placement {r['placement_s_per_step']:.2f} s/step")
    return 0


if __name__ == "__main__":
    sys.exit(main())
