"""Numbers that compare motions, planned or measured: the paper's mean torque (Table I),
contact-force peaks and rates (Fig. 8), knee torques (Fig. 9), ZMP and joint tracking
errors, falls and foot slip.

Every function takes :class:`~cocomopl.motion.Motion` objects, whoever produced them (OC,
primitives, the Kajita baseline, the MuJoCo simulator), and returns SI values.  Torques and
contact wrenches hold over ``[t[k], t[k+1])`` (zero-order hold); the zero-length interval
of a touchdown (pre-impact duplicate sample) therefore weighs nothing.  A measured motion
is compared with its reference after aligning their first samples: the simulator's time
0 is the reference's first sample.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from cocomopl.analysis.feasibility import polygon_margin, support_polygon
from cocomopl.dynamics import GRAVITY, SIDES, pelvis_placements, sole_placements
from cocomopl.errors import Error
from cocomopl.motion import Motion
from cocomopl.robot import Robot

# fallen: the pelvis below this fraction of its starting height, or the trunk tilted this much
FALL_HEIGHT_RATIO = 0.6
FALL_TILT = np.radians(45.0)

# Width (s) of the moving average applied to contact forces before differentiating them.
# A simulator's forces chatter from one 1 kHz step to the next and spike for a single
# sample at touchdown, so their raw rate measures the integrator more than the motion.
# The smoothed peak rate of such a spike scales as 1/width: compare motions at one width.
FORCE_FILTER_S = 0.02
# A sole pushing with less than this fraction of the body weight is not counted as a
# stance foot for slip: while the foot rolls off or lands it may move legitimately.
SLIP_FORCE_RATIO = 0.05
# s: a measured touchdown further than this from a planned one is not that touchdown
TOUCHDOWN_WINDOW_S = 0.2


def windowed(motion: Motion, start: float, end: float) -> Motion:
    """The samples of ``motion`` with ``start <= t <= end`` (s, on its own clock), its
    impacts, phases and steps cut to match (a step that began before ``start`` keeps its
    label, starting at the window's first sample).  At least one sample is kept."""
    first = min(int(np.searchsorted(motion.t, start - 1e-9, side="left")), motion.n - 1)
    last = max(int(np.searchsorted(motion.t, end + 1e-9, side="right")), first + 1)
    if first == 0 and last == motion.n:
        return motion
    ends = np.append(motion.step_starts[1:], motion.n)
    kept = np.flatnonzero((motion.step_starts < last) & (ends > first))
    return dataclasses.replace(
        motion,
        **{key: getattr(motion, key)[first:last] for key in ("t", "q", "v", "tau", "wrenches", "contact", "zmp")},
        impacts=motion.impacts[(motion.impacts >= first) & (motion.impacts < last - 1)] - first,
        phases=[(kind, max(a, first) - first, min(b, last - 1) - first) for kind, a, b in motion.phases if b >= first and a < last],
        steps=[motion.steps[k] for k in kept],
        step_starts=np.maximum(motion.step_starts[kept] - first, 0),
    )


def _joint_columns(motion: Motion, joints: list[str] | None) -> list[int]:
    if joints is None:
        return list(range(len(motion.joint_names)))
    missing = [name for name in joints if name not in motion.joint_names]
    if missing:
        raise Error(f"motion {motion.name!r} has no joint named {missing[0]!r}")
    return [motion.joint_names.index(name) for name in joints]


def torque_integral(motion: Motion, joints: list[str] | None = None) -> float:
    """``∫ Σ_i τ_i(t)² dt`` (N² m² s) over the motion, torques held over each interval.

    Parameters
    ----------
    motion : any motion
    joints : names of the joints to sum over; all actuated joints if None
    """
    tau = motion.tau[:-1, _joint_columns(motion, joints)]
    return float(np.sum(np.sum(tau**2, axis=1) * np.diff(motion.t)))


def mean_torque(motion: Motion, joints: list[str] | None = None) -> float:
    """The paper's mean joint torque (Table I): ``(∫ Σ_i τ_i² dt)^½ / (N t_f)``.

    Clever et al. (2017, sec. V) divide the root of the time integral of the summed squared
    torques of the ``N`` actuated joints by ``N`` and the duration ``t_f``; they report it
    in "N m s⁻¹" (strictly N m s^-½).  Here ``τ`` are the motion's joint torques (for an OC
    motion its rigid-body joint torques, the paper's "OC joint t"; for a simulated one the
    servo torques, "sim"), ``N`` is the number of joints summed over (30 for TALOS, as for
    HRP-2) and ``t_f`` the motion's duration.  The value shrinks as ``t_f^-½`` for a
    steady gait, so only motions of about the same duration compare; the magnitudes of
    Table I (15.6 to 34.1 for HRP-2) are not reproduced by this literal reading, see
    :func:`rms_torque` for a per-joint torque in N m.

    Parameters
    ----------
    motion : any motion
    joints : restrict the sum (and ``N``) to these joints; all actuated joints if None
    """
    n_joints = len(_joint_columns(motion, joints))
    return float(np.sqrt(torque_integral(motion, joints)) / (n_joints * motion.duration))


def rms_torque(motion: Motion, joints: list[str] | None = None) -> float:
    """Root-mean-square joint torque ``(∫ Σ_i τ_i² dt / (N t_f))^½``, N m.

    :func:`mean_torque` with the root taken after the division: a per-joint average torque
    that does not shrink with the duration, for comparing motions of different lengths.
    """
    n_joints = len(_joint_columns(motion, joints))
    return float(np.sqrt(torque_integral(motion, joints) / (n_joints * motion.duration)))


def vertical_forces(motion: Motion) -> np.ndarray:
    """Vertical contact force (n, 2) of the (left, right) sole, N."""
    return motion.wrenches[:, :, 2].copy()


def peak_force_over_weight(motion: Motion, robot_mass: float) -> np.ndarray:
    """Largest vertical force of each (left, right) sole over the body weight ``m g``, (2,)."""
    return vertical_forces(motion).max(axis=0) / (robot_mass * GRAVITY)


def smoothed_forces(motion: Motion, window: float = FORCE_FILTER_S) -> tuple[np.ndarray, np.ndarray]:
    """Vertical forces averaged over a centred window of ``window`` seconds.

    ``F_w(t) = (1/w) ∫_{t-w/2}^{t+w/2} F(s) ds`` with ``F`` held over each sample interval,
    the window shortened at the ends of the motion.  Being an integral in time, it does not
    depend on how the samples are spaced: a near-duplicate sample (a few µs apart) cannot
    produce a huge rate, and ``|dF_w/dt|`` never exceeds the largest force jump over ``w``.

    Returns
    -------
    t : (m,) the distinct sample times (pre-impact duplicates dropped), s
    forces : (m, 2) the (left, right) averaged vertical forces, N
    """
    keep = motion.kept_samples()
    t, forces = motion.t[keep], vertical_forces(motion)[keep]
    integral = np.vstack([np.zeros(2), np.cumsum(forces[:-1] * np.diff(t)[:, None], axis=0)])
    lower = np.maximum(t - window / 2, t[0])
    upper = np.minimum(t + window / 2, t[-1])
    averaged = [np.interp(upper, t, c) - np.interp(lower, t, c) for c in integral.T]
    return t, np.column_stack(averaged) / (upper - lower)[:, None]


def force_rates(motion: Motion, window: float | None = FORCE_FILTER_S) -> np.ndarray:
    """``dF_z/dt`` (m-1, 2) of each sole between consecutive distinct sample times, N/s.

    Parameters
    ----------
    window : width (s) of the moving average applied first (:func:`smoothed_forces`);
        None for the raw forces
    """
    if window is None:
        keep = motion.kept_samples()
        t, forces = motion.t[keep], vertical_forces(motion)[keep]
    else:
        t, forces = smoothed_forces(motion, window)
    return np.diff(forces, axis=0) / np.diff(t)[:, None]


def max_force_rate(motion: Motion, window: float | None = FORCE_FILTER_S) -> np.ndarray:
    """``max_k |dF_z/dt|`` of each (left, right) sole (2,), N/s; see :func:`force_rates`."""
    return np.abs(force_rates(motion, window)).max(axis=0)


def force_rate_rms(motion: Motion, window: float | None = FORCE_FILTER_S) -> np.ndarray:
    """Smoothness of the contact forces: ``(∫ (dF_z/dt)² dt / t_f)^½`` per sole (2,), N/s.

    The time-weighted RMS of :func:`force_rates`: a force profile that loads and unloads
    a foot gently scores low, one with spikes and chatter high, whatever the peak force.
    """
    rates = force_rates(motion, window)
    dt = np.diff(motion.t[motion.kept_samples()])
    return np.sqrt(np.sum(rates**2 * dt[:, None], axis=0) / dt.sum())


def force_variation(motion: Motion, window: float | None = FORCE_FILTER_S) -> np.ndarray:
    """Total variation ``∫ |dF_z/dt| dt`` of each (left, right) sole's vertical force (2,), N.

    Smoothness that, unlike :func:`force_rate_rms`, does not depend on how long the motion
    stands still before or after it walks.  A foot loaded and unloaded ``k`` times without
    overshoot scores ``2 k`` times its peak load; spikes and chatter add twice their height.
    """
    rates = force_rates(motion, window)
    return np.sum(np.abs(rates) * np.diff(motion.t[motion.kept_samples()])[:, None], axis=0)


def total_force_variation(motion: Motion, window: float | None = FORCE_FILTER_S) -> float:
    """Total variation ``∫ |d(F_z,left + F_z,right)/dt| dt`` of the two soles' summed vertical force, N.

    The summed force is ``m (g + z̈_CoM)``: this measures how much the motion accelerates
    the centre of mass up and down, whereas :func:`force_variation` also counts the weight
    passing from one foot to the other.
    """
    rates = force_rates(motion, window).sum(axis=1)
    return float(np.sum(np.abs(rates) * np.diff(motion.t[motion.kept_samples()])))


def _aligned(measured: Motion, reference: Motion, values: str, columns: slice) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``values`` of ``measured`` and of ``reference`` at the measured times, both
    timed from their first samples; only times inside the reference's span."""
    keep_m, keep_r = measured.kept_samples(), reference.kept_samples()
    t_ref = reference.t[keep_r] - reference.t[0]
    t = measured.t[keep_m] - measured.t[0]
    inside = t <= t_ref[-1]
    ours = getattr(measured, values)[keep_m][inside][:, columns]
    theirs = getattr(reference, values)[keep_r][:, columns]
    # linear interpolation; a NaN (undefined ZMP) spreads to the neighbouring interval
    return ours, np.column_stack([np.interp(t[inside], t_ref, column) for column in theirs.T])


def zmp_rms_error(measured: Motion, reference: Motion) -> float:
    """``(mean_k |p_m(t_k) - p_r(t_k)|²)^½`` of the horizontal ZMP, m, both world frame.

    The reference ZMP is interpolated linearly onto the measured sample times; samples
    where either ZMP is undefined (NaN: no foot pushes) are left out.  NaN if none remain.
    """
    ours, theirs = _aligned(measured, reference, "zmp", slice(0, 2))
    error = np.sum((ours - theirs) ** 2, axis=1)
    error = error[np.isfinite(error)]
    return float(np.sqrt(error.mean())) if len(error) else float("nan")


@dataclasses.dataclass(frozen=True)
class TrackingError:
    """Joint-angle error of a measured motion against its reference (:func:`tracking_error`), rad.

    Attributes
    ----------
    rms : over all joints and samples
    max : the largest absolute error
    per_joint_rms : {joint name: rms over the samples}
    """

    rms: float
    max: float
    per_joint_rms: dict[str, float]


def tracking_error(measured: Motion, reference: Motion) -> TrackingError:
    """Joint-angle error of ``measured`` against ``reference`` at the measured times, rad."""
    if list(measured.joint_names) != list(reference.joint_names):
        raise Error("the measured and reference motions have different joints")
    ours, theirs = _aligned(measured, reference, "q", slice(7, None))
    error = ours - theirs
    return TrackingError(
        rms=float(np.sqrt(np.mean(error**2))),
        max=float(np.abs(error).max()),
        per_joint_rms=dict(zip(measured.joint_names, np.sqrt(np.mean(error**2, axis=0)).tolist())),
    )


def knee_joints(robot: Robot) -> dict[str, int]:
    """Actuated-joint index of each leg's knee: the pitch joint between hip and ankle
    (:meth:`Robot.leg_roles`; TALOS ``leg_left_4_joint`` and ``leg_right_4_joint``)."""
    return {side: roles["knee"] for side, roles in robot.leg_roles().items()}


def knee_torques(robot: Robot, motion: Motion) -> dict[str, np.ndarray]:
    """Knee torque (n,) of each side, N m."""
    return {side: motion.tau[:, i].copy() for side, i in knee_joints(robot).items()}


def swing_heights(robot: Robot, motion: Motion) -> np.ndarray:
    """Peak height (m) of the sole frame above the ground over each swing, in time order of
    the lift-offs: a swing is a run of samples where a sole is out of contact."""
    soles = sole_placements(robot, motion.q)[..., 2]
    out = []
    for j in range(2):
        edges = np.diff(np.concatenate([[0], (~motion.contact[:, j]).astype(int), [0]]))
        out += [(first, float(soles[first:end, j].max())) for first, end in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))]
    return np.array([height for _, height in sorted(out)])


