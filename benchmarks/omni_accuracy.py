"""How close does a model of footsteps come to OC steps it was not trained on?

Reads held-out OC steps and predicts each from its spec alone (no conditioning), on the
normalised time grid the model warps its training steps to.  A held-out set is a dataset
solved at footsteps drawn uniformly over the whole allowed range, every parameter of either
sign (backward and forward, inward and outward, toe-in and toe-out), start and end footsteps
drawn independently, on a design seed nothing was tuned on::

    cocomopl dataset generate --step-space 10/30 --sampling random --design-seed 2027 --out held.h5

Reports the RMS error per signal group (legs, torso, arms in mrad; ZMP in mm; pelvis
orientation in mrad) over the steps and the worst step of each group, with how many steps
are over the floors (legs over 10 mrad; any of legs, torso, arms and pelvis over 20 mrad;
pelvis over 10 mrad; ZMP over 5 mm) and how many the model flags out of its training support
(``predict(spec).in_support``): over all steps, per step kind (start, cyclic, transition,
stop) and per parameter of the step's footstep (its end footstep; a stop's start footstep,
the one it stops from): length backward / 0-200 mm / 200-400 mm, width inward / 0-75 mm /
over 75 mm, turn toe-in / toe-out.  JSON keeps SI units (rad, m); ``per_step`` holds every
step with its start and end footsteps, ``per_footstep`` the steps pooled by their footstep.

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
from cocomopl.motion import STEP_KINDS
from cocomopl.primitives.family import GROUPS, signal_group_indices
from cocomopl.primitives.model_file import load_model, model_robot
from cocomopl.primitives.training import load_training_steps

ANGLE_GROUPS = ("legs", "torso", "arms", "pelvis")  # rad; the ZMP is in m
# the floors a step is counted against: (key, groups, limit in rad or m)
FLOORS = (("legs_over_10mrad", ("legs",), 0.010), ("any_over_20mrad", ANGLE_GROUPS, 0.020),
          ("pelvis_over_10mrad", ("pelvis",), 0.010), ("zmp_over_5mm", ("zmp",), 0.005))
PARAMETERS = ("length", "width", "turn")


def parameter_bin(parameter: str, value: float) -> str:
    """The bin of a footstep parameter (m or rad) that the per-parameter breakdown pools."""
    if parameter == "length":
        return "backward (< 0)" if value < 0 else "0-200 mm" if value < 0.2 else "200-400 mm"
    if parameter == "width":
        return "inward (< 0)" if value < 0 else "0-75 mm" if value <= 0.075 else "over 75 mm"
    return "toe-in (< 0)" if value < 0 else "toe-out (> 0)" if value > 0 else "straight (0)"


BINS = {p: [parameter_bin(p, v) for v in values]
        for p, values in (("length", (-1, 0, 0.3)), ("width", (-1, 0, 1)), ("turn", (-1, 0, 1)))}


def squared_errors(estimator, steps, groups: dict) -> dict[str, np.ndarray]:
    """Per signal group, each held-out step's mean squared error, (K,)."""
    truth, predicted = estimator.reconstruct(steps)  # (K, I, T)
    return {g: ((truth - predicted)[:, idx] ** 2).mean(axis=(1, 2)) for g, idx in groups.items()}


def summary(rows: list[dict], prefixes: list[str]) -> dict:
    """Over ``rows`` (per-step rows): their number, per group the RMS over the steps, the
    worst step's RMS and name, the steps over each floor and those out of the support."""
    out: dict = {"steps": len(rows), "out_of_support": int(sum(not r["in_support"] for r in rows))}
    for p in prefixes:
        for g in GROUPS:
            errors = np.array([r[f"{p}{g}_rms"] for r in rows])
            worst = int(np.argmax(errors)) if rows else None  # an empty bin has none: null in JSON
            out |= {f"{p}{g}_rms": float(np.sqrt(np.mean(errors ** 2))) if rows else None,
                    f"{p}{g}_rms_max": float(errors[worst]) if rows else None,
                    f"{p}{g}_worst_step": rows[worst]["step"] if rows else None}
        for key, groups, limit in FLOORS:
            out[f"{p}{key}"] = int(sum(any(r[f"{p}{g}_rms"] > limit for g in groups) for r in rows))
    return out


