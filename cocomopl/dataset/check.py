"""An independent check of a dataset that does not trust the solver.

Every motion is recomputed with Pinocchio (:mod:`cocomopl.analysis.feasibility`), and
every pair of steps that may follow each other is checked for continuity.  Each check
reports its worst value; the dataset passes when every worst value is within tolerance.
"""

from __future__ import annotations

from cocomopl.analysis.feasibility import AT_LEAST, check_motion, passes, tolerances
from cocomopl.dataset.continuity import step_mismatch
from cocomopl.dataset.plan import successors
from cocomopl.motion import Motion
from cocomopl.robot import Robot


def check_dataset(robot: Robot, motions: dict[str, Motion], friction: float, dt: float) -> dict:
    """Check every motion and every step-to-step junction; ``ok`` if all pass.

    ``friction`` and ``dt`` are those the motions were made with (see :func:`tolerances`).
    """
    limits = tolerances(dt)
    per_motion = {name: check_motion(robot, m, friction) for name, m in motions.items()}
    worst = {}
    where = {}
    for key in limits:
        if key == "continuity":
            continue
        values = {name: r[key] for name, r in per_motion.items()}
        pick = min if key in AT_LEAST else max
        name = pick(values, key=values.get)
        worst[key], where[key] = values[name], name
    by_spec = {m.steps[0]: m for m in motions.values()}
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