def posture_statistics(robot: Robot, motion: Motion) -> dict:
    """Knee angles (rad, both knees) and CoM height (m) of ``motion``: mean, min and max over
    its samples.  How crouched a walk is sets its knee torques."""
    data = robot.model.createData()
    com = np.array([pin.centerOfMass(robot.model, data, q)[2] for q in motion.q])
    knees = motion.q[:, 7 + np.array(list(knee_joints(robot).values()))]
    return {
        "knee_angle_mean_rad": float(knees.mean()),
        "knee_angle_min_rad": float(knees.min()),
        "knee_angle_max_rad": float(knees.max()),
        "com_height_mean_m": float(com.mean()),
        "com_height_min_m": float(com.min()),
        "com_height_max_m": float(com.max()),
    }


def fell(robot: Robot, motion: Motion, *, height_ratio: float = FALL_HEIGHT_RATIO, tilt: float = FALL_TILT) -> bool:
    """Whether the robot fell: the simulator said so (``simulation.fell``), or at some sample
    the pelvis is below ``height_ratio`` times its first height, or its z axis is tilted
    from the vertical by more than ``tilt`` rad."""
    if motion.simulation is not None and motion.simulation.fell:
        return True
    pelvis = pelvis_placements(robot, motion.q)
    height = np.array([M.translation[2] for M in pelvis])
    tilts = np.arccos(np.clip([M.rotation[2, 2] for M in pelvis], -1.0, 1.0))
    return bool(np.any(height < height_ratio * height[0]) or np.any(tilts > tilt))


