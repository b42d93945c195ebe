"""The training set of the primitives: every step's 36 signals on one per-phase normalised time grid.

Steps differ in duration and in how that duration splits into phases.  Each step *type*
(kind and swinging foot, e.g. ``cyclic`` swinging ``left``) gets a phase template: the
mean fraction of the step each phase takes.  A step is warped piecewise linearly so its
phase boundaries land on its template's, then sampled on a uniform grid ``tau`` in [0, 1].
Events (lift-off, touchdown) then sit at the same ``tau`` for all steps of a type, and the
phase durations themselves become regression targets.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from cocomopl.errors import Error
from cocomopl.gait import TURN_SCALE, WIDTH_SCALE
from cocomopl.motion import StepSpec
from cocomopl.motion_file import read_motions


def step_type(spec: StepSpec) -> str:
    """The discrete part of the step parameters: kind and swinging foot, e.g. ``cyclic_left``.

    Mirror images share lengths but not trajectories, so the swinging foot belongs to the
    type on which eq. (5)'s Kronecker delta acts.
    """
    return f"{spec.kind}_{spec.swing_side}"


STRAIGHT_PARAMETERS = 2  # start and end length: all a model of straight steps has
FOOTSTEP_PARAMETERS = 6  # and the start and end widths and turns


def step_lengths(spec: StepSpec, count: int = STRAIGHT_PARAMETERS) -> np.ndarray:
    """The continuous part of the step parameters, as the weight GPs take them: (start length,
    end length) in m and, for ``count`` = :data:`FOOTSTEP_PARAMETERS`, the start and end widths
    and turns scaled to metres (:data:`WIDTH_SCALE`, :data:`TURN_SCALE`).

    Raises
    ------
    Error
        For a step that turns or side-steps and a ``count`` that has no room for it.
    """
    if count == STRAIGHT_PARAMETERS:
        if not spec.straight:
            raise Error(f"step {spec.name} turns or side-steps, and the model knows straight steps only")
        return np.array([spec.start_length, spec.end_length])
    return np.array([spec.start_length, spec.end_length, WIDTH_SCALE * spec.start_width, WIDTH_SCALE * spec.end_width,
                     TURN_SCALE * spec.start_turn, TURN_SCALE * spec.end_turn])


def with_step_lengths(spec: StepSpec, z: np.ndarray) -> StepSpec:
    """``spec`` with the step parameters ``z`` (as :func:`step_lengths` gives them)."""
    values = {"start_length": float(z[0]), "end_length": float(z[1])}
    if len(z) == FOOTSTEP_PARAMETERS:
        values.update(start_width=float(z[2]) / WIDTH_SCALE, end_width=float(z[3]) / WIDTH_SCALE,
                      start_turn=float(z[4]) / TURN_SCALE, end_turn=float(z[5]) / TURN_SCALE)
    return replace(spec, **values)


def parameter_count(specs: list[StepSpec]) -> int:
    """How many step parameters a model of ``specs`` takes: lengths only if all are straight."""
    return STRAIGHT_PARAMETERS if all(s.straight for s in specs) else FOOTSTEP_PARAMETERS


@dataclass
class TrainingSteps:
    """OC steps as the primitives learn them.

    Attributes
    ----------
    specs : list of StepSpec, one per step
    values : list of (n_k, I) arrays, the signals at the step's samples
    phase_time : list of (n_k,) arrays, per-phase normalised time (0 .. number of phases)
    durations : list of (P_k,) arrays, phase durations in s
    signal_names : the I signal names
    source : where the steps came from (path and dataset creation date)
    """

    specs: list
    values: list
    phase_time: list
    durations: list
    signal_names: list
    source: dict

    def __len__(self) -> int:
        return len(self.specs)

    def subset(self, keep) -> TrainingSteps:
        """The steps at indices ``keep``."""
        keep = list(keep)
        return TrainingSteps(
            [self.specs[k] for k in keep],
            [self.values[k] for k in keep],
            [self.phase_time[k] for k in keep],
            [self.durations[k] for k in keep],
            self.signal_names,
            self.source,
        )


def load_training_steps(path) -> TrainingSteps:
    """Read the training signals of every motion of a cocomopl dataset file, checked
    (:func:`cocomopl.motion_file.read_motions`)."""
    motions, attrs = read_motions(path, dataset=True, signals=True)
    specs, values, phase_time, durations, signal_names = [], [], [], [], None
    for name in sorted(motions):
        if len(motions[name].steps) != 1:
            raise Error(f"{path}: motion {name} has {len(motions[name].steps)} steps; training needs single steps")
        signals = attrs["signals"][name]
        if signal_names is not None and signals["names"] != signal_names:
            raise Error(f"{path}: motion {name} has different signals from the others")
        signal_names = signals["names"]
        specs.append(motions[name].steps[0])
        values.append(signals["values"])
        phase_time.append(signals["phase_time"])
        durations.append(_phase_durations(signals["t"], signals["phase_time"]))
    source = {"path": str(path), "created": str(attrs.get("created", "")), "robot": next(iter(motions.values())).robot,
              "robot_description": attrs.get("robot_description"), "robot_model": attrs.get("robot_model")}
    return TrainingSteps(specs, values, phase_time, durations, signal_names, source)


def _phase_durations(t: np.ndarray, phase_time: np.ndarray) -> np.ndarray:
    """Duration of each phase from the times at which the phase counter passes each integer."""
    n_phases = round(phase_time[-1])
    boundaries = np.interp(np.arange(n_phases + 1), phase_time, t)
    return np.diff(boundaries)


def phase_templates(steps: TrainingSteps, types: list[str] | None = None) -> dict[str, np.ndarray]:
    """Per step type, the mean fraction of the step at which each phase ends (boundaries in [0, 1]).

    ``types`` (one per step) overrides :func:`step_type`, for steps learned in parts.
    """
    types = _types(steps, types)
    out = {}
    for type_ in sorted(set(types)):
        fractions = [d / d.sum() for t, d in zip(types, steps.durations) if t == type_]
        if len({len(f) for f in fractions}) != 1:
            raise Error(f"steps of type {type_} do not all have the same phases")
        out[type_] = np.concatenate([[0.0], np.cumsum(np.mean(fractions, axis=0))])
        out[type_][-1] = 1.0
    return out


def to_template_time(phase_time: np.ndarray, boundaries: np.ndarray) -> np.ndarray:
    """Map per-phase time (0 .. P) to template time in [0, 1] with the given phase boundaries."""
    return np.interp(phase_time, np.arange(len(boundaries)), boundaries)


def resample(
    steps: TrainingSteps, templates: dict[str, np.ndarray], tau: np.ndarray, *, types: list[str] | None = None
) -> np.ndarray:
    """All steps' signals on the template grid ``tau``: (K, I, T); ``types`` as in :func:`phase_templates`."""
    return np.stack(
        [resample_step(v, pt, templates[t], tau=tau) for t, v, pt in zip(_types(steps, types), steps.values, steps.phase_time)]
    )


