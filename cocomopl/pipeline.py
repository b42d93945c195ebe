"""The stages chained: step lengths -> generated walk (-> simulated walk -> report).

:func:`generate_walk` and :func:`simulate_walk` are the online pipeline;
:func:`walk_report` (``cocomopl walk``) and :func:`reproduce_report` (``cocomopl
reproduce``) chain them into report folders, so scripts get what the command line gives.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cocomopl.data import dataset_path as bundled_dataset_path
from cocomopl.data import model_path as bundled_model_path
from cocomopl.dataset.signals import signal_names
from cocomopl.dynamics import SIDES
from cocomopl.errors import Error
from cocomopl.gait import M_GEN, M_OPT, sequence_specs, wrap_angle
from cocomopl.kinematics import check_reach
from cocomopl.motion import Motion, StepSpec
from cocomopl.ocp.settings import DEFAULT_WARM_START
from cocomopl.planning.footsteps import Landing, landings_of, midpoint, walk_specs
from cocomopl.planning.goal import plan_through
from cocomopl.primitives.estimator import MovementPrimitives, PredictedStep
from cocomopl.primitives.model_file import load_model
from cocomopl.provenance import stamp
from cocomopl.robot import DEFAULT_ROBOT, Robot
from cocomopl.synthesis.step_chain import OutOfSupportWarning, generate_steps
from cocomopl.synthesis.world import place_steps, replace_stretch

if TYPE_CHECKING:  # the simulator is imported where a walk is simulated
    from cocomopl.sim.perturbations import Push
    from cocomopl.sim.servos import ServoSettings
    from cocomopl.sim.stabilizer import StabilizerGains

# m: the dynamics filter's RMS ZMP error above which a walk is flagged.  On 50 random walks
# (benchmarks/random_walks.py --seed 1), 25 of the 31 that fell were above it and 12 of the
# 19 that walked below.
FILTER_WARNING_M = 0.03
Goal = tuple[float, float, float]  # x, y (m), yaw (rad) of the feet's midpoint, world frame
# s: sample spacing of generated walks, the OC training data's knot spacing
PLAN_DT = 0.025
PLAN_DT_RANGE = (0.01, 0.05)  # s: see check_plan_dt; at 0.01 M_gen takes 76 s on 2 cores, at 0.005 500 s


@dataclass
class GeneratedWalk:
    """A walk from the primitives, with what it cost to make."""

    robot: Robot
    model: MovementPrimitives
    motion: Motion
    steps: list[PredictedStep]
    generation_s: float  # the primitives alone, after loading
    placement_s: float  # world placement, dynamics filter and inverse dynamics
    warnings: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class SimSettings:
    """How a walk is simulated: the simulation options of ``walk``, ``simulate`` and
    ``reproduce``, carried as one value from the command line to the rollout.

    Attributes
    ----------
    stabilizer : add the stabilizer's corrections to the commanded joint angles
    contact_time_constant : s, the sole-floor softness; None: the model's
    reference_cutoff_hz : Hz, the reference's low-pass; None: the rollout's default; 0: none
    feedforward : the servos' torque feedforward from the plan
    sim_model : a MuJoCo model file of the robot made elsewhere
        (:func:`~cocomopl.sim.mujoco_model.load_sim_model`); None: the project's own model
    servos : :class:`~cocomopl.sim.servos.ServoSettings` (gains, latency, encoder noise);
        None: the model's servos, ideal
    gains : the stabilizer's :class:`~cocomopl.sim.stabilizer.StabilizerGains`; None: those
        tuned for the motion's generator
    pushes : :class:`~cocomopl.sim.perturbations.Push` forces on the pelvis
    """

    stabilizer: bool = True
    contact_time_constant: float | None = None
    reference_cutoff_hz: float | None = None
    feedforward: bool = False
    sim_model: str | Path | None = None
    servos: ServoSettings | None = None
    gains: StabilizerGains | None = None
    pushes: tuple[Push, ...] = ()


def recovery_for(walk: GeneratedWalk, dt: float = PLAN_DT):
    """Recovery by stepping for ``walk`` (:class:`~cocomopl.sim.recovery.StepRecovery`): its
    own model generates it again, on its landings with one moved, placed every ``dt`` s; a
    moved footstep stays within the model's footstep range (a straight model's: forward only)."""
    from cocomopl.sim.recovery import StepRecovery

    def generate(landings: Sequence[Landing]) -> Motion:
        return _noting_footsteps(place_steps(walk.robot, generate_steps(walk.model, walk_specs(walk.robot, landings)), dt),
                                 landings)

    landings = landings_of(walk.robot, walk.motion.steps)
    return StepRecovery(walk.robot, landings, walk.motion, generate, walk.model.footstep_range())


def reaiming_for(walk: GeneratedWalk, dt: float = PLAN_DT):
    """Footstep re-aiming for ``walk`` (:class:`~cocomopl.sim.reaiming.Reaiming`): each step
    aimed from the measured stance sole at the walk's planned landing, within the model's
    footstep range; its own model generates the changed walk, and the stretch between stops
    that changed is placed again, every ``dt`` s (:func:`~cocomopl.synthesis.world.replace_stretch`)."""
    from cocomopl.sim.reaiming import Reaiming

    def generate(specs: Sequence[StepSpec], motion: Motion, step: int) -> Motion:
        changed = replace_stretch(walk.robot, motion, generate_steps(walk.model, specs), step, dt)
        return _noting_footsteps(changed, landings_of(walk.robot, specs))

    return Reaiming(walk.robot, walk.motion, generate, walk.model.footstep_range())


def _noting_footsteps(motion: Motion, landings: Sequence[Landing]) -> Motion:
    """``motion`` with the ``landings`` it was planned on in its metadata (the report's and
    the JSON's ``footsteps``)."""
    motion.meta["footsteps"] = [landing.as_dict() for landing in landings]
    return motion


def check_plan_dt(dt: float) -> float:
    """``dt`` (s) if it is a sample spacing for a generated walk within ``PLAN_DT_RANGE``, else :class:`Error`."""
    low, high = PLAN_DT_RANGE
    if not low <= dt <= high:
        raise Error(f"--dt {dt:g} s is outside {low:g} to {high:g} s (the dynamics filter's QP grows with the "
                    "number of samples; beyond the upper end the touchdowns are not resolved)")
    return dt


def plan_in_support(robot: Robot, model: MovementPrimitives, goals: list[Goal], strict: bool = False) -> list[StepSpec]:
    """The steps of a walk through ``goals`` (:func:`~cocomopl.planning.goal.plan_through`)
    within ``model``'s learned footstep range, every step within its training support where
    such a walk exists: the learned range is a box around footsteps that need not fill it.
    Where none exists, the walk in the range, whose steps are then warned about, or with
    ``strict`` the planner's error."""
    def supported(specs: list[StepSpec]) -> bool:
        return all(step.in_support for step in model.predict_many(specs))

    try:
        return plan_through(robot, goals, model.footstep_range(), supported)
    except Error:
        if strict:
            raise
    return plan_through(robot, goals, model.footstep_range())


def generate_walk(
    lengths: Sequence[float] | None = None,
    model_path: str | Path | None = None,
    dt: float | None = None,
    first_swing: str = "left",
    strict: bool = False,
    landings: Sequence[Landing] | None = None,
    goal: Goal | Sequence[Goal] | None = None,
) -> GeneratedWalk:
    """Generate and place a walk: start, ..., stop.

    The walk is one of: step ``lengths`` (m, straight ahead, ``first_swing`` first); the world
    ``landings`` of a footstep plan (:mod:`cocomopl.planning.footsteps`); or a ``goal`` pose
    (x, y in m, yaw in rad) of the feet's midpoint, planned within the model's learned
    footstep range (:func:`~cocomopl.planning.goal.plan_to_goal`), or a list of such poses,
    which the walk reaches in turn, stopping at each (:func:`~cocomopl.planning.goal.plan_through`).

    ``model_path`` defaults to the bundled model (for footsteps and goals, the bundled
    omnidirectional one) and ``dt`` (s) to ``PLAN_DT``.  A goal's walk is planned within the
    training support where it can be (:func:`plan_in_support`).  Steps outside the support
    are warned about (``warnings``), or refused with ``strict``.  So is a walk that the
    dynamics filter could not make consistent (its ZMP more than ``FILTER_WARNING_M`` RMS
    from the learned one): most such walks fall.
    """
    if sum(x is not None for x in (lengths, landings, goal)) != 1:
        raise Error("a walk is given by exactly one of step lengths, footsteps or a goal")
    if lengths is not None:
        specs = sequence_specs(lengths, first_swing)  # an impossible walk is refused before loading
    model_path = bundled_model_path(model_path, omni=lengths is None)
    model = load_model(model_path).prepare()
    robot = Robot(model.metadata_.get("robot", DEFAULT_ROBOT))
    if list(model.signal_names) != signal_names(robot):
        raise Error(f"{model_path}: its signals are not robot {robot.name}'s joints, ZMP and pelvis")
    if lengths is not None:
        check_reach(robot, lengths)
    elif landings is not None:
        specs = walk_specs(robot, landings)
    else:
        specs = plan_in_support(robot, model, goal_list(goal), strict)
    dt = PLAN_DT if dt is None else check_plan_dt(dt)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", OutOfSupportWarning)
        started = time.perf_counter()
        steps = generate_steps(model, specs, strict=strict)
        generation_s = time.perf_counter() - started
    started = time.perf_counter()
    motion = place_steps(robot, steps, dt)
    placement_s = time.perf_counter() - started
    motion.meta["model"] = Path(model_path).name
    if lengths is not None:
        motion.meta["lengths_mm"] = [1000 * x for x in lengths]
    else:
        _noting_footsteps(motion, landings_of(robot, specs))
    messages = [str(w.message) for w in caught]
    error = motion.meta["plan_zmp_error_m"]
    if error > FILTER_WARNING_M:
        messages.append(
            f"the dynamics filter left the walk's ZMP {100 * error:.1f} cm RMS from the learned one "
            f"(over {100 * FILTER_WARNING_M:.0f} cm): it is not dynamically consistent and will likely fall"
        )
    return GeneratedWalk(robot, model, motion, steps, generation_s, placement_s, messages)


def refine(motion: Motion, dataset_path: str | Path | None = None, progress: bool = False,
           warm_start_from: str = DEFAULT_WARM_START):
    """Refine a generated walk by the OCPs of the dataset it was learned from (by default the
    bundled one, the omnidirectional one for a walk that turns or side-steps;
    :func:`cocomopl.ocp.refine.refine_walk`), each warm-started as ``warm_start_from`` says
    (:func:`cocomopl.ocp.refine.guess_states`): from the dataset's solved steps around it,
    interpolated (``"interpolated"``, the default), from the nearest one (``"nearest"``), or
    from the generated step (``"generated"``).

    Returns the :class:`~cocomopl.ocp.refine.RefinedWalk` and its summary: per step the
    solver's ``iterations``, whether it ``converged`` and the ``guess`` it started from,
    ``iterations_median``, ``refine_s`` and ``raw_cost_ratio``, the torque cost ∫Στ²dt of the
    generated walk as placed over the refined walk's.
    """
    import statistics

    from cocomopl.motion_file import load_robot, read_motions
    from cocomopl.ocp.refine import check_refinable, refine_walk, torque_cost
    from cocomopl.ocp.settings import OCPSettings

    dataset_path = bundled_dataset_path(dataset_path, omni=not all(spec.straight for spec in motion.steps))
    dataset, attrs = read_motions(dataset_path, dataset=True)
    robot = load_robot(next(iter(dataset.values())).robot)
    check_refinable(motion, robot)
    gait_states = {m.steps[0].start_footstep.gait_key: np.concatenate([m.q[0], m.v[0]]) for m in dataset.values()
                   if m.steps[0].kind == "cyclic" and m.steps[0].swing_side == "left"}
    refined = refine_walk(robot, motion, OCPSettings.from_saved(attrs["settings"]), progress, gait_states,
                          warm_start_from, dataset)
    iterations = [row["iterations"] for row in refined.steps]
    summary = {
        "steps": [row["step"] for row in refined.steps],
        "warm_start": warm_start_from,
        "guess": [row["guess"] for row in refined.steps],
        "iterations": iterations,
        "converged": [row["converged"] for row in refined.steps],
        "fallback": [row["fallback"] for row in refined.steps],
        "cost": [row["cost"] for row in refined.steps],
        "iterations_median": statistics.median(iterations),
        "refine_s": refined.refine_s,
        "raw_cost_ratio": torque_cost(motion) / torque_cost(refined.motion),
        "dataset": Path(dataset_path).name,
    }
    return refined, summary


def walk_provenance(command: str | None, model_path: str | Path | None = None, omni: bool = False, **inputs) -> dict:
    """The provenance of a file made from a generated walk: who made it, when, and the
    model's (and any other input's) name and checksum; ``omni``: the model defaults to the
    bundled omnidirectional one."""
    return stamp(command, ("mujoco", "pin"), model=bundled_model_path(model_path, omni), **inputs)


def simulate_walk(
    robot: Robot,
    motion: Motion,
    settings: SimSettings = SimSettings(),
    video: Path | None = None,
    progress: bool = False,
    recovery=None,
    reaiming=None,
):
    """Simulate ``motion`` in MuJoCo (:func:`rollout_of`) and measure it.

    Returns the :class:`~cocomopl.sim.rollout.Rollout` and its metrics against the reference
    (the walk it ended up following, where ``recovery`` or ``reaiming`` replanned it).
    """
    from cocomopl.analysis.metrics import summary

    rollout = rollout_of(robot, motion, settings, video, progress, recovery, reaiming)
    replanner = recovery or reaiming
    return rollout, summary(robot, rollout.measured, motion if replanner is None else replanner.motion)


def simulation_record(measured: Motion) -> dict:
    """How a rollout was simulated, as its measured motion's metadata records it: the
    settings a report carries beside its figures."""
    keys = ("stabilizer", "stabilizer_gains", "feedforward", "sim_model", "servos", "contact_time_constant_s",
            "reference_cutoff_hz")
    return {key: measured.meta[key] for key in keys}


def rollout_of(
    robot: Robot,
    motion: Motion,
    settings: SimSettings = SimSettings(),
    video: Path | None = None,
    progress: bool = False,
    recovery=None,
    reaiming=None,
):
    """The :class:`~cocomopl.sim.rollout.Rollout` of ``motion`` in MuJoCo as ``settings`` say
    (:func:`~cocomopl.sim.rollout.simulate`); with ``video``, also rendered there (MP4);
    ``recovery``: recovery by stepping (:func:`recovery_for`); ``reaiming``: footstep
    re-aiming (:func:`reaiming_for`)."""
    from cocomopl.sim.mujoco_model import build_sim_model, load_sim_model
    from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ, simulate
    from cocomopl.sim.video import render_video

    if settings.sim_model is not None:
        sim = load_sim_model(robot, settings.sim_model, settings.contact_time_constant)
    else:
        sim = build_sim_model(robot, visuals=video is not None, contact_time_constant=settings.contact_time_constant)
    cutoff = REFERENCE_CUTOFF_HZ if settings.reference_cutoff_hz is None else settings.reference_cutoff_hz
    rollout = simulate(sim, motion, stabilizer=settings.stabilizer, progress=progress, reference_cutoff_hz=cutoff,
                       gains=settings.gains, feedforward=settings.feedforward, servos=settings.servos,
                       pushes=settings.pushes, recovery=recovery, reaiming=reaiming)
    if video is not None:
        render_video(sim, rollout.measured.t, rollout.qpos, video, progress=progress)
    return rollout


def walk_report(
    lengths: list[float] | None,
    out_dir: str | Path,
    model_path: str | Path | None = None,
    settings: SimSettings = SimSettings(),
    video: bool = True,
    progress: bool = False,
    dt: float | None = None,
    first_swing: str = "left",
    strict: bool = False,
    command: str | None = None,
    refine_steps: bool = False,
    dataset: str | Path | None = None,
    landings: Sequence[Landing] | None = None,
    goal: Goal | Sequence[Goal] | None = None,
    recover: bool = False,
    reaim: bool | None = None,
    warm_start_from: str = DEFAULT_WARM_START,
) -> dict:
    """The main job: generate a walk, simulate it, and write a report folder.

    The walk is given by step ``lengths``, footstep ``landings`` or a ``goal`` pose (or
    several), as in :func:`generate_walk`; with goals the report adds how far the simulated
    robot's feet ended from the last (``final_position_error_m``, ``final_yaw_error_deg``).

    With ``refine_steps`` the generated walk is refined by the OCPs of ``dataset`` (default:
    the bundled one; :func:`refine`, warm-started as ``warm_start_from`` says) and the
    refined walk is simulated; the summary is ``refine`` in the report.
    ``out_dir`` receives ``motions.h5`` (the generated and the measured motion),
    ``metrics.json``, comparison plots (ZMP, contact forces, knee torques, leg joints),
    ``walk.mp4`` (unless ``video`` is False) and ``walk.html``, an interactive 3-D view,
    written as a unit (:func:`~cocomopl.motion_file.report_folder`): a run that fails or is
    interrupted leaves the folder as it was.  ``dt``, ``first_swing`` and ``strict`` are
    :func:`generate_walk`'s; ``settings`` say how the walk is simulated (:class:`SimSettings`).
    With ``recover`` a push the stabilizer cannot absorb moves a landing and the walk is
    generated again (:func:`recovery_for`; the report's ``recoveries``).  With ``reaim`` each
    step is aimed from the measured stance sole at its planned landing (:func:`reaiming_for`;
    the report's ``reaimed``); left ``None`` it is on for a walk to a ``goal`` that neither
    refines nor recovers (a robot that walks to a goal aims its steps from where it stands)
    and off otherwise.
    Returns the metrics with the timings, the files written and their provenance.
    """
    from cocomopl.analysis.report_plots import plot_comparison
    from cocomopl.analysis.viewer import write_html_viewer
    from cocomopl.motion_file import report_folder, write_json, write_motions

    started = time.perf_counter()
    # missing inputs are refused before anything is written
    if recover and (refine_steps or not settings.stabilizer):
        raise Error("recovery by stepping needs the stabilizer, and replans with the primitives: "
                    "it cannot be combined with --no-stabilizer or --refine")
    if reaim is None:
        reaim = goal is not None and not refine_steps and not recover
    if reaim and (refine_steps or recover):
        raise Error("footstep re-aiming replans with the primitives: it cannot be combined with --refine or --recover")
    omni = lengths is None
    dataset = bundled_dataset_path(dataset, omni) if refine_steps else None
    provenance = walk_provenance(command, model_path, omni, dataset=dataset)
    with report_folder(out_dir, inputs=[bundled_model_path(model_path, omni)] + ([dataset] if dataset else [])) as work:
        walk = generate_walk(lengths, model_path, dt, first_swing, strict, landings, goal)
        planned, refined = {"generated": walk.motion}, None
        if refine_steps:
            refined_walk, refined = refine(walk.motion, dataset, progress, warm_start_from)
            planned["refined"] = refined_walk.motion
        recovery = recovery_for(walk, dt or PLAN_DT) if recover else None
        reaiming = reaiming_for(walk, dt or PLAN_DT) if reaim else None
        rollout, metrics = simulate_walk(walk.robot, planned["refined" if refine_steps else "generated"], settings,
                                         work / "walk.mp4" if video else None, progress, recovery, reaiming)
        if (recovery is not None and recovery.replanned) or (reaiming is not None and reaiming.reaimed):
            planned["replanned"] = (recovery or reaiming).motion
        motions = {**planned, "simulated": rollout.measured}
        files = [work / "motions.h5"]
        write_motions(files[0], motions, {"robot": walk.robot.name, "producer": "cocomopl walk", **provenance})
        files += plot_comparison(walk.robot, motions, work)
        title = f"cocomopl walk {walk_label(lengths, goal)}"
        files.append(write_html_viewer(walk.robot, rollout.measured, work / "walk.html", title=title))
        if video:
            files.append(work / "walk.mp4")
        payload = {
            **({"lengths_mm": [1000 * x for x in lengths]} if lengths is not None else {"footsteps": walk.motion.meta["footsteps"]}),
            **(goal_errors(walk.robot, rollout.measured, goal_list(goal)) if goal is not None else {}),
            "steps": [s.spec.name for s in walk.steps],
            **simulation_record(rollout.measured),
            "pushes": rollout.measured.meta["pushes"],
            **({"recoveries": rollout.measured.meta["recoveries"]} if recover else {}),
            "reaim": reaim,
            **({"reaimed": rollout.measured.meta["reaimed"]} if reaim else {}),
            **metrics,
            "generation_s": walk.generation_s,
            "placement_s": walk.placement_s,
            "dynamics_filter_zmp_error_m": walk.motion.meta["plan_zmp_error_m"],
            "warnings": walk.warnings,
            **({"refine": refined} if refined else {}),
            "files": _report_files(out_dir, files, "metrics.json"),
            "provenance": provenance,
        }
        payload["wall_time_s"] = time.perf_counter() - started
        write_json(work / "metrics.json", payload)
    return payload


def goal_list(goal: Goal | Sequence[Goal]) -> list[Goal]:
    """One goal pose (x, y, yaw) or a sequence of them, as a list of poses."""
    return [tuple(goal)] if np.ndim(goal) == 1 else [tuple(g) for g in goal]


def walk_label(lengths: Sequence[float] | None, goal: Goal | Sequence[Goal] | None) -> str:
    """How a walk was asked for, in a line: its lengths, its goals, or footsteps."""
    if lengths is not None:
        return ",".join(f"{1000 * x:g}" for x in lengths) + " mm"
    if goal is not None:
        return "to " + " then ".join(f"{g[0]:g} m, {g[1]:g} m, {math.degrees(g[2]):g} deg" for g in goal_list(goal))
    return "on footsteps"


def _pose(goal: Goal) -> dict:
    return {"x_m": goal[0], "y_m": goal[1], "yaw_deg": math.degrees(goal[2])}


def goal_errors(robot: Robot, motion: Motion, goals: list[Goal]) -> dict:
    """The goals, and the distance (m) and heading error (deg) of the feet's midpoint at the
    end of ``motion`` from the last: ``goal``, and ``waypoints`` where the walk stopped before it."""
    soles = {}
    for side in SIDES:
        M = robot.frame_placement(motion.q[-1], robot.foot_frames[side])
        soles[side] = np.array([M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0])])
    end, goal = midpoint(soles), goals[-1]
    return {
        "goal": _pose(goal),
        **({"waypoints": [_pose(g) for g in goals[:-1]]} if len(goals) > 1 else {}),
        "final_position_error_m": float(np.hypot(end[0] - goal[0], end[1] - goal[1])),
        "final_yaw_error_deg": abs(math.degrees(wrap_angle(end[2] - goal[2]))),
    }


