"""The stages chained: a walk request -> generated walk (-> simulated walk -> report).

:func:`generate_walk` (a :class:`~cocomopl.requests.WalkRequest` in, a :class:`GeneratedWalk`
out) and :func:`simulate_walk` are the online pipeline; :func:`walk_report` (``cocomopl
walk``) and :func:`reproduce_report` (``cocomopl reproduce``) chain them into report folders
and return the typed results of :mod:`cocomopl.results`, so scripts get what the command
line gives.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cocomopl.data import dataset_path as bundled_dataset_path
from cocomopl.data import model_path as bundled_model_path
from cocomopl.dataset.signals import signal_names
from cocomopl.dynamics import SIDES
from cocomopl.errors import Error
from cocomopl.gait import m_gen, m_opt, sequence_specs, wrap_angle
from cocomopl.kinematics import check_reach
from cocomopl.motion import Motion, PlanRecord, StepSpec
from cocomopl.planning.footsteps import Landing, landings_of, midpoint, walk_specs
from cocomopl.planning.goal import plan_through
from cocomopl.primitives.estimator import MovementPrimitives, PredictedStep
from cocomopl.primitives.model_file import load_model, model_robot
from cocomopl.provenance import stamp
from cocomopl.requests import PLAN_DT, Commands, Footsteps, Goal, Goals, Refinement, StraightSteps, WalkRequest
from cocomopl.results import GoalErrors, RefineSummary, ReproduceReport, SimulationRecord, WalkReport
from cocomopl.robot import Robot
from cocomopl.synthesis.dynamics_filter import plan_zmp_error
from cocomopl.synthesis.step_chain import OutOfSupportWarning, generate_steps, outside_support, support_radius
from cocomopl.synthesis.world import place_steps, replace_stretch

if TYPE_CHECKING:  # the simulator is imported where a walk is simulated
    from cocomopl.analysis.metrics import WalkMetrics
    from cocomopl.sim.hooks import Hook
    from cocomopl.sim.perturbations import Push
    from cocomopl.sim.rollout import Rollout
    from cocomopl.sim.servos import ServoSettings
    from cocomopl.sim.stabilizer import StabilizerGains

# m: the dynamics filter's RMS ZMP error above which a walk is flagged.  On 50 random walks
# (benchmarks/random_walks.py --seed 1), 25 of the 31 that fell were above it and 12 of the
# 19 that walked below.
FILTER_WARNING_M = 0.03


@dataclass
class GeneratedWalk:
    """A walk from the primitives, with what it cost to make, and its refinement by optimal
    control where the request asked for one."""

    robot: Robot
    model: MovementPrimitives
    motion: Motion
    steps: list[PredictedStep]
    path: StraightSteps | Footsteps | Goals  # the request's, the default lengths filled in
    generation_s: float  # the primitives alone, after loading
    placement_s: float  # world placement, dynamics filter and inverse dynamics
    warnings: list[str] = field(default_factory=list)
    refined: Motion | None = None  # the walk refined by optimal control
    refinement: RefineSummary | None = None

    @property
    def planned(self) -> Motion:
        """The walk to follow: the refined one where there is one, else the generated one."""
        return self.motion if self.refined is None else self.refined


@dataclass(frozen=True)
class SimSettings:
    """How a walk is simulated: the simulation options of ``walk``, ``simulate`` and
    ``reproduce``, carried as one value from the command line to the rollout.

    Attributes
    ----------
    stabilizer : add the stabilizer's corrections to the commanded joint angles
    contact_time_constant : s, the sole-floor softness; None: the model's
    reference_cutoff_hz : Hz, the reference's low-pass; None: the rollout's default; 0: none
    feedforward : the servos' torque feedforward from the plan; None: the robot's default
        (:func:`servo_feedforward`)
    sim_model : a MuJoCo model file of the robot made elsewhere
        (:func:`~cocomopl.sim.mujoco_model.load_sim_model`); None: the project's own model
    servos : :class:`~cocomopl.sim.servos.ServoSettings` (gains, latency, encoder noise);
        None: the model's servos, ideal
    gains : the stabilizer's :class:`~cocomopl.sim.stabilizer.StabilizerGains`; None: those
        tuned for the motion's generator
    pushes : :class:`~cocomopl.sim.perturbations.Push` forces on the pelvis
    hooks : further controllers or perturbations (:class:`~cocomopl.sim.hooks.Hook`), called
        after the pushes in this order
    """

    stabilizer: bool = True
    contact_time_constant: float | None = None
    reference_cutoff_hz: float | None = None
    feedforward: bool | None = None
    sim_model: str | Path | None = None
    servos: ServoSettings | None = None
    gains: StabilizerGains | None = None
    pushes: tuple[Push, ...] = ()
    hooks: tuple[Hook, ...] = ()


def servo_feedforward(settings: SimSettings, robot: Robot) -> bool:
    """Whether the servos get the plan's torque feedforward: as ``settings`` say, else as the
    robot's description does (``defaults.simulation.feedforward``, docs/robots.md), else on
    for a robot whose leg servos are softer than full torque at 30 mrad
    (:func:`~cocomopl.sim.mujoco_model.leg_servos_capped`; G1, Alexander): such servos sag
    under the plan's loads further than TALOS's, and the feedforward supplies the loads."""
    from cocomopl.sim.mujoco_model import leg_servos_capped

    if settings.feedforward is not None:
        return settings.feedforward
    given = (robot.override("simulation") or {}).get("feedforward")
    return leg_servos_capped(robot) if given is None else bool(given)


def recovery_for(walk: GeneratedWalk, dt: float = PLAN_DT):
    """Recovery by stepping for ``walk`` (:class:`~cocomopl.sim.recovery.StepRecovery`): its
    own model generates it again, on its landings with one moved, placed every ``dt`` s; a
    moved footstep stays within the model's footstep range (a straight model's: forward only)."""
    from cocomopl.sim.recovery import StepRecovery

    def generate(landings: Sequence[Landing]) -> Motion:
        return _noting_footsteps(place_steps(walk.robot, generate_steps(walk.model, walk_specs(walk.robot, landings)), dt=dt),
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
        changed = replace_stretch(walk.robot, motion, generate_steps(walk.model, specs), step=step, dt=dt)
        return _noting_footsteps(changed, landings_of(walk.robot, specs))

    return Reaiming(walk.robot, walk.motion, generate, walk.model.footstep_range())


def _noting_footsteps(motion: Motion, landings: Sequence[Landing]) -> Motion:
    """``motion`` with the ``landings`` it was planned on in its plan record (the report's and
    the JSON's ``footsteps``)."""
    motion.plan = replace(motion.plan, footsteps=[landing.as_dict() for landing in landings])
    return motion


def plan_in_support(robot: Robot, model: MovementPrimitives, goals: list[Goal]) -> list[StepSpec]:
    """The steps of a walk through ``goals`` (:func:`~cocomopl.planning.goal.plan_through`)
    within ``model``'s learned footstep range and every step inside its training support:
    the learned range is a box around footsteps that need not fill it, so a plan with a step
    outside the support gives way to the next (more steps, each smaller).

    Raises
    ------
    Error
        If no plan within the range reaches a goal (the planner's error), or none within the
        support: naming the goal and, of the plans refused for it, the step that lies least
        far outside (:func:`~cocomopl.synthesis.step_chain.outside_support`).
    """
    reached = []  # the plans accepted, one per goal reached
    nearest = None  # (excess over the support radius, step number, step): the refused plan least far outside

    def supported(specs: list[StepSpec]) -> bool:
        nonlocal nearest
        first = sum(len(plan) for plan in reached) + 1
        outside = [(step.distance - support_radius(model, spec), number, step)
                   for number, (spec, step) in enumerate(zip(specs, model.predict_many(specs)), start=first)
                   if not step.in_support]
        if not outside:
            reached.append(specs)
            nearest = None
            return True
        farthest = max(outside, key=lambda item: item[0])
        if nearest is None or farthest[0] < nearest[0]:
            nearest = farthest
        return False

    try:
        return plan_through(robot, goals, limits=model.footstep_range(), accept=supported)
    except Error:
        if nearest is None:  # no plan within the range either
            raise
    x, y, yaw = goals[len(reached)]
    which = f"goal {len(reached) + 1} of {len(goals)}" if len(goals) > 1 else "the goal"
    _, number, step = nearest
    raise Error(f"no walk within the model's support reaches {which} ({x:g} m, {y:g} m, {math.degrees(yaw):g} deg): "
                f"the nearest plan in its footstep range has step {number} ({step.spec.name}) "
                f"{outside_support(model, step)}")


def generate_walk(request: WalkRequest, *, progress: bool = False) -> GeneratedWalk:
    """Generate and place the walk of ``request``: start, ..., stop.

    The walk follows the request's path: straight step lengths (first swing as given); the
    world landings of a footstep plan (:mod:`cocomopl.planning.footsteps`); or goal poses
    (x, y in m, yaw in rad) of the feet's midpoint, reached in turn, stopping at each, on
    footsteps planned within the model's learned footstep range and training support
    (:func:`plan_in_support`; a goal no such plan reaches is refused).  Every step outside
    the support is warned about (``warnings``, one line naming it:
    :func:`~cocomopl.synthesis.step_chain.generate_steps`), or with ``strict`` the walk is
    refused naming the first.  A walk that the dynamics filter could not make consistent
    (its ZMP more than ``FILTER_WARNING_M`` RMS from the learned one) is warned about too:
    most such walks fall.  With the request's refinement the walk is then refined by
    optimal control (:func:`refine`; ``progress`` shows its bar): ``refined`` and
    ``refinement``.
    """
    path = request.path
    if isinstance(path, StraightSteps) and path.lengths:
        specs = sequence_specs(path.lengths, path.first_swing)  # an impossible walk is refused before loading
    model_path = request.model_file()
    model = load_model(model_path).prepare()
    robot = model_robot(model)
    if list(model.signal_names) != signal_names(robot):
        raise Error(f"{model_path}: its signals are not robot {robot.name}'s joints, ZMP and pelvis")
    if request.robot is not None and request.robot != robot.name:
        raise Error(f"{model_path} is a model of robot {robot.name!r}, not {request.robot!r}")
    if isinstance(path, Commands):
        return _streamed_walk(request, model, robot, model_path)
    if isinstance(path, StraightSteps):
        path = replace(path, lengths=path.lengths or m_gen(robot))
        specs = sequence_specs(path.lengths, path.first_swing)
        check_reach(robot, path.lengths)
    elif isinstance(path, Footsteps):
        specs = walk_specs(robot, path.landings)
    else:
        specs = plan_in_support(robot, model, list(path.poses))
    dt = PLAN_DT if request.dt is None else request.dt
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", OutOfSupportWarning)
        started = time.perf_counter()
        steps = generate_steps(model, specs, strict=request.strict)
        generation_s = time.perf_counter() - started
    started = time.perf_counter()
    motion = place_steps(robot, steps, dt=dt)
    placement_s = time.perf_counter() - started
    motion.plan = replace(motion.plan, model=Path(model_path).name)
    if isinstance(path, StraightSteps):
        motion.plan = replace(motion.plan, lengths_mm=[1000 * x for x in path.lengths])
    else:
        _noting_footsteps(motion, landings_of(robot, specs))
    messages = [str(w.message) for w in caught]
    error = motion.plan.plan_zmp_error_m
    if error > FILTER_WARNING_M:
        messages.append(
            f"the dynamics filter left the walk's ZMP {100 * error:.1f} cm RMS from the learned one "
            f"(over {100 * FILTER_WARNING_M:.0f} cm): it is not dynamically consistent and will likely fall"
        )
    walk = GeneratedWalk(robot, model, motion, steps, path, generation_s, placement_s, messages)
    if request.refinement is not None:
        refinement = replace(request.refinement, dataset=request.dataset_file())
        refined, walk.refinement = refine(motion, refinement, progress=progress)
        walk.refined = refined.motion
    return walk


def _streamed_walk(request: WalkRequest, model: MovementPrimitives, robot: Robot, model_path: Path) -> GeneratedWalk:
    """The walk of a request's velocity commands, streamed by the online generator
    (:class:`~cocomopl.online.WalkingGenerator`, knots ``request.dt`` apart at most): its
    filtered knots as the generated motion; commands beyond what the model's footsteps allow
    are refused naming the first."""
    from cocomopl.online import VelocityCommand, WalkingGenerator, command_range
    from cocomopl.online.commands import check_commands

    generator = WalkingGenerator(model, robot, plan_dt=PLAN_DT if request.dt is None else request.dt, keep_knots=True)
    commands = [(t, VelocityCommand(*c)) for t, *c in request.path.commands]
    check_commands(commands, command_range(period=generator.period_, limits=generator.limits_))
    started = time.perf_counter()
    generator.follow(commands)
    streamed_s = time.perf_counter() - started
    motion = generator.knot_motion()
    steps = generator.walked_steps()
    error = plan_zmp_error(robot, motion)
    motion.plan = PlanRecord(dynamics_filter_zmp_error_m=[error], dynamics_filter_kept_error_m=error, upper_body_limits={},
                             plan_zmp_error_m=error, model=Path(model_path).name)
    _noting_footsteps(motion, landings_of(robot, motion.steps))
    messages = [f"step {k} ({s.spec.name}): {outside_support(model, s)}"
                for k, s in enumerate(steps, start=1) if not s.in_support]
    return GeneratedWalk(robot, model, motion, steps, request.path, generator.generation_s_,
                         streamed_s - generator.generation_s_, messages)


def refine(motion: Motion, refinement: Refinement | None = None, *, progress: bool = False):
    """Refine a generated walk by the OCPs of the refinement's dataset, the one it was learned
    from (by default the bundled one, the omnidirectional one for a walk that turns or
    side-steps; :func:`cocomopl.ocp.refine.refine_walk`), each warm-started as the
    refinement's ``warm_start`` says
    (:func:`cocomopl.ocp.refine.guess_states`): from the dataset's solved steps around it,
    interpolated (``"interpolated"``, the default), from the nearest one (``"nearest"``), or
    from the generated step (``"generated"``).

    Returns the :class:`~cocomopl.ocp.refine.RefinedWalk` and its
    :class:`~cocomopl.results.RefineSummary`, whose ``raw_cost_ratio`` is the torque cost
    ∫Στ²dt of the generated walk as placed over the refined walk's.
    """
    import statistics

    from cocomopl.motion_file import load_robot, read_motions
    from cocomopl.ocp.refine import check_refinable, refine_walk, torque_cost
    from cocomopl.ocp.settings import OCPSettings

    refinement = refinement or Refinement()
    dataset_path = bundled_dataset_path(refinement.dataset, omni=not all(spec.straight for spec in motion.steps),
                                        robot=motion.robot)
    dataset, attrs = read_motions(dataset_path, dataset=True)
    robot = load_robot(next(iter(dataset.values())).robot)
    check_refinable(motion, robot)
    gait_states = {m.steps[0].start_footstep.gait_key: np.concatenate([m.q[0], m.v[0]]) for m in dataset.values()
                   if m.steps[0].kind == "cyclic" and m.steps[0].swing_side == "left"}
    refined = refine_walk(robot, motion, OCPSettings.from_saved(attrs["settings"]), progress=progress, gait_states=gait_states,
                          warm_start_from=refinement.warm_start, solved=dataset)
    iterations = [row["iterations"] for row in refined.steps]
    summary = RefineSummary(
        steps=[row["step"] for row in refined.steps],
        warm_start=refinement.warm_start,
        guess=[row["guess"] for row in refined.steps],
        iterations=iterations,
        converged=[row["converged"] for row in refined.steps],
        fallback=[row["fallback"] for row in refined.steps],
        cost=[row["cost"] for row in refined.steps],
        iterations_median=statistics.median(iterations),
        refine_s=refined.refine_s,
        raw_cost_ratio=torque_cost(motion) / torque_cost(refined.motion),
        dataset=Path(dataset_path).name,
    )
    return refined, summary


def walk_provenance(command: str | None, model_path: str | Path | None = None, **inputs) -> dict:
    """The provenance of a file made from a generated walk: who made it, when, and the
    model's (default: the bundled one) and any other input's name and checksum."""
    return stamp(command, ("mujoco", "pin"), model=bundled_model_path(model_path), **inputs)


def robot_provenance(robot: Robot) -> dict:
    """The robot a report or file was made for: its name and fingerprint
    (:attr:`~cocomopl.robot.Robot.fingerprint`), which readers check."""
    return {"robot": robot.name, "robot_model": robot.fingerprint}


def simulate_walk(
    robot: Robot,
    motion: Motion,
    settings: SimSettings = SimSettings(),
    *,
    video: Path | None = None,
    progress: bool = False,
    replanner=None,
    goals: Sequence[Goal] = (),
) -> tuple[Rollout, WalkMetrics]:
    """Simulate ``motion`` in MuJoCo (:func:`rollout_of`, which draws the ``goals`` in its
    video) and measure it.

    Returns the :class:`~cocomopl.sim.rollout.Rollout` and its
    :class:`~cocomopl.analysis.metrics.WalkMetrics` against the reference (the walk it ended
    up following, where the ``replanner`` replanned it).
    """
    from cocomopl.analysis.metrics import summary

    rollout = rollout_of(robot, motion, settings, video=video, progress=progress, replanner=replanner, goals=goals)
    return rollout, summary(robot, rollout.measured, motion if replanner is None else replanner.motion)


def simulation_record(measured: Motion) -> SimulationRecord:
    """How a rollout was simulated, as its measured motion's metadata records it: the
    settings a report carries beside its figures."""
    return SimulationRecord(**{f: getattr(measured.simulation, f) for f in SimulationRecord.__dataclass_fields__})


def rollout_of(
    robot: Robot,
    motion: Motion,
    settings: SimSettings = SimSettings(),
    *,
    video: Path | None = None,
    progress: bool = False,
    replanner=None,
    goals: Sequence[Goal] = (),
):
    """The :class:`~cocomopl.sim.rollout.Rollout` of ``motion`` in MuJoCo as ``settings`` say
    (:func:`~cocomopl.sim.rollout.simulate`); with ``video``, also rendered there (MP4), with
    the motion's planned footsteps and the ``goals`` (x, y, yaw) drawn on the floor;
    ``replanner``: recovery by stepping (:func:`recovery_for`) or footstep re-aiming
    (:func:`reaiming_for`), a :class:`~cocomopl.sim.hooks.Replanner`."""
    from cocomopl.analysis.footprint import planned_landings
    from cocomopl.sim.mujoco_model import build_sim_model, load_sim_model
    from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ, simulate
    from cocomopl.sim.video import render_video

    if settings.sim_model is not None:
        sim = load_sim_model(robot, settings.sim_model, settings.contact_time_constant)
    else:
        sim = build_sim_model(robot, visuals=video is not None, contact_time_constant=settings.contact_time_constant)
    cutoff = REFERENCE_CUTOFF_HZ if settings.reference_cutoff_hz is None else settings.reference_cutoff_hz
    rollout = simulate(sim, motion, stabilizer=settings.stabilizer, progress=progress, reference_cutoff_hz=cutoff,
                       gains=settings.gains, feedforward=servo_feedforward(settings, robot), servos=settings.servos,
                       pushes=settings.pushes, hooks=settings.hooks, replanner=replanner)
    if video is not None:
        render_video(sim, rollout.measured.t, rollout.qpos, path=video, progress=progress,
                     footsteps=planned_landings(robot, motion), goals=goals)
    return rollout


def walk_report(
    request: WalkRequest,
    out_dir: str | Path,
    *,
    settings: SimSettings = SimSettings(),
    video: bool = True,
    progress: bool = False,
    command: str | None = None,
) -> WalkReport:
    """The main job: generate the walk of ``request``, simulate it, and write a report folder.

    The walk is generated (and refined, if the request asks so) by :func:`generate_walk`; the
    refined walk is the one simulated, and the refinement's summary is ``refine`` in the
    report.  For a walk to goals the report adds how far the simulated robot's feet ended
    from the last (``final_position_error_m``, ``final_yaw_error_deg``).  The request's
    replanner replans the walk as it runs: "recover", recovery by stepping, moves a landing
    where a push the stabilizer cannot absorb needs it and generates the walk again
    (:func:`recovery_for`; the report's ``recoveries``); "reaim", footstep re-aiming, aims
    each step from the measured stance sole at its planned landing (:func:`reaiming_for`;
    the report's ``reaimed``).  ``settings`` say how the walk is simulated
    (:class:`SimSettings`).

    ``out_dir`` receives ``motions.h5`` (the generated and the measured motion),
    ``metrics.json`` (the report's JSON), comparison plots (ZMP, contact forces, knee
    torques, leg joints), ``footsteps.png`` (the landings, soles and goals from above),
    ``walk.mp4`` (unless ``video`` is False) and ``walk.html``, an interactive 3-D view,
    written as a unit (:func:`~cocomopl.motion_file.report_folder`): a run that fails or is
    interrupted leaves the folder as it was.
    """
    from cocomopl.analysis.report_plots import plot_comparison
    from cocomopl.analysis.viewer import write_html_viewer
    from cocomopl.motion_file import report_folder, write_json, write_motions

    started = time.perf_counter()
    # missing inputs are refused before anything is written
    if request.replanner == "recover" and not settings.stabilizer:
        raise Error("recovery by stepping needs the stabilizer: it cannot be combined with --no-stabilizer")
    provenance = walk_provenance(command, request.model_file(), dataset=request.dataset_file())
    with report_folder(out_dir, inputs=request.inputs()) as work:
        walk = generate_walk(request, progress=progress)
        planned = {"generated": walk.motion} | ({"refined": walk.refined} if walk.refined is not None else {})
        dt = request.dt or PLAN_DT
        replanning = {"recover": recovery_for, "reaim": reaiming_for}.get(request.replanner)
        replanner = replanning(walk, dt) if replanning else None
        goals = request.path.poses if isinstance(request.path, Goals) else ()
        rollout, metrics = simulate_walk(walk.robot, walk.planned, settings, video=work / "walk.mp4" if video else None,
                                         progress=progress, replanner=replanner, goals=goals)
        if replanner is not None and any(replanner.metadata().values()):
            planned["replanned"] = replanner.motion
        motions = {**planned, "simulated": rollout.measured}
        files = [work / "motions.h5"]
        provenance |= robot_provenance(walk.robot)
        write_motions(files[0], motions, {"producer": "cocomopl walk", **provenance})
        files += plot_comparison(walk.robot, motions, work, top_view=True, goals=goals)
        title = f"cocomopl walk {walk.path.label()}"
        files.append(write_html_viewer(walk.robot, rollout.measured, work / "walk.html", title=title))
        if video:
            files.append(work / "walk.mp4")
        straight = isinstance(request.path, StraightSteps)
        simulated = rollout.measured.simulation
        report = WalkReport(
            label=walk.path.label(),
            folder=str(Path(out_dir)),
            lengths_mm=walk.motion.plan.lengths_mm if straight else None,
            footsteps=None if straight else walk.motion.plan.footsteps,
            goal=goal_errors(walk.robot, rollout.measured, request.path.poses) if isinstance(request.path, Goals) else None,
            steps=[s.spec.name for s in walk.steps],
            simulation=simulation_record(rollout.measured),
            pushes=simulated.pushes,
            recoveries=simulated.recoveries if request.replanner == "recover" else None,
            reaim=request.replanner == "reaim",
            reaimed=simulated.reaimed if request.replanner == "reaim" else None,
            metrics=metrics,
            generation_s=walk.generation_s,
            placement_s=walk.placement_s,
            dynamics_filter_zmp_error_m=walk.motion.plan.plan_zmp_error_m,
            warnings=walk.warnings,
            refine=walk.refinement,
            files=_report_files(out_dir, files, "metrics.json"),
            provenance=provenance,
        )
        report.wall_time_s = time.perf_counter() - started
        write_json(work / "metrics.json", report.to_json())
    return report


def _pose(goal: Goal) -> dict:
    return {"x_m": goal[0], "y_m": goal[1], "yaw_deg": math.degrees(goal[2])}


def goal_errors(robot: Robot, motion: Motion, goals: Sequence[Goal]) -> GoalErrors:
    """The goals, and the distance (m) and heading error (deg) of the feet's midpoint at the
    end of ``motion`` from the last: ``goal``, and ``waypoints`` where the walk stopped before it."""
    soles = {}
    for side in SIDES:
        M = robot.frame_placement(motion.q[-1], robot.foot_frames[side])
        soles[side] = np.array([M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0])])
    end, goal = midpoint(soles), goals[-1]
    return GoalErrors(
        goal=_pose(goal),
        waypoints=[_pose(g) for g in goals[:-1]] if len(goals) > 1 else None,
        final_position_error_m=float(np.hypot(end[0] - goal[0], end[1] - goal[1])),
        final_yaw_error_deg=abs(math.degrees(wrap_angle(end[2] - goal[2]))),
    )


