"""Benchmark of the primitives stage: generation speed against one OC step solve.

Measured in one run on this machine:

* one generated step (the 390 mm transition of M_gen, conditioned on its predecessor);
* the paper's 9-step sequence M_gen (150 start, 150, 250, 350, 390, 350, 250, 150, 150 stop),
  every step conditioned on the previous one;
* placing M_gen in the world as a Motion (forward and inverse dynamics; not needed online);
* reading the model file, with its checks of every array and a prediction of every training step;
* the OC solve of one cyclic 250 mm step, as the dataset stage solves it;
* with ``--train``, training with model selection on the bundled dataset (else the time
  recorded in the bundled model's metadata).

Usage::

    python benchmarks/bench_primitives.py [--model MODEL] [--train] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import cocomopl  # noqa: F401  (one OpenMP thread per process)


def median_time(fn, repeats: int) -> float:
    """Median wall time of ``fn()`` in seconds over ``repeats`` calls (after one warm-up)."""
    fn()
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def main() -> int:
    from bench_ocp import cocomopl_cyclic

    from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL
    from cocomopl.gait import M_GEN, sequence_specs
    from cocomopl.primitives.model_file import load_model, model_robot
    from cocomopl.synthesis.step_chain import generate_steps
    from cocomopl.synthesis.world import place_steps

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default=str(BUNDLED_MODEL))
    parser.add_argument("--train", action="store_true", help="time training with model selection afresh")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    load_s = median_time(lambda: load_model(args.model), 3)
    model = load_model(args.model).prepare()
    specs = sequence_specs(list(M_GEN))
    chain = generate_steps(model, specs)
    step_s = median_time(lambda: model.predict(specs[4], start=chain[3].values[-1]), 2000)
    sequence_s = median_time(lambda: generate_steps(model, specs), 300)
    robot = model_robot(model)
    placement_s = median_time(lambda: place_steps(robot, chain, dt=0.025), 3)
    print("solving one OC step ...", file=sys.stderr)
    oc_s = cocomopl_cyclic(0.25)["solve_time_s"]
    if args.train:
        from cocomopl.primitives.selection import select_model
        from cocomopl.primitives.training import load_training_steps

        start = time.perf_counter()
        select_model(load_training_steps(BUNDLED_DATASET), workers=os.cpu_count() or 1, progress=True)
        training_s, training_source = time.perf_counter() - start, "measured here"
    else:
        training_s, training_source = model.metadata_.get("training_wall_time_s"), "from the model's metadata"
    report = {
        "one_step_s": step_s,
        "m_gen_sequence_s": sequence_s,
        "m_gen_placement_s": placement_s,
        "model_file_read_s": load_s,
        "oc_one_step_solve_s": oc_s,
        "speedup_one_step": oc_s / step_s,
        "training_with_selection_s": training_s,
        "training_source": training_source,
        "cores": os.cpu_count(),
    }
    if args.json:
        print(json.dumps(report))
    else:
        print(f"one generated step (conditioned)       {step_s * 1e6:10.1f} us   (goal < 100 us)")
        print(f"M_gen, 9 steps, chained                {sequence_s * 1e6:10.1f} us   (goal < 1000 us)")
        print(f"M_gen placed in the world (FK, filter, ID) {placement_s:7.2f} s")
        print(f"model file read and checked            {load_s:10.2f} s")
        print(f"OC solve of one cyclic 250 mm step     {oc_s:10.2f} s    -> generation is {oc_s / step_s:,.0f}x faster")
        print(f"training with model selection          {training_s:10.1f} s    ({training_source}; goal < 300 s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
