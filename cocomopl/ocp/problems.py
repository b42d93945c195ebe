"""Multi-phase shooting problems for the four kinds of walking step.

Every problem is built for right support first (the left foot swings first) in the *step
frame*: the right sole at the origin, x forward, z up.  Left-support steps are obtained by
mirroring (:mod:`cocomopl.robot.mirror`).  A step is a list of :class:`Phase` s -- double
support, single support, touchdown impulse -- that :func:`build_problem` turns into knots.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import crocoddyl
import numpy as np
import pinocchio as pin

from cocomopl.gait import OTHER_SIDE, footstep_origin, footstep_pose
from cocomopl.kinematics import flat_placement, inverse_kinematics
from cocomopl.motion import StepSpec
from cocomopl.ocp.action_models import contact_knot, impulse_knot, soles_gap
from cocomopl.ocp.settings import OCPSettings
from cocomopl.robot import Robot, mirror_state


@dataclass
class Phase:
    """One phase of a step.

    ``kind`` is ``"ds"`` (both feet down), ``"ss"`` (``swing`` in the air, from
    ``swing_from`` to ``swing_to``, (x, y) in metres, turning from yaw ``yaw_from`` to
    ``yaw_to``, rad) or ``"impact"`` (``swing`` lands).
    """

    kind: str
    knots: int = 0
    swing: str | None = None
    swing_from: tuple[float, float] | None = None
    swing_to: tuple[float, float] | None = None
    yaw_from: float = 0.0
    yaw_to: float = 0.0


@dataclass
class StepPlan:
    """The phases of one OCP, its initial state and, where continuity demands, its end state.

    ``tau0``: the torques before the first knot, from which the torque-rate cost starts (None:
    those that hold ``x0`` quasi-statically, as a step from rest or the dataset's steps do).
    """

    spec: StepSpec
    phases: list[Phase]
    x0: np.ndarray
    x_target: np.ndarray | None = None
    tau0: np.ndarray | None = None


def translate_state(robot: Robot, x: np.ndarray, offset: Sequence[float]) -> np.ndarray:
    """Move a state's floating base horizontally by ``offset`` (dx, dy) m (velocities are in
    the base frame: unchanged)."""
    dx, dy = offset
    out = np.array(x, dtype=float, copy=True)
    out[..., 0] += dx
    out[..., 1] += dy
    return out


def turn_state(robot: Robot, x: np.ndarray, yaw: float) -> np.ndarray:
    """Turn a state's floating base by ``yaw`` (rad) about the vertical through the origin
    (velocities are in the base frame: unchanged)."""
    out = np.array(x, dtype=float, copy=True)
    if yaw == 0.0:
        return out
    rotation = pin.Quaternion(flat_placement(0.0, 0.0, yaw).rotation)
    for row in out.reshape(-1, out.shape[-1]):
        row[:3] = rotation.matrix() @ row[:3]
        row[3:7] = (rotation * pin.Quaternion(row[3:7])).coeffs()
    return out


def next_step_state(robot: Robot, x_start_next: np.ndarray, landed_at: tuple[float, float],
                    *, landed_yaw: float = 0.0) -> np.ndarray:
    """Where the next step's start state lies in this step's frame.

    ``x_start_next`` is the next step's start in its own (right-support) frame; the next
    step stands on the foot that just landed at ``landed_at`` turned by ``landed_yaw``, so it
    is mirrored, turned and moved there.
    """
    return translate_state(robot, turn_state(robot, mirror_state(robot, x_start_next), landed_yaw), landed_at)


def _knots(duration: float, dt: float) -> int:
    return max(2, round(duration / dt))


def walk_phases(
    specs: list[StepSpec],
    separation: float,
    settings: OCPSettings,
    *,
    durations: tuple[float, float] | None = None,
) -> list[Phase]:
    """Phases of consecutive steps, feet alternating, the first swing foot the left one.

    Positions are in the first step's frame (right sole at the origin).  ``durations`` =
    (double support, single support) in seconds overrides the defaults.
    """
    ds, ss = durations if durations is not None else (settings.ds_duration, settings.ss_duration)
    dt = settings.dt
    first = specs[0]
    right = np.zeros(3)
    left = (footstep_pose(right, "left", (0.0, 0.0, 0.0), separation=separation) if first.kind == "start" else
            footstep_origin(right, "right", (first.start_length, first.start_width, first.start_turn),
                            separation=separation))
    feet = {"right": right, "left": left}
    phases: list[Phase] = []
    swing = "left"

    def step(to: np.ndarray, ds_time: float) -> None:
        nonlocal swing
        phases.append(Phase("ds", _knots(ds_time, dt)))
        start = feet[swing]
        phases.append(Phase("ss", _knots(ss, dt), swing, (start[0], start[1]), (to[0], to[1]), start[2], to[2]))
        phases.append(Phase("impact", swing=swing, swing_to=(to[0], to[1]), yaw_to=to[2]))
        feet[swing] = to
        swing = OTHER_SIDE[swing]

    def landing(length: float, width: float, turn: float) -> np.ndarray:
        return footstep_pose(feet[OTHER_SIDE[swing]], swing, (length, width, turn), separation=separation)

    for spec in specs:
        if spec.kind == "start":
            step(landing(spec.end_length, spec.end_width, spec.end_turn), max(ds, settings.start_ds_duration))
        elif spec.kind in ("cyclic", "transition"):
            step(landing(spec.end_length, spec.end_width, spec.end_turn), ds)
        elif spec.kind == "stop":
            # one more step of the same footstep, then the other foot closes up beside it
            step(landing(spec.start_length, spec.start_width, spec.start_turn), ds)
            step(landing(0.0, 0.0, 0.0), ds)
            phases.append(Phase("ds", _knots(settings.rest_duration, dt)))
        else:
            raise ValueError(f"unknown step kind {spec.kind!r}")
    return phases


def landing_point(phases: list[Phase]) -> tuple[float, float]:
    """Where the last foot to touch down landed, (x, y) in the problem's frame."""
    return [p for p in phases if p.kind == "impact"][-1].swing_to


