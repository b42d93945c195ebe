"""Generation and placement per step, straight against omnidirectional, side by side.

M_gen with the bundled straight model and the 12-step walk to (1.0 m, 0.5 m, 90 deg) with
the bundled omnidirectional model: generation (the primitives alone, caches built, median of
50 runs) and placement (world placement, dynamics filter, limits, inverse dynamics) per step.

    python benchmarks/omni_speed.py
"""
import math
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

warnings.simplefilter("ignore")
robot = Robot("talos")
for label, path, specs_of in (("straight M_gen", BUNDLED_MODEL, lambda m: sequence_specs(list(M_GEN))),
                              ("omni 1.0,0.5,90", BUNDLED_OMNI_MODEL, lambda m: plan_to_goal(robot, (1.0, 0.5, math.radians(90)), m.footstep_range()))):
    model = load_model(path).prepare()
    specs = specs_of(model)
    generate_steps(model, specs)  # caches built
    runs = []
    for _ in range(50):
        t = time.perf_counter(); steps = generate_steps(model, specs); runs.append(time.perf_counter() - t)
    t = time.perf_counter(); place_steps(robot, steps, 0.025); placed = time.perf_counter() - t
    print(f"{label}: {len(specs)} steps, generation median {1e6 * np.median(runs) / len(specs):.0f} us/step, placement {placed / len(specs):.2f} s/step")
