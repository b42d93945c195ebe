"""What each ``cocomopl`` command returns: a dataclass with its JSON and its table.

:meth:`Result.to_json` gives the object ``--json`` prints (and report folders write), its
keys in the order of the fields; :meth:`Result.to_table` the text the command prints by
default; :attr:`Result.exit_code` the command's exit status.  Any field value with a
``to_json`` method (a result, :class:`~cocomopl.analysis.metrics.WalkMetrics`) is written
as its JSON.  Figures computed elsewhere with their own open set of names (the dataset
check's worst values, ...) stay dictionaries inside these fields.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cocomopl.errors import plural

if TYPE_CHECKING:
    from cocomopl.analysis.metrics import WalkMetrics
    from cocomopl.primitives.coverage import Coverage

# field metadata: OPTIONAL fields are left out of the JSON when None; INLINE fields (dicts or
# results) are spliced into it; HIDDEN fields are for the table only
OPTIONAL, INLINE, HIDDEN = {"optional": True}, {"inline": True}, {"hidden": True}


def _plain(value: Any) -> Any:
    if callable(getattr(value, "to_json", None)):
        return value.to_json()
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


@dataclass
class Result:
    """A command's result: fields in the order of its JSON object."""

    def to_json(self) -> dict:
        """The JSON object of the result (values JSON-serialisable, NumPy scalars as floats)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.metadata.get("hidden") or (value is None and f.metadata.get("optional")):
                continue
            if f.metadata.get("inline"):
                out.update(_plain(value) or {})
            else:
                out[f.metadata.get("key", f.name)] = _plain(value)
        return out

    def to_table(self) -> str:
        """The text the command prints without ``--json`` (here: one ``key: value`` line per JSON key)."""
        return "\n".join(f"{key}: {value}" for key, value in self.to_json().items())

    def __str__(self) -> str:
        return self.to_table()

    @property
    def exit_code(self) -> int:
        """0, or 1 where the command did its work but the result fails (a fall, a failed check, ...)."""
        return 0


# ---------------------------------------------------------------------------- shared parts
METRIC_ROWS = (
    ("fell", "fell", "{}"),
    ("peak_force_over_weight", "peak vertical force / weight", "{:.2f}"),
    ("max_force_rate", "max vertical force rate, 20 ms (N/s)", "{:.0f}"),
    ("mean_torque", "mean torque (Table I, N m s^-1/2)", "{:.4f}"),
    ("rms_torque", "RMS joint torque (N m)", "{:.2f}"),
    ("zmp_rms_error", "ZMP RMS error vs reference (m)", "{:.4f}"),
    ("tracking_rms_rad", "joint tracking RMS (rad)", "{:.4f}"),
    ("touchdown_delay_median_s", "median touchdown delay (s)", "{:+.3f}"),
    ("foot_slip_m", "foot slip (m)", "{:.4f}"),
    ("duration_s", "duration (s)", "{:.2f}"),
)


def _mm(metres, separator: str = ",") -> str:
    """Lengths in m as millimetres joined by ``separator``."""
    return separator.join(f"{1000 * x:g}" for x in metres)


def metrics_table(metrics: WalkMetrics) -> str:
    """The main simulation metrics (:func:`~cocomopl.analysis.metrics.summary`), one per line."""
    values = ((label, fmt, getattr(metrics, name)) for name, label, fmt in METRIC_ROWS)
    return "\n".join(f"{label:38s} {'-' if value is None else fmt.format(value)}" for label, fmt, value in values)


def selection_table(rows: list[dict], best: tuple[str, int] | None) -> list[str]:
    """The model-selection table, the ``best`` (kernel, S) marked."""
    lines = [f"{'kernel':9s} {'S':>3s} {'free energy':>13s} {'EV joints':>10s} {'EV zmp':>8s} {'EV pelvis':>10s} {'iter':>5s}"]
    for r in rows:
        ev = r["explained_variance"]
        mark = "  <- best" if (r["kernel"], r["n_primitives"]) == best else ""
        lines.append(
            f"{r['kernel']:9s} {r['n_primitives']:3d} {r['bound']:13.1f} {100 * ev['joints']:9.3f}% "
            f"{100 * ev['zmp']:7.3f}% {100 * ev['pelvis']:9.3f}% {r['iterations']:5d}{mark}"
        )
    return lines


@dataclass
class SimulationRecord(Result):
    """How a rollout was simulated, as its measured motion's metadata records it."""

    stabilizer: bool
    stabilizer_gains: dict | None
    feedforward: bool
    sim_model: str | None
    servos: dict | None
    contact_time_constant_s: float
    reference_cutoff_hz: float