def _refuse_failing_dataset(robot, path, dataset: dict, attrs: dict) -> None:
    """An :class:`Error` if the dataset fails its own check: a Table I from it would mislead."""
    from cocomopl.dataset.check import check_dataset

    settings = attrs["settings"]
    signals = {name: s["values"] for name, s in attrs["signals"].items()}
    report = check_dataset(robot, dataset, float(settings["friction"]), float(settings["dt"]), signals)
    if not report["ok"]:
        key = report["failures"][0]
        raise Error(f"{path}: fails 'cocomopl dataset check' ({key} {report['worst'][key]:.4g} in "
                    f"{report['worst_in'][key]}); reproduce needs a dataset that passes")


def reproduce_report(
    out_dir: str | Path,
    model_path: str | Path | None = None,
    dataset_path: str | Path | None = None,
    progress: bool = False,
    settings: SimSettings = SimSettings(),
    command: str | None = None,
    kajita_variant: str = "two-stage",
) -> dict:
    """The paper's experiment (sec. V): M_gen from the primitives, M_gen refined by the OCPs
    of the dataset at ``dataset_path`` (:func:`refine`), M_opt from chained OCPs (that
    dataset's steps, and the transitions it lacks solved here) and the Kajita baseline (``kajita_variant``, :func:`kajita_for`) on M_gen's footsteps and
    timing, all four simulated with the stabilizer tuned for their generator and measured
    over the same walking window (:mod:`cocomopl.analysis.comparison`); the analogue of
    Table I (mean torques) and of Figs. 6, 8 and 9.

    ``out_dir`` receives ``motions.h5`` (planned and simulated motions), ``table1.json`` with
    every metric, and the comparison PNGs, written as a unit as :func:`walk_report`'s; the
    model and dataset default to the bundled ones.  ``settings`` say how the walks are
    simulated (:class:`SimSettings`), always with the stabilizer and each walk's tuned gains.
    """
    from cocomopl.analysis.report_plots import plot_comparison
    from cocomopl.motion_file import report_folder, write_json, write_motions

    started = time.perf_counter()
    dataset_path = bundled_dataset_path(dataset_path)
    provenance = walk_provenance(command, model_path, dataset=dataset_path)
    with report_folder(out_dir, inputs=[bundled_model_path(model_path), dataset_path]) as work:
        robot, planned, simulated, payload = _paper_experiment(model_path, dataset_path, progress, settings, kajita_variant)
        payload["provenance"] = provenance
        motions = {f"{name}_{kind}": m for kind, by_name in (("planned", planned), ("simulated", simulated))
                   for name, m in by_name.items()}
        files = [work / "motions.h5"]
        write_motions(files[0], motions, {"robot": robot.name, "producer": "cocomopl reproduce", **provenance})
        compared = {"MP planned": planned["MP"], **{f"{name} simulated": m for name, m in simulated.items()}}
        files += plot_comparison(robot, compared, work)
        payload["files"] = _report_files(out_dir, files, "table1.json")
        payload["wall_time_s"] = time.perf_counter() - started
        write_json(work / "table1.json", payload)
    return payload


