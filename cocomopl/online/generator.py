"""A walking pattern generator that streams whole-body references tick by tick.

:class:`WalkingGenerator` holds the robot's stance and the steps ahead of it.  Commands (a
velocity command, a list of footsteps, stop) may come at any time; each control tick
(:meth:`WalkingGenerator.tick`) returns the joint positions, velocities, feed-forward
torques, the reference ZMP and the soles' contact state of one instant.

How a tick is made, causally:

1. **Steps, just in time.**  When the stream needs a step that is not planned yet, its
   footstep comes from the command (:mod:`cocomopl.online.commands`) or the footstep queue,
   and the primitives predict it with its start conditioned on the previous step's end (the
   paper's chaining, :meth:`~cocomopl.primitives.estimator.PredictedStep.conditioned_on`).
2. **Kinematic knots**, placed in the world as the whole-walk placement places them
   (:func:`~cocomopl.synthesis.world.place_steps`, on its sample times, every ``plan_dt`` at
   most, a touchdown's time twice): the learned joints and pelvis orientation, the pelvis
   hung from the soles on the ground, the learned reference ZMP.
3. **The dynamics filter as preview control** (Kajita et al., IROS 2003, sec. IV, its
   online form): the multibody ZMP of the knots, from the floating base's rows of inverse
   dynamics, against the reference; a ZMP preview servo
   (:class:`~cocomopl.baselines.preview_control.PreviewController`) over the next
   ``preview_s`` seconds of that error gives the pelvis the horizontal shift that cancels
   it, by the multibody ZMP's own answer to a pelvis shift
   (:func:`~cocomopl.synthesis.dynamics_filter.pelvis_shift_response`), and the legs are
   placed by inverse kinematics so the soles stay on their footsteps (in the air, on their
   learned path bent to land on the footstep).  ``passes`` such passes run one after the
   other, each on the one before's knots, as the whole-walk filter's passes do; a local
   least-squares correction over blocks of ``BLOCK_INSTANTS`` instants then takes out the
   short errors at touchdowns and lift-offs.
4. **Ticks** between the filtered knots, on the uniform cubic B-spline they control (through
   a touchdown too, its pre-impact knot left out, so the velocities stay continuous);
   inverse dynamics gives their torques and contact wrenches.

The stages run ahead of the tick returned, a few knots a tick, so that no tick computes a
preview horizon at once.  A command replaces the steps that begin a whole ``passes *
preview_s`` after the last corrected block, so that every pass previews them; the steps
before stay, and the new ones are conditioned on the end of the last kept one, so no
reference jumps.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from cocomopl.baselines.preview_control import PreviewController
from cocomopl.dynamics import GRAVITY, SIDES, contact_inverse_dynamics, kinematic_motion, total_wrench_zmp
from cocomopl.errors import Error
from cocomopl.export.grid import GridMotion
from cocomopl.gait import OTHER_SIDE, footsteps, initial_soles, phase_plan
from cocomopl.kinematics import flat_placement, leg_joints, place_legs
from cocomopl.motion import Footstep, Motion, StepSpec
from cocomopl.online.commands import STOP, VelocityCommand, command_footstep, step_period
from cocomopl.planning.footsteps import Landing, same_footstep
from cocomopl.primitives.estimator import MovementPrimitives, PredictedStep
from cocomopl.primitives.model_file import model_robot
from cocomopl.requests import PLAN_DT, PLAN_DT_RANGE
from cocomopl.robot import Robot
from cocomopl.synthesis.dynamics_filter import FILTER_HEIGHT_WEIGHT, pelvis_shift_response
from cocomopl.synthesis.step_chain import in_next_step_frame
from cocomopl.synthesis.world import StepCurves, anchor_weights, anchored, soles_on_ground, zmp_in_support

TICK_S = 0.005  # the default control period
PREVIEW_S = 0.75  # s of the ZMP error each filter pass previews
PASSES = 2
SERVO_WEIGHT_INPUT = 1e-8  # the preview servo's jerk weight
ERROR_GAIN = 1.0  # share of the ZMP error each pass corrects (divided by the response's kappa)
TIME_EPS = 1e-9  # s: times this close are the same instant
BLOCK_INSTANTS = 8  # of the local correction after the preview passes
WORK_ITEMS = 2  # stage knots a tick works ahead at most
PREVIEW_MARGIN = 4  # knots a preview pass's input runs beyond its horizon: touchdowns' twin knots
BLOCK_SIZE_WEIGHT = 1e-3  # of its shifts (m) against its ZMP errors (m), as the whole-walk filter's SIZE_WEIGHT


@dataclass(frozen=True)
class Reference:
    """What the generator commands at one control tick.

    Attributes
    ----------
    t : s since the generator started
    q : (nq,) configuration: base position, base quaternion (x, y, z, w), joint angles (rad)
    v : (nv,) velocity: base twist in the base frame, joint velocities
    tau : (nu,) feed-forward joint torques, N m
    wrenches : (2, 6) the contact wrenches of the (left, right) soles those torques assume
    zmp : (3,) reference ZMP, world frame, m
    contact : (2,) bool, (left, right) sole on the ground
    step : the step under way, None while standing
    landings : the landings planned ahead, world frame, in order
    """

    t: float
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    wrenches: np.ndarray
    zmp: np.ndarray
    contact: np.ndarray
    step: StepSpec | None
    landings: tuple[Landing, ...]


@dataclass
class _Knot:
    """One knot of the kinematic stream: time, configuration, reference ZMP, contacts, the
    soles' targets (on the ground, or on their bent swing path), the step (None: standing),
    its impact-free stretch and whether a touchdown follows it at the same time."""

    t: float
    q: np.ndarray
    zmp: np.ndarray
    contact: np.ndarray
    targets: list
    spec: StepSpec | None
    stretch: int
    pre_impact: bool = False
    instant: int = 0  # a touchdown's two knots are one instant


@dataclass(frozen=True)
class _Stance:
    """Where the walk stands between two steps: the soles' poses (x, y, yaw) by side, the
    step before (None: none yet), its end signals in the next step's frame and, while the
    robot stands, its standing knot."""

    soles: dict
    spec: StepSpec | None
    end: np.ndarray
    rest: _Knot | None = None

    @property
    def standing(self) -> bool:
        return self.rest is not None


@dataclass
class _Planned:
    """A step placed in the world from real time ``t0``, the stance before it and its knot
    times (s from its start) per impact-free part."""

    spec: StepSpec
    step: PredictedStep
    curves: StepCurves
    feet: dict
    t0: float
    before: _Stance
    knots: list = field(default_factory=list)
    swings: list | None = None  # (lift-off s, touchdown s, foot, lift twist, land twist), when first needed

    @property
    def t1(self) -> float:
        return self.t0 + self.step.duration

    @property
    def landing(self) -> Landing:
        side = self.spec.swing_side
        return Landing(float(self.feet["end"][side][0]), float(self.feet["end"][side][1]), self.feet["yaw"]["end"][side], side)


@dataclass
class _Pass:
    """One pass of the causal dynamics filter, by knot: the ZMP errors of its input, the
    preview servo's states, the pelvis shifts so far (this pass's and the passes' before)
    and its filtered configurations."""

    errors: dict = field(default_factory=dict)
    states: dict = field(default_factory=dict)
    shifts: dict = field(default_factory=dict)
    outputs: dict = field(default_factory=dict)

    def forget_after(self, committed: int, *, errors_from: int) -> None:
        """Drop the knots after ``committed``, and the errors from ``errors_from`` on."""
        for store, first in ((self.outputs, committed + 1), (self.shifts, committed + 1), (self.errors, errors_from),
                             (self.states, committed + 2)):
            for index in [i for i in store if i >= first]:
                del store[index]

    def forget_before(self, first: int) -> None:
        for store in (self.errors, self.states, self.shifts, self.outputs):
            for index in [i for i in store if i < first]:
                del store[index]


class WalkingGenerator:
    """Streams a walk's references tick by tick from the movement primitives.

    Parameters
    ----------
    model : a fitted model (the step-space one for velocity commands: a straight model's
        footsteps have neither width nor turn); its arrays are prepared for prediction here
    robot : the robot it was trained for; default the model's
    dt : the control period, s (5 ms by default; 1 ms to ``plan_dt``)
    plan_dt : the knots' spacing at most, s, as the whole-walk placement's ``dt``
    preview_s : how far ahead (s) each pass of the dynamics filter previews the ZMP error
    passes : the dynamics filter's passes, each on the one before's knots
    soles : the soles' starting poses (x, y, yaw) by side; default side by side at the origin
    keep_knots : keep every filtered knot, for :meth:`knot_motion`

    Attributes
    ----------
    period_ : s, the step period a velocity command's footsteps are sized by
    limits_ : the footstep range the model was trained on; commands are saturated to it
    generation_s_ : s spent predicting steps so far (the rest of a tick places and filters)
    """

    def __init__(self, model: MovementPrimitives, robot: Robot | None = None, *, dt: float = TICK_S, plan_dt: float = PLAN_DT,
                 preview_s: float = PREVIEW_S, passes: int = PASSES, soles: dict[str, np.ndarray] | None = None,
                 keep_knots: bool = False):
        if not (_is_number(plan_dt) and PLAN_DT_RANGE[0] <= plan_dt <= PLAN_DT_RANGE[1]):
            raise Error(f"knot spacing {plan_dt!r} s is outside {PLAN_DT_RANGE[0]:g}..{PLAN_DT_RANGE[1]:g} s")
        if not (_is_number(dt) and 0.001 <= dt <= plan_dt):
            raise Error(f"control period {dt!r} s is outside 0.001..{plan_dt:g} s")
        if not (_is_number(preview_s) and 4 * plan_dt <= preview_s <= 5.0):
            raise Error(f"preview {preview_s!r} s is outside {4 * plan_dt:g}..5 s")
        if not (isinstance(passes, int) and not isinstance(passes, bool) and 1 <= passes <= 6):
            raise Error(f"{passes!r} filter passes is outside 1..6")
        robot = model_robot(model) if robot is None else robot
        self.model, self.robot, self.dt, self.plan_dt, self.preview_s = model.prepare(), robot, float(dt), float(plan_dt), float(preview_s)
        self.period_ = step_period(model)
        self.limits_ = model.footstep_range()
        self._data = robot.model.createData()
        self._legs = leg_joints(robot)
        self._command = STOP
        self._queue: list[Footstep] = []
        self._planned: list[_Planned] = []
        self._slots: dict[int, tuple] = {}  # knot index -> (time, step or None, part, time in the step)
        self._knots: dict[int, _Knot] = {}
        self._passes = [_Pass() for _ in range(passes + 1)]  # the preview passes, then the local correction
        self._block_first: dict[int, int] = {}  # first knot of each block of the local correction
        self._k, self._interval = 0, 0  # the next tick; the knot at or before it
        self._kept: list[tuple[_Knot, np.ndarray]] | None = [] if keep_knots else None
        self._walked: list[_Planned] = []  # with keep_knots, the steps already walked and let go
        self.generation_s_ = 0.0
        soles = {s: np.asarray(p, dtype=float) for s, p in (soles or initial_soles(robot)).items()}
        first = model.predict(StepSpec.between("start", Footstep(0.0), Footstep(0.0)))
        stance = _Stance(soles, None, first.values[0])
        standing = _Planned(first.spec, first, StepCurves(first), footsteps(robot, [first.spec], soles)[0], 0.0, stance,
                            swings=[])
        self._stance = replace(stance, rest=self._knot_of_step(standing, 0, 0.0, stretch=0))
        kappa, height = pelvis_shift_response(robot, self._stance.rest.q)
        self._gain, self._kappa, self._height = ERROR_GAIN / kappa, kappa, height
        self._servo = PreviewController(plan_dt, height, preview_time=preview_s, weight_input=SERVO_WEIGHT_INPUT)
        self._horizon = len(self._servo.gain_preview)
        # the first pass starts at rest where its shift cancels the standing posture's static ZMP error
        rest = self._stance.rest
        error = total_wrench_zmp(robot, self._data, rest.q, np.zeros(robot.model.nv), np.zeros(robot.model.nv)) - rest.zmp[:2]
        for stage, filter_pass in enumerate(self._passes):
            filter_pass.states[0] = self._servo.at_rest(-self._gain * error if stage == 0 else np.zeros(2))
        while self._work_ahead():  # the pipeline filled while the robot stands: no tick fills it at once
            pass

    # ------------------------------------------------------------------ commands
    @property
    def time(self) -> float:
        """s, the time of the next tick."""
        return self._k * self.dt

    def command(self, command: VelocityCommand) -> None:
        """Walk at ``command`` from the first step boundary that can still change; a stop
        command ends the walk with a stop step, then the robot stands."""
        self._queue, self._command = [], command
        self._replan()

    def walk_footsteps(self, footsteps: list[Footstep]) -> None:
        """Take these footsteps (each where a sole lands from the other, as a
        :class:`~cocomopl.motion.StepSpec` measures them), then stop."""
        self._queue, self._command = [Footstep(*map(float, f)) for f in footsteps], STOP
        self._replan()

    def follow(self, commands: list[tuple[float, VelocityCommand]], *, standing_s: float = 1.0) -> list[Reference]:
        """Tick through timed ``commands`` ((s from now, command), in order, the last a stop),
        each given at its time, until the robot has stood still for ``standing_s`` with no
        step ahead of it: the references of every tick."""
        start, pending, references, still = self.time, list(commands), [], 0
        limit = start + (pending[-1][0] if pending else 0.0) + len(self._passes) * self.preview_s + 10 * self.period_
        while self.time < limit:
            while pending and self.time >= start + pending[0][0] - TIME_EPS:
                self.command(pending.pop(0)[1])
            references.append(self.tick())
            # standing still: no command or footstep left to walk, and no step under way or planned
            done = not pending and self._command.is_stop and not self._queue
            still = still + 1 if done and references[-1].step is None and not references[-1].landings else 0
            if still * self.dt >= standing_s:
                break
        return references

    def walked_steps(self) -> list[PredictedStep]:
        """The predicted steps the knots kept for :meth:`knot_motion` belong to, in order."""
        if self._kept is None:
            raise Error("walked_steps needs a generator made with keep_knots=True")
        specs = self.knot_motion().steps
        return [p.step for p in (self._walked + self._planned)[: len(specs)]]

    def _replan(self) -> None:
        """Drop the steps not begun by the end of the last corrected block (``committed``),
        their knots and everything computed from them; the knots of the steps under way stay."""
        committed = max(self._passes[-1].shifts, default=-1)
        # the filter's passes see a change a whole preview ahead: the steps that begin before stay
        t = (self._slots[committed][0] if committed >= 0 else 0.0) + len(self._passes[:-1]) * self.preview_s
        kept = [p for p in self._planned if p.t0 <= t + TIME_EPS]
        if len(kept) < len(self._planned):
            self._stance = self._planned[len(kept)].before
        self._planned = kept
        # the first knot that changes: the first of a dropped step, or a standing robot's first after t
        changed = min([i for i, (ti, p, _, _) in self._slots.items()
                       if i > committed and ti > t + TIME_EPS and (p is None or p not in kept)],
                      default=max(self._slots, default=-1) + 1)
        changed = max(changed - 1, committed + 1)  # the knot before: whether a touchdown follows it is not known yet
        for store in (self._slots, self._knots):
            for index in [i for i in store if i >= changed]:
                del store[index]
        for block in [b for b, i in self._block_first.items() if i >= changed]:
            del self._block_first[block]
        for stage, filter_pass in enumerate(self._passes):
            # a knot's error depends on the knots either side of it; a pass's later knots on its preview
            filter_pass.forget_after(committed, errors_from=changed - 1 if stage == 0 else committed)

    # ------------------------------------------------------------------ planning
    def _next_spec(self) -> StepSpec | None:
        """The next step from the footstep queue or the command; None: keep standing."""
        stance = self._stance
        side = self._lead_side() if stance.standing else OTHER_SIDE[stance.spec.swing_side]
        if self._queue:
            footstep = self._queue.pop(0)
        elif self._command.is_stop:
            footstep = None
        else:
            footstep = command_footstep(self._command, side, period=self.period_, limits=self.limits_)
        if stance.standing:
            return None if footstep is None else StepSpec.between("start", Footstep(0.0), footstep, swing_side=side)
        previous = stance.spec.end_footstep
        if footstep is None:
            return StepSpec.between("stop", previous, Footstep(0.0), swing_side=side)
        kind = "cyclic" if same_footstep(previous, footstep) else "transition"
        return StepSpec.between(kind, previous, previous if kind == "cyclic" else footstep, swing_side=side)

    def _lead_side(self) -> str:
        """The first foot to swing: the one on the side the command goes (the left if straight)."""
        c = self._command
        return "left" if c.sideways > 0 or (c.sideways == 0 and c.yaw_rate >= 0) else "right"

    def _plan(self, t0: float) -> _Planned | None:
        """The next step, from ``t0`` s; None if the robot is to keep standing."""
        spec = self._next_spec()
        if spec is None:
            return None
        before = self._stance
        started = time.perf_counter()
        step = self.model.predict(spec, start=before.end)
        self.generation_s_ += time.perf_counter() - started
        feet = footsteps(self.robot, [spec], before.soles)[0]
        planned = _Planned(spec, step, StepCurves(step), feet, t0, before)
        planned.knots = planned.curves.knots(self.plan_dt)
        soles = {side: np.array([*feet["end"][side][:2], feet["yaw"]["end"][side]]) for side in SIDES}
        last = len(planned.knots) - 1
        rest = self._knot_of_step(planned, last, step.duration, stretch=0) if spec.kind == "stop" else None
        self._stance = _Stance(soles, spec, in_next_step_frame(self.model, spec, step.values[-1]), rest)
        self._planned.append(planned)
        return planned

    def _swings(self, p: _Planned) -> list:
        """Per swing of step ``p``: lift-off and touchdown (s from the step's start), the foot,
        and the twists that bend its learned path to leave from and land on its footsteps."""
        out, edges = [], p.step.phase_edges
        for phase, (kind, air) in enumerate(phase_plan(p.spec)):
            if kind == "ss":
                twists = []
                for t, when in ((edges[phase], "start"), (edges[phase + 1], "end")):
                    part = max(k for k, times in enumerate(p.knots) if times[0] <= t + TIME_EPS and t <= times[-1] + TIME_EPS)
                    placed = self.robot.frame_placement(self._kinematic(p, part, t)[0], self.robot.foot_frames[air])
                    ground = flat_placement(*p.feet[when][air][:2], p.feet["yaw"][when][air])
                    twists.append(pin.log6(ground * placed.inverse()).vector)
                out.append((edges[phase], edges[phase + 1], air, *twists))
        return out

    # ------------------------------------------------------------------ the kinematic knots
    def _slot(self, index: int) -> tuple:
        """Knot ``index``'s (time, step or None, part of the step, time in the step),
        planning steps as the stream reaches them."""
        while index not in self._slots:
            last = max(self._slots, default=-1)
            t, p, part, local = self._slots[last] if last >= 0 else (-self.plan_dt, None, 0, 0.0)
            if p is not None:
                times = p.knots[part]
                k = int(np.searchsorted(times, local + TIME_EPS))
                if k < len(times):
                    self._slots[last + 1] = (p.t0 + times[k], p, part, times[k])
                    continue
                if part + 1 < len(p.knots):  # a touchdown inside the step: its time again, post-impact
                    self._slots[last + 1] = (t, p, part + 1, p.knots[part + 1][0])
                    continue
            # after a step ending in a touchdown the next starts there; a standing robot starts at the next knot
            t0 = t if p is not None and p.spec.kind != "stop" else t + self.plan_dt
            nxt = self._plan(t0)
            self._slots[last + 1] = (t0, nxt, 0, 0.0) if nxt is not None else (t0, None, 0, 0.0)
        return self._slots[index]

    def _knot(self, index: int) -> _Knot:
        """Kinematic knot ``index`` (the knots before it made first)."""
        if index not in self._knots:
            for i in range(max(self._knots, default=-1) + 1, index + 1):
                t, p, part, local = self._slot(i)
                before = self._knots.get(i - 1)
                # a knot whose time repeats the one before is post-impact: a new impact-free stretch
                stretch = 0 if before is None else before.stretch + (abs(t - before.t) < TIME_EPS)
                if p is None:
                    knot = replace(self._stance_at(i).rest, t=t, stretch=stretch, spec=None)
                else:
                    knot = self._knot_of_step(p, part, local, stretch=stretch)
                knot.pre_impact = abs(self._slot(i + 1)[0] - t) < TIME_EPS
                knot.instant = 0 if before is None else before.instant + (not before.pre_impact)
                if knot.instant % BLOCK_INSTANTS == 0 and (before is None or not before.pre_impact):
                    self._block_first[knot.instant // BLOCK_INSTANTS] = i
                self._knots[i] = knot
        return self._knots[index]

    def _stance_at(self, index: int) -> _Stance:
        """The stance a standing knot ``index`` stands in: after the last step planned before it."""
        t = self._slots[index][0]
        steps = [p for p in self._planned if p.t0 <= t + TIME_EPS]
        return self._stance if len(steps) == len(self._planned) else self._planned[len(steps)].before

    def _kinematic(self, p: _Planned, part: int, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Configuration (nq,), reference ZMP (3,) and phase (1,) of step ``p`` at ``t`` s from
        its start in impact-free part ``part``, placed in the world."""
        values, phase = p.curves.at(np.array([t]), part)
        weights = anchor_weights(p.step, np.array([t]), phase, first=p.spec.kind == "start")
        q, zmp = anchored(self.robot, p.step, p.feet, values, phase, weights, self._data)
        return q[0], zmp[0], phase

    def _knot_of_step(self, p: _Planned, part: int, t: float, *, stretch: int) -> _Knot:
        """The kinematic knot of step ``p`` at ``t`` s from its start, in part ``part``."""
        if p.swings is None:
            p.swings = self._swings(p)
        q, zmp, phase = self._kinematic(p, part, t)
        contact, ground = soles_on_ground(p.step, p.feet, phase)
        targets = [g if g is not None else self.robot.frame_placement(q, self.robot.foot_frames[side])
                   for side, g in zip(SIDES, ground[0])]
        for t_lift, t_land, air, lift, land in p.swings:
            if t_lift - TIME_EPS <= t <= t_land + TIME_EPS:
                s = min(max((t - t_lift) / (t_land - t_lift), 0.0), 1.0)
                s = s * s * (3 - 2 * s)  # smoothstep: no velocity jump at lift-off or touchdown
                j = SIDES.index(air)
                targets[j] = pin.exp6((1 - s) * lift + s * land) * targets[j]
        zmp = zmp_in_support(self.robot, zmp[None], ground)[0]  # as the whole-walk placement's
        return _Knot(p.t0 + t, q, zmp, contact[0], targets, p.spec, stretch)

    # ------------------------------------------------------------------ the filter
    def _input(self, stage: int, index: int) -> np.ndarray:
        """The configuration that enters filter pass ``stage`` at knot ``index``."""
        return self._knot(index).q if stage == 0 else self._output(stage - 1, index)

    def _error(self, stage: int, index: int) -> np.ndarray:
        """The multibody ZMP less the reference (2,) of the input of pass ``stage`` at knot
        ``index``, with the differences of :func:`~cocomopl.dynamics.inverse_dynamics_with_contacts`,
        by which the walk is judged: velocity backwards, acceleration forwards; at a
        stretch's first knot the velocity of the knot after it (the walk's first) or the
        mean of the velocities either side of the touchdown (a post-impact knot)."""
        errors = self._passes[stage].errors
        if index not in errors:
            model = self.robot.model
            now, after = self._knot(index), self._knot(index + 1)
            q1, q2 = self._input(stage, index), self._input(stage, index + 1)
            v_after = pin.difference(model, q1, q2) / (after.t - now.t)
            before = self._knots.get(index - 1)
            if before is None:
                v = v_after
            elif before.stretch == now.stretch:
                v = pin.difference(model, self._input(stage, index - 1), q1) / (now.t - before.t)
            else:
                first = self._knots[index - 2]
                v_before = pin.difference(model, self._input(stage, index - 2), self._input(stage, index - 1)) / (before.t - first.t)
                v = 0.5 * (v_before + v_after)
            a = (v_after - v) / (after.t - now.t)
            errors[index] = total_wrench_zmp(self.robot, self._data, q1, v, a) - now.zmp[:2]
        return errors[index]

    def _preview(self, stage: int, index: int) -> np.ndarray:
        """The errors of pass ``stage`` from knot ``index`` over the servo's horizon, one per
        instant (a pre-impact knot's instant is its post-impact knot's)."""
        out, i = [], index
        while len(out) <= self._horizon:
            if not self._knot(i).pre_impact:
                out.append(self._error(stage, i))
            i += 1
        return np.array(out)

    def _output(self, stage: int, index: int) -> np.ndarray:
        """The configuration filter pass ``stage`` gives knot ``index`` (its knots before
        first: the preview servo runs in order, one period per instant)."""
        filter_pass = self._passes[stage]
        if stage == len(self._passes) - 1:
            if index not in filter_pass.outputs:
                if index not in filter_pass.shifts:
                    self._correct_block(self._knot(index).instant // BLOCK_INSTANTS)
                knot = self._knots[index]
                q = self._output(stage - 1, index).copy()  # its legs nearly placed already
                q[:2] = knot.q[:2] + filter_pass.shifts[index]
                filter_pass.outputs[index] = place_legs(self.robot, q, dict(zip(SIDES, knot.targets)), legs=self._legs,
                                                        height_weight=FILTER_HEIGHT_WEIGHT, data=self._data)
        elif index not in filter_pass.outputs:
            for i in range(max(filter_pass.outputs, default=-1) + 1, index + 1):
                state, knot = filter_pass.states[i], self._knot(i)
                filter_pass.states[i + 1] = state if knot.pre_impact else self._servo.step(
                    state, -self._gain * self._preview(stage, i))
                shift = state.x[0] + (self._passes[stage - 1].shifts[i] if stage else 0.0)
                q = (self._output(stage - 1, i) if stage else knot.q).copy()  # the legs nearly placed already
                q[:2] = knot.q[:2] + shift
                filter_pass.shifts[i] = shift
                filter_pass.outputs[i] = place_legs(self.robot, q, dict(zip(SIDES, knot.targets)), legs=self._legs,
                                                    height_weight=FILTER_HEIGHT_WEIGHT, data=self._data)
        return filter_pass.outputs[index]

    def _correct_block(self, block: int) -> None:
        """The local correction's pelvis shifts of the knots of ``block`` (``BLOCK_INSTANTS``
        instants): the shifts, zero at the block's first and last instant, whose cart-table ZMP
        (:func:`~cocomopl.synthesis.dynamics_filter.pelvis_shift_response`) cancels the last
        preview pass's error over the block in least squares, as the whole-walk filter
        cancels it over the walk.  It takes out what a preview servo leaves: the short
        errors at touchdowns and lift-offs, which its smooth jerk cannot follow."""
        stage = len(self._passes) - 1
        first = self._block_first[block]
        knots = []
        while self._knot(first + len(knots)).instant < (block + 1) * BLOCK_INSTANTS:
            knots.append(first + len(knots))
        rows = [i for i in knots if not self._knots[i].pre_impact]
        errors = np.array([self._error(stage, i) for i in rows])
        t = np.array([self._knots[i].t for i in rows])
        before = self._knots.get(first - 1)
        t_before = before.t if before is not None else t[0] - self.plan_dt
        t_after = self._knot(knots[-1] + 1).t
        times = np.concatenate([[t_before], t, [t_after]])
        n = len(rows)
        response = np.zeros((n, n + 2))  # on the shifts at the instants before, in and after the block
        for r in range(n):
            h0, h1 = times[r + 1] - times[r], times[r + 2] - times[r + 1]
            second = np.array([2 / (h0 * (h0 + h1)), -2 / (h0 * h1), 2 / (h1 * (h0 + h1))])
            # a post-impact knot's velocity is the mean of those either side of the touchdown: half the curvature
            if self._knots.get(rows[r] - 1) is not None and self._knots[rows[r] - 1].pre_impact:
                second = second / 2
            response[r, r : r + 3] -= self._height / GRAVITY * second
            response[r, r + 1] += 1.0
        free = response[:, 2:n]  # the block's first and last instant stay put, so do the shifts beyond
        A = np.vstack([self._kappa * free, np.sqrt(BLOCK_SIZE_WEIGHT) * np.eye(n - 2)])
        shift_rows = np.zeros((n, 2))
        if n > 2:
            shift_rows[1:-1] = -np.linalg.lstsq(A, np.vstack([errors, np.zeros((n - 2, 2))]), rcond=None)[0]
        shift_of = dict(zip(rows, shift_rows))
        for i in knots:
            self._passes[stage].shifts[i] = self._passes[stage - 1].shifts[i] + shift_of.get(i, shift_of.get(i + 1))

    def _work_ahead(self) -> int:
        """Up to ``WORK_ITEMS`` knots of the stages (kinematic knots, the preview passes, the
        local correction) whose inputs are ready, the stages in turn, the earlier ones
        further ahead, up to what the ticks of the block after the next will need: no tick
        then waits for a block or a preview horizon to be computed at once, even after a
        command dropped the steps ahead.  Returns the knots computed."""
        margin = self._horizon + PREVIEW_MARGIN
        targets = [self._interval + 2 + 2 * BLOCK_INSTANTS]  # the local correction
        targets.insert(0, targets[0] + BLOCK_INSTANTS + 2)  # the last preview pass: the block's errors
        while len(targets) < len(self._passes) + 1:  # the passes before it, then the kinematic knots
            targets.insert(0, targets[0] + margin)
        done = [max(self._knots, default=-1)] + [max(p.outputs, default=-1) for p in self._passes]
        items, steps = 0, len(self._planned)
        for k in range(len(targets)):
            stage = (self._k + k) % len(targets)
            while done[stage] < targets[stage] and items < WORK_ITEMS and self._ready(stage, done[stage] + 1, done):
                if stage == 0:
                    self._knot(done[0] + 1)
                else:
                    self._output(stage - 1, done[stage] + 1)
                done[stage] += 1
                items += 1
                if len(self._planned) != steps:  # a step was planned: enough for one tick
                    return items
        return items

    def _ready(self, stage: int, index: int, done: list[int]) -> bool:
        """Whether stage ``stage`` (0: the kinematic knots, then the filter's) has the inputs
        knot ``index`` needs, ``done`` the last knot of each stage computed."""
        if stage == 0:
            return True
        if stage < len(self._passes):
            return done[stage - 1] >= index + self._horizon + PREVIEW_MARGIN
        shifts = self._passes[-1].shifts
        if index in shifts:
            return True
        block = self._knot(index).instant // BLOCK_INSTANTS
        first = self._block_first.get(block + 1)
        return first is not None and done[stage - 1] >= first + 1

    # ------------------------------------------------------------------ the tick
    def tick(self) -> Reference:
        """The references of the next control tick."""
        t, model = self._k * self.dt, self.robot.model
        while self._slot(self._interval + 1)[0] <= t + TIME_EPS:  # at a touchdown, the post-impact knot
            self._interval += 1
        # the ticks run through a touchdown on one curve, its pre-impact knot left out: a
        # position-controlled robot's reference keeps its velocity continuous
        j, last = self._interval, len(self._passes) - 1
        before = j - 1 - (j - 1 in self._knots and self._knots[j - 1].pre_impact)
        following = j + 1 + self._knot(j + 1).pre_impact
        later = following + 1 + self._knot(following + 1).pre_impact
        now, after = self._knot(j), self._knot(following)
        knots = [self._output(last, i) if i in self._knots else None for i in (before, j, following, later)]
        h = after.t - now.t
        s = (t - now.t) / h
        q, v, a = _bspline(model, knots, s, h)
        zmp = (1 - s) * now.zmp + s * self._knots[j + 1].zmp  # up to a touchdown, the pre-impact ZMP
        tau, wrenches = contact_inverse_dynamics(self.robot, self._data, q, v, a, now.contact)
        if j - 3 in self._knots:  # something to forget: the knot before the two kept
            self._forget_before(j - 2)
        self._work_ahead()
        self._k += 1
        return Reference(t, q, v, tau, wrenches, zmp, now.contact, now.spec,
                         tuple(p.landing for p in self._planned if p.t1 > t + TIME_EPS))

    def _forget_before(self, first: int) -> None:
        """Drop the knots before ``first`` (kept for :meth:`knot_motion` if asked) and what
        was computed of them."""
        for index in [i for i in self._knots if i < first]:
            if self._kept is not None:
                self._kept.append((self._knots[index], self._passes[-1].outputs[index]))
            del self._knots[index]
        for index in [i for i in self._slots if i < first]:
            del self._slots[index]
        for filter_pass in self._passes:
            filter_pass.forget_before(first)
        t = self._slots[first][0]
        if self._kept is not None:
            self._walked += [p for p in self._planned if p.t1 <= t - 1.0]
        self._planned = [p for p in self._planned if p.t1 > t - 1.0]
        for block in [b for b, i in self._block_first.items() if i < first - 2 * BLOCK_INSTANTS]:
            del self._block_first[block]

    def knot_motion(self) -> Motion:
        """The filtered knots so far, up to the one before the next tick's, as a
        :class:`~cocomopl.motion.Motion` (inverse dynamics by
        :func:`~cocomopl.dynamics.kinematic_motion`, the reference ZMP as streamed): what the
        ticks interpolate, on the whole-walk placement's sample times."""
        if self._kept is None:
            raise Error("knot_motion needs a generator made with keep_knots=True")
        last = len(self._passes) - 1
        knots = self._kept + [(self._knots[i], self._output(last, i)) for i in sorted(self._knots) if i <= self._interval]
        # from the first step's first knot to the last step's last: standing before and after is the same posture
        walking = [k for k, (knot, _) in enumerate(knots) if knot.spec is not None]
        if not walking:
            raise Error("the generator has not walked yet: no step to make a motion of")
        knots = knots[walking[0] : walking[-1] + 1]
        t = np.array([k.t for k, _ in knots]) - knots[0][0].t
        contact = np.array([k.contact for k, _ in knots])
        impacts = np.array([i for i, (k, _) in enumerate(knots[:-1]) if k.pre_impact], dtype=int)
        phases, first = [], 0
        for i in range(1, len(knots) + 1):
            if i == len(knots) or not np.array_equal(contact[i], contact[first]):
                phases.append(("ds" if contact[first].all() else "ss", first, i - 1))
                first = i
        steps, starts = [], []
        for i, (k, _) in enumerate(knots):
            if k.spec is not None and (not steps or steps[-1] != k.spec or (i > 0 and knots[i - 1][0].spec is None)):
                steps.append(k.spec)
                starts.append(i)
        return kinematic_motion(self.robot, t, np.array([q for _, q in knots]), contact=contact, impacts=impacts,
                                phases=phases, steps=steps, step_starts=np.array(starts, dtype=int),
                                producer="primitives", zmp=np.array([k.zmp for k, _ in knots]))


def _is_number(value) -> bool:
    """Whether ``value`` is a real number (``True`` is an int in Python, not a number here)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _bspline(model: pin.Model, knots: list, s: float, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Configuration, velocity and acceleration at ``s`` in [0, 1) between the second and the
    third of four consecutive knots ``h`` s apart, on the uniform cubic B-spline they control,
    in the tangent space of the second.  At a knot its acceleration is the knots' second
    difference, the one the knot's ZMP was filtered with, and it is linear in between.  The
    curve passes within ``h^2 a / 6`` of the knots (0.1 mm of the CoM at 1 m/s^2).  A missing
    first knot (None: the walk's first interval) is extrapolated linearly."""
    middle = [pin.difference(model, knots[1], q) for q in knots[1:3]]
    first = pin.difference(model, knots[1], knots[0]) if knots[0] is not None else 2 * middle[0] - middle[1]
    last = pin.difference(model, knots[1], knots[3]) if knots[3] is not None else 2 * middle[1] - middle[0]
    controls = np.array([first, *middle, last])
    r = 1.0 - s
    position = np.array([r**3, 3 * s**3 - 6 * s**2 + 4, -3 * s**3 + 3 * s**2 + 3 * s + 1, s**3]) / 6.0 @ controls
    velocity = np.array([-r**2, 3 * s**2 - 4 * s, -3 * s**2 + 2 * s + 1, s**2]) / 2.0 @ controls
    acceleration = np.array([r, 3 * s - 2, 1 - 3 * s, s]) @ controls
    return pin.integrate(model, knots[1], position), velocity / h, acceleration / h**2


def grid_of(references: list[Reference]) -> GridMotion:
    """Streamed references as the export's 5 ms table (:class:`~cocomopl.export.grid.GridMotion`),
    for its safety gate (:func:`~cocomopl.export.safety.check_safe`): every streamed sample
    checked as an exported one is."""
    q = np.array([r.q for r in references])
    rpy = np.unwrap([pin.rpy.matrixToRpy(pin.Quaternion(x[6], x[3], x[4], x[5]).toRotationMatrix()) for x in q], axis=0)
    wrenches = np.array([r.wrenches for r in references])
    return GridMotion(
        t=np.array([r.t for r in references]) - references[0].t,
        joints=q[:, 7:],
        velocities=np.array([r.v[6:] for r in references]),
        torques=np.array([r.tau for r in references]),
        forces=wrenches[:, :, :3],
        moments=wrenches[:, :, 3:],
        contact=np.array([r.contact for r in references], dtype=float),
        waist=q[:, :3],
        waist_rpy=rpy,
        zmp=np.array([pin.rpy.rpyToMatrix(a).T @ (r.zmp - w) for a, r, w in zip(rpy, references, q[:, :3])]),
    )
