"""Solving step OCPs: the four kinds, cyclic start states, warm starts and solver statistics.

The dependency between problems follows the paper: every step that begins at step length
``L`` begins in the same state ``S(L)``, the start state of the cyclic step of length
``L``.  :func:`cyclic_state` finds it; start, transition and stop steps are then solved
with their ends pinned to those states, so that consecutive steps join.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import crocoddyl
import numpy as np
import pinocchio as pin

from cocomopl.analysis.feasibility import check_motion, tolerances, violations
from cocomopl.dynamics import SIDES, sole_placements, zmp_from_wrenches
from cocomopl.errors import Error
from cocomopl.gait import OTHER_SIDE, foot_separation
from cocomopl.kinematics import double_support_posture
from cocomopl.motion import Footstep, Motion, SolutionRecord, StepSpec, as_footstep
from cocomopl.ocp.problems import (
    StepPlan,
    build_problem,
    initial_guess,
    initial_yaw,
    landing_point,
    landing_yaw,
    next_step_state,
    state_count,
    translate_state,
    turn_state,
    walk_phases,
)
from cocomopl.ocp.settings import OCPSettings
from cocomopl.ocp.torque_rate import with_torque_rate
from cocomopl.robot import Robot, mirror_state

CHUNK = 25  # solver iterations between convergence tests
WALK_ITERATIONS = 200  # the warm-up walk of cyclic_state: with soft landings its cost levels off later than 60


@dataclass
class Solution:
    """A solved OCP: states ``xs`` (N+1, nx), controls ``us`` (N, nu) (empty rows at impacts),
    the plan it solved and solver statistics."""

    plan: StepPlan
    xs: np.ndarray
    us: list[np.ndarray]
    forces: list[dict[str, np.ndarray]]
    stats: dict = field(default_factory=dict)


def initial_states(robot: Robot, plan: StepPlan, settings: OCPSettings, *,
                   guess: str | list[np.ndarray]) -> list[np.ndarray]:
    """The initial state trajectory ``guess`` names: ``"kinematic"`` (feet on their paths by
    inverse kinematics), ``"static"`` (the initial state held), or the states themselves."""
    if not isinstance(guess, str):
        xs = [np.asarray(x) for x in guess]
    elif guess == "kinematic":
        xs = initial_guess(robot, plan.phases, plan.x0, settings=settings)
    elif guess == "static":
        xs = [plan.x0] * state_count(plan.phases)
    else:
        raise ValueError(f"unknown initial guess {guess!r}")
    xs[0] = plan.x0
    return xs


Controls = list[np.ndarray] | Callable[[crocoddyl.ShootingProblem, list[np.ndarray]], list[np.ndarray]] | None


def prepared_problem(
    robot: Robot, plan: StepPlan, settings: OCPSettings, *, xs: list[np.ndarray], us: Controls = None
) -> tuple[crocoddyl.ShootingProblem, crocoddyl.SolverBoxFDDP, list[np.ndarray], list[np.ndarray]]:
    """The plan's problem, its box-FDDP solver (torque limits are hard bounds) and the initial
    guess in the solver's state: states ``xs`` and controls ``us`` (None: quasi-static; a
    function: of the problem and the states)."""
    problem = build_problem(robot, plan, settings)
    if callable(us):
        us = us(problem, xs)
    quasi_static = problem.quasiStatic(xs[:-1]) if us is None else None
    us = quasi_static if us is None else [np.asarray(u) for u in us]
    solver_problem = problem
    if settings.w_torque_rate > 0:
        tau0 = plan.tau0
        if tau0 is None:  # holding the initial state quasi-statically
            tau0 = quasi_static[0] if quasi_static is not None else problem.runningModels[0].quasiStatic(
                problem.runningDatas[0], plan.x0)
        solver_problem = with_torque_rate(problem, tau0, settings.w_torque_rate / settings.dt)
        xs = _with_previous_torques(xs, us, tau0)
    return problem, crocoddyl.SolverBoxFDDP(solver_problem), xs, us


def solve_plan(
    robot: Robot,
    plan: StepPlan,
    settings: OCPSettings,
    *,
    guess: str | list[np.ndarray] = "kinematic",
    max_iterations: int | None = None,
    controls: list[np.ndarray] | None = None,
) -> Solution:
    """Solve one plan with Crocoddyl's box-constrained FDDP from the initial states ``guess``
    (:func:`initial_states`) and ``controls`` (None: quasi-static)."""
    xs_init = initial_states(robot, plan, settings, guess=guess)
    problem, solver, xs_init, us_init = prepared_problem(robot, plan, settings, xs=xs_init, us=controls)
    budget = max_iterations or settings.max_iterations
    start = time.perf_counter()
    iterations, converged, previous_cost = 0, False, np.inf
    # FDDP's own stop test is rarely met on these stiff, barrier-laden problems even when
    # the cost has long stopped moving; so solve in chunks and also accept a plateau
    while iterations < budget and not converged:
        chunk = min(CHUNK, budget - iterations)
        solved = solver.solve(xs_init, us_init, chunk, False)
        iterations += solver.iter
        xs_init, us_init = list(solver.xs), list(solver.us)
        plateau = abs(previous_cost - solver.cost) < settings.tolerance * max(1.0, abs(solver.cost))
        converged = solver.ffeas < 1e-6 and (solved or plateau)
        previous_cost = solver.cost
        if solver.iter == 0:
            break
    stats = {
        "iterations": iterations,
        "cost": float(solver.cost),
        "feasibility": float(solver.ffeas),
        "stop": float(solver.stop),
        "converged": bool(converged),
        "solve_time_s": time.perf_counter() - start,
    }
    return solution_of(problem, solver, plan, stats=stats)


def solution_of(problem: crocoddyl.ShootingProblem, solver, plan: StepPlan, *, stats: dict) -> Solution:
    """The :class:`Solution` a solver reached on ``problem`` (without the torque-rate states)."""
    nx = problem.runningModels[0].state.nx
    xs = np.array(solver.xs)[:, :nx]
    # the datas hold the last line-search trial; evaluate the accepted trajectory again
    problem.calc(list(xs), list(solver.us))
    forces = []
    for model, data in zip(problem.runningModels, problem.runningDatas):
        if isinstance(model, crocoddyl.ActionModelImpulseFwdDynamics):
            forces.append({})
            continue
        contacts = data.differential.multibody.contacts.contacts.todict()
        forces.append({name.split("_")[0]: np.array(c.f.vector) for name, c in contacts.items()})
    return Solution(plan, xs, [np.array(u) for u in solver.us], forces, stats)


def _with_previous_torques(xs: list[np.ndarray], us: list[np.ndarray], tau0: np.ndarray) -> list[np.ndarray]:
    """States augmented with the torque of the knot before (impulses carry it over)."""
    previous, out = tau0, [np.concatenate([xs[0], tau0])]
    for x, u in zip(xs[1:], us):
        if len(u):
            previous = u
        out.append(np.concatenate([x, previous]))
    return out


WALK_STEPS = {"start": [0], "cyclic": [2], "stop": [3, 4, 5]}  # double-support phases of each spec


def resting_at_the_end(robot: Robot, phases: list) -> np.ndarray:
    """Standing still in double support where ``phases`` leave the soles (at their last
    touchdowns), the CoM between them."""
    impacts = [p for p in phases if p.kind == "impact"]
    last = {side: next(p for p in reversed(impacts) if p.swing == side) for side in ("left", "right")}
    posture = double_support_posture(robot, last["left"].swing_to, last["right"].swing_to,
                                     yaws=(last["left"].yaw_to, last["right"].yaw_to))
    return robot.state_from_posture(posture)


def warm_up_plan(robot: Robot, footstep: float | Footstep, settings: OCPSettings) -> StepPlan:
    """The warm-up walk's problem at one footstep (or straight step length, m): start, two
    cyclic steps, stop, from rest to rest (right sole at the origin, left swinging first)."""
    footstep = as_footstep(footstep)
    separation = foot_separation(robot)
    x_rest = robot.state_from_posture(double_support_posture(robot, (0.0, separation), (0.0, 0.0)))
    rest = Footstep(0.0)
    specs = [
        StepSpec.between("start", rest, footstep),
        StepSpec.between("cyclic", footstep, footstep),
        StepSpec.between("cyclic", footstep, footstep),
        StepSpec.between("stop", footstep, rest),
    ]
    phases = walk_phases(specs, separation, settings)
    return StepPlan(specs[0], phases, x_rest, resting_at_the_end(robot, phases))


def warm_up_walk(robot: Robot, footstep: float | Footstep, settings: OCPSettings, *, guess: np.ndarray | None = None,
                 controls: list[np.ndarray] | None = None, neighbour: np.ndarray | None = None) -> Solution:
    """A short walk at one footstep (:func:`warm_up_plan`), from rest to rest.

    A single cyclic step cannot be solved for its own start state with a DDP solver, whose
    initial state is fixed; a walk settles into its gait by the second cyclic step, whose
    start is the cyclic state ``S(L)``.  The walk's steps also warm-start the single-step
    OCPs of the same length.  ``guess``: states on the walk's knots, e.g. the model's walk
    (a grown length); None starts from the kinematic guess.  ``controls``: the guess's
    torques (None: quasi-static); the model's walk at 230 mm took 75 iterations with its
    torques, 200 (not converged) without, and the kinematic guess 90.  ``neighbour``: the
    solved walk of a neighbouring footstep with the same phase timing (continuation), of
    which only the upper body is taken (:func:`continued_guess`).
    """
    plan = warm_up_plan(robot, footstep, settings)
    knots = state_count(plan.phases)
    if neighbour is not None and len(neighbour) == knots:
        guess, controls = continued_guess(robot, plan, settings, neighbour=neighbour), None
    # the walk only needs to settle into its gait, not to converge tightly
    fits = guess is not None and len(guess) == knots
    start = list(guess) if fits else "kinematic"
    return solve_plan(robot, plan, replace(settings, w_torque_rate=0.0), guess=start, max_iterations=WALK_ITERATIONS,
                      controls=controls if fits else None)


def continued_guess(robot: Robot, plan: StepPlan, settings: OCPSettings, *, neighbour: np.ndarray) -> list[np.ndarray]:
    """The kinematic guess of ``plan`` with the upper body (the joints off the leg chains:
    positions and velocities) of a ``neighbour``'s solved states on the same knots.

    The upper body is what the cost leaves nearly free, so it is what can land on another
    solution branch; taking it from the neighbour keeps neighbours on one branch.  The base
    and legs come from the kinematic guess, whose soles are where this plan's contacts hold
    them: with the neighbour's whole states, whose soles stand a footstep away, a walk of
    300 mm continued from 150 mm had not converged after 200 iterations (cost 160 times
    its optimum), and the footstep was solved again afresh.
    """
    nq = robot.model.nq
    upper = robot.upper_body_joint_indices()
    columns = np.concatenate([7 + upper, nq + 6 + upper])
    xs = initial_states(robot, plan, settings, guess="kinematic")
    for x, y in zip(xs[1:], neighbour[1:]):
        x[columns] = y[columns]
    return xs


def walk_segment(robot: Robot, walk: Solution, kind: str) -> list[np.ndarray]:
    """The states of the walk's ``start``, second ``cyclic`` or ``stop`` step, moved into
    that step's own right-support frame."""
    phases = walk.plan.phases
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, walk.xs[0][: robot.model.nq])
    feet = {side: (*data.oMf[robot.foot_frames[side]].translation[:2], initial_yaw(phases, side))
            for side in ("left", "right")}
    ds_seen, k, first, stance = -1, 0, None, None
    wanted = WALK_STEPS[kind]
    for idx, phase in enumerate(phases):
        if phase.kind == "ds":
            ds_seen += 1
            if ds_seen == wanted[0]:
                first = k
                stance = OTHER_SIDE[next(p.swing for p in phases[idx:] if p.kind == "ss")]
                origin = feet[stance]
            if ds_seen == wanted[-1] + 1:
                break
        if phase.kind == "impact":
            feet[phase.swing] = (*phase.swing_to, phase.yaw_to)
        k += 1 if phase.kind == "impact" else phase.knots
    last = k if ds_seen == wanted[-1] + 1 else len(walk.xs) - 1
    segment = turn_state(robot, translate_state(robot, walk.xs[first : last + 1], (-origin[0], -origin[1])), -origin[2])
    if stance == "left":
        segment = mirror_state(robot, segment)
    return list(segment)