def kajita_for(walk: GeneratedWalk, variant: str = "two-stage") -> Motion:
    """The Kajita baseline on a generated walk's footsteps and phase timing: the
    ``variant`` of :data:`~cocomopl.baselines.kajita.VARIANTS`, the two-stage one with the
    generated walk's mean swing height."""
    import dataclasses

    import numpy as np

    from cocomopl.analysis.metrics import swing_heights
    from cocomopl.baselines.kajita import VARIANTS, kajita_walk

    if variant not in VARIANTS:
        raise Error(f"unknown Kajita variant {variant!r}: choose from {', '.join(VARIANTS)}")
    settings = VARIANTS[variant]
    if variant == "two-stage":
        settings = dataclasses.replace(settings, swing_height=float(np.mean(swing_heights(walk.robot, walk.motion))))
    durations = [np.diff(s.phase_edges) for s in walk.steps]
    return kajita_walk(walk.robot, [s.spec for s in walk.steps], durations, dt=PLAN_DT, settings=settings)


def simulate_compared(robot: Robot, planned: dict[str, Motion], progress: bool = False,
                      settings: SimSettings = SimSettings(), gains: dict | None = None,
                      window: tuple[float, float] | None = None) -> tuple[dict, dict, tuple[float, float]]:
    """Simulate each of the ``planned`` walks with the stabilizer, otherwise as ``settings``
    say, and measure them by the comparison protocol (:mod:`cocomopl.analysis.comparison`).

    ``gains`` maps a walk's name to its :class:`~cocomopl.sim.stabilizer.StabilizerGains`;
    by default each walk gets those tuned for its generator.  ``window`` (s) defaults to
    the walks' common window.
    Returns the simulated motions (on the plans' clock), the figures per walk and the window.
    """
    import dataclasses

    from cocomopl.analysis.comparison import common_window, window_figures

    window = window or common_window(planned)
    simulated = {}
    for name, motion in planned.items():
        walk_settings = dataclasses.replace(settings, stabilizer=True, gains=(gains or {}).get(name))
        # measured below, over the window only
        rollout = rollout_of(robot, motion, walk_settings, progress=progress)
        # the simulator's clock starts at the plan's first sample
        simulated[name] = dataclasses.replace(rollout.measured, t=rollout.measured.t + motion.t[0])
    return simulated, window_figures(robot, planned, simulated, window), window


