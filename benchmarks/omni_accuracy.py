"""How close does a model of footsteps come to OC steps it was not trained on?

Reads held-out OC steps (a dataset made by ``cocomopl dataset generate --gaits=...`` at
gaits off the training grid) and predicts each from its spec alone (no conditioning), on the
normalised time grid the model warps its training steps to.  Reports the RMS error per
signal group (legs, torso, arms in rad; ZMP in m; pelvis orientation in rad), over all
held-out steps and per step, with each step's footstep parameters (length and width in m,
turn in rad) so the errors can be read per parameter.

    python benchmarks/omni_accuracy.py HELD_OUT.h5 --model MODEL.npz [--json]
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from cocomopl.errors import Error
from cocomopl.primitives.family import signal_group_indices
from cocomopl.primitives.model_file import load_model
from cocomopl.primitives.training import load_training_steps
from cocomopl.robot import Robot


def accuracy(model_path: str, held_out_path: str) -> dict:
    model = load_model(model_path).prepare()
    steps = load_training_steps(held_out_path)
    robot = Robot(model.metadata_.get("robot", "talos"))
    groups = signal_group_indices(robot, model.signal_names)
    truth, predicted = model.reconstruct(steps)  # (K, I, T)
    squared = {g: ((truth - predicted)[:, idx] ** 2).mean(axis=(1, 2)) for g, idx in groups.items()}
    rows = []
    for k, spec in enumerate(steps.specs):
        footstep = spec.start_footstep if spec.kind == "stop" else spec.end_footstep
        rows.append({"step": spec.name, "length_m": footstep.length, "width_m": footstep.width, "turn_rad": footstep.turn,
                     "distance": float(model.predict(spec).distance),
                     **{f"{g}_rms": float(np.sqrt(squared[g][k])) for g in groups}})
    return {"model": model_path, "held_out": held_out_path, "steps": len(rows),
            **{f"{g}_rms": float(np.sqrt(squared[g].mean())) for g in groups},
            **{f"{g}_rms_max": float(np.sqrt(squared[g].max())) for g in groups},
            "per_step": rows}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("held_out", metavar="HELD_OUT.h5")
    parser.add_argument("--model", required=True, metavar="MODEL.npz")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    try:
        report = accuracy(args.model, args.held_out)
    except Error as exc:
        parser.error(str(exc))
    if args.json:
        print(json.dumps(report))
        return 0
    groups = ("legs", "torso", "arms", "zmp", "pelvis")
    print(f"{report['steps']} held-out steps; RMS over all (largest step):")
    for g in groups:
        unit, scale = ("mm", 1000) if g == "zmp" else ("mrad", 1000)
        print(f"  {g:7s} {scale * report[f'{g}_rms']:7.1f} {unit} ({scale * report[f'{g}_rms_max']:.1f})")
    print(f"{'step':44s} " + " ".join(f"{g:>7s}" for g in groups))
    for row in report["per_step"]:
        print(f"{row['step']:44s} " + " ".join(f"{1000 * row[f'{g}_rms']:7.1f}" for g in groups))
    return 0


if __name__ == "__main__":
    sys.exit(main())
