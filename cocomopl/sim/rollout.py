"""Run a motion in MuJoCo as a position-controlled robot would, and measure what happens.

The reference joint angles go, interpolated to the 1 kHz loop and low-passed, to the joint
position servos; the stabilizer (:mod:`cocomopl.sim.stabilizer`) may add small corrections.
The plans are sampled every 25 ms and interpolated linearly: their kinks carry content up
to and beyond the 20 Hz Nyquist rate of those knots, which no servo should be asked to
follow.  A zero-phase low-pass (second-order Butterworth, run forwards and backwards over
the whole reference, which is known before it is played) keeps the gait, whose content
lies below 5 Hz, and removes that.  The robot first stands for ``settle`` seconds in the
motion's first posture, as a real robot does before it is told to walk.  What comes out is
a :class:`Motion` of the same schema: measured configurations, velocities, servo torques,
contact wrenches of each sole (summed over its contact points, about the sole frame
origin), contact flags and the ZMP of those wrenches.

:func:`simulate` is one loop that steps MuJoCo, records and detects a fall; the stabilizer,
the servo channel, pushes and any other controller or perturbation are hooks it calls at
each step, and recovery by stepping or footstep re-aiming its one replanner
(:mod:`cocomopl.sim.hooks`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import mujoco
import numpy as np
from tqdm import tqdm

from cocomopl.analysis.metrics import FALL_HEIGHT_RATIO, FALL_TILT
from cocomopl.dynamics import SIDES, zmp_from_wrenches
from cocomopl.errors import Error
from cocomopl.motion import Motion, RolloutRecord
from cocomopl.sim.hooks import Hook, Replanner, Step
from cocomopl.sim.mujoco_model import TIMESTEP, SimModel
from cocomopl.sim.perturbations import Push
from cocomopl.sim.servos import CommandChannel, ServoSettings, with_gains
from cocomopl.sim.stabilizer import Stabilizer, StabilizerGains, robot_gains

RECORD_DT = 0.005  # s between recorded samples
SETTLE_S = 0.5  # s standing before the motion starts
HOLD_S = 1.0  # s standing in the last posture after it ends: a walk must also come to rest
CONTACT_FORCE = 1.0  # N: a sole with less than this is in the air
# Hz: cut-off of the reference's low-pass, below the 20 Hz Nyquist rate of 25 ms plans.
# Measured on 20 random walks of seeds 0 and 1 with the stabilizer, the median peak force
# went from 1.51 and 1.45 to 1.36 and 1.37 x weight; README "Stage 3" has the rest.
REFERENCE_CUTOFF_HZ = 15.0
REPLAN_BLEND_S = 0.1  # s over which the commands move onto a walk replanned while it is played


@dataclass
class Rollout:
    """A simulated motion: what was measured, and the MuJoCo states for rendering."""

    measured: Motion
    qpos: np.ndarray  # (n, mj.nq) at the measured samples
    fell: bool
    fall_time: float | None


def check_reference_cutoff(value: float) -> float:
    """``value`` (Hz) if it is a usable cut-off for the reference low-pass (0: none), else
    :class:`Error`: it must lie below the Nyquist rate of the 1 kHz control loop."""
    if not 0 <= value < 0.5 / TIMESTEP:
        raise Error(f"reference cut-off {value:g} Hz is outside 0 (no filter) to {0.5 / TIMESTEP:g} Hz")
    return value


def low_passed(samples: np.ndarray, dt: float, cutoff: float) -> np.ndarray:
    """``samples`` (n, m) every ``dt`` s through the reference's zero-phase low-pass at
    ``cutoff`` Hz (0: unchanged)."""
    if not cutoff:
        return samples
    # imported here: scipy.signal takes 0.7 s to load, which every command would pay
    from scipy.signal import butter, sosfiltfilt

    # the robot stands still before and after: extend the ends with constant postures
    sos = butter(2, cutoff, fs=1.0 / dt, output="sos")
    return sosfiltfilt(sos, samples, axis=0, padtype="constant", padlen=min(len(samples) - 1, int(1.0 / dt)))


class Reference:
    """The plan's joint commands at any time, the source of each control step's command:
    ``motion``'s joint angles linear between its knots, sampled every ``dt``, low-passed at
    ``cutoff`` Hz (0 or None: not filtered), held at the ends.

    With ``servo_gains``, the servos' ``(kp, kv)`` (2, joints), each command is offset by
    ``(tau + kv qdot) / kp`` for the plan's torque ``tau`` and joint velocity ``qdot``
    (the torque feedforward): a servo ``kp (command - q) - kv qdot`` then delivers the plan's
    torque where it follows the plan, instead of sagging under the load and lagging behind
    the motion.  A walk replanned while it is played is blended in over ``REPLAN_BLEND_S``.
    """

    def __init__(self, motion: Motion, dt: float, cutoff: float | None, *, servo_gains: np.ndarray | None = None):
        self.dt, self.cutoff, self.servo_gains = dt, cutoff, servo_gains
        self._at = self._sampled(motion)

    def at(self, time: float) -> np.ndarray:
        """The joint command (nu,) at ``time``, s on the reference's clock."""
        return self._at(time)

    def command(self, step: Step) -> np.ndarray:
        return self._at(step.clock)

    def replanned(self, step: Step, motion: Motion) -> None:
        """Move onto ``motion``'s commands from ``step`` on."""
        self._at = _blended(self._at, self._sampled(motion), step.clock, REPLAN_BLEND_S)

    def _sampled(self, motion: Motion):
        dt, cutoff = self.dt, self.cutoff
        keep = motion.kept_samples()
        t = motion.t[keep]
        grid = np.arange(t[0], t[-1] + dt / 2, dt)

        def sampled(values: np.ndarray) -> np.ndarray:
            return low_passed(np.column_stack([np.interp(grid, t, x) for x in values.T]), dt, cutoff)

        samples = sampled(motion.q[keep, 7:])
        if self.servo_gains is not None:
            kp, kv = self.servo_gains
            samples = samples + (sampled(motion.tau[keep]) + kv * np.gradient(samples, dt, axis=0)) / kp

        def at(time: float) -> np.ndarray:
            return samples[min(max(round((time - t[0]) / dt), 0), len(grid) - 1)]

        return at