def solve_with_retries(
    robot: Robot,
    spec: StepSpec,
    start_states: dict[float, np.ndarray],
    *,
    settings: OCPSettings,
    guesses: list,
    extra_iterations: int = 0,
) -> tuple[Solution | None, list[dict]]:
    """Solve a step from each initial guess in turn until one converges.

    Later attempts get twice the iteration budget.  If none converges and
    ``extra_iterations`` is positive, the attempt of least cost that stopped unconverged is
    continued from where it stopped for that many iterations more.  Returns the converged
    solution (or None) and a record of every attempt.
    """
    attempts, unconverged = [], []

    def accepted(solution: Solution, label: str) -> bool:
        record = {"guess": label, **solution.stats}
        attempts.append(record)
        if not solution.stats["converged"]:
            unconverged.append((solution, label))
            return False
        failed, gap = failed_checks(robot, solution, settings)
        record.update(failed_checks=failed, target_error=gap)
        if failed:
            return False
        solution.stats["attempts"] = attempts
        return True

    for i, guess in enumerate(guesses):
        label = guess if isinstance(guess, str) else "warm start"
        budget = settings.max_iterations * (1 if i == 0 else 2)
        try:
            solution = solve_step(robot, spec, start_states, settings=settings, guess=guess, max_iterations=budget)
        except Error as exc:
            attempts.append({"guess": label, "error": str(exc)})
            continue
        if accepted(solution, label):
            return solution, attempts
    if extra_iterations > 0 and unconverged:
        closest, label = min(unconverged, key=lambda tried: tried[0].stats["cost"])
        solution = solve_plan(robot, closest.plan, settings, guess=list(closest.xs), controls=closest.us,
                              max_iterations=extra_iterations)
        if accepted(solution, f"{label}, continued"):
            return solution, attempts
    return None, attempts