@dataclass
class RefineSummary(Result):
    """A walk refined by optimal control (:func:`cocomopl.pipeline.refine`): per step its name,
    the guess it started from, the solver's iterations, convergence, fallback and cost; the
    median iterations, the wall time (s) and the generated walk's torque cost over the
    refined walk's."""

    steps: list[str]
    warm_start: str
    guess: list[str]
    iterations: list[int]
    converged: list[bool]
    fallback: list
    cost: list[float]
    iterations_median: float
    refine_s: float
    raw_cost_ratio: float
    dataset: str

    def to_table(self) -> str:
        return "\n".join(self.lines())

    def lines(self) -> list[str]:
        """Per step its iterations, convergence and warm start, then the totals."""
        lines = [f"{'refined step':24s} {'iterations':>10s}  converged  warm start"]
        lines += [f"{step:24s} {n:10d}  {'yes' if ok else 'NO':9s}  {guess}"
                  for step, n, ok, guess in zip(self.steps, self.iterations, self.converged, self.guess)]
        lines.append(f"refined in {self.refine_s:.1f} s (median {self.iterations_median:g} iterations per step); "
                     f"the generated walk's torque cost is {self.raw_cost_ratio:.3f} x the refined one's")
        return lines


@dataclass
class GoalErrors(Result):
    """The goals of a walk and how far the simulated feet ended from the last (m, deg)."""

    goal: dict
    waypoints: list[dict] | None = field(default=None, metadata=OPTIONAL)
    final_position_error_m: float = 0.0
    final_yaw_error_deg: float = 0.0


# ---------------------------------------------------------------------------- stage 1
@dataclass
class DatasetSummary(Result):
    """``dataset generate``: the dataset written, its OCPs solved, reused and failed."""

    output: str
    ocps: int
    solved: int
    reused: int
    failed: list[str]
    motions: int
    wall_time_s: float

    def to_table(self) -> str:
        table = (f"wrote {self.output}: {plural(self.motions, 'motion')} from {plural(self.ocps, 'OCP')} "
                 f"({self.solved} solved, {self.reused} reused) in {self.wall_time_s:.1f} s")
        return table + (f"\nNOT CONVERGED (left out): {', '.join(self.failed)}" if self.failed else "")

    @property
    def exit_code(self) -> int:
        return 1 if self.failed else 0


@dataclass
class DatasetInfo(Result):
    """``dataset info``: the summary of :func:`cocomopl.dataset.info.dataset_info`."""

    info: dict = field(metadata=INLINE)

    def to_table(self) -> str:
        from cocomopl.dataset.info import format_info

        return format_info(self.info)


@dataclass
class CheckReport(Result):
    """``dataset check``: the independent check of a file (:func:`cocomopl.dataset.check.check_dataset`)."""

    file: str
    ok: bool
    failures: list[str]
    worst: dict[str, float]
    worst_in: dict[str, str]
    tolerances: dict[str, float]
    motions: int
    junctions: int
    per_motion: dict | None = field(default=None, metadata=OPTIONAL)

    def to_table(self) -> str:
        lines = [f"{self.file}: {plural(self.motions, 'motion')}, {plural(self.junctions, 'step junction')}",
                 f"{'check':28s} {'worst':>12s} {'tolerance':>10s}  result  where"]
        for key, value in self.worst.items():
            ok = key not in self.failures
            bound = (">= " if key in ("zmp_margin", "min_normal_force") else "<= ") + f"{self.tolerances[key]:g}"
            lines.append(f"{key:28s} {value:12.4g} {bound:>10s}  {'ok' if ok else 'FAIL':6s}  {self.worst_in[key]}")
        lines.append("PASS" if self.ok else f"FAIL: {', '.join(self.failures)}")
        return "\n".join(lines)

    @property
    def exit_code(self) -> int:
        return 0 if self.ok else 1


def _group_header(width: int) -> str:
    from cocomopl.primitives.family import GROUPS

    return "".join(f"{g:>{width}s}" for g in GROUPS)