def foot_slip(robot: Robot, motion: Motion, force_ratio: float = SLIP_FORCE_RATIO) -> float:
    """Largest horizontal drift of a sole while it carries weight, m.

    For each sole and each run of consecutive samples where its vertical force exceeds
    ``force_ratio`` times the body weight, the horizontal distance of the sole origin from
    where it was at the run's first sample; the maximum over runs and soles.
    """
    soles = sole_placements(robot, motion.q)[..., :2]
    loaded = vertical_forces(motion) > force_ratio * robot.mass * GRAVITY
    slip = 0.0
    for j in range(2):
        edges = np.diff(np.concatenate([[0], loaded[:, j].astype(int), [0]]))
        for first, end in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            drift = np.linalg.norm(soles[first:end, j] - soles[first, j], axis=1)
            slip = max(slip, float(drift.max()))
    return slip


def end_balance_margin(robot: Robot, motion: Motion, force_ratio: float = SLIP_FORCE_RATIO) -> float:
    """Signed distance (m) of the CoM's ground projection inside the support polygon of the
    soles carrying weight at the last sample; negative outside, NaN if no sole carries any.

    A walk ends at rest, so a negative margin means the robot is falling when the motion
    ends, even if it has not yet dropped far enough for :func:`fell`.
    """
    loaded = vertical_forces(motion)[-1] > force_ratio * robot.mass * GRAVITY
    if not loaded.any():
        return float("nan")
    q = motion.q[-1]
    com = pin.centerOfMass(robot.model, robot.model.createData(), q)
    return polygon_margin(support_polygon(robot, q, loaded), com[:2])