def last_resort(settings: OCPSettings) -> int:
    """Iterations more for the closest unconverged attempt at a start, stop or transition step
    when every guess fails.  Some corner-to-corner transitions need 600-700 iterations from
    their warm start (G1's (-110 mm, -35 mm, -25 deg) to (290 mm, 120 mm, 25 deg): 687) where
    the guesses get 300 and 600.  Not inside the cyclic step's duration search, where a
    failed duration is a result, not a loss."""
    return 4 * settings.max_iterations


def failed_checks(robot: Robot, solution: Solution, settings: OCPSettings) -> tuple[list[str], float]:
    """The independent checks a solved step fails, and its end's distance from its target.

    A converged penalty formulation can still sit in a poor local minimum that breaks a
    constraint, or stop on a plateau short of its end target: only a solution that passes
    :func:`~cocomopl.analysis.feasibility.check_motion` and ends within the continuity
    tolerance of its target is accepted.
    """
    limits = tolerances(settings.dt)
    failed = violations(check_motion(robot, to_motion(robot, solution, settings), settings.friction), limits)
    gap = target_error(robot, solution) if solution.plan.x_target is not None else 0.0
    if gap > limits["continuity"]:
        failed.append("continuity")
    return failed, gap


def length_steps(footstep: float | Footstep) -> dict[str, StepSpec]:
    """The right-support cyclic, start and stop steps of one footstep (or straight step
    length, m), by kind."""
    footstep, rest = as_footstep(footstep), Footstep(0.0)
    return {
        "cyclic": StepSpec.between("cyclic", footstep, footstep),
        "start": StepSpec.between("start", rest, footstep),
        "stop": StepSpec.between("stop", footstep, rest),
    }