def _blended(old, new, start: float, span: float):
    """Commands that move from ``old``'s to ``new``'s over ``span`` s from ``start`` (raised cosine)."""

    def at(time: float) -> np.ndarray:
        if time >= start + span:
            return new(time)
        weight = 0.5 - 0.5 * np.cos(np.pi * max(time - start, 0.0) / span)
        return old(time) + weight * (new(time) - old(time))

    return at


def placed_on_floor(sim: SimModel, data: mujoco.MjData, q0: np.ndarray) -> None:
    """Set the state to ``q0`` at rest, lowered so that the lowest sole touches the floor."""
    data.qpos[:] = sim.qpos(q0)
    data.qvel[:] = 0.0
    mujoco.mj_kinematics(sim.mj, data)
    data.qpos[2] -= min(data.site_xpos[sim.sole_sites[s]][2] for s in SIDES)
    mujoco.mj_forward(sim.mj, data)


def _tilt(quat_wxyz: np.ndarray) -> float:
    """Angle between the base's z axis and the vertical."""
    _w, x, y, _z = quat_wxyz
    return float(np.arccos(min(max(1 - 2 * (x * x + y * y), -1.0), 1.0)))


def simulate(
    sim: SimModel,
    motion: Motion,
    *,
    stabilizer: bool = True,
    gains: StabilizerGains | None = None,
    feedforward: bool = False,
    reference_cutoff_hz: float = REFERENCE_CUTOFF_HZ,
    servos: ServoSettings | None = None,
    pushes: Sequence[Push] = (),
    hooks: Sequence[Hook] = (),
    replanner: Replanner | None = None,
    settle: float = SETTLE_S,
    hold: float = HOLD_S,
    record_dt: float = RECORD_DT,
    progress: bool = False,
) -> Rollout:
    """Play ``motion`` on the simulated robot with joint position control.

    The loop (:mod:`cocomopl.sim.hooks`) takes each control step's command from the
    :class:`Reference` and passes it through the hooks in this order: the stabilizer, the
    pushes, ``hooks``, and the servos' :class:`~cocomopl.sim.servos.CommandChannel`.

    Parameters
    ----------
    sim : the compiled model (:func:`cocomopl.sim.mujoco_model.build_sim_model`)
    motion : the reference, world frame, starting at rest on the floor
    stabilizer : add the stabilizer's corrections to the commanded joint angles
    gains : the stabilizer's gains; default those tuned for the generator that made
        ``motion`` (:func:`~cocomopl.sim.stabilizer.robot_gains`)
    feedforward : offset the commands by the plan's torques and the servos' damping of the
        plan's velocity (:class:`Reference`), so that the servos track the plan rather than
        sag and lag
    reference_cutoff_hz : cut-off (Hz) of the zero-phase low-pass of the reference joints;
        0 plays the linear interpolation of the knots as it is (:func:`check_reference_cutoff`)
    servos : per-group servo gains, control latency and encoder noise
        (:class:`~cocomopl.sim.servos.ServoSettings`); default the model's servos, ideal
    pushes : forces on the pelvis (:class:`~cocomopl.sim.perturbations.Push`), timed from the
        motion's start
    hooks : further controllers or perturbations (:class:`~cocomopl.sim.hooks.Hook`)
    replanner : changes the walk while it is played (:class:`~cocomopl.sim.hooks.Replanner`):
        recovery by stepping (:class:`~cocomopl.sim.recovery.StepRecovery`, needs the
        stabilizer) or footstep re-aiming (:class:`~cocomopl.sim.reaiming.Reaiming`); the
        rollout follows each walk it generates from then on
    settle : seconds standing in the first posture before the motion starts
    hold : seconds the last posture is held after the motion ends (recorded: a robot that
        topples right after the last step has fallen)
    record_dt : seconds between recorded samples

    Returns
    -------
    Rollout with the measured :class:`Motion` (time 0 = the reference's first sample)
    """
    check_reference_cutoff(reference_cutoff_hz)
    servos = servos or ServoSettings()
    sim = with_gains(sim, servos)
    dt = sim.mj.opt.timestep
    reference = Reference(motion, dt, reference_cutoff_hz, servo_gains=sim.servo_gains() if feedforward else None)
    gains = (gains or robot_gains(sim.robot, motion.producer)) if stabilizer else None
    control = None if gains is None else Stabilizer(sim, motion, gains)
    if replanner is not None:
        replanner.start(control)
    channel = CommandChannel(servos, dt, sim.robot.nu)
    played = _played(sim, motion, reference, [*([control] if control else []), *pushes, *hooks, channel],
                     replanner=replanner, settle=settle, hold=hold, record_dt=record_dt, progress=progress)
    record = RolloutRecord(
        reference_producer="unknown" if played.motion.producer is None else played.motion.producer,
        stabilizer=gains is not None,
        stabilizer_gains=None if gains is None else gains.as_dict(),
        reference_cutoff_hz=reference_cutoff_hz,
        feedforward=feedforward,
        fell=played.fell,
        fall_time_s=played.fall_time,
        timestep_s=float(dt),
        sim_model=sim.source,
        contact_time_constant_s=sim.contact_time_constant,
        servos=servos.as_dict(),
        pushes=[asdict(push) for push in pushes],
        **({} if replanner is None else replanner.metadata()),
    )
    measured = _measured_motion(sim, played.motion, played.rows, record)
    return Rollout(measured, np.array(played.rows["qpos"]), played.fell, played.fall_time)