@dataclass
class FamilyReport(Result):
    """``dataset family``: steps solved between the trained lengths, their RMS distance from the
    model's predictions and from linear interpolation (:func:`~cocomopl.primitives.family.family_errors`)."""

    dataset: str
    model: str
    lengths_mm: list[float]
    solved: int
    failed: list[str]
    solve_s: float
    errors: dict = field(metadata=INLINE)

    def to_table(self) -> str:
        from cocomopl.primitives.family import GROUPS

        lines = [f"{plural(self.solved, 'step')} solved at {', '.join(f'{x:g}' for x in self.lengths_mm)} mm in "
                 f"{self.solve_s:.0f} s" + (f"; not converged: {', '.join(self.failed)}" if self.failed else ""),
                 "RMS distance of the OC steps from the model's prediction (and from the linear interpolation of the",
                 "trained steps around them); joints and pelvis in mrad, ZMP in mm:",
                 f"{'steps':8s}" + _group_header(16)]
        for kind in ("all", "cyclic", "start", "stop"):
            if kind in self.errors:
                model, linear = self.errors[kind]["model"], self.errors[kind]["linear"]
                lines.append(f"{kind:8s}" + "".join(f"{1000 * model[g]:8.1f} ({1000 * linear[g]:5.1f})" for g in GROUPS))
        return "\n".join(lines)


@dataclass
class GrowReport(Result):
    """``dataset grow``: the lengths added, the grown dataset and retrained model, and the
    held-out error before and after."""

    grown: dict = field(metadata=INLINE)  # the record kept in the grown dataset
    dataset: str = ""
    model: str = ""
    source: str = field(default="", metadata={"key": "from"})
    solved: int = 0
    failed: list[str] = field(default_factory=list)
    held_out_steps: int = 0
    kernel: str = ""
    n_primitives: int = 0
    held_out: dict = field(default_factory=dict)
    wall_time_s: float = 0.0

    def to_table(self) -> str:
        from cocomopl.primitives.family import GROUPS

        picked = ", ".join(f"{x:g}" for x in self.grown["picked_mm"])
        held_out = ", ".join(f"{x:g}" for x in self.grown["held_out_mm"])
        lines = [(f"wrote {self.dataset} and {self.model}: {self.grown['method']} growth by {picked} mm "
                  f"({plural(self.solved, 'OCP')} solved)" + (f"; NOT CONVERGED: {', '.join(self.failed)}" if self.failed else "")),
                 (f"RMS error on {plural(self.held_out_steps, 'held-out step')} ({held_out} mm); "
                  "joints and pelvis in mrad, ZMP in mm:"),
                 f"{'model':8s}" + _group_header(10)]
        for when in ("before", "after"):
            lines.append(f"{when:8s}" + "".join(f"{1000 * self.held_out[when]['model'][g]:10.2f}" for g in GROUPS))
        return "\n".join(lines)

    @property
    def exit_code(self) -> int:
        return 1 if self.failed else 0


# ---------------------------------------------------------------------------- stage 2
@dataclass
class TrainReport(Result):
    """``train``: the model chosen and written, its plot, and the selection table."""

    output: str
    plot: str
    kernel: str
    n_primitives: int
    bound: float
    explained_variance: dict[str, float]
    selection: list[dict]
    wall_time_s: float

    def to_table(self) -> str:
        lines = selection_table(self.selection, (self.kernel, self.n_primitives))
        lines.append(f"wrote {self.output} ({self.kernel}, {self.n_primitives} primitives) and "
                     f"{self.plot} in {self.wall_time_s:.0f} s")
        return "\n".join(lines)


@dataclass
class ModelInfo(Result):
    """``model info``: a model file's summary; its training dataset by name and checksum."""

    file: str
    n_primitives: int | None
    kernel: str | None
    max_iterations: int | None
    n_widths: int | None
    bound: float | None
    explained_variance: dict | None
    n_grid: int | None
    created: str | None
    command: str | None
    versions: dict | None
    training_wall_time_s: float | None
    checksum: str | None
    format_version: int | None
    dataset: dict
    coverage: Coverage
    selection: list[dict] | None = field(default=None, metadata=OPTIONAL)  # with --verbose

    def to_table(self) -> str:
        ev, dataset = self.explained_variance or {}, self.dataset
        checksum = f", sha256 {dataset['sha256'][:12]}" if dataset.get("sha256") else ""
        lines = [
            f"{self.file}: {self.n_primitives} primitives, {self.kernel} kernel, {self.n_widths} candidate weight-kernel "
            f"widths, free energy {self.bound:.1f}",
            "explained variance: " + ", ".join(f"{g} {100 * v:.3f}%" for g, v in ev.items()),
            f"trained {self.created} by: {self.command}",
            f"on {dataset.get('name', '?')}{checksum} ({dataset.get('steps', '?')} steps)",
            *self.coverage.table_lines(),
        ]
        if self.selection:
            lines += ["model selection:", *selection_table(self.selection, (self.kernel, self.n_primitives))]
        return "\n".join(lines)