def accuracy(model_path: str, held_out_path: str, dataset_path: str | None = None) -> dict:
    model = load_model(model_path).prepare()
    steps = load_training_steps(held_out_path)
    robot = model_robot(model)
    groups = signal_group_indices(robot, model.signal_names)
    errors = {"": squared_errors(model, steps, groups)}
    if dataset_path is not None:
        errors["pca_"] = squared_errors(PCAPeer().fit(load_training_steps(dataset_path)), steps, groups)
    prefixes = list(errors)
    rows = []
    for k, (spec, predicted) in enumerate(zip(steps.specs, model.predict_many(list(steps.specs)))):
        footstep = spec.start_footstep if spec.kind == "stop" else spec.end_footstep
        rows.append({"step": spec.name, "kind": spec.kind, "swing_side": spec.swing_side,
                     "length_m": footstep.length, "width_m": footstep.width, "turn_rad": footstep.turn,
                     "start_footstep": list(spec.start_footstep), "end_footstep": list(spec.end_footstep),
                     "distance": float(predicted.distance), "in_support": bool(predicted.in_support),
                     **{f"{p}{g}_rms": float(np.sqrt(e[g][k])) for p, e in errors.items() for g in groups}})
    return {"model": model_path, "held_out": held_out_path, "dataset": dataset_path,
            **summary(rows, prefixes),
            "per_kind": {kind: summary([r for r in rows if r["kind"] == kind], prefixes) for kind in STEP_KINDS},
            "per_parameter": {p: {b: summary([r for r in rows if parameter_bin(p, r[f"{p}_{unit}"]) == b], prefixes)
                                  for b in BINS[p]}
                              for p, unit in zip(PARAMETERS, ("m", "m", "rad"))},
            "per_footstep": per_footstep(rows, prefixes),
            "per_step": rows}


def per_footstep(rows: list[dict], prefixes: list[str]) -> list[dict]:
    """The steps that take the same footstep (length, width, turn; a stop's the one it stops
    from) pooled: :func:`summary` of each, with the footstep."""
    pooled: dict[tuple, list[dict]] = {}
    for row in rows:
        pooled.setdefault((round(row["length_m"], 4), round(row["width_m"], 4), round(row["turn_rad"], 5)), []).append(row)
    return [{"length_m": key[0], "width_m": key[1], "turn_rad": key[2], **summary(group, prefixes)}
            for key, group in sorted(pooled.items())]


def table(report: dict, *, worst: int = 10) -> str:
    """The report as text: the pooled rows (RMS, worst step in brackets), then the worst steps."""
    pca = report["dataset"] is not None
    header = f"{'':28s} {'steps':>5s} " + " ".join(f"{g:>13s}" for g in GROUPS) + \
        f" {'>10 legs':>8s} {'>20 any':>7s} {'out of support':>14s}"

    def line(label: str, s: dict, prefix: str = "") -> str:
        if not s["steps"]:
            return f"{label:28s} {0:5d}"
        cells = " ".join(f"{1000 * s[f'{prefix}{g}_rms']:6.1f} ({1000 * s[f'{prefix}{g}_rms_max']:4.1f})"
                         for g in GROUPS)
        return (f"{label:28s} {s['steps']:5d} {cells} {s[f'{prefix}legs_over_10mrad']:8d} "
                f"{s[f'{prefix}any_over_20mrad']:7d} {s['out_of_support']:14d}")

    out = [f"{report['steps']} held-out steps of {report['held_out']}, model {report['model']}",
           "RMS over the steps (worst step), mrad (ZMP mm); steps over 10 mrad in the legs, over 20 mrad "
           "in any of legs/torso/arms/pelvis; steps out of the model's support", header,
           line("all", report)]
    if pca:
        out.append(line("  PCA interpolation", report, "pca_"))
    for kind, s in report["per_kind"].items():
        out.append(line(kind, s))
    for parameter, bins in report["per_parameter"].items():
        for name, s in bins.items():
            if s["steps"] or "straight" not in name:
                out.append(line(f"{parameter} {name}", s))
    out.append("worst step per group: " + ", ".join(f"{g} {report[f'{g}_worst_step']}" for g in GROUPS))
    out.append(f"the {min(worst, report['steps'])} worst steps in the legs:")
    out.append(f"{'step':44s} " + " ".join(f"{g:>7s}" for g in GROUPS) + "  support")
    for row in sorted(report["per_step"], key=lambda r: -r["legs_rms"])[:worst]:
        out.append(f"{row['step']:44s} " + " ".join(f"{1000 * row[f'{g}_rms']:7.1f}" for g in GROUPS)
                   + ("  in" if row["in_support"] else f"  OUT ({1000 * row['distance']:.0f} mm)"))
    return "\n".join(out)


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
    print(json.dumps(report) if args.json else table(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
