"""How much variance can S shared primitives explain at best?  An upper limit for any model.

The model of the paper writes every signal of every training step as a weighted sum of the
same S time functions, so on the training data it is a rank-S approximation of the
(steps x signals, time) matrix.  For a given weighting of the signal groups the best such
approximation is the weighted truncated SVD (Eckart-Young).  This script scans group
weights (ZMP and pelvis against the joints, 17 values from 1 to 1e4 each) and
reports, for each S, the weighting whose worst group explains the most: what the best
possible shared basis of S functions reaches in all three groups at once.  A scan of
weights gives points on the trade-off curve, not a proof that no other basis does better.

Signals are those of training (``load_training_steps``) on the phase-normalised grid of
100 points; explained variance is ``1 - SSE / total`` about each signal's mean, as in
``cocomopl train``.

``--split-stops`` asks what the limit would be if stop steps, which make two swings in one
step, were learned as two parts cut at their middle touchdown (``split_phases``), each part
on its own phase template like a step type of its own.

Usage::

    python benchmarks/explained_variance_limit.py [DATASET] [--primitives 9,11,13] [--split-stops] [--json]
"""

from __future__ import annotations

import argparse
import itertools
import json

import numpy as np

from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.primitives.estimator import signal_groups
from cocomopl.primitives.training import learned_parts, load_training_steps, phase_templates, resample

DATASET = BUNDLED_DATASET
WEIGHTS = np.geomspace(1.0, 1e4, 17)  # squared weight of the ZMP and pelvis groups


def rank_limited(X: np.ndarray, row_weights: np.ndarray, S: int) -> np.ndarray:
    """The best rank-``S`` approximation of (K, I, T) signals in time under row weights (I,)."""
    Y = (X * row_weights[None, :, None]).reshape(-1, X.shape[2])
    basis = np.linalg.svd(Y, full_matrices=False)[2][:S]
    return np.einsum("kit,st,su->kiu", X, basis, basis)


def best_balanced(X: np.ndarray, groups: dict[str, np.ndarray], S: int) -> dict:
    """Over the weight grid, the rank-``S`` basis whose worst group explains the most."""
    centred = X - X.mean(axis=(0, 2), keepdims=True)
    total = {g: (centred[:, i] ** 2).sum() for g, i in groups.items()}
    best = None
    for w_zmp, w_pelvis in itertools.product(WEIGHTS, WEIGHTS):
        weights = np.ones(X.shape[1])
        weights[groups["zmp"]] = np.sqrt(w_zmp)
        weights[groups["pelvis"]] = np.sqrt(w_pelvis)
        X_hat = rank_limited(X, weights, S)
        explained = {g: float(1 - ((X - X_hat)[:, i] ** 2).sum() / total[g]) for g, i in groups.items()}
        if best is None or min(explained.values()) > min(best["explained_variance"].values()):
            best = {"explained_variance": explained, "weights": {"zmp": float(w_zmp), "pelvis": float(w_pelvis)}}
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("dataset", nargs="?", default=DATASET)
    parser.add_argument("--primitives", default="9,11,13,15", help="comma-separated numbers of primitives S")
    parser.add_argument("--split-stops", action="store_true", help="learn stop steps as two parts, cut at their middle touchdown")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    args = parser.parse_args()
    try:
        sizes = [int(x) for x in args.primitives.split(",")]
    except ValueError:
        parser.error(f"--primitives {args.primitives!r}: expected whole numbers such as 9,11,13")
    if min(sizes) < 1:
        parser.error(f"--primitives {args.primitives!r}: each number of primitives must be at least 1")
    try:
        steps = load_training_steps(args.dataset)
    except Error as exc:
        parser.error(str(exc))
    types = None
    if args.split_stops:
        try:
            steps, types = learned_parts(steps)
        except Error as exc:
            parser.error(str(exc))
    X = resample(steps, phase_templates(steps, types), np.linspace(0.0, 1.0, 100), types=types)
    groups = signal_groups(steps.signal_names)
    rows = [{"n_primitives": S, **best_balanced(X, groups, S)} for S in sizes]
    if args.json:
        print(json.dumps({"dataset": args.dataset, "split_stops": args.split_stops, "trajectories": len(steps), "limits": rows}))
        return 0
    split = ", stops split at their middle touchdown" if args.split_stops else ""
    print(f"best rank-S shared basis, worst group maximised over group weights ({args.dataset}, {len(steps)} trajectories{split})")
    print(f"{'S':>3}  {'joints':>8}  {'ZMP':>8}  {'pelvis':>8}  weights (ZMP, pelvis)")
    for row in rows:
        ev = row["explained_variance"]
        print(
            f"{row['n_primitives']:>3}  {100 * ev['joints']:7.3f}%  {100 * ev['zmp']:7.3f}%  {100 * ev['pelvis']:7.3f}%"
            f"  {row['weights']['zmp']:.3g}, {row['weights']['pelvis']:.3g}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