@dataclass
class _Played:
    rows: dict[str, list]  # per recorded sample: t, q, v, tau, wrenches, qpos
    motion: Motion  # the walk followed at the end (the last the replanner made)
    fell: bool
    fall_time: float | None


def _played(sim: SimModel, motion: Motion, reference: Reference, hooks: Sequence[Hook], *,
            replanner: Replanner | None, settle: float, hold: float, record_dt: float, progress: bool) -> _Played:
    """The loop: stand for ``settle`` s, play ``motion`` and hold its end for ``hold`` s,
    recording every ``record_dt`` s, until the end or a fall."""
    model = sim.mj
    dt = model.opt.timestep
    data = mujoco.MjData(model)
    placed_on_floor(sim, data, motion.q[0])
    t0 = float(motion.t[0])
    every = max(round(record_dt / dt), 1)
    n_settle = round(settle / dt)
    n_total = n_settle + int(np.ceil((motion.duration + hold) / dt))
    start_height = float(data.qpos[2])
    rows: dict[str, list] = {k: [] for k in ("t", "q", "v", "tau", "wrenches", "qpos")}
    fell, fall_time = False, None
    bar = tqdm(total=n_total + 1, desc="simulating", unit="ms", disable=not progress, leave=False)
    i = 0
    while i <= n_total:
        time = t0 + (i - n_settle) * dt
        step = Step(sim, data, clock=max(time, t0), elapsed=time - t0,
                    sample=i >= n_settle and (i - n_settle) % every == 0)
        command = reference.command(step)
        for hook in hooks:
            command = hook.command(step, command)
        sim.command(data, command)
        data.xfrc_applied[:] = 0.0
        for hook in hooks:
            hook.before_step(step)
        if step.sample:
            rows["t"].append(step.elapsed)
            rows["q"].append(sim.q(data.qpos))
            rows["v"].append(sim.v(data.qpos, data.qvel))
            rows["tau"].append(sim.joint_torques(data))
            rows["wrenches"].append(sim.sole_wrenches(data))
            rows["qpos"].append(data.qpos.copy())
            replanned = None if replanner is None else replanner.replan(step)
            if replanned is not None:
                for hook in (reference, *hooks):
                    hook.replanned(step, replanned)
                motion = replanned
                n_total = n_settle + int(np.ceil((motion.duration + hold) / dt))
        if data.qpos[2] < FALL_HEIGHT_RATIO * start_height or _tilt(data.qpos[3:7]) > FALL_TILT:
            fell, fall_time = True, max(time - t0, 0.0)
            break
        mujoco.mj_step(model, data)
        i += 1
        bar.update()
    bar.close()
    return _Played(rows, motion, fell, fall_time)


