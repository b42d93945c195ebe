"""Place a chain of predicted steps in the world and make it a :class:`Motion`.

Each step's signals are resampled from its normalised grid to real time (cubic splines, so
velocities and accelerations exist).  Footsteps follow from the step lengths (and widths
and turns); the pelvis takes the learned orientation, turned with the stance sole, and its
position comes by forward kinematics from the feet on the ground: from the stance foot in
single support, blended from the old to the new stance foot over double support.  Torques and contact wrenches come from Pinocchio inverse
dynamics of the resulting motion, so every analysis tool can read it like an OC motion.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pinocchio as pin
from scipy.interpolate import CubicSpline

from cocomopl.analysis.feasibility import nearest_inside, soles_polygon
from cocomopl.dynamics import SIDES, kinematic_motion
from cocomopl.gait import OTHER_SIDE, footsteps, ground_position, ground_yaw, phase_plan, sole_poses
from cocomopl.kinematics import flat_placement
from cocomopl.motion import SAMPLED, TIME_TOLERANCE, Motion, PlanRecord
from cocomopl.primitives.estimator import PredictedStep
from cocomopl.robot import Robot
from cocomopl.synthesis.dynamics_filter import dynamics_filter, plan_zmp_error
from cocomopl.synthesis.upper_body_limits import limit_upper_body

REFILTER_PASSES = 2  # of the dynamics filter after the upper-body correction
ZMP_INSET = 1e-4  # m inside the support polygon, where a reference ZMP outside it is moved: a 5 ms table stays inside


def _segments(step: PredictedStep) -> list[tuple[int, int]]:
    """(first, last) phases of each impact-free part: a touchdown ends every single support."""
    plan, out, first = phase_plan(step.spec), [], 0
    for p, (kind, _) in enumerate(plan):
        if kind == "ss" or p == len(plan) - 1:
            out.append((first, p))
            first = p + 1
    return out


class StepCurves:
    """A predicted step's signals as functions of real time from the step's start.

    Each impact-free part gets its own cubic spline, so velocities may jump at a touchdown
    (as they do physically) without the spline ringing.  A part's spline is built when it
    is first evaluated.

    Attributes
    ----------
    step : the :class:`PredictedStep`
    segments : per impact-free part, its (first, last) phases and real start and end times (s)
    """

    def __init__(self, step: PredictedStep):
        self.step = step
        edges = step.phase_edges
        self.segments = [(first, last, edges[first], edges[last + 1]) for first, last in _segments(step)]
        self._splines: dict[int, CubicSpline] = {}

    def knots(self, dt: float) -> list[np.ndarray]:
        """Per impact-free part, its sample times (s from the step's start), evenly spaced at
        most ``dt`` apart from its start to its end: a short last interval would blow up
        finite differences."""
        out = []
        for _, _, t0, t1 in self.segments:
            n = max(int(np.ceil((t1 - t0) / dt - 1e-9)), 1)
            out.append(np.linspace(t0, t1, n + 1))
        return out

    def at(self, t: np.ndarray, segment: int) -> tuple[np.ndarray, np.ndarray]:
        """The signals (n, I) and phase indices (n,) at real times ``t`` (s, from the step's
        start) within impact-free part ``segment``."""
        first, last, _, _ = self.segments[segment]
        edges, step = self.step.phase_edges, self.step
        if segment not in self._splines:
            b0, b1 = step.boundaries[first], step.boundaries[last + 1]
            inside = (step.tau > b0) & (step.tau < b1)
            knots = np.concatenate([[b0], step.tau[inside], [b1]])
            ends = [_value_at(step, b0, after=True), _value_at(step, b1, after=False)]
            self._splines[segment] = CubicSpline(knots, np.vstack([ends[0], step.values[inside], ends[1]]), axis=0)
        phases = np.clip(np.searchsorted(edges, t + TIME_TOLERANCE, side="right") - 1, first, last)
        return self._splines[segment](np.interp(t, edges, step.boundaries)), phases


def sample_step(step: PredictedStep, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Real times, signals and phase index of a step sampled at most ``dt`` apart
    (:class:`StepCurves`); the touchdown time between two impact-free parts appears twice,
    pre- and post-impact, as in every :class:`Motion`."""
    curves = StepCurves(step)
    ts, values, phases = [], [], []
    for k, t in enumerate(curves.knots(dt)):
        x, phase = curves.at(t, k)
        ts.append(t)
        values.append(x)
        phases.append(phase)
    return np.concatenate(ts), np.concatenate(values), np.concatenate(phases)


def _value_at(step: PredictedStep, b: float, after: bool) -> np.ndarray:
    """The step's signals (I,) at normalised time ``b``.  Where the grid repeats ``b`` (the
    touchdown between two parts a step was learned in), the post-impact value if ``after``,
    else the pre-impact one."""
    at = np.flatnonzero(step.tau == b)
    if len(at) > 1:
        return step.values[at[-1] if after else at[0]]
    return step.values_at(np.array([b]))[0]


def _support(air: str | None) -> np.ndarray:
    """(left, right) weights of the soles on the ground when ``air`` swings (None: both, evenly)."""
    if air is None:
        return np.array([0.5, 0.5])
    return np.array([float(air != side) for side in SIDES])


def anchor_weights(step: PredictedStep, t: np.ndarray, phase: np.ndarray, first: bool) -> np.ndarray:
    """Weight (n, 2) of the (left, right) sole in the pelvis position, per sample.

    Single support hangs on the stance sole; double support blends from the sole that
    carried the previous phase to the one that carries the next, so the pelvis never jumps.
    """
    edges = step.phase_edges
    plan = phase_plan(step.spec)
    # before the step the previous step's stance foot, this step's swing foot, carried the robot
    previous_air = None if first else OTHER_SIDE[step.spec.swing_side]
    out = np.zeros((len(t), 2))
    for p, (kind, air) in enumerate(plan):
        rows = phase == p
        if kind == "ss":
            out[rows] = _support(air)
            continue
        before = _support(plan[p - 1][1] if p > 0 else previous_air)
        after = _support(plan[p + 1][1] if p + 1 < len(plan) else None)
        s = (t[rows] - edges[p]) / (edges[p + 1] - edges[p])
        out[rows] = (1 - s)[:, None] * before + s[:, None] * after
    return out


def anchored(robot: Robot, step: PredictedStep, feet: dict, values: np.ndarray, phase: np.ndarray,
             weights: np.ndarray, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
    """World configurations (n, nq) and reference ZMP (n, 3) of a step's signals ``values``
    (n, I) in phases ``phase``: the learned joints and pelvis orientation, turned with the
    step's stance sole, and the pelvis hung from the soles on the ground (``feet``,
    :func:`~cocomopl.gait.footsteps`) by forward kinematics with the ``weights`` (n, 2) of
    :func:`anchor_weights`."""
    model = robot.model
    n_joints = len(robot.joint_names)
    plan = phase_plan(step.spec)
    joints, zmp_local, rpy = values[:, :n_joints], values[:, n_joints : n_joints + 3], values[:, n_joints + 3 :]
    # the step's signals are in its stance sole's frame, which the footsteps may have turned
    heading = flat_placement(0.0, 0.0, feet["yaw"]["start"][OTHER_SIDE[step.spec.swing_side]]).rotation
    q = np.empty((len(values), model.nq))
    zmp = np.empty((len(values), 3))
    for j in range(len(values)):
        R = heading @ pin.rpy.rpyToMatrix(rpy[j])
        q[j] = robot.q_ref
        q[j, :3] = 0.0
        q[j, 3:7] = [0, 0, 0, 1]
        q[j, 7:] = joints[j]
        pin.framesForwardKinematics(model, data, q[j])
        position = np.zeros(3)
        for s, side in enumerate(SIDES):
            if weights[j, s] > 0:
                sole = data.oMf[robot.foot_frames[side]].translation  # in the pelvis frame
                position += weights[j, s] * (ground_position(feet, plan, side, phase=phase[j]) - R @ sole)
        q[j, :3] = position
        q[j, 3:7] = pin.Quaternion(R).coeffs()
        zmp[j] = position + R @ zmp_local[j]
    return q, zmp


def soles_on_ground(step: PredictedStep, feet: dict, phase: np.ndarray) -> tuple[np.ndarray, list[list]]:
    """Per sample of a step in phases ``phase``: which soles (left, right) are in contact,
    (n, 2), and where each stands (a flat placement, None in the air)."""
    plan = phase_plan(step.spec)
    contact = np.array([[plan[p][1] != side for side in SIDES] for p in phase])
    ground = [[flat_placement(*ground_position(feet, plan, side, phase=p)[:2], ground_yaw(feet, plan, side, phase=p)) if c else None
               for side, c in zip(SIDES, row)]
              for p, row in zip(phase, contact)]
    return contact, ground


def zmp_in_support(robot: Robot, zmp: np.ndarray, ground: list[list]) -> np.ndarray:
    """The predicted reference ZMP (n, 3), each sample that leaves the support polygon of its
    soles on the ground (``ground``: per sample, each side's placement or None) moved to the
    polygon's nearest point, :data:`ZMP_INSET` inside.

    The primitives smooth the ZMP's jump at a touchdown, so the last sample before one can
    lean towards the landing foot; on narrow soles (the G1's are 50 mm wide) that leaves the
    stance sole, where no real ZMP can be.
    """
    out = zmp.copy()
    corners = np.array(robot.sole.corners(), dtype=float)[:, :2]
    sole = corners.min(axis=0), corners.max(axis=0)  # a sole's rectangle in its own frame
    for k, soles in enumerate(ground):
        placed = [placement for placement in soles if placement is not None]
        # a ZMP strictly on a sole lies inside the soles' hull, which costs 0.1 ms to build
        if placed and not any(_on_sole(zmp[k], placement, sole) for placement in placed):
            out[k, :2] = nearest_inside(soles_polygon(robot, placed), zmp[k, :2], ZMP_INSET)
    return out


def _on_sole(point: np.ndarray, placement: pin.SE3, sole: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether ``point`` (3,) lies strictly inside the rectangle ``sole`` (low, high corners in
    the sole's frame) of the sole at ``placement``."""
    local = (placement.rotation.T @ (point - placement.translation))[:2]
    return bool(np.all(sole[0] < local) and np.all(local < sole[1]))


def _upper_body_within_limits(robot: Robot, t, q, contact, impacts, ground, zmp) -> tuple[np.ndarray, dict]:
    """The upper-body limit correction of a filtered walk.  The corrected arms move the ZMP
    (by up to 5 cm on random walks), so the dynamics filter runs again, briefly, to take that
    back, and the correction once more on what the filter's new pelvis motion changes.

    Returns the configurations and the report of :func:`limit_upper_body`, from the first
    correction's excess to the last's.
    """
    upper = 7 + robot.upper_body_joint_indices()
    filtered = q[:, upper]
    q, first = limit_upper_body(robot, t, q, contact=contact, impacts=impacts)
    q, _, _ = dynamics_filter(robot, t, q, contact=contact, impacts=impacts, ground=ground, zmp_ref=zmp,
                              passes=REFILTER_PASSES)
    q, last = limit_upper_body(robot, t, q, contact=contact, impacts=impacts)
    report = {k: v for k, v in first.items() if k.endswith("_before")} | {k: v for k, v in last.items() if k.endswith("_after")}
    return q, report | {
        "largest_change_rad": float(np.abs(q[:, upper] - filtered).max()),
        "qps_solved": first["qps_solved"] + last["qps_solved"],
    }


def place_steps(robot: Robot, steps: list[PredictedStep], *, dt: float = 0.005,
                soles: dict[str, np.ndarray] | None = None) -> Motion:
    """The whole sequence as one world-frame :class:`Motion` sampled every ``dt`` seconds,
    starting from the sole poses ``soles`` (:func:`~cocomopl.gait.footsteps`; default: side
    by side at the origin)."""
    data = robot.model.createData()
    feet_per_step = footsteps(robot, [s.spec for s in steps], soles)
    ts, qs, zmps, contacts, phases, starts, impacts, ground = [], [], [], [], [], [], [], []
    offset, count = 0.0, 0
    for k, (step, feet) in enumerate(zip(steps, feet_per_step)):
        t, values, phase = sample_step(step, dt)
        weights = anchor_weights(step, t, phase, first=(k == 0))
        plan = phase_plan(step.spec)
        q, zmp = anchored(robot, step, feet, values, phase, weights, data)
        contact, on_ground = soles_on_ground(step, feet, phase)
        ground += on_ground
        for p in range(len(plan)):
            rows = np.flatnonzero(phase == p)
            phases.append((plan[p][0], count + int(rows[0]), count + int(rows[-1]) + (plan[p][0] == "ds" and p + 1 < len(plan))))
        impacts += [count + int(i) for i in np.flatnonzero(np.diff(t) == 0)]
        starts.append(count)
        ts.append(offset + t)
        qs.append(q)
        zmps.append(zmp)
        contacts.append(contact)
        offset += t[-1]
        count += len(t)
        impacts.append(count - 1)
    t, q, contact = np.concatenate(ts), np.concatenate(qs), np.concatenate(contacts)
    zmp = zmp_in_support(robot, np.concatenate(zmps), ground)
    impacts = np.array(impacts[:-1], dtype=int)
    q, filter_errors, kept = dynamics_filter(robot, t, q, contact=contact, impacts=impacts, ground=ground, zmp_ref=zmp)
    q, upper_body = _upper_body_within_limits(robot, t, q, contact, impacts, ground, zmp)
    motion = kinematic_motion(
        robot, t, q, contact=contact, impacts=impacts, phases=phases, steps=[s.spec for s in steps],
        step_starts=np.array(starts), producer="primitives", zmp=zmp,
    )
    # the upper-body correction and the filter's second run move the ZMP after the first
    # run's kept pass: what the walk is judged by is the plan's own
    motion.plan = PlanRecord(dynamics_filter_zmp_error_m=filter_errors, dynamics_filter_kept_error_m=filter_errors[kept],
                             upper_body_limits=upper_body, plan_zmp_error_m=plan_zmp_error(robot, motion))
    return motion


def replace_stretch(robot: Robot, motion: Motion, steps: list[PredictedStep], *, step: int,
                    dt: float = 0.005) -> Motion:
    """``motion`` with the stretch of steps from a start to a stop that holds ``step`` placed
    anew from ``steps``, the whole walk's predicted steps, of which only that stretch changed.

    A walk through several goals stands still, feet side by side, between its stretches, so
    one can be placed alone and joined to the others where they stand: a change then costs
    the placement of its stretch, not of the whole walk.  Later stretches keep their samples,
    moved in time by the change of the stretch's duration.
    """
    specs = [s.spec for s in steps]
    first = max(k for k in range(step + 1) if specs[k].kind == "start")
    last = next(k for k in range(step, len(specs)) if specs[k].kind == "stop")
    if len(specs) != len(motion.steps) or specs[:first] != motion.steps[:first] or specs[last + 1 :] != motion.steps[last + 1 :]:
        raise ValueError("only the stretch holding the changed step may differ from the motion's steps")
    stretch = place_steps(robot, steps[first : last + 1], dt=dt, soles=sole_poses(robot, specs)[first])
    a = int(motion.step_starts[first])
    b = int(motion.step_starts[last + 1]) if last + 1 < len(specs) else motion.n
    t_new = stretch.t + motion.t[a]
    shift = (len(stretch.t) + a) - b  # of the later samples' indices
    later_t = motion.t[b:] + (t_new[-1] - motion.t[b]) if b < motion.n else motion.t[b:]

    impacts = [int(i) for i in motion.impacts if i < a] + [int(i) + a for i in stretch.impacts]
    if b < motion.n:  # the stretch's last sample and the next one share their time
        impacts.append(a + len(stretch.t) - 1)
    impacts += [int(i) + shift for i in motion.impacts if i >= b]
    return Motion(
        t=np.concatenate([motion.t[:a], t_new, later_t]),
        **{field: np.concatenate([getattr(motion, field)[:a], getattr(stretch, field), getattr(motion, field)[b:]])
           for field in SAMPLED},
        phases=[p for p in motion.phases if p[1] < a] + [(k, f + a, l + a) for k, f, l in stretch.phases]
        + [(k, f + shift, l + shift) for k, f, l in motion.phases if f >= b],
        impacts=np.array(impacts, dtype=int),
        steps=specs,
        step_starts=np.concatenate([motion.step_starts[:first], stretch.step_starts + a, motion.step_starts[last + 1 :] + shift]),
        joint_names=list(motion.joint_names),
        robot=motion.robot,
        meta={**motion.meta, **stretch.meta},
        producer=stretch.producer,
        plan=replace(stretch.plan, model=motion.plan.model, lengths_mm=motion.plan.lengths_mm,
                     footsteps=motion.plan.footsteps),
    )