def solve_length(
    robot: Robot,
    length: float | Footstep,
    settings: OCPSettings,
    *,
    kinds: tuple[str, ...] = ("cyclic", "start", "stop"),
    cyclic_start: np.ndarray | None = None,
    walk_guess: np.ndarray | None = None,
    walk_controls: list[np.ndarray] | None = None,
    neighbour_walk: np.ndarray | None = None,
) -> tuple[dict[str, Solution | None], dict]:
    """The cyclic, start and stop steps of one length (or footstep), and the cyclic start state ``S(L)``.

    Phase timing is free, as in the paper, but the solver has no time variable: the
    single-support duration is searched outside it (:func:`descend` from
    ``settings.ss_duration`` in steps of ``settings.ss_search_step``), and the cyclic step
    of least cost (eq. 1 plus penalties) fixes the timing of this length's start and stop
    steps too.  ``cyclic_start`` is ``S(L)`` when the cyclic
    step is already solved (its timing is then that of ``settings``).  ``walk_guess`` warm-starts
    the warm-up walk (:func:`warm_up_walk`; ``walk_controls`` its torques), e.g. the model's
    walk; ``neighbour_walk``, the warm-up walk of a neighbouring length, continues from its
    upper body.

    Returns ``({kind: solution or None}, info)`` with ``info`` holding ``start_state``,
    ``durations`` (double, single support; s), ``duration_search``, ``attempts`` and ``walk``
    (the warm-up walk's states, to continue from).
    """
    footstep = as_footstep(length)
    spec_of = length_steps(footstep)
    key = footstep.gait_key
    solutions, attempts, search = {}, {}, []
    if cyclic_start is None:
        tried: dict[float, tuple | None] = {}

        def evaluate(ss: float) -> float:
            """Cost of the cyclic step with single support ``ss`` (inf if none accepted)."""
            ss = round(ss, 6)
            if ss not in tried:
                opts = replace(settings, ss_duration=ss)
                tried[ss], continued = None, False
                # a neighbour's walk can lead the cyclic step where it fails (150 mm, 150 mm out:
                # failed from both neighbours, solved from the kinematic walk), or onto another
                # branch, where it needs the whole budget (the same step of a denser design: 300
                # iterations, 2.2 times the cost it has from its own walk, 0.7 rad away in the
                # upper body): then it is also solved afresh, and the lower cost is kept
                given = {"guess": walk_guess, "controls": walk_controls, "neighbour": neighbour_walk}
                warm = walk_guess is not None or neighbour_walk is not None
                for start in [given] + ([{}] if warm else []):
                    walk = warm_up_walk(robot, footstep, opts, **start)
                    segment = walk_segment(robot, walk, "cyclic")
                    x0 = segment[0]
                    guesses = [segment, "kinematic", "static"]
                    solution, record = solve_with_retries(robot, spec_of["cyclic"], {key: x0}, settings=opts,
                                                          guesses=guesses)
                    attempts.setdefault("cyclic", []).extend(record)
                    if solution is None:
                        continue
                    if tried[ss] is None or solution.stats["cost"] < tried[ss][0].stats["cost"]:
                        tried[ss], continued = (solution, record, walk, x0, opts), start is given
                    if solution.stats["iterations"] < opts.max_iterations:
                        break
                kept = tried[ss][0] if tried[ss] else None
                search.append({"ss_duration": ss, "cost": None if kept is None else kept.stats["cost"],
                               "continued": continued})
            return np.inf if tried[ss] is None else tried[ss][0].stats["cost"]

        best = descend(evaluate, settings.ss_duration, settings.ss_search_step, bounds=settings.ss_bounds)
        if tried[round(best, 6)] is None:
            return dict.fromkeys(kinds), {"attempts": attempts, "duration_search": search}
        solutions["cyclic"], attempts["cyclic"], walk, cyclic_start, settings = tried[round(best, 6)]
    else:
        walk = warm_up_walk(robot, footstep, settings, guess=walk_guess, controls=walk_controls,
                            neighbour=neighbour_walk)
    states = {key: cyclic_start}
    for kind in kinds:
        if kind == "cyclic":
            continue
        guesses = [walk_segment(robot, walk, kind), "kinematic", "static"]
        solutions[kind], attempts[kind] = solve_with_retries(robot, spec_of[kind], states, settings=settings,
                                                             guesses=guesses, extra_iterations=last_resort(settings))
    info = {
        "start_state": cyclic_start,
        "durations": (settings.ds_duration, settings.ss_duration),
        "duration_search": search,
        "attempts": attempts,
        "walk": walk.xs,
    }
    return solutions, info