def _refuse_failing_dataset(robot, path, dataset: dict, attrs: dict) -> None:
    """An :class:`Error` if the dataset fails its own check: a Table I from it would mislead."""
    from cocomopl.dataset.check import check_dataset

    settings = attrs["settings"]
    signals = {name: s["values"] for name, s in attrs["signals"].items()}
    report = check_dataset(robot, dataset, float(settings["friction"]), dt=float(settings["dt"]), signals=signals)
    if not report["ok"]:
        key = report["failures"][0]
        raise Error(f"{path}: fails 'cocomopl dataset check' ({key} {report['worst'][key]:.4g} in "
                    f"{report['worst_in'][key]}); reproduce needs a dataset that passes")


def reproduce_report(
    out_dir: str | Path,
    model_path: str | Path | None = None,
    dataset_path: str | Path | None = None,
    *,
    progress: bool = False,
    settings: SimSettings = SimSettings(),
    command: str | None = None,
    kajita_variant: str = "two-stage",
    robot: str | None = None,
) -> ReproduceReport:
    """The paper's experiment (sec. V): M_gen from the primitives, M_gen refined by the OCPs
    of the dataset at ``dataset_path`` (:func:`refine`), M_opt from chained OCPs (that
    dataset's steps, and the transitions it lacks solved here) and the Kajita baseline (``kajita_variant``, :func:`kajita_for`) on M_gen's footsteps and
    timing, all four simulated with the stabilizer tuned for their generator and measured
    over the same walking window (:mod:`cocomopl.analysis.comparison`); the analogue of
    Table I (mean torques) and of Figs. 6, 8 and 9.

    ``out_dir`` receives ``motions.h5`` (planned and simulated motions), ``table1.json`` (the
    report's JSON, every metric), and the comparison PNGs, written as a unit as :func:`walk_report`'s; the
    model and dataset default to the bundled ones of ``robot`` (a bundled name; None: TALOS),
    and M_gen and M_opt are scaled to it (:func:`~cocomopl.gait.m_gen`).  ``settings`` say how the walks are
    simulated (:class:`SimSettings`), always with the stabilizer and each walk's tuned gains.
    """
    from cocomopl.analysis.report_plots import plot_comparison
    from cocomopl.motion_file import report_folder, write_json, write_motions

    started = time.perf_counter()
    dataset_path = bundled_dataset_path(dataset_path, robot=robot)
    model_path = bundled_model_path(model_path, robot=robot)
    provenance = walk_provenance(command, model_path, dataset=dataset_path)
    with report_folder(out_dir, inputs=[model_path, dataset_path]) as work:
        robot, planned, simulated, figures = _paper_experiment(model_path, dataset_path, progress=progress,
                                                              settings=settings, kajita_variant=kajita_variant,
                                                              robot_name=robot)
        provenance |= robot_provenance(robot)
        report = ReproduceReport(folder=str(Path(out_dir)), **figures, provenance=provenance)
        motions = {f"{name}_{kind}": m for kind, by_name in (("planned", planned), ("simulated", simulated))
                   for name, m in by_name.items()}
        files = [work / "motions.h5"]
        write_motions(files[0], motions, {"producer": "cocomopl reproduce", **provenance})
        compared = {"MP planned": planned["MP"], **{f"{name} simulated": m for name, m in simulated.items()}}
        files += plot_comparison(robot, compared, work)
        report.files = _report_files(out_dir, files, "table1.json")
        report.wall_time_s = time.perf_counter() - started
        write_json(work / "table1.json", report.to_json())
    return report