@dataclass
class StepRow(Result):
    """One generated step: its duration and uncertainty, and whether it lies in the training support."""

    step: str
    duration_s: float
    duration_std_s: float
    joint_std_max_rad: float
    in_support: bool
    distance_mm: float

    def line(self) -> str:
        return (f"{self.step:24s} {self.duration_s:8.3f}s {self.joint_std_max_rad:12.4f}rad  "
                + ("ok" if self.in_support else f"OUTSIDE ({self.distance_mm:.0f} mm away)"))


@dataclass
class GenerateReport(Result):
    """``generate``: the walk written, per step, with timings, the dynamics filter's error
    left, the upper-body correction and the refinement's summary where it was refined."""

    output: str
    steps: list[StepRow]
    n_steps: int
    duration_s: float
    generation_s: float
    placement_s: float
    dynamics_filter_zmp_error_m: float
    upper_body_limits: dict
    out_of_support: list[str]
    warnings: list[str]
    footsteps: list[dict] | None = field(default=None, metadata=OPTIONAL)  # of a walk on footsteps or to goals
    refine: RefineSummary | None = field(default=None, metadata=OPTIONAL)

    def to_table(self) -> str:
        lines = [f"{'step':24s} {'duration':>9s} {'max joint std':>14s}  support", *(r.line() for r in self.steps)]
        upper = self.upper_body_limits
        if upper:
            lines.append(f"upper body (the joints that carry no sole) corrected by up to {upper['largest_change_rad']:.3f} "
                         f"rad: torque {upper['torque_ratio_before']:.2f} -> {upper['torque_ratio_after']:.2f}, velocity "
                         f"{upper['velocity_ratio_before']:.2f} -> {upper['velocity_ratio_after']:.2f} of the limits")
        else:
            lines.append("upper body (the joints that carry no sole) not corrected into its limits: a streamed walk")
        if self.refine is not None:
            lines += self.refine.lines()
        lines.append(f"wrote {self.output}: {plural(len(self.steps), 'step')}, {self.duration_s:.2f} s of walking; "
                     f"generated in {self.generation_s * 1e6:.0f} us, placed in the world in "
                     f"{self.placement_s * 1e3:.0f} ms")
        return "\n".join(lines)


@dataclass
class RefineReport(Result):
    """``refine``: the refined walk written and the refinement's summary."""

    output: str
    summary: RefineSummary = field(metadata=INLINE)

    def to_table(self) -> str:
        return "\n".join([*self.summary.lines(), f"wrote {self.output}"])

    @property
    def exit_code(self) -> int:
        return 0 if all(self.summary.converged) else 1


# ---------------------------------------------------------------------------- stage 3 and tools
@dataclass
class SimulateReport(Result):
    """``simulate``: the measured motion written, how it was simulated and its metrics."""

    output: str
    simulation: SimulationRecord = field(metadata=INLINE)
    metrics: WalkMetrics = field(metadata=INLINE)

    def to_table(self) -> str:
        return metrics_table(self.metrics) + f"\nwrote {self.output}"

    @property
    def exit_code(self) -> int:
        return 1 if self.metrics.fell else 0


def _recovery_line(changes: list[dict]) -> str:
    if not changes:
        return "recovery by stepping: no landing moved"
    moves = "; ".join(f"landing {c['landing'] + 1} moved {100 * c['shift_m'][0]:+.1f}, {100 * c['shift_m'][1]:+.1f} cm "
                      f"at {c['time_s']:.2f} s" for c in changes)
    return f"recovery by stepping: {moves}"


def _reaim_line(changes: list[dict]) -> str:
    if not changes:
        return "footstep re-aiming: no step re-aimed"
    worst = max(math.hypot(*c["stance_error_m"]) for c in changes)
    return (f"footstep re-aiming: {plural(len(changes), 'step')} re-aimed, their stance soles up to {100 * worst:.1f} cm "
            "from the plan")