def descend(cost, start: float, step: float, *, bounds: tuple[float, float]) -> float:
    """A 1-D grid descent: from ``start``, move by ``step`` while the cost falls.

    Returns the grid point of least cost found, within ``bounds``.  ``step == 0`` only
    evaluates ``start``.
    """
    best, best_cost = start, cost(start)
    if step <= 0:
        return best
    for direction in (1.0, -1.0):
        x = best + direction * step
        moved = False
        while bounds[0] - 1e-9 <= x <= bounds[1] + 1e-9:
            c = cost(x)
            if c >= best_cost:
                break
            best, best_cost, moved = x, c, True
            x += direction * step
        if moved:
            break
    return best


def step_plan(robot: Robot, spec: StepSpec, start_states: dict, *, settings: OCPSettings) -> StepPlan:
    """Initial state, phases and continuity target of a right-support step ``spec``;
    ``start_states``: the gait states ``S`` by :attr:`~cocomopl.motion.Footstep.gait_key`."""
    separation = foot_separation(robot)
    phases = walk_phases([spec], separation, settings)
    if spec.kind == "start":
        x0 = robot.state_from_posture(double_support_posture(robot, (0.0, separation), (0.0, 0.0)))
    else:
        x0 = start_states[spec.start_footstep.gait_key]
    if spec.kind == "stop":
        target = resting_at_the_end(robot, phases)
    else:
        target = next_step_state(robot, start_states[spec.end_footstep.gait_key], landing_point(phases),
                                 landed_yaw=landing_yaw(phases))
    return StepPlan(spec, phases, x0, target)