def _measured_motion(sim: SimModel, reference: Motion, rows: dict, record: RolloutRecord) -> Motion:
    t = np.array(rows["t"])
    q = np.array(rows["q"])
    wrenches = np.array(rows["wrenches"])
    soles = np.zeros((len(t), 2, 3))
    data = mujoco.MjData(sim.mj)
    for k, qpos in enumerate(rows["qpos"]):
        data.qpos[:] = qpos
        mujoco.mj_kinematics(sim.mj, data)
        soles[k] = [data.site_xpos[sim.sole_sites[s]] for s in SIDES]
    contact = wrenches[..., 2] > CONTACT_FORCE
    starts = np.searchsorted(t, reference.t[reference.step_starts] - reference.t[0])
    return Motion(
        t=t,
        q=q,
        v=np.array(rows["v"]),
        tau=np.array(rows["tau"]),
        wrenches=wrenches,
        contact=contact,
        zmp=zmp_from_wrenches(soles, wrenches),
        phases=[],
        impacts=np.zeros(0, dtype=int),
        steps=list(reference.steps),
        step_starts=np.minimum(starts, max(len(t) - 1, 0)).astype(int),
        joint_names=list(reference.joint_names),
        robot=reference.robot,
        producer="mujoco",
        simulation=record,
    )