def landing_yaw(phases: list[Phase]) -> float:
    """The yaw (rad) of the last foot to touch down, in the problem's frame."""
    return [p for p in phases if p.kind == "impact"][-1].yaw_to


def _swing_guide(phase: Phase, s: float, clearance: float) -> pin.SE3:
    """A smooth reference for the swing sole at phase fraction ``s``: it only steers the
    solver's early iterations (small weight), the landing and clearance are what count."""
    blend = 0.5 - 0.5 * np.cos(np.pi * s)
    start, end = np.asarray(phase.swing_from), np.asarray(phase.swing_to)
    xy = start + blend * (end - start)
    apex = 1.6 * (clearance + 0.02)  # comfortably above the clearance constraint
    z = apex * np.sin(np.pi * s) ** 2
    yaw = phase.yaw_from + blend * (phase.yaw_to - phase.yaw_from)
    return pin.SE3(flat_placement(0.0, 0.0, yaw).rotation, np.array([xy[0], xy[1], z]))


def swing_gap(robot: Robot, phase: Phase, stance: pin.SE3, *, settings: OCPSettings) -> float | None:
    """The least gap (m) between the soles' rectangles through single-support ``phase``, if a
    sole turns: ``settings.sole_gap``, or less where the swing sole lifts off or lands closer.
    Soles that all face ahead need none: the swing's lane keeps them apart."""
    if phase.yaw_from == phase.yaw_to == 0.0 and np.allclose(stance.rotation, np.eye(3)):
        return None
    ends = (_flat(phase.swing_from, phase.yaw_from), _flat(phase.swing_to, phase.yaw_to))
    return min(settings.sole_gap, *(soles_gap(robot, end, stance) for end in ends))


def _flat(xy: tuple[float, float], yaw: float = 0.0) -> pin.SE3:
    return flat_placement(xy[0], xy[1], yaw)


def initial_yaw(phases: list[Phase], side: str) -> float:
    """The planned yaw of sole ``side`` at the start of ``phases``: where its first swing
    starts from (a sole that does not swing is the stance sole, at yaw 0 in the step frame)."""
    return next((p.yaw_from for p in phases if p.kind == "ss" and p.swing == side), 0.0)


def load_shares(phases: list[Phase], i: int, from_rest: bool) -> list[dict[str, float] | None]:
    """Fractions of the body weight each sole should carry at the knots of double support
    ``phases[i]``, if it hands the weight over from one foot to the other.

    Between a touchdown (or the start of a step that continues a walk) and the next lift-off
    the weight moves linearly from the foot that carried it to the one that stays down:
    none on a sole when it lands, none when it lifts.  Double supports that begin or end at
    rest (``from_rest``: the first of a start step; the last of a stop) get None at every
    knot: held to the transfer there too, four of the 32 training OCPs found no solution
    within the friction cone.
    """
    phase = phases[i]
    before = phases[i - 1] if i > 0 else None
    after = phases[i + 1] if i + 1 < len(phases) else None
    if (from_rest and before is None) or after is None or after.kind != "ss":
        return [None] * phase.knots
    landed, lifts = OTHER_SIDE[after.swing], after.swing
    return [{landed: k / phase.knots, lifts: 1.0 - k / phase.knots} for k in range(phase.knots)]


