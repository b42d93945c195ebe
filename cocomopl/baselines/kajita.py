"""The classic baseline: a walk from ZMP preview control of the cart-table model (Kajita 2003).

The footsteps and phase timing are given (the same as a generated walk's); the ZMP
reference stays at the stance sole's centre in single support and moves linearly to the
next stance sole over double support, starting and ending between the feet.  Preview
control turns it into a CoM trajectory at constant height; swing soles follow minimum-jerk
paths with a bell-shaped lift; inverse kinematics, warm-started sample to sample, gives the
whole body.  Torques and contact wrenches then come from Pinocchio inverse dynamics, so the
result is a :class:`Motion` like any other and can be checked against its own claims.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np
import pinocchio as pin
from scipy.interpolate import CubicHermiteSpline

from cocomopl.baselines.preview_control import PreviewController
from cocomopl.dynamics import SIDES, kinematic_motion, sole_placements
from cocomopl.errors import Error
from cocomopl.gait import footsteps, ground_position, phase_plan
from cocomopl.kinematics import leg_joints, place_legs
from cocomopl.motion import Motion, StepSpec
from cocomopl.robot import Robot

STANDING_ITERATIONS = (
    10  # pelvis shifts to bring the CoM of the first posture above its target
)
REACH_TOLERANCE = (
    1e-3  # m: a sole farther than this from its target is out of the legs' reach
)


@dataclass(frozen=True)
class KajitaSettings:
    """Settings of the baseline, SI units.

    Attributes
    ----------
    swing_height : peak height of the swing sole above the ground, m
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
    pelvis_drop : how much lower than in the reference posture the pelvis walks, m: bent
        knees let the legs reach long steps (TALOS at the reference height cannot land a
        0.39 m step)
    """

    swing_height: float = 0.08
    preview_time: float = 1.6
    weight_error: float = 1.0
    weight_input: float = 1e-6
    control_dt: float = 0.005
    ik_iterations: int = 2
    prelude: float = 1.6
    postlude: float = 1.0
    pelvis_drop: float = 0.04


@dataclass(frozen=True)
class SupportPhase:
    """One phase of a walk, both soles down (``ds``) or one swinging (``ss``).

    Attributes
    ----------
    kind : ``"ds"`` or ``"ss"``
    duration : s
    start, end : (2, 3) positions of the (left, right) sole frames at the phase's start and
        end, world frame; soles are flat and face +x
    swing : the side in the air in single support, else None
    step : index of the step the phase belongs to
    """

    kind: str
    duration: float
    start: np.ndarray
    end: np.ndarray
    swing: str | None
    step: int


def default_durations(
    specs: list[StepSpec],
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
                np.array([ground_position(feet, plan, side, i) for side in SIDES])
                for i in (p, p + 1)
            )
            out.append(SupportPhase(kind, float(duration), start, end, swing, k))
    return out


def _sole_centre(robot: Robot, position: np.ndarray) -> np.ndarray:
    """Horizontal centre of a flat sole whose frame is at ``position``."""
    return position[:2] + np.array([0.5 * (robot.sole.front - robot.sole.back), 0.0])


def zmp_reference(
    robot: Robot,
    phases: list[SupportPhase],
    t: np.ndarray,
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
    between = 0.5 * (
        _sole_centre(robot, phases[0].start[0])
        + _sole_centre(robot, phases[0].start[1])
    )
    knots = [between, between]
    for p, phase in enumerate(phases):
        carrier = (
            phase
            if phase.kind == "ss"
            else (phases[p + 1] if p + 1 < len(phases) else None)
        )
        if carrier is None:  # at the end, at rest between the feet
            knots.append(
                0.5
                * (
                    _sole_centre(robot, phase.end[0])
                    + _sole_centre(robot, phase.end[1])
                )
            )
        else:
            stance = 1 - SIDES.index(carrier.swing)
            knots.append(_sole_centre(robot, carrier.end[stance]))
    knots = np.array(knots)
    return np.stack([np.interp(t, edges, knots[:, i]) for i in range(2)], axis=1)


def swing_position(
    start: np.ndarray, end: np.ndarray, s: float, height: float
) -> np.ndarray:
    """Swing sole position at phase ``s`` in [0, 1]: minimum-jerk horizontally, a bell vertically.

    The velocity vanishes at lift-off and touchdown; the lift ``16 s^2 (1-s)^2`` peaks at
    ``height`` at mid-swing.  It leaves and meets the ground with a finite vertical
    acceleration: a flatter bell (zero acceleration too) skims the floor so long that, in
    simulation, the sole touches down early.
    """
    blend = s**3 * (10 - 15 * s + 6 * s**2)
    out = start + blend * (end - start)
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


def _sole_targets(
    phases: list[SupportPhase], t: np.ndarray, index: np.ndarray, height: float
) -> np.ndarray:
    """Target (n, 2, 3) of the (left, right) sole frames per sample."""
    edges = np.concatenate([[0.0], np.cumsum([p.duration for p in phases])])
    out = np.empty((len(t), 2, 3))
    for k, (time, p) in enumerate(zip(t, index)):
        phase = phases[p]
        out[k] = phase.start
        if phase.swing is not None:
            j = SIDES.index(phase.swing)
            s = np.clip((time - edges[p]) / phase.duration, 0.0, 1.0)
            out[k, j] = swing_position(phase.start[j], phase.end[j], s, height)
    return out


def _preview_com(
    robot: Robot,
    phases: list[SupportPhase],
    t: np.ndarray,
    com_height: float,
    settings: KajitaSettings,
    settle: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Preview CoM (n, 2), starting at rest above the reference, and reference ZMP (n, 2) at times ``t``.

    The reference holds between the feet over the prelude and the last ``settle`` seconds.
    """
    controller = PreviewController(
        settings.control_dt,
        com_height,
        settings.preview_time,
        settings.weight_error,
        settings.weight_input,
    )
    grid = np.arange(0.0, t[-1] + 1.5 * settings.control_dt, settings.control_dt)
    com, com_vel, _, _ = controller.track(
        zmp_reference(robot, phases, grid, settings.prelude, settle)
    )
    return CubicHermiteSpline(grid, com, com_vel, axis=0)(t), zmp_reference(
        robot, phases, t, settings.prelude, settle
    )


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
    soles: np.ndarray,
    com: np.ndarray,
    iterations: int,
) -> np.ndarray:
    """Configurations (n, nq) with the soles at ``soles`` (n, 2, 3) and the CoM above ``com`` (n, 2).

    As Kajita's pattern generator: the pelvis keeps the orientation and height of ``q`` and
    the upper body its posture; per sample the pelvis slides horizontally by the CoM error
    and the legs follow the soles (:func:`~cocomopl.kinematics.place_legs`),
    warm-started from the sample before.
    """
    model, data = robot.model, robot.model.createData()
    legs = leg_joints(robot)
    out = np.empty((len(t), model.nq))
    for k in range(len(t)):
        if (
            k > 0 and t[k] == t[k - 1]
        ):  # a post-impact sample repeats the pre-impact configuration
            out[k] = out[k - 1]
            continue
        targets = {
            side: pin.SE3(np.eye(3), soles[k, j]) for j, side in enumerate(SIDES)
        }
        for _ in range(iterations):
            q = place_legs(robot, q, targets, legs)
            q[:2] += com[k] - pin.centerOfMass(model, data, q)[:2]
        out[k] = q = place_legs(robot, q, targets, legs)
    return out