def resample_step(values: np.ndarray, phase_time: np.ndarray, boundaries: np.ndarray, *, tau: np.ndarray) -> np.ndarray:
    """One step's signals (n, I) at per-phase times ``phase_time`` on the template grid
    ``tau`` of phase ``boundaries``: (I, T)."""
    x = to_template_time(phase_time, boundaries)
    return np.stack([np.interp(tau, x, values[:, i]) for i in range(values.shape[1])])


def split_phases(steps: TrainingSteps, kind: str, phase: int) -> tuple[TrainingSteps, list[str]]:
    """Cut every step of ``kind`` in two at the start of phase ``phase``.

    Returns the parts (each keeps its step's spec) and their types: a cut step's parts are
    ``<type>_part1`` and ``<type>_part2``, other steps keep :func:`step_type`.  A stop makes
    two swings within one step; cut at its middle touchdown, each part has one, like the
    other kinds.
    """
    parts, types = [], []
    for k, spec in enumerate(steps.specs):
        pt = steps.phase_time[k]
        if spec.kind != kind:
            parts.append((spec, steps.values[k], pt, steps.durations[k]))
            types.append(step_type(spec))
            continue
        if not 0 < phase < len(steps.durations[k]):
            raise Error(f"a {kind} step has {len(steps.durations[k])} phases: cannot cut it at phase {phase}")
        before, after = pt <= phase, pt >= phase
        parts.append((spec, steps.values[k][before], pt[before], steps.durations[k][:phase]))
        parts.append((spec, steps.values[k][after], pt[after] - phase, steps.durations[k][phase:]))
        types += [f"{step_type(spec)}_part1", f"{step_type(spec)}_part2"]
    specs, values, phase_time, durations = (list(x) for x in zip(*parts))
    return TrainingSteps(specs, values, phase_time, durations, steps.signal_names, steps.source), types


# a stop's phases: double support, swing, double support, swing, double support; its middle
# touchdown starts phase 2
STOP_MIDDLE_PHASE = 2


def learned_parts(steps: TrainingSteps) -> tuple[TrainingSteps, list[str]]:
    """The trajectories the primitives learn: every step whole, except stops, which are cut
    at their middle touchdown (:func:`split_phases`).

    A stop makes two swings within one step; learned whole, its second swing sits at a
    different normalised time from every other step's one, and the stops alone left most of
    what 11 shared primitives cannot explain (README, "Stage 2: primitives").
    """
    return split_phases(steps, "stop", STOP_MIDDLE_PHASE)


def _types(steps: TrainingSteps, types: list[str] | None) -> list[str]:
    if types is None:
        return [step_type(s) for s in steps.specs]
    if len(types) != len(steps):
        raise Error(f"{len(types)} step types given for {len(steps)} steps")
    return list(types)
