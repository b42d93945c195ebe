"""How close does a model of footsteps come to OC steps it was not trained on?

Reads held-out OC steps (a dataset made by ``cocomopl dataset generate --gaits=...`` at
gaits off the training grid) and predicts each from its spec alone (no conditioning), on the
normalised time grid the model warps its training steps to.  Reports the RMS error per
signal group (legs, torso, arms in rad; ZMP in m; pelvis orientation in rad), over all
held-out steps, per footstep (the steps taking the same length, width and turn pooled) and
per step, with each step's footstep parameters (length and width in m, turn in rad), so that
the errors can be read per parameter.

With ``--dataset TRAIN.h5`` (the model's training data), the PCA-interpolation baseline of
``primitive_peers.py`` is fitted on it and measured on the same held-out steps, on its own
grid (``pca_`` keys): 11 components, coefficients interpolated linearly in the footstep
parameters that each step type's training steps span.

    python benchmarks/omni_accuracy.py HELD_OUT.h5 --model MODEL.npz [--dataset TRAIN.h5] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
from primitive_peers import PCAPeer

from cocomopl.errors import Error
from cocomopl.primitives.family import signal_group_indices
from cocomopl.primitives.model_file import load_model
from cocomopl.primitives.training import load_training_steps
from cocomopl.robot import Robot


def squared_errors(estimator, steps, groups: dict) -> dict[str, np.ndarray]:
    """Per signal group, each held-out step's mean squared error, (K,)."""
    truth, predicted = estimator.reconstruct(steps)  # (K, I, T)
    return {g: ((truth - predicted)[:, idx] ** 2).mean(axis=(1, 2)) for g, idx in groups.items()}


def accuracy(model_path: str, held_out_path: str, dataset_path: str | None = None) -> dict:
    model = load_model(model_path).prepare()
    steps = load_training_steps(held_out_path)
    robot = Robot(model.metadata_.get("robot", "talos"))
    groups = signal_group_indices(robot, model.signal_names)
    errors = {"": squared_errors(model, steps, groups)}
    if dataset_path is not None:
        errors["pca_"] = squared_errors(PCAPeer().fit(load_training_steps(dataset_path)), steps, groups)
    rows = []
    for k, spec in enumerate(steps.specs):
        footstep = spec.start_footstep if spec.kind == "stop" else spec.end_footstep
        rows.append({"step": spec.name, "length_m": footstep.length, "width_m": footstep.width, "turn_rad": footstep.turn,
                     "distance": float(model.predict(spec).distance),
                     **{f"{p}{g}_rms": float(np.sqrt(e[g][k])) for p, e in errors.items() for g in groups}})
    return {"model": model_path, "held_out": held_out_path, "dataset": dataset_path, "steps": len(rows),
            **{f"{p}{g}_rms": float(np.sqrt(e[g].mean())) for p, e in errors.items() for g in groups},
            **{f"{p}{g}_rms_max": float(np.sqrt(e[g].max())) for p, e in errors.items() for g in groups},
            "per_footstep": per_footstep(rows, [f"{p}{g}" for p in errors for g in groups]),
            "per_step": rows}


def per_footstep(rows: list[dict], columns: list[str]) -> list[dict]:
    """RMS errors pooled over the steps that take the same footstep (length, width, |turn|):
    the errors read per footstep parameter."""
    pooled: dict[tuple, list[dict]] = {}
    for row in rows:
        key = (round(row["length_m"], 4), round(row["width_m"], 4), round(abs(row["turn_rad"]), 5))
        pooled.setdefault(key, []).append(row)
    return [{"length_m": key[0], "width_m": key[1], "turn_abs_rad": key[2], "steps": len(group),
             **{f"{c}_rms": float(np.sqrt(np.mean([r[f"{c}_rms"] ** 2 for r in group]))) for c in columns}}
            for key, group in sorted(pooled.items())]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("held_out", metavar="HELD_OUT.h5")
    parser.add_argument("--model", required=True, metavar="MODEL.npz")
    parser.add_argument("--dataset", metavar="TRAIN.h5", help="the model's training data: also measure the PCA baseline")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    try:
        report = accuracy(args.model, args.held_out, args.dataset)
    except Error as exc:
        parser.error(str(exc))
    if args.json:
        print(json.dumps(report))
        return 0
    groups = ("legs", "torso", "arms", "zmp", "pelvis")
    print(f"{report['steps']} held-out steps; RMS over all (largest step), mrad or mm:")
    for g in groups:
        pca = f"; PCA {1000 * report[f'pca_{g}_rms']:.1f} ({1000 * report[f'pca_{g}_rms_max']:.1f})" if args.dataset else ""
        print(f"  {g:7s} {1000 * report[f'{g}_rms']:7.1f} ({1000 * report[f'{g}_rms_max']:.1f}){pca}")
    print(f"{'footstep (mm, mm, deg)':44s} " + " ".join(f"{g:>7s}" for g in groups))
    for row in report["per_footstep"]:
        label = f"{1000 * row['length_m']:.0f}, {1000 * row['width_m']:.0f}, {np.degrees(row['turn_abs_rad']):.1f} ({row['steps']} steps)"
        print(f"{label:44s} " + " ".join(f"{1000 * row[f'{g}_rms']:7.1f}" for g in groups))
    print(f"{'step':44s} " + " ".join(f"{g:>7s}" for g in groups))
    for row in report["per_step"]:
        print(f"{row['step']:44s} " + " ".join(f"{1000 * row[f'{g}_rms']:7.1f}" for g in groups))
    return 0


if __name__ == "__main__":
    sys.exit(main())