def kajita_motion(
    robot: Robot,
    phases: list[SupportPhase],
    specs: list[StepSpec],
    dt: float = 0.005,
    settings: KajitaSettings = KajitaSettings(),
) -> Motion:
    """The preview-control walk through given support phases, a world-frame :class:`Motion`.

    ``specs`` only label the steps (``Motion.steps``); footsteps and timing are the phases',
    the first (a double support) lengthened by ``settings.prelude`` and, if the walk ends at
    rest (in double support), the last by ``settings.postlude``.
    The robot starts in the reference posture with the pelvis ``settings.pelvis_drop``
    lower, upright, its CoM above the ZMP reference's start; the CoM height of that posture
    is the cart-table's.

    Raises
    ------
    Error
        If the legs cannot reach the footsteps at that pelvis height.
    """
    model, data = robot.model, robot.model.createData()
    settle = settings.postlude if phases[-1].kind == "ds" else 0.0
    phases = list(phases)
    phases[0] = replace(phases[0], duration=phases[0].duration + settings.prelude)
    phases[-1] = replace(phases[-1], duration=phases[-1].duration + settle)
    t, index = _sample_times(phases, dt)
    soles = _sole_targets(phases, t, index, settings.swing_height)
    com_start = zmp_reference(robot, phases, t[:1])[0]
    crouched = robot.q_ref.copy()
    crouched[2] -= settings.pelvis_drop
    standing = _whole_body(
        robot, crouched, t[:1], soles[:1], com_start[None], STANDING_ITERATIONS
    )[0]
    com_height = float(pin.centerOfMass(model, data, standing)[2])
    com, zmp_ref = _preview_com(robot, phases, t, com_height, settings, settle)
    q = _whole_body(robot, standing, t, soles, com, settings.ik_iterations)
    reached = sole_placements(robot, q)
    sole_error = np.abs(reached - soles).max(axis=(1, 2))
    if sole_error.max() > REACH_TOLERANCE:
        k = int(np.argmax(sole_error))
        raise Error(
            f"footsteps out of the legs' reach with the pelvis at {standing[2]:.3f} m (sole {1000 * sole_error[k]:.1f} mm "
            f"off at t = {t[k]:.2f} s): lower it (KajitaSettings.pelvis_drop) or shorten the steps"
        )
    contact = np.array([[phases[p].swing != side for side in SIDES] for p in index])
    impacts = np.flatnonzero(np.diff(t) == 0)
    coms = np.array([pin.centerOfMass(model, data, qk) for qk in q])
    step_of = np.array([phases[p].step for p in index])
    starts = [np.flatnonzero(step_of == k)[0] for k in range(len(specs))]
    motion = kinematic_motion(robot, t, q, contact, impacts, _phase_ranges(phases, index), specs, starts, meta={})
    motion.meta = {
        "producer": "kajita",
        **asdict(settings),
        "com_height_m": com_height,
        "com_height_range_m": float(np.ptp(coms[:, 2])),
        "pelvis_height_m": float(standing[2]),
        "sole_error_m": float(sole_error.max()),
        "com_error_m": float(np.abs(coms[:, :2] - com).max()),
        # the cart-table neglects angular momentum and the legs' swing: the price of the baseline
        "zmp_reference_rms_m": float(np.sqrt(np.nanmean(np.sum((motion.zmp[:, :2] - zmp_ref) ** 2, axis=1)))),
    }
    return motion


def kajita_walk(
    robot: Robot,
    specs: list[StepSpec],
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
        robot, support_phases(robot, specs, durations), specs, dt, settings
    )