def _touchdowns(motion: Motion) -> np.ndarray:
    """(sample k, sole j) pairs, (m, 2): sole j is in the air at sample k and in contact at
    k + 1 (the pre-impact sample of a planned motion, the last airborne sample of a measured one)."""
    return np.argwhere(motion.contact[1:] & ~motion.contact[:-1])


def landing_speeds(robot: Robot, motion: Motion) -> np.ndarray:
    """Speed (m/s) of each sole just before each of its touchdowns.

    A touchdown is a sample after which a sole in the air is in contact: the pre-impact
    sample of a planned motion, the last airborne sample (within one recording interval of
    the contact) of a measured one.  On a stiff position-controlled robot the landing
    speed, not the planned force, sets the force peak.
    """
    model, data = robot.model, robot.model.createData()
    speeds = []
    for k, j in _touchdowns(motion):
        pin.forwardKinematics(model, data, motion.q[k], motion.v[k])
        pin.updateFramePlacements(model, data)
        velocity = pin.getFrameVelocity(model, data, robot.foot_frames[SIDES[j]], pin.LOCAL_WORLD_ALIGNED)
        speeds.append(float(np.linalg.norm(velocity.linear)))
    return np.array(speeds)


def touchdown_times(motion: Motion) -> list[np.ndarray]:
    """Per (left, right) sole, the times (s, from the motion's first sample) of its
    touchdowns: the first sample in contact after one in the air (a planned motion's
    post-impact sample, a measured one's first sample with force)."""
    t = motion.t - motion.t[0]
    pairs = _touchdowns(motion)
    return [t[pairs[pairs[:, 1] == j, 0] + 1] for j in range(2)]