@dataclass
class WalkReport(Result):
    """``walk``: a generated (and perhaps refined) walk simulated, its metrics against the
    plan it ended up following, the files of its report folder and their provenance."""

    label: str = field(metadata=HIDDEN)  # how the walk was asked for
    folder: str = field(metadata=HIDDEN)
    lengths_mm: list[float] | None = field(metadata=OPTIONAL)
    footsteps: list[dict] | None = field(metadata=OPTIONAL)
    goal: GoalErrors | None = field(metadata={**INLINE, **OPTIONAL})
    steps: list[str]
    simulation: SimulationRecord = field(metadata=INLINE)
    pushes: list[dict]
    recoveries: list[dict] | None = field(metadata=OPTIONAL)  # with recovery by stepping
    reaim: bool
    reaimed: list[dict] | None = field(metadata=OPTIONAL)  # with footstep re-aiming
    metrics: WalkMetrics = field(metadata=INLINE)
    generation_s: float
    placement_s: float
    dynamics_filter_zmp_error_m: float
    warnings: list[str]
    refine: RefineSummary | None = field(metadata=OPTIONAL)
    files: list[str]
    provenance: dict
    wall_time_s: float = 0.0

    def to_table(self) -> str:
        lines = [f"walk {self.label}: {plural(len(self.steps), 'step')}, generated in {self.generation_s * 1e3:.2f} ms, "
                 + ("refined by optimal control, " if self.refine else "")
                 + f"simulated in MuJoCo ({'with' if self.simulation.stabilizer else 'without'} stabilizer)",
                 *(self.refine.lines() if self.refine else []),
                 metrics_table(self.metrics)]
        if self.goal is not None:
            lines.append(f"ended {100 * self.goal.final_position_error_m:.1f} cm and "
                         f"{self.goal.final_yaw_error_deg:.1f} deg from the goal")
        if self.recoveries is not None:
            lines.append(_recovery_line(self.recoveries))
        if self.reaimed is not None:
            lines.append(_reaim_line(self.reaimed))
        lines.append(f"report in {self.folder}/ ({self.wall_time_s:.0f} s): " + ", ".join(Path(f).name for f in self.files))
        return "\n".join(lines)

    @property
    def exit_code(self) -> int:
        return 1 if self.metrics.fell else 0


