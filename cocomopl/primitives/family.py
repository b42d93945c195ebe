"""The family check: do the dataset's OC steps form one smooth family a model can learn?

Steps are solved at lengths between the trained ones (by default the midpoints), exactly
as ``dataset generate`` solves its own, and each is compared on the model's normalised
time grid with

* the model's prediction from the step's spec alone, and
* the linear interpolation, in step length, of the two trained steps of the same kind
  that bracket it (the PCA-free baseline: what the family would give if it were linear).

Errors are RMS over the grid and the group's signals, per joint group (legs, torso and
head, arms), for the ZMP (m, in the pelvis frame) and the pelvis orientation.  A family
whose legs sit where the model predicts them but whose arms do not is on several solution
branches: the interpolation error shows it without any model.
"""

from __future__ import annotations

import itertools

import numpy as np

from cocomopl.dataset.signals import training_signals
from cocomopl.errors import Error
from cocomopl.motion import Motion, StepSpec
from cocomopl.primitives.estimator import MovementPrimitives, signal_groups
from cocomopl.primitives.training import TrainingSteps, resample_step, step_type
from cocomopl.robot import Robot

GROUPS = ("legs", "torso", "arms", "zmp", "pelvis")
KINDS = ("cyclic", "start", "stop")


def probe_lengths(lengths: list[float]) -> list[float]:
    """The midpoints between consecutive trained lengths (m)."""
    lengths = sorted(set(lengths))
    return [round((a + b) / 2, 6) for a, b in itertools.pairwise(lengths)]


def signal_group_indices(robot: Robot, names: list[str]) -> dict[str, np.ndarray]:
    """Signal indices of each of :data:`GROUPS`: the joints split into legs, torso (with the
    head) and arms (:meth:`~cocomopl.robot.Robot.joint_groups`), then the ZMP and the pelvis
    orientation."""
    groups = signal_groups(names)
    joints = groups["joints"]  # the robot's joints, in its order
    return {**{group: joints[idx] for group, idx in robot.joint_groups().items()},
            "zmp": groups["zmp"], "pelvis": groups["pelvis"]}


def probe_steps(robot: Robot, motions: dict[StepSpec, Motion], source: dict) -> TrainingSteps:
    """Solved probe steps as the primitives read them."""
    specs = sorted(motions, key=lambda s: (s.kind, s.start_length, s.end_length))
    signals = [training_signals(robot, motions[s]) for s in specs]
    durations = [np.array([m.t[last] - m.t[first] for _, first, last in m.phases]) for m in (motions[s] for s in specs)]
    return TrainingSteps(specs, [x["values"] for x in signals], [x["phase_time"] for x in signals], durations,
                         signals[0]["names"], source)


def bracket(spec: StepSpec, training: TrainingSteps) -> tuple[int, int, float]:
    """Indices of the two trained steps of ``spec``'s type that bracket it in length, and the
    weight of the upper one."""
    varying = 1 if spec.kind == "start" else 0  # a start varies in its end length, the others in their start
    length = (spec.start_length, spec.end_length)[varying]
    same = [k for k, s in enumerate(training.specs) if step_type(s) == step_type(spec)
            and (spec.kind != "cyclic" or s.kind == "cyclic")]
    at = {(training.specs[k].start_length, training.specs[k].end_length)[varying]: k for k in same}
    below, above = [x for x in at if x < length], [x for x in at if x > length]
    if not below or not above:
        raise Error(f"{spec.name} is not between two trained steps of its kind")
    a, b = max(below), min(above)
    return at[a], at[b], (length - a) / (b - a)


def family_errors(model: MovementPrimitives, probes: TrainingSteps, training: TrainingSteps, *,
                  groups: dict[str, np.ndarray]) -> dict:
    """Per step kind and over all probes: RMS error per group of the model's prediction and
    of the linear interpolation of the bracketing trained steps."""
    squared = {"model": [], "linear": []}
    for spec, values, phase_time in zip(probes.specs, probes.values, probes.phase_time):
        step = model.predict(spec)
        truth = resample_step(values, phase_time, step.boundaries, tau=step.tau)
        lower, upper, weight = bracket(spec, training)
        linear = sum(w * resample_step(training.values[k], training.phase_time[k], step.boundaries, tau=step.tau)
                     for k, w in ((lower, 1.0 - weight), (upper, weight)))
        for name, estimate in (("model", step.values_at(step.tau).T), ("linear", linear)):
            squared[name].append({g: float(((truth - estimate)[idx] ** 2).mean()) for g, idx in groups.items()})

    def rms(rows: list[dict]) -> dict:
        return {g: float(np.sqrt(np.mean([r[g] for r in rows]))) for g in groups}

    out = {"all": {name: rms(rows) for name, rows in squared.items()}}
    for kind in KINDS:
        keep = [i for i, s in enumerate(probes.specs) if s.kind == kind]
        if keep:
            out[kind] = {name: rms([rows[i] for i in keep]) for name, rows in squared.items()}
    out["steps"] = [{"step": s.name, **{f"{name}_{g}": float(np.sqrt(squared[name][i][g])) for name in squared for g in groups}}
                    for i, s in enumerate(probes.specs)]
    return out