def touchdown_delays(measured: Motion, reference: Motion, window: float = TOUCHDOWN_WINDOW_S) -> np.ndarray:
    """How late (s; negative: early) each planned touchdown happens in ``measured``.

    Each touchdown of ``reference`` is matched to the same sole's nearest measured one;
    a planned touchdown with none within ``window`` seconds (the robot fell before it, or
    the foot never landed) is left out.  Both motions are timed from their first samples.
    A position-controlled robot that lands late drops its weight onto the foot as it
    arrives; one that lands early takes the load gradually.
    """
    out = []
    for planned, actual in zip(touchdown_times(reference), touchdown_times(measured)):
        if len(actual) == 0:  # this sole never landed
            continue
        for t in planned:
            nearest = actual[np.argmin(np.abs(actual - t))]
            if abs(nearest - t) <= window:
                out.append(nearest - t)
    return np.array(out)


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


@dataclasses.dataclass(frozen=True)
class WalkMetrics:
    """The comparison numbers of one motion (:func:`summary`), SI units, undefined values None.

    Per-foot values are the larger of the two feet; the fields from ``zmp_rms_error`` on
    need a reference and are None without one.

    Attributes
    ----------
    fell : whether the robot fell (:func:`fell`)
    duration_s : the measured motion's duration, s
    mean_torque : :func:`mean_torque`, N m s^-½
    rms_torque : :func:`rms_torque`, N m
    peak_force_over_weight : largest vertical sole force over the body weight
    max_force_rate : largest ``|dF_z/dt|`` of the smoothed forces (:func:`max_force_rate`), N/s
    max_force_rate_raw : the same without smoothing, N/s
    force_rate_rms : :func:`force_rate_rms`, N/s
    force_variation_over_weight : :func:`force_variation` over the body weight
    total_force_variation_over_weight : :func:`total_force_variation` over the body weight
    knee_torque_peak : largest absolute knee torque, N m
    foot_slip_m : :func:`foot_slip`, m
    end_balance_margin_m : :func:`end_balance_margin`, m; None when no sole carries weight
    max_landing_speed : fastest touchdown (:func:`landing_speeds`), m/s
    zmp_rms_error : :func:`zmp_rms_error`, m; None where the ZMP is never defined
    tracking_rms_rad, tracking_max_rad : :func:`tracking_error`'s ``rms`` and ``max``, rad
    touchdown_delay_median_s, touchdown_delay_max_s : the median and the largest absolute
        value (sign kept) of :func:`touchdown_delays`, s; None if no touchdown matches
    reference_mean_torque : the reference's :func:`mean_torque`, N m s^-½
    completed : measured duration over reference duration, at most 1
    """

    fell: bool
    duration_s: float
    mean_torque: float
    rms_torque: float
    peak_force_over_weight: float
    max_force_rate: float
    max_force_rate_raw: float
    force_rate_rms: float
    force_variation_over_weight: float
    total_force_variation_over_weight: float
    knee_torque_peak: float
    foot_slip_m: float
    end_balance_margin_m: float | None
    max_landing_speed: float
    zmp_rms_error: float | None = None
    tracking_rms_rad: float | None = None
    tracking_max_rad: float | None = None
    touchdown_delay_median_s: float | None = None
    touchdown_delay_max_s: float | None = None
    reference_mean_torque: float | None = None
    completed: float | None = None

    def to_json(self) -> dict:
        """The metrics as a JSON object, keys in the order of the fields."""
        return dataclasses.asdict(self)


