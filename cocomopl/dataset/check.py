"""An independent check of a dataset that does not trust the solver.

Every motion is recomputed with Pinocchio (:mod:`cocomopl.analysis.feasibility`), and
every pair of steps that may follow each other is checked for continuity.  Each check
reports its worst value; the dataset passes when every worst value is within tolerance.
"""

from __future__ import annotations

import numpy as np

from cocomopl.analysis.feasibility import AT_LEAST, check_motion, passes, tolerances
from cocomopl.dataset.continuity import step_mismatch
from cocomopl.dataset.plan import successors
from cocomopl.motion import Motion
from cocomopl.robot import Robot
from cocomopl.validation import NO_PUSH_FORCE


def non_finite_values(motion: Motion, signals: np.ndarray | None = None) -> int:
    """How many NaN or infinite values a motion (and its training signals) holds; the ZMP
    counts only where a sole pushes, as it is undefined elsewhere."""
    arrays = [motion.t, motion.q, motion.v, motion.tau, motion.wrenches]
    pushing = np.nan_to_num(motion.wrenches[:, :, 2], nan=1.0).sum(axis=1) > NO_PUSH_FORCE
    arrays.append(motion.zmp[pushing])
    if signals is not None:
        arrays.append(signals)
    return int(sum(np.count_nonzero(~np.isfinite(a)) for a in arrays))


def check_dataset(robot: Robot, motions: dict[str, Motion], friction: float, *, dt: float,
                  signals: dict[str, np.ndarray] | None = None) -> dict:
    """Check every motion and every step-to-step junction; ``ok`` if all pass.

    The junctions are every ordered pair of motions of which the second may follow the
    first, a dataset's mirror images included (the count in ``junctions``).

    ``friction`` and ``dt`` are those the motions were made with (see :func:`tolerances`);
    ``signals`` the training signals of a dataset's motions, by name.  A motion holding a
    NaN or an infinite value fails ``non_finite_values`` and is left out of the other
    checks, whose worst values would otherwise depend on where the NaN sits.
    """
    limits = {"non_finite_values": 0, **tolerances(dt)}
    signals = signals or {}
    counts = {name: non_finite_values(m, signals.get(name)) for name, m in motions.items()}
    finite = {name: m for name, m in motions.items() if counts[name] == 0}
    per_motion = {name: {"non_finite_values": counts[name], **(check_motion(robot, m, friction) if name in finite else {})}
                  for name, m in motions.items()}
    name = max(counts, key=counts.get)
    worst, where = {"non_finite_values": counts[name]}, {"non_finite_values": name}
    for key in limits:
        if key in ("continuity", "non_finite_values") or not finite:
            continue
        values = {name: per_motion[name][key] for name in finite}
        pick = min if key in AT_LEAST else max
        name = pick(values, key=values.get)
        worst[key], where[key] = values[name], name
    by_spec = {m.steps[0]: m for m in finite.values()}
    junctions = {}
    for spec, motion in by_spec.items():
        for nxt in successors(spec, list(by_spec)):
            junctions[f"{motion.name}->{by_spec[nxt].name}"] = step_mismatch(robot, motion, by_spec[nxt])
    if junctions:
        name = max(junctions, key=junctions.get)
        worst["continuity"], where["continuity"] = junctions[name], name
    failures = sorted(key for key, value in worst.items() if not passes(key, value, limits))
    return {
        "ok": not failures,
        "failures": failures,
        "worst": worst,
        "worst_in": where,
        "tolerances": limits,
        "motions": len(motions),
        "junctions": len(junctions),
        "per_motion": per_motion,
    }
