"""The classic baseline: a walk from ZMP preview control of the cart-table model (Kajita 2003),
set up as jrl-walkgen, the authors' reference implementation, runs it.

The footsteps and phase timing are given (the same as a generated walk's); the ZMP
reference stays at the stance sole's centre in single support and moves linearly to the
next stance sole over double support, starting and ending between the feet, and is
smoothed by jrl-walkgen's 50 ms sin² window.  Two stages, as jrl-walkgen's default
``ZMPPreviewControlWithMultiBodyZMP``:

1. preview control turns the reference into a CoM trajectory at a constant height; swing
   soles follow minimum-jerk paths with a bell-shaped lift; inverse kinematics, warm-started
   sample to sample, gives the whole body, the pelvis upright and the arms held;
2. the multibody ZMP of that motion (inverse dynamics) is brought back onto the reference by
   moving the pelvis horizontally: the dynamics filter the generated walks get
   (:mod:`cocomopl.synthesis.dynamics_filter`), Kajita et al.'s second stage solved over
   the whole walk instead of by a second preview controller.

The constant CoM height is the highest the legs can hold through the whole walk, found by
bisection on the pelvis height (:func:`highest_pelvis_drop`).  Torques and contact wrenches
come from Pinocchio inverse dynamics, so the result is a :class:`Motion` like any other and
can be checked against its own claims.  ``LEGACY`` keeps the earlier single-stage variant
(4 cm crouch, no smoothing, 8 cm swing) for comparison.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import NamedTuple

import numpy as np
import pinocchio as pin
from scipy.interpolate import CubicHermiteSpline

from cocomopl.baselines.preview_control import PreviewController
from cocomopl.dynamics import SIDES, kinematic_motion, sole_placements
from cocomopl.errors import Error
from cocomopl.gait import footsteps, ground_position, ground_yaw, mean_yaw, phase_plan
from cocomopl.kinematics import flat_placement, leg_joints, place_legs
from cocomopl.motion import Motion, StepSpec
from cocomopl.robot import Robot
from cocomopl.robot.description import checked_overrides, finite_number, positive_number
from cocomopl.synthesis.dynamics_filter import dynamics_filter, multibody_zmp, rms_zmp_error

STANDING_ITERATIONS = 10  # pelvis shifts to bring the CoM of the first posture above its target
REACH_TOLERANCE = 1e-3  # m: a sole farther than this from its target is out of the legs' reach
DROP_SEARCH_RESOLUTION = 1e-3  # m: where the pelvis height search stops


@dataclass(frozen=True)
class KajitaSettings:
    """Settings of the baseline, SI units.  The defaults are jrl-walkgen's set-up; ``LEGACY``
    is the earlier single-stage variant.

    Attributes
    ----------
    swing_height : peak height of the swing sole above the ground, m; :func:`swing_apex`
        measures a walk's, to match it
    preview_time : preview horizon, s
    weight_error, weight_input : preview-control weights ``Qe`` (ZMP error) and ``R`` (jerk)
    control_dt : sampling period of the preview controller, s (independent of the motion's)
    ik_iterations : pelvis shifts per sample towards the preview CoM, warm-started from the last
    prelude : standing time added to the walk's first double support, the ZMP reference held
        between the feet: preview control moves the CoM before the ZMP does, so a walk that
        starts from rest needs about the preview horizon to get going (without it, the
        cart-table ZMP of a 0.4 s start overshoots by metres)
    postlude : standing time added to a walk's final double support, the ZMP reference held
        between the feet: once the ZMP is there the CoM only closes in at the cart-table's
        own rate (time constant ``sqrt(z_c/g)``, about 0.3 s), so without it the walk ends
        with the CoM still moving sideways at about 0.1 m/s
    pelvis_drop : how much lower than in the reference posture the pelvis walks, m; None:
        the least the legs allow, so the highest feasible CoM (:func:`highest_pelvis_drop`)
    zmp_smoothing : length of jrl-walkgen's sin² window over the ZMP reference, s (``FilterZMPRef``,
        50 ms "from Kajita's San Matlab files"); 0: the piecewise-linear reference as it is
    second_stage : correct the whole body's multibody ZMP onto the reference (the dynamics
        filter); False leaves the cart-table's error in the plan
    drop_search_range : the pelvis drops (m, below the reference posture; negative is above
        it, where TALOS's knees straighten) the height search brackets
    """

    swing_height: float = 0.08
    preview_time: float = 1.6
    weight_error: float = 1.0
    weight_input: float = 1e-6
    control_dt: float = 0.005
    ik_iterations: int = 2
    prelude: float = 1.6
    postlude: float = 1.0
    pelvis_drop: float | None = None
    zmp_smoothing: float = 0.05
    second_stage: bool = True
    drop_search_range: tuple[float, float] = (-0.06, 0.12)

    def scaled_to(self, robot: Robot) -> KajitaSettings:
        """These settings (TALOS's) scaled to ``robot``'s size, then the description's
        ``defaults.kajita`` in place of any (docs/robots.md#settings-scaled-to-the-robot).

        Heights scale with the leg length and durations with its square root, the cart-table's
        time (``sqrt(z_c / g)``), so that the preview servo answers a ZMP reference in the
        robot's time and size as it answers TALOS's.  The preview weights are kept: they
        change that answer by less than the controller's fixed 5 ms period does.  TALOS's
        scale is exactly 1.

        Raises
        ------
        Error
            If ``defaults.kajita`` names a field that is not a setting or gives it a value of
            the wrong kind.
        """
        length, time = robot.scale.length, robot.scale.time
        scaled = replace(
            self,
            swing_height=self.swing_height * length,
            preview_time=self.preview_time * time,
            prelude=self.prelude * time,
            postlude=self.postlude * time,
            zmp_smoothing=self.zmp_smoothing * time,
            pelvis_drop=None if self.pelvis_drop is None else self.pelvis_drop * length,
            drop_search_range=(self.drop_search_range[0] * length, self.drop_search_range[1] * length),
        )
        return replace(scaled, **checked_overrides(robot.override("kajita") or {}, _OVERRIDE_CHECKS, section="kajita",
                                                   what="a Kajita setting (a field of KajitaSettings)"))


# per field of KajitaSettings: what a description may give it, and how to say so
_OVERRIDE_CHECKS = {
    **dict.fromkeys(("swing_height", "preview_time", "weight_error", "weight_input", "control_dt", "zmp_smoothing"),
                    (positive_number, "a positive number (SI units)")),
    **dict.fromkeys(("prelude", "postlude"), (lambda v: finite_number(v) and v >= 0, "a number of seconds, at least 0")),
    "ik_iterations": (lambda v: isinstance(v, int) and not isinstance(v, bool) and v > 0, "a positive whole number"),
    "pelvis_drop": (lambda v: v is None or finite_number(v), "a number in m, or null to search for it"),
    "second_stage": (lambda v: isinstance(v, bool), "true or false"),
    "drop_search_range": (lambda v: isinstance(v, list) and len(v) == 2 and all(map(finite_number, v)) and v[0] < v[1],
                          "[low, high] in m, low < high"),
}


# The single-stage baseline (`reproduce --kajita legacy`): a fixed 4 cm crouch, the raw
# reference, no multibody correction, to compare with (docs/results.md#the-papers-experiment).
LEGACY = KajitaSettings(pelvis_drop=0.04, zmp_smoothing=0.0, second_stage=False)
VARIANTS = {"two-stage": KajitaSettings(), "legacy": LEGACY}


@dataclass(frozen=True)
class SupportPhase:
    """One phase of a walk, both soles down (``ds``) or one swinging (``ss``).

    Attributes
    ----------
    kind : ``"ds"`` or ``"ss"``
    duration : s
    start, end : (2, 3) positions of the (left, right) sole frames at the phase's start and
        end, world frame; soles are flat
    swing : the side in the air in single support, else None
    step : index of the step the phase belongs to
    start_yaw, end_yaw : (2,) the soles' yaws (rad) at the phase's start and end
    """

    kind: str
    duration: float
    start: np.ndarray
    end: np.ndarray
    swing: str | None
    step: int
    start_yaw: np.ndarray = field(default_factory=lambda: np.zeros(2))
    end_yaw: np.ndarray = field(default_factory=lambda: np.zeros(2))


def default_durations(
    specs: list[StepSpec],
    *,
    double_support: float = 0.15,
    single_support: float = 0.8,
    start_double_support: float = 0.4,
    rest: float = 0.4,
) -> list[np.ndarray]:
    """Phase durations (s) per step in the order of its phases: ``[ds, ss]``, a stop ``[ds, ss, ds, ss, rest]``.

    The first double support of a start step lasts ``start_double_support``.
    """
    out = []
    for spec in specs:
        first = start_double_support if spec.kind == "start" else double_support
        if spec.kind == "stop":
            out.append(
                np.array([first, single_support, double_support, single_support, rest])
            )
        else:
            out.append(np.array([first, single_support]))
    return out


def support_phases(
    robot: Robot, specs: list[StepSpec], durations: list[np.ndarray]
) -> list[SupportPhase]:
    """The phases of a walk: footsteps as in :func:`cocomopl.synthesis.world.footsteps`, given timing.

    ``durations[k]`` holds step ``k``'s phase durations (s) in the order of its phase plan,
    as :func:`default_durations` or a predicted step's ``np.diff(step.phase_edges)``.

    Raises
    ------
    Error
        If a step's durations do not match its phases or are not positive.
    """
    out = []
    for k, (step, feet, times) in enumerate(
        zip(specs, footsteps(robot, specs), durations)
    ):
        plan = phase_plan(step)
        times = np.asarray(times, dtype=float)
        if times.shape != (len(plan),) or not np.all(times > 0):
            raise Error(
                f"step {k} ({step.name}) needs {len(plan)} positive phase durations, got {times.tolist()}"
            )
        for p, ((kind, swing), duration) in enumerate(zip(plan, times)):
            start, end = (
                np.array([ground_position(feet, plan, side, phase=i) for side in SIDES])
                for i in (p, p + 1)
            )
            start_yaw, end_yaw = (
                np.array([ground_yaw(feet, plan, side, phase=i) for side in SIDES]) for i in (p, p + 1)
            )
            out.append(SupportPhase(kind, float(duration), start, end, swing, k, start_yaw, end_yaw))
    return out


def _sole_centre(robot: Robot, position: np.ndarray, yaw: float) -> np.ndarray:
    """Horizontal centre of a flat sole whose frame is at ``position``, turned by ``yaw`` (rad)."""
    ahead = 0.5 * (robot.sole.front - robot.sole.back)
    return position[:2] + ahead * np.array([np.cos(yaw), np.sin(yaw)])


def zmp_reference(
    robot: Robot,
    phases: list[SupportPhase],
    t: np.ndarray,
    *,
    hold: float = 0.0,
    settle: float = 0.0,
) -> np.ndarray:
    """Reference ZMP (n, 2) at times ``t``: on the stance sole, between the soles at rest.

    Piecewise linear between the phase edges; a double support moves it from the sole that
    carried the phase before to the one that carries the phase after.  It stays between the
    soles for the first ``hold`` seconds of the first phase (a double support longer than that)
    and reaches its last point ``settle`` seconds before the last phase ends.
    """
    edges = np.concatenate([[0.0, hold], np.cumsum([p.duration for p in phases])])
    edges[-1] -= settle
    first = phases[0]
    between = 0.5 * (_sole_centre(robot, first.start[0], first.start_yaw[0]) + _sole_centre(robot, first.start[1], first.start_yaw[1]))
    knots = [between, between]
    for p, phase in enumerate(phases):
        carrier = (
            phase
            if phase.kind == "ss"
            else (phases[p + 1] if p + 1 < len(phases) else None)
        )
        if carrier is None:  # at the end, at rest between the feet
            knots.append(0.5 * (_sole_centre(robot, phase.end[0], phase.end_yaw[0])
                                + _sole_centre(robot, phase.end[1], phase.end_yaw[1])))
        else:
            stance = 1 - SIDES.index(carrier.swing)
            knots.append(_sole_centre(robot, carrier.end[stance], carrier.end_yaw[stance]))
    knots = np.array(knots)
    return np.stack([np.interp(t, edges, knots[:, i]) for i in range(2)], axis=1)


def smoothed(reference: np.ndarray, dt: float, window: float) -> np.ndarray:
    """``reference`` (n, 2), sampled every ``dt`` s, through jrl-walkgen's ZMP filter: a causal
    moving average with ``sin²`` weights over ``window`` seconds (0: unchanged).

    Causal, as there: each sample averages the ``window`` before it, so the smoothed
    reference lags by half the window (25 ms for 50 ms); the preview sees it all the same.
    """
    n = int(np.floor(window / dt + 1e-9))
    if n < 1:
        return reference
    weights = np.sin(np.pi * np.arange(n + 1) / n) ** 2
    weights /= weights.sum()
    padded = np.vstack([np.repeat(reference[:1], n, axis=0), reference])
    return np.stack([np.convolve(padded[:, i], weights, mode="valid") for i in range(2)], axis=1)


def minimum_jerk(s: float) -> float:
    """The minimum-jerk blend from 0 to 1 over ``s`` in [0, 1], at rest at both ends."""
    return s**3 * (10 - 15 * s + 6 * s**2)


def swing_position(
    start: np.ndarray, end: np.ndarray, s: float, *, height: float
) -> np.ndarray:
    """Swing sole position at phase ``s`` in [0, 1]: minimum-jerk horizontally, a bell vertically.

    The velocity vanishes at lift-off and touchdown; the lift ``16 s^2 (1-s)^2`` peaks at
    ``height`` at mid-swing.  It leaves and meets the ground with a finite vertical
    acceleration: a flatter bell (zero acceleration too) skims the floor so long that, in
    simulation, the sole touches down early.  The sole's yaw turns by the same blend.
    """
    out = start + minimum_jerk(s) * (end - start)
    out[2] += height * 16 * s**2 * (1 - s) ** 2
    return out


def _sample_times(
    phases: list[SupportPhase], dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """Times at most ``dt`` apart and the phase of each; a touchdown time appears twice.

    Each phase is sampled evenly including its start; a single support also keeps its end
    (pre-impact), and the double support after it starts at the same time (post-impact).
    """
    t0, ts, index = 0.0, [], []
    for p, phase in enumerate(phases):
        n = max(int(np.ceil(phase.duration / dt - 1e-9)), 1)
        t = t0 + np.linspace(0.0, phase.duration, n + 1)
        keep = t if (phase.kind == "ss" or p == len(phases) - 1) else t[:-1]
        ts.append(keep)
        index.append(np.full(len(keep), p))
        t0 += phase.duration
    return np.concatenate(ts), np.concatenate(index)


class Soles(NamedTuple):
    """Targets of the (left, right) sole frames per sample: ``positions`` (n, 2, 3), m, and
    ``yaws`` (n, 2), rad; the soles stay level."""

    positions: np.ndarray
    yaws: np.ndarray

    def placement(self, k: int, j: int) -> pin.SE3:
        return pin.SE3(flat_placement(0.0, 0.0, float(self.yaws[k, j])).rotation, self.positions[k, j])

    def first(self) -> Soles:
        return Soles(self.positions[:1], self.yaws[:1])


def _sole_targets(
    phases: list[SupportPhase], t: np.ndarray, index: np.ndarray, height: float
) -> Soles:
    """Targets of the (left, right) sole frames per sample."""
    edges = np.concatenate([[0.0], np.cumsum([p.duration for p in phases])])
    out, yaws = np.empty((len(t), 2, 3)), np.empty((len(t), 2))
    for k, (time, p) in enumerate(zip(t, index)):
        phase = phases[p]
        out[k], yaws[k] = phase.start, phase.start_yaw
        if phase.swing is not None:
            j = SIDES.index(phase.swing)
            s = np.clip((time - edges[p]) / phase.duration, 0.0, 1.0)
            out[k, j] = swing_position(phase.start[j], phase.end[j], s, height=height)
            yaws[k, j] += minimum_jerk(s) * (phase.end_yaw[j] - phase.start_yaw[j])
    return Soles(out, yaws)


def _preview_com(
    robot: Robot,
    phases: list[SupportPhase],
    t: np.ndarray,
    com_height: float,
    settings: KajitaSettings,
    settle: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Preview CoM (n, 2), starting at rest above the reference, and the smoothed reference
    ZMP (n, 2) it follows, at times ``t``.

    The reference holds between the feet over the prelude and the last ``settle`` seconds.
    """
    controller = PreviewController(
        settings.control_dt,
        com_height,
        preview_time=settings.preview_time,
        weight_error=settings.weight_error,
        weight_input=settings.weight_input,
    )
    grid = np.arange(0.0, t[-1] + 1.5 * settings.control_dt, settings.control_dt)
    reference = smoothed(
        zmp_reference(robot, phases, grid, hold=settings.prelude, settle=settle), settings.control_dt,
        settings.zmp_smoothing
    )
    com, com_vel, _, _ = controller.track(reference)
    at_t = np.stack([np.interp(t, grid, reference[:, i]) for i in range(2)], axis=1)
    return CubicHermiteSpline(grid, com, com_vel, axis=0)(t), at_t


def _phase_ranges(
    phases: list[SupportPhase], index: np.ndarray
) -> list[tuple[str, int, int]]:
    """(kind, first, last) per phase; a double support also holds the first sample of the phase after it."""
    out = []
    for p, phase in enumerate(phases):
        rows = np.flatnonzero(index == p)
        shares = (
            phase.kind == "ds"
            and p + 1 < len(phases)
            and phases[p + 1].step == phase.step
        )
        out.append((phase.kind, int(rows[0]), int(rows[-1]) + int(shares)))
    return out


def _whole_body(
    robot: Robot,
    q: np.ndarray,
    t: np.ndarray,
    soles: Soles,
    com: np.ndarray,
    iterations: int,
) -> np.ndarray:
    """Configurations (n, nq) with the soles at ``soles`` and the CoM above ``com`` (n, 2).

    As Kajita's pattern generator: the pelvis keeps the height and the roll and pitch of
    ``q`` and the upper body its posture, and faces halfway between the soles' yaws; per
    sample the pelvis slides horizontally by the CoM error and the legs follow the soles
    (:func:`~cocomopl.kinematics.place_legs`), warm-started from the sample before.
    """
    model, data = robot.model, robot.model.createData()
    legs = leg_joints(robot)
    roll, pitch, _ = pin.rpy.matrixToRpy(pin.Quaternion(q[3:7].copy()).matrix())
    upright = pin.rpy.rpyToMatrix(roll, pitch, 0.0)
    out = np.empty((len(t), model.nq))
    for k in range(len(t)):
        if (
            k > 0 and t[k] == t[k - 1]
        ):  # a post-impact sample repeats the pre-impact configuration
            out[k] = out[k - 1]
            continue
        targets = {side: soles.placement(k, j) for j, side in enumerate(SIDES)}
        heading = mean_yaw(soles.yaws[k, 0], soles.yaws[k, 1])
        q[3:7] = pin.Quaternion(flat_placement(0.0, 0.0, heading).rotation @ upright).coeffs()
        for _ in range(iterations):
            q = place_legs(robot, q, targets, legs=legs, data=data)
            q[:2] += com[k] - pin.centerOfMass(model, data, q)[:2]
        out[k] = q = place_legs(robot, q, targets, legs=legs, data=data)
    return out


def _out_of_reach(robot: Robot, t: np.ndarray, q: np.ndarray, soles: np.ndarray) -> str | None:
    """Why the configurations ``q`` (n, nq) do not realise the walk, or None if they do: a
    sole more than ``REACH_TOLERANCE`` from its target ``soles`` (n, 2, 3), or a joint faster
    than its limit (a knee that snaps straight to reach a footstep)."""
    reached = sole_placements(robot, q)
    sole_error = np.abs(reached - soles).max(axis=(1, 2))
    if sole_error.max() > REACH_TOLERANCE:
        k = int(np.argmax(sole_error))
        return f"sole {1000 * sole_error[k]:.1f} mm off at t = {t[k]:.2f} s"
    distinct = np.flatnonzero(np.diff(t) > 0)
    speed = np.abs(np.diff(q[:, 7:], axis=0)[distinct] / np.diff(t)[distinct, None])
    ratio = speed / robot.model.velocityLimit[6:]
    if ratio.max() > 1.0:
        k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        return f"{robot.joint_names[j]} at {ratio.max():.2f} x its velocity limit at t = {t[distinct[k]]:.2f} s"
    return None


def _first_stage(
    robot: Robot,
    phases: list[SupportPhase],
    t: np.ndarray,
    soles: Soles,
    drop: float,
    settings: KajitaSettings,
    settle: float,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Stage 1 with the pelvis ``drop`` m below the reference posture: the configurations
    (n, nq), the smoothed reference ZMP (n, 2) and the cart-table's CoM height (m).

    The robot starts in the reference posture, lowered and upright, its CoM above the
    reference's start; the CoM height of that posture is the cart-table's.
    """
    model, data = robot.model, robot.model.createData()
    com_start = zmp_reference(robot, phases, t[:1])[0]
    crouched = robot.q_ref.copy()
    crouched[2] -= drop
    standing = _whole_body(robot, crouched, t[:1], soles.first(), com_start[None], STANDING_ITERATIONS)[0]
    com_height = float(pin.centerOfMass(model, data, standing)[2])
    com, zmp_ref = _preview_com(robot, phases, t, com_height, settings, settle)
    return _whole_body(robot, standing, t, soles, com, settings.ik_iterations), zmp_ref, com_height


def highest_pelvis_drop(
    robot: Robot,
    phases: list[SupportPhase],
    t: np.ndarray,
    *,
    soles: Soles,
    settings: KajitaSettings,
    settle: float,
) -> tuple[float, tuple | None]:
    """The least pelvis drop (m), so the highest constant CoM, at which stage 1 realises the
    walk (:func:`_out_of_reach`): bisection over ``settings.drop_search_range`` down to
    ``DROP_SEARCH_RESOLUTION``, about eight first stages.  Returns the drop and
    :func:`_first_stage`'s result there (None if untried).

    A higher pelvis straightens the knees, so the longest step is the first the legs fail to
    reach: feasibility is monotonic in the drop.  The lowest pelvis of the range is returned
    untried if nothing above it works; the walk then fails its own reach check.
    """
    high, low = settings.drop_search_range
    found = None
    while low - high > DROP_SEARCH_RESOLUTION:
        middle = 0.5 * (low + high)
        stage = _first_stage(robot, phases, t, soles, middle, settings, settle)
        if _out_of_reach(robot, t, stage[0], soles.positions) is None:
            low, found = middle, stage
        else:
            high = middle
    return low, found


def _ground(soles: Soles, contact: np.ndarray) -> list[list[pin.SE3 | None]]:
    """Per sample and sole, the planned flat placement while in contact, None in the air."""
    return [[soles.placement(k, j) if contact[k, j] else None for j in range(2)] for k in range(len(contact))]


def kajita_motion(
    robot: Robot,
    phases: list[SupportPhase],
    specs: list[StepSpec],
    *,
    dt: float = 0.005,
    settings: KajitaSettings = KajitaSettings(),
) -> Motion:
    """The preview-control walk through given support phases, a world-frame :class:`Motion`.

    ``specs`` only label the steps (``Motion.steps``); footsteps and timing are the phases',
    the first (a double support) lengthened by ``settings.prelude`` and, if the walk ends at
    rest (in double support), the last by ``settings.postlude``.  Time 0 is when the phases
    begin, so the prelude runs at negative times; ``meta["walking_span_s"]`` is the span of
    the phases themselves, without prelude and postlude.  ``meta`` holds the
    settings, the pelvis drop and CoM height used, and the RMS distance of the plan's
    multibody ZMP from the smoothed reference (``zmp_reference_rms_m``; after stage 1 alone
    ``first_stage_zmp_reference_rms_m``).

    Raises
    ------
    Error
        If the legs cannot reach the footsteps at the pelvis height.
    """
    model, data = robot.model, robot.model.createData()
    settle = settings.postlude if phases[-1].kind == "ds" else 0.0
    phases = list(phases)
    phases[0] = replace(phases[0], duration=phases[0].duration + settings.prelude)
    phases[-1] = replace(phases[-1], duration=phases[-1].duration + settle)
    t, index = _sample_times(phases, dt)
    soles = _sole_targets(phases, t, index, settings.swing_height)
    contact = np.array([[phases[p].swing != side for side in SIDES] for p in index])
    impacts = np.flatnonzero(np.diff(t) == 0)
    drop, stage = settings.pelvis_drop, None
    if drop is None:
        drop, stage = highest_pelvis_drop(robot, phases, t, soles=soles, settings=settings, settle=settle)
    q, zmp_ref, com_height = stage or _first_stage(robot, phases, t, soles, drop, settings, settle)
    zmp_ref = np.column_stack([zmp_ref, np.zeros(len(t))])
    first_error = rms_zmp_error(multibody_zmp(robot, t, q, contact=contact, impacts=impacts), zmp_ref, impacts)
    if settings.second_stage:
        q, _, _ = dynamics_filter(robot, t, q, contact=contact, impacts=impacts, ground=_ground(soles, contact),
                                  zmp_ref=zmp_ref)
    why = _out_of_reach(robot, t, q, soles.positions)
    if why is not None:
        remedy = "shorten the steps" if settings.pelvis_drop is None else "lower it (KajitaSettings.pelvis_drop) or shorten the steps"
        raise Error(f"footsteps out of the legs' reach with the pelvis {100 * drop:.1f} cm low ({why}): {remedy}")
    coms = np.array([pin.centerOfMass(model, data, qk) for qk in q])
    step_of = np.array([phases[p].step for p in index])
    starts = [np.flatnonzero(step_of == k)[0] for k in range(len(specs))]
    # the clock starts when the walking does: the standing prelude runs at negative times
    motion = kinematic_motion(robot, t - settings.prelude, q, contact=contact, impacts=impacts,
                              phases=_phase_ranges(phases, index), steps=specs, step_starts=starts,
                              producer="kajita")
    motion.meta = {
        **asdict(settings),
        "pelvis_drop": drop,
        "pelvis_drop_searched": settings.pelvis_drop is None,
        "walking_span_s": [0.0, float(t[-1] - settings.prelude - settle)],
        "com_height_m": com_height,
        "com_height_range_m": float(np.ptp(coms[:, 2])),
        "pelvis_height_m": float(q[0, 2]),
        "sole_error_m": float(np.abs(sole_placements(robot, q) - soles.positions).max()),
        # the cart-table neglects angular momentum and the legs' swing: what stage 2 corrects
        "first_stage_zmp_reference_rms_m": first_error,
        "zmp_reference_rms_m": rms_zmp_error(motion.zmp, zmp_ref, impacts),
    }
    return motion


def kajita_walk(
    robot: Robot,
    specs: list[StepSpec],
    *,
    durations: list[np.ndarray] | None = None,
    dt: float = 0.005,
    settings: KajitaSettings = KajitaSettings(),
) -> Motion:
    """The Kajita baseline for a step sequence: footsteps from ``specs``, timing from ``durations``.

    Parameters
    ----------
    robot : the robot
    specs : the walk's steps, e.g. :func:`cocomopl.synthesis.step_chain.sequence_specs`
    durations : per step, its phase durations (s), as for :func:`support_phases`; to match a
        generated walk pass ``[np.diff(s.phase_edges) for s in steps]``; default
        :func:`default_durations`
    dt : sampling period of the motion, s
    settings : swing height, preview and IK settings
    """
    if durations is None:
        durations = default_durations(specs)
    if len(durations) != len(specs):
        raise Error(f"{len(specs)} steps but {len(durations)} lists of phase durations")
    return kajita_motion(
        robot, support_phases(robot, specs, durations), specs, dt=dt, settings=settings
    )