@dataclass
class ReproduceReport(Result):
    """``reproduce``: the paper's experiment, Table I's analogue and every figure behind it."""

    folder: str = field(metadata=HIDDEN)
    window_s: list[float]
    table1_mean_torque: dict[str, float]
    mp_vs_oc_simulated_mean_torque_difference: float
    mp_vs_oc: dict
    mp_vs_kajita: dict
    refined_vs_oc: dict
    refine: RefineSummary
    metrics: dict[str, dict]
    sim_model: str | None
    servos: dict | None
    contact_time_constant_s: float
    reference_cutoff_hz: float
    kajita: dict
    m_opt_steps: int
    m_opt_solved_now: list[str]
    m_opt_solve_s: float
    m_opt_solver: dict | None
    generation_s: float
    provenance: dict = field(default_factory=dict)
    files: list[str] = field(default_factory=list)
    wall_time_s: float = 0.0

    def to_table(self) -> str:
        start, end = self.window_s
        lines = [(f"every figure over the walking window {start:g} to {end:g} s; contact time constant "
                  f"{1000 * self.contact_time_constant_s:g} ms, reference low-pass {self.reference_cutoff_hz:g} Hz"),
                 ("Table I analogue: mean torque (N m s^-1/2), M_gen (MP), M_gen refined by optimal control (refined), "
                  "M_opt (OC), Kajita on M_gen's footsteps")]
        lines += [f"  {name:36s} {value:.4f}" for name, value in self.table1_mean_torque.items()]
        lines.append(f"MP vs OC simulated mean torque: {100 * self.mp_vs_oc_simulated_mean_torque_difference:+.2f} %; "
                     f"refined vs OC: {100 * self.refined_vs_oc['mean_torque']['relative_difference']:+.2f} %")
        lines.append(f"{'simulated':9s} {'fell':>5s} {'peak F/W':>8s} {'var/sole':>8s} {'var sum':>8s} {'max dF/dt':>9s} "
                     f"{'knee mean':>9s} {'CoM mean':>8s} {'(range, m)':>13s} {'stabilizer D, K':>16s}")
        for name, m in self.metrics.items():
            gains = m["stabilizer_gains"]
            lines.append(f"{name:9s} {m['fell']!s:>5s} {m['peak_force_over_weight']:8.2f} "
                         f"{m['force_variation_over_weight']:8.2f} {m['total_force_variation_over_weight']:8.2f} "
                         f"{m['max_force_rate']:9.2e} {m['knee_angle_mean_rad']:9.2f} {m['com_height_mean_m']:8.3f} "
                         f"{m['com_height_min_m']:6.3f}-{m['com_height_max_m']:.3f} "
                         f"{gains['ankle_damping']:>10g}, {gains['dcm_gain']:g}")
        for other, comparison in (("OC", self.mp_vs_oc), ("Kajita", self.mp_vs_kajita)):
            lower = [k for k, c in comparison.items() if c["lower"] == "MP"]
            higher = [k for k, c in comparison.items() if c["lower"] != "MP"]
            lines.append(f"MP lower than {other} in: {', '.join(lower) or 'none'}; higher in: {', '.join(higher) or 'none'}")
        refined = self.refine
        lines.append(f"refined M_gen: {sum(refined.converged)} of {plural(len(refined.converged), 'step')} converged, "
                     f"median {refined.iterations_median:g} iterations, {refined.refine_s:.1f} s; M_gen's torque cost "
                     f"is {refined.raw_cost_ratio:.3f} x the refined walk's")
        k = self.kajita
        lines.append(f"Kajita ({k['variant']}): CoM at {k['com_height_m']:.3f} m (pelvis {100 * k['pelvis_drop']:.1f} cm "
                     f"low{', searched' if k['pelvis_drop_searched'] else ''}), multibody ZMP "
                     f"{100 * k['zmp_reference_rms_m']:.2f} cm RMS from its reference "
                     f"({100 * k['first_stage_zmp_reference_rms_m']:.2f} cm after preview control alone)")
        solved = self.m_opt_solved_now
        lines.append(f"M_opt: {self.m_opt_steps} step OCPs, {self.m_opt_steps - len(solved)} from the dataset and "
                     f"{len(solved)} solved now{' (' + ', '.join(solved) + ')' if solved else ''} in "
                     f"{self.m_opt_solve_s:.1f} s; report in {self.folder}/ ({self.wall_time_s:.0f} s)")
        return "\n".join(lines)


@dataclass
class ExportReport(Result):
    """``export``: the files written, the safety gate's report and the reasons it was forced past."""

    files: list[str]
    format: str
    unsafe: list[str]
    forced: bool
    gate: dict

    def to_table(self) -> str:
        from cocomopl.export.safety import margins_text

        lines = [f"wrote {f}" for f in self.files] + [f"warning (--force): {r}" for r in self.unsafe]
        if not self.unsafe:
            lines.append(f"safety gate passed: {margins_text(self.gate)}")
        return "\n".join(lines)


@dataclass
class ModelExport(Result):
    """``export-model``: the model file written and what it holds (:func:`cocomopl.export.mjcf.export_model`)."""

    info: dict = field(metadata=INLINE)

    def to_table(self) -> str:
        return f"wrote {self.info['output']}"