def solve_step(
    robot: Robot,
    spec: StepSpec,
    start_states: dict[float, np.ndarray],
    *,
    settings: OCPSettings,
    guess: str | list[np.ndarray] = "kinematic",
    max_iterations: int | None = None,
) -> Solution:
    """Solve a right-support step whose neighbours start in ``start_states[length]``."""
    if spec.swing_side != "left":
        raise Error("only right-support steps (left swing) are solved; left ones come by mirroring")
    plan = step_plan(robot, spec, start_states, settings=settings)
    return solve_plan(robot, plan, settings, guess=guess, max_iterations=max_iterations)


def to_motion(robot: Robot, solution: Solution, settings: OCPSettings, *, producer: str = "ocp") -> Motion:
    """The :class:`Motion` of a solved step (in its step frame)."""
    xs, nq = solution.xs, robot.model.nq
    n = len(xs)
    t = np.zeros(n)
    tau = np.zeros((n, robot.nu))
    wrenches = np.zeros((n, 2, 6))
    contact = np.zeros((n, 2), dtype=bool)
    phases, impacts = [], []
    k = 0
    for phase in solution.plan.phases:
        if phase.kind == "impact":
            impacts.append(k)
            t[k + 1] = t[k]
            tau[k], wrenches[k], contact[k] = tau[k - 1], wrenches[k - 1], contact[k - 1]
            k += 1
            continue
        phases.append((phase.kind, k, k + phase.knots))
        for _ in range(phase.knots):
            t[k + 1] = t[k] + settings.dt
            tau[k] = solution.us[k]
            for j, side in enumerate(SIDES):
                if side in solution.forces[k]:
                    wrenches[k, j] = solution.forces[k][side]
                    contact[k, j] = True
            k += 1
    tau[-1], wrenches[-1], contact[-1] = tau[-2], wrenches[-2], True
    q = xs[:, :nq]
    zmp = zmp_from_wrenches(sole_placements(robot, q), wrenches)
    return Motion(
        t=t,
        q=q,
        v=xs[:, nq:],
        tau=tau,
        wrenches=wrenches,
        contact=contact,
        zmp=zmp,
        phases=phases,
        impacts=np.array(impacts, dtype=int),
        steps=[solution.plan.spec],
        step_starts=np.array([0], dtype=int),
        joint_names=list(robot.joint_names),
        robot=robot.name,
        producer=producer,
        solution=SolutionRecord(solver=solution.stats),
    )


def target_error(robot: Robot, solution: Solution) -> float:
    """Largest difference (tangent space) between a step's end and the state it must reach."""
    target = solution.plan.x_target
    nq = robot.model.nq
    dq = pin.difference(robot.model, target[:nq], solution.xs[-1][:nq])
    dv = solution.xs[-1][nq:] - target[nq:]
    return float(max(np.abs(dq).max(), np.abs(dv).max()))


__all__ = [
    "Solution",
    "length_steps",
    "solve_length",
    "solve_plan",
    "solve_step",
    "solve_with_retries",
    "step_plan",
    "target_error",
    "to_motion",
    "walk_segment",
    "warm_up_plan",
    "warm_up_walk",
]


def phase_durations(cyclic: Motion) -> dict:
    """The double- and single-support durations (s) of a solved cyclic step."""
    (_, a, b), (_, c, d) = cyclic.phases[:2]
    return {"ds_duration": float(cyclic.t[b] - cyclic.t[a]), "ss_duration": float(cyclic.t[d] - cyclic.t[c])}


def solve_transition(
    robot: Robot, settings: OCPSettings, spec: StepSpec, *, cyclic_from: Motion, cyclic_to: Motion
) -> tuple[Motion | None, list]:
    """A transition step between the start states of two cyclic steps, warm-started from
    the cyclic step of its start length (or footstep).

    Returns the motion (None if no attempt converged) and the attempts made.
    """
    # the transition keeps the timing of the gait it leaves, whose cyclic step warm-starts it
    opts = replace(settings, **phase_durations(cyclic_from))
    states = {
        spec.start_footstep.gait_key: np.concatenate([cyclic_from.q[0], cyclic_from.v[0]]),
        spec.end_footstep.gait_key: np.concatenate([cyclic_to.q[0], cyclic_to.v[0]]),
    }
    warm = list(np.hstack([cyclic_from.q, cyclic_from.v]))
    solution, attempts = solve_with_retries(robot, spec, states, settings=opts, guesses=[warm, "kinematic", "static"],
                                            extra_iterations=last_resort(opts))
    return (None if solution is None else to_motion(robot, solution, opts)), attempts