def _paper_experiment(model_path, dataset_path: Path, progress: bool, settings: SimSettings,
                      kajita_variant: str = "two-stage") -> tuple[Robot, dict, dict, dict]:
    """:func:`reproduce_report`'s work: the robot, the planned and the simulated motions (by method: "MP", "refined"
    (M_gen refined by optimal control), "OC", "Kajita") and the summary without provenance, files and wall time."""
    from cocomopl.analysis.comparison import per_measure
    from cocomopl.motion_file import load_robot, read_motions
    from cocomopl.ocp.chained_steps import solve_sequence

    dataset, attrs = read_motions(dataset_path, dataset=True, signals=True)
    _refuse_failing_dataset(load_robot(next(iter(dataset.values())).robot), dataset_path, dataset, attrs)
    walk = generate_walk(list(M_GEN), model_path)
    robot = walk.robot
    if robot.name != next(iter(dataset.values())).robot:
        raise Error(f"the model is for robot {robot.name!r} and the dataset {dataset_path} for another")
    solve_started = time.perf_counter()
    m_opt = solve_sequence(robot, sequence_specs(list(M_OPT)), dataset, attrs["settings"], progress=progress)
    solve_s = time.perf_counter() - solve_started
    refined, refine_summary = refine(walk.motion, dataset_path, progress)
    kajita = kajita_for(walk, kajita_variant)
    planned = {"MP": walk.motion, "refined": refined.motion, "OC": m_opt, "Kajita": kajita}
    simulated, figures, window = simulate_compared(robot, planned, progress, settings)
    table = {}
    for name, label in (("OC", "OC planned (joint torques)"), ("MP", "MP planned (inverse dynamics)"),
                        ("refined", "refined planned (joint torques)"), ("Kajita", "Kajita planned (inverse dynamics)")):
        table[label] = figures[name]["planned"]["mean_torque"]
        table[f"{name} simulated"] = figures[name]["mean_torque"]
    payload = {
        "window_s": list(window),
        "table1_mean_torque": table,
        "mp_vs_oc_simulated_mean_torque_difference": table["MP simulated"] / table["OC simulated"] - 1,
        "mp_vs_oc": per_measure(figures, "MP", "OC"),
        "mp_vs_kajita": per_measure(figures, "MP", "Kajita"),
        "refined_vs_oc": per_measure(figures, "refined", "OC"),
        "refine": refine_summary,
        "metrics": figures,
        "sim_model": simulated["MP"].meta["sim_model"],
        "servos": simulated["MP"].meta["servos"],
        "contact_time_constant_s": simulated["MP"].meta["contact_time_constant_s"],
        "reference_cutoff_hz": simulated["MP"].meta["reference_cutoff_hz"],
        "kajita": {key: kajita.meta[key] for key in (
            "pelvis_drop", "pelvis_drop_searched", "com_height_m", "swing_height", "zmp_smoothing", "second_stage",
            "first_stage_zmp_reference_rms_m", "zmp_reference_rms_m", "walking_span_s")} | {"variant": kajita_variant},
        "m_opt_steps": len(m_opt.steps),
        "m_opt_solved_now": m_opt.meta["solved_now"],
        "m_opt_solve_s": solve_s,
        "m_opt_solver": m_opt.meta.get("solver"),
        "generation_s": walk.generation_s,
    }
    return robot, planned, simulated, payload


def _report_files(out_dir: str | Path, written: list[Path], summary: str) -> list[str]:
    """The paths a report's files will have once its folder is in place: those ``written`` in the temporary folder,
    and the JSON ``summary`` that lists them (written last)."""
    return [str(Path(out_dir) / name) for name in [*(f.name for f in written), summary]]