def summary(robot: Robot, measured: Motion, reference: Motion | None = None) -> WalkMetrics:
    """The comparison numbers of ``measured``, against ``reference`` where given.

    Force rates are of the forces smoothed over ``FORCE_FILTER_S`` (:func:`force_rates`);
    ``max_force_rate_raw`` is without smoothing.  With a reference, the torque means are
    over its duration only (:func:`windowed`): a rollout goes on standing after the motion
    ends, and those standing torques would dilute a mean per second; everything else, a
    fall or slip while standing included, is over the whole motion.
    """
    walked = measured if reference is None else windowed(measured, measured.t[0], measured.t[0] + reference.duration)
    out = WalkMetrics(
        fell=fell(robot, measured),
        duration_s=measured.duration,
        mean_torque=mean_torque(walked),
        rms_torque=rms_torque(walked),
        peak_force_over_weight=float(peak_force_over_weight(measured, robot.mass).max()),
        max_force_rate=float(max_force_rate(measured).max()),
        max_force_rate_raw=float(max_force_rate(measured, None).max()),
        force_rate_rms=float(force_rate_rms(measured).max()),
        force_variation_over_weight=float(force_variation(measured).max() / (robot.mass * GRAVITY)),
        total_force_variation_over_weight=total_force_variation(measured) / (robot.mass * GRAVITY),
        knee_torque_peak=float(max(np.abs(tau).max() for tau in knee_torques(robot, measured).values())),
        foot_slip_m=foot_slip(robot, measured),
        end_balance_margin_m=_finite_or_none(end_balance_margin(robot, measured)),
        max_landing_speed=float(landing_speeds(robot, measured).max(initial=0.0)),
    )
    if reference is None:
        return out
    tracking = tracking_error(measured, reference)
    delays = touchdown_delays(measured, reference)
    return dataclasses.replace(
        out,
        touchdown_delay_median_s=float(np.median(delays)) if len(delays) else None,
        touchdown_delay_max_s=float(delays[np.argmax(np.abs(delays))]) if len(delays) else None,
        zmp_rms_error=_finite_or_none(zmp_rms_error(measured, reference)),
        tracking_rms_rad=tracking.rms,
        tracking_max_rad=tracking.max,
        reference_mean_torque=mean_torque(reference),
        completed=min(measured.duration / reference.duration, 1.0),
    )