@dataclass
class RobotCheck(Result):
    """``robot check``: what cocomopl derives from a robot's description (``docs/robots.md``)."""

    robot: str
    mass_kg: float
    actuated_joints: int
    groups: dict[str, list[str]]
    mirror_pairs: list[list[str]]
    soles: dict
    posture: dict
    placement_symmetrised_m: float
    inertia_symmetrised_m: float
    armature: dict
    scale: dict
    defaults: dict
    png: str | None = field(default=None, metadata=OPTIONAL)

    def to_table(self) -> str:
        s, p = self.soles, self.posture
        lines = [f"robot {self.robot}: {self.mass_kg:.2f} kg, {self.actuated_joints} actuated joints"]
        lines += [f"  {group:6s} {', '.join(names) or '-'}" for group, names in self.groups.items()]
        lines.append(f"mirror pairs: {', '.join(f'{a}/{b}' for a, b in self.mirror_pairs)}")
        lines.append(f"soles ({s['source']}): {s['left']} and {s['right']}, front {s['front_m'] * 1000:.1f} mm, "
                     f"back {s['back_m'] * 1000:.1f} mm, half width {s['half_width_m'] * 1000:.1f} mm")
        lines.append(f"posture ({p['source']}): pelvis {p['pelvis_height_m'] * 1000:.0f} mm above the soles "
                     f"({p['straight_pelvis_height_m'] * 1000:.0f} mm with straight legs), knees "
                     + ", ".join(f"{k:.2f}" for k in p['knees_rad']) + " rad")
        lines.append(f"symmetrised: joint placements by up to {self.placement_symmetrised_m * 1e6:.1f} um, "
                     f"link centres of mass by up to {self.inertia_symmetrised_m * 1e3:.2f} mm")
        a, k = self.armature, self.scale
        lines.append(f"armature ({a['source']}): {a['min_kg_m2']:.4g} to {a['max_kg_m2']:.4g} kg m^2")
        stride = "" if k.get("stride") is None else f", step lengths {k['stride']:g} (what the legs reach)"
        lines.append(f"scale against TALOS: mass {k['mass']:g}, leg length {k['length']:g}, sole half width "
                     f"{k['width']:g}, durations {k['time']:.3f}{stride} (docs/robots.md)")
        d = self.defaults
        given = f" (the description sets {', '.join(d['given'])})" if d["given"] else ""
        r = d["footstep_range"]
        lines.append(f"defaults{given}: walk {_mm(d['walk_m'])} mm; training lengths {_mm(d['training_lengths_m'])} mm; "
                     f"footsteps length {_mm(r['length'], '..')} mm, width {_mm(r['width'], '..')} mm, turn "
                     + "..".join(f"{math.degrees(x):g}" for x in r["turn"]) + " deg; single support "
                     f"{d['ocp']['ss_duration']:g} s, ZMP margin {1000 * d['ocp']['zmp_margin']:g} mm; "
                     f"servo torque feedforward {'on' if d['feedforward'] else 'off'} in simulation")
        g, kp = d["stabilizer"], d["leg_servo_kp"].values()
        lines.append(f"simulation: leg servos kp {min(kp):.0f}..{max(kp):.0f} N m/rad; stabilizer ankle damping "
                     f"{g['ankle_damping']:g} N m s/rad, DCM gain {g['dcm_gain']:g}, attitude rate gains "
                     + "/".join(f"{x:g}" for x in g["attitude_rate_gains"]) + " s (roll/pitch)")
        kj = d["kajita"]
        lines.append(f"Kajita baseline: preview {kj['preview_time']:.3g} s, jerk weight {kj['weight_input']:.3g}, "
                     f"prelude {kj['prelude']:.3g} s, postlude {kj['postlude']:.3g} s, ZMP smoothing "
                     f"{1000 * kj['zmp_smoothing']:.3g} ms, pelvis drop searched over "
                     f"{_mm(kj['drop_search_range'], '..')} mm")
        if self.png:
            lines.append(f"wrote {self.png}")
        return "\n".join(lines)


@dataclass
class StageRecord(Result):
    """One stage of ``robot bootstrap``: its output, whether it ran or its output was kept, its wall time."""

    stage: str
    output: str
    status: str  # "run", or "kept": its output was there already, made from the stage before
    wall_time_s: float


@dataclass
class BootstrapReport(Result):
    """``robot bootstrap``: each stage's record, the walking report, and the dataset's wall
    time projected to clusters of N workers (:func:`cocomopl.bootstrap.dataset_projection`)."""

    robot: str
    folder: str
    stages: list[StageRecord]
    check: bool
    walk: WalkReport
    dataset_projection_s: dict[int, float] | None
    wall_time_s: float

    def to_table(self) -> str:
        lines = [f"robot {self.robot} bootstrapped in {self.folder}/ in {self.wall_time_s / 60:.1f} min"]
        lines += [f"  {s.stage:8s} {s.status:5s} {s.wall_time_s:8.1f} s  {s.output}" for s in self.stages]
        if self.dataset_projection_s:
            lines.append("the dataset on N workers (projected from this run): " + ", ".join(
                f"{n}: {seconds / 60:.1f} min" for n, seconds in self.dataset_projection_s.items()))
        lines += ["", self.walk.to_table()]
        return "\n".join(lines)

    @property
    def exit_code(self) -> int:
        return self.walk.exit_code


@dataclass
class PlotReport(Result):
    """``plot``: the PNGs written."""

    files: list[str]

    def to_table(self) -> str:
        return "\n".join(f"wrote {f}" for f in self.files)