def build_problem(robot: Robot, plan: StepPlan, settings: OCPSettings) -> crocoddyl.ShootingProblem:
    """A Crocoddyl shooting problem for a step plan."""
    state = crocoddyl.StateMultibody(robot.model)
    x_ref = robot.state_from_posture(robot.q_ref)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, plan.x0[: robot.model.nq])
    feet = {side: _flat(data.oMf[robot.foot_frames[side]].translation[:2], initial_yaw(plan.phases, side))
            for side in ("left", "right")}
    knots: list = []
    for i, phase in enumerate(plan.phases):
        if phase.kind == "ds":
            knots += [
                contact_knot(robot, state, dict(feet), x_ref=x_ref, settings=settings, dt=settings.dt,
                             load_shares=shares)
                for shares in load_shares(plan.phases, i, plan.spec.kind == "start")
            ]
        elif phase.kind == "ss":
            stance = {OTHER_SIDE[phase.swing]: feet[OTHER_SIDE[phase.swing]]}
            gap = swing_gap(robot, phase, feet[OTHER_SIDE[phase.swing]], settings=settings)
            for k in range(phase.knots):
                s = (k + 1) / phase.knots
                in_air = 0.25 <= s <= 0.75
                knots.append(
                    contact_knot(
                        robot,
                        state,
                        stance,
                        x_ref=x_ref,
                        settings=settings,
                        dt=settings.dt,
                        swing=phase.swing,
                        swing_guide=_swing_guide(phase, s, settings.clearance),
                        clearance=settings.clearance if in_air else -1.0,
                        sole_gap=gap,
                    )
                )
        elif phase.kind == "impact":
            feet[phase.swing] = _flat(phase.swing_to, phase.yaw_to)
            knots.append(impulse_knot(robot, state, phase.swing, placement=feet[phase.swing], x_ref=x_ref,
                                      settings=settings))
        else:
            raise ValueError(f"unknown phase kind {phase.kind!r}")
    terminal = contact_knot(robot, state, dict(feet), x_ref=x_ref, settings=settings, dt=0.0, x_target=plan.x_target)
    return crocoddyl.ShootingProblem(plan.x0, knots, terminal)


def initial_guess(robot: Robot, phases: list[Phase], x0: np.ndarray, *, settings: OCPSettings) -> list[np.ndarray]:
    """A kinematic warm start: feet on their planned paths, the CoM shifted over the stance
    foot in double support and kept there in single support, solved knot by knot by
    inverse kinematics; velocities by finite differences."""
    model = robot.model
    nq = model.nq
    data = model.createData()
    q = x0[:nq].copy()
    pin.framesForwardKinematics(model, data, q)
    feet = {side: _flat(data.oMf[robot.foot_frames[side]].translation[:2], initial_yaw(phases, side))
            for side in ("left", "right")}
    com = pin.centerOfMass(model, data, q)[:2].copy()
    postures = [q]
    inward = {"left": -0.01, "right": 0.01}

    def next_swing(i: int) -> str | None:
        return next((p.swing for p in phases[i:] if p.kind == "ss"), None)

    for i, phase in enumerate(phases):
        if phase.kind == "ds":
            swing = next_swing(i)
            if swing is None:
                goal = 0.5 * (feet["left"].translation[:2] + feet["right"].translation[:2])
            else:
                stance = OTHER_SIDE[swing]
                goal = feet[stance].translation[:2] + feet[stance].rotation[:2, :2] @ np.array([0.0, inward[stance]])
            for k in range(phase.knots):
                c = com + (goal - com) * (k + 1) / phase.knots
                postures.append(inverse_kinematics(robot, feet, c, q_init=postures[-1], iterations=20, check=False))
            com = goal
        elif phase.kind == "ss":
            for k in range(phase.knots):
                s = (k + 1) / phase.knots
                feet[phase.swing] = _swing_guide(phase, s, settings.clearance)
                postures.append(inverse_kinematics(robot, feet, com, q_init=postures[-1], iterations=20, check=False))
        else:  # impact: no time passes
            feet[phase.swing] = _flat(phase.swing_to, phase.yaw_to)
            postures.append(postures[-1])
    xs = [x0]
    for k in range(1, len(postures)):
        dt = settings.dt if phases_time_step(phases, k - 1) else 0.0
        v = pin.difference(model, postures[k - 1], postures[k]) / dt if dt > 0 else xs[-1][nq:]
        xs.append(np.concatenate([postures[k], v]))
    return xs


def state_count(phases: list[Phase]) -> int:
    """How many states a problem of ``phases`` has: one per knot and impact, and the terminal one."""
    return sum(1 if p.kind == "impact" else p.knots for p in phases) + 1


def phases_time_step(phases: list[Phase], knot: int) -> bool:
    """Whether knot ``knot`` (0-based) of the phases takes time (False at impacts)."""
    k = 0
    for phase in phases:
        n = 1 if phase.kind == "impact" else phase.knots
        if knot < k + n:
            return phase.kind != "impact"
        k += n
    return True