def kajita_for(walk: GeneratedWalk, variant: str = "two-stage") -> Motion:
    """The Kajita baseline on a generated walk's footsteps and phase timing: the
    ``variant`` of :data:`~cocomopl.baselines.kajita.VARIANTS` scaled to the walk's robot
    (:meth:`~cocomopl.baselines.kajita.KajitaSettings.scaled_to`), the two-stage one with the
    generated walk's mean swing height."""
    import dataclasses

    import numpy as np

    from cocomopl.analysis.metrics import swing_heights
    from cocomopl.baselines.kajita import VARIANTS, kajita_walk

    if variant not in VARIANTS:
        raise Error(f"unknown Kajita variant {variant!r}: choose from {', '.join(VARIANTS)}")
    settings = VARIANTS[variant].scaled_to(walk.robot)
    if variant == "two-stage":
        settings = dataclasses.replace(settings, swing_height=float(np.mean(swing_heights(walk.robot, walk.motion))))
    durations = [np.diff(s.phase_edges) for s in walk.steps]
    return kajita_walk(walk.robot, [s.spec for s in walk.steps], durations=durations, dt=PLAN_DT, settings=settings)


def simulate_compared(robot: Robot, planned: dict[str, Motion], *, progress: bool = False,
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
    return simulated, window_figures(robot, planned, simulated, window=window), window


def _paper_experiment(model_path, dataset_path: Path, *, progress: bool, settings: SimSettings,
                      kajita_variant: str = "two-stage", robot_name: str | None = None) -> tuple[Robot, dict, dict, dict]:
    """:func:`reproduce_report`'s work: the robot, the planned and the simulated motions (by method: "MP", "refined"
    (M_gen refined by optimal control), "OC", "Kajita") and the :class:`~cocomopl.results.ReproduceReport`'s
    figures (all but provenance, files and wall time)."""
    from cocomopl.analysis.comparison import per_measure
    from cocomopl.motion_file import load_robot, read_motions
    from cocomopl.ocp.chained_steps import solve_sequence

    dataset, attrs = read_motions(dataset_path, dataset=True, signals=True)
    _refuse_failing_dataset(load_robot(next(iter(dataset.values())).robot), dataset_path, dataset, attrs)
    walk = generate_walk(WalkRequest(StraightSteps(), model=model_path, robot=robot_name))
    robot = walk.robot
    if robot.name != next(iter(dataset.values())).robot:
        raise Error(f"the model is for robot {robot.name!r} and the dataset {dataset_path} for another")
    solve_started = time.perf_counter()
    optimal = solve_sequence(robot, sequence_specs(list(m_opt(robot))), dataset, settings=attrs["settings"], progress=progress)
    solve_s = time.perf_counter() - solve_started
    refined, refine_summary = refine(walk.motion, Refinement(dataset_path), progress=progress)
    kajita = kajita_for(walk, kajita_variant)
    planned = {"MP": walk.motion, "refined": refined.motion, "OC": optimal, "Kajita": kajita}
    simulated, figures, window = simulate_compared(robot, planned, progress=progress, settings=settings)
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
        "sim_model": simulated["MP"].simulation.sim_model,
        "servos": simulated["MP"].simulation.servos,
        "contact_time_constant_s": simulated["MP"].simulation.contact_time_constant_s,
        "reference_cutoff_hz": simulated["MP"].simulation.reference_cutoff_hz,
        "kajita": {key: kajita.meta[key] for key in (
            "pelvis_drop", "pelvis_drop_searched", "com_height_m", "swing_height", "zmp_smoothing", "second_stage",
            "first_stage_zmp_reference_rms_m", "zmp_reference_rms_m", "walking_span_s")} | {"variant": kajita_variant},
        "m_opt_steps": len(optimal.steps),
        "m_opt_solved_now": optimal.solution.solved_now,
        "m_opt_solve_s": solve_s,
        "m_opt_solver": optimal.solution.solver,
        "generation_s": walk.generation_s,
    }
    return robot, planned, simulated, payload


def _report_files(out_dir: str | Path, written: list[Path], summary: str) -> list[str]:
    """The paths a report's files will have once its folder is in place: those ``written`` in the temporary folder,
    and the JSON ``summary`` that lists them (written last)."""
    return [str(Path(out_dir) / name) for name in [*(f.name for f in written), summary]]
