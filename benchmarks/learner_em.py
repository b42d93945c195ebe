"""The free energy reached by variational EM against the joint L-BFGS-B optimiser, per S.

Both start from the same PCA start on the bundled dataset (100-point grid); EM runs until a
round gains less than ``em.RELATIVE_TOLERANCE`` of the bound or ``--rounds`` rounds, the joint optimiser
``--iterations`` iterations.  Reports the bound, the wall time, the explained variance per
signal group, the learned time-kernel hyperparameters, the weight kernels' median width and
nugget, and EM's last round's gain (what stopping left on the table).

    python benchmarks/learner_em.py [--kernel rbf] [--primitives 7,11,15,23,31] [--rounds 40]
        [--joint] [--iterations 150] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from cocomopl.data import dataset_path
from cocomopl.primitives import em, optimise
from cocomopl.primitives.estimator import SlotLayout, explained_variance, pca_signal_weights
from cocomopl.primitives.training import learned_parts, load_training_steps, phase_templates, resample


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kernel", default="rbf")
    parser.add_argument("--primitives", default="7,11,15,23,31")
    parser.add_argument("--rounds", type=int, default=40)
    parser.add_argument("--joint", action="store_true", help="also run the joint L-BFGS-B optimiser")
    parser.add_argument("--iterations", type=int, default=150)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    steps = load_training_steps(dataset_path())
    parts, types = learned_parts(steps)
    tau = np.linspace(0.0, 1.0, 100)
    X = resample(parts, phase_templates(parts, types), tau, types=types)
    layout = SlotLayout(parts, types)
    data = (layout.to_slots(X), layout.mask, layout.d2)
    weights = pca_signal_weights(X, steps.signal_names)
    rows = []
    for S in (int(x) for x in args.primitives.split(",")):
        fits = {"em": lambda S=S: em.maximise_bound_em(*data, tau=tau, S=S, kernel=args.kernel, max_rounds=args.rounds,
                                                        signal_weights=weights)}
        if args.joint:
            fits["joint"] = lambda S=S: optimise.maximise_bound(*data, tau=tau, S=S, kernel=args.kernel,
                                                                 max_iterations=args.iterations, signal_weights=weights)
        for name, fit in fits.items():
            started = time.perf_counter()
            result = fit()
            rows.append({
                "optimiser": name, "n_primitives": S, "kernel": args.kernel, "bound": result["bound"],
                "iterations": result["iterations"], "wall_time_s": time.perf_counter() - started,
                "explained_variance": explained_variance(X, layout.from_slots(result["reconstruction"]), steps.signal_names),
                "alpha_t": result["arrays"]["alpha_t"].tolist(), "ell_t": result["arrays"]["ell_t"].tolist(),
                "last_round_gain": float(np.diff(result["bounds"])[-1]) if len(result.get("bounds", [])) > 1 else None,
                "weight_width_median_m": float(np.median(1.0 / np.sqrt(2.0 * result["arrays"]["gamma_w"]))),
                "weight_nugget_median": float(np.median(result["arrays"]["eta_w"])),
            })
            if not args.json:
                r = rows[-1]
                ev = " / ".join(f"{100 * v:.4f}" for v in r["explained_variance"].values())
                gain = "" if r["last_round_gain"] is None else f" (last round +{r['last_round_gain']:.1f})"
                print(f"S = {S:2d} {name:5s} bound {r['bound']:12.1f}{gain} in {r['iterations']:3d} steps, "
                      f"{r['wall_time_s']:6.1f} s; explained joints / ZMP / pelvis {ev} %; weight widths, "
                      f"median {r['weight_width_median_m']:.3f} m, nuggets {r['weight_nugget_median']:.1e}", flush=True)
    if args.json:
        print(json.dumps({"rows": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
