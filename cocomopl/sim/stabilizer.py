"""A walking stabilizer for a position-controlled humanoid, after HRP-2's.

Small corrections are added to the commanded joint angles of the legs; the ankle damping
control is steered by the DCM feedback:

* **Body attitude feedback** (hip roll and pitch).  The pelvis roll and pitch measured by
  the IMU are compared with the reference's; with the foot on the ground, turning a hip
  joint by δ turns the pelvis by -δ about the same axis, so the error, times a gain, is
  added to the hip roll and pitch commands of the supporting legs.
* **Ankle damping control** (ankle pitch and roll, Kajita et al., IROS 2010).  The ankle
  servo torque measured is compared with the reference motion's inverse-dynamics torque,
  which is the ankle torque that puts the ZMP where the reference wants it.  The ankle
  command yields to the difference, ``dΔ/dt = -(τ_measured - τ_reference) / D - Δ / T``:
  the foot complies with the ground instead of tipping the robot, and the leak ``T``
  returns it to the reference posture.
* **DCM feedback** (linear inverted pendulum tracking, Kajita et al., IROS 2010; Englsberger
  et al., IROS 2011).  The divergent component of motion ``ξ = c + ċ/ω`` of the measured
  centre of mass ``c`` is compared with the reference's, and the ZMP is asked to move by
  ``K (ξ - ξ_ref)``, which pushes ξ back.  Each sole in contact takes that shift of its
  centre of pressure as an added ankle torque target, ``-J_legᵀ`` of the moment ``f_z × Δp``
  its reference force makes, which the ankle damping control then realises.
* **Foot force difference control** (Kajita et al., IROS 2010).  The difference of the two
  soles' vertical forces, left minus right, is compared with the reference's, and the soles
  are moved vertically against each other, ``dz/dt = (ΔF_measured - ΔF_reference) / D -
  z / T``, the left sole raised by ``z/2`` and the right lowered by ``z/2``: a foot that
  lands early or carries too much load is drawn up and the other pushed down.  The sole
  displacement becomes leg-joint offsets through the damped inverse of the leg Jacobian,
  taken on the reference.
* **Sole tilt adaptation** (single support).  A loaded stance sole that the ground tilts
  away from the reference's orientation (a sole across a bump's edge, a sloping floor) is
  measured from the pelvis attitude and the leg's joints (here the simulation's sole
  pose); the ankle takes up the tilt beyond a small dead band, so that the leg keeps its
  planned posture in the world while the sole rests on the ground as it lies.  Without it a
  sole across an edge rolls over the edge as the centre of pressure moves onto it, and the
  whole robot tips with it.

The first two act only on feet the reference has in contact; a swinging foot's ankle
corrections decay with a faster leak, so that it lands flat.  ``cocomopl simulate --no-stabilizer`` switches it off.
"""

from __future__ import annotations

import bisect
from dataclasses import asdict, dataclass, replace

import mujoco
import numpy as np
import pinocchio as pin

from cocomopl.dynamics import GRAVITY, SIDES
from cocomopl.motion import Motion
from cocomopl.robot import Robot
from cocomopl.sim.hooks import Hook, Step
from cocomopl.sim.mujoco_model import servo_stiffness

# The gains and limits in N, m and N m below are TALOS's: the stabilizer scales them to the
# robot it runs on (Robot.scale, docs/robots.md#settings-scaled-to-the-robot).
ATTITUDE_GAIN = 1.0  # rad of hip command per rad of pelvis attitude error
ATTITUDE_RATE_GAIN = 0.05  # s: damping of the attitude feedback
# The rate term is a damper on the upper body through the hip servos, kp g_r θ' against the
# inertia I the hips turn, and its loop crosses over at kp g_r / I: a command latency costs
# that times the latency of its phase margin.  On another robot it keeps TALOS's crossover,
# g_r = ATTITUDE_RATE_GAIN x (2 kp_hip / I)_TALOS / (2 kp_hip / I)_robot per axis, with the
# project's servos' kp (sim.mujoco_model.servo_stiffness).  TALOS's, roll and pitch, 1/s²:
REFERENCE_HIP_AUTHORITY = (850.9, 1051.3)
# N m s/rad: D, how slowly an ankle yields to a torque error.  3000, not 300: a stiffer ankle
# keeps the sole flat through the weight transfer (benchmarks/stabilizer_tuning.py)
ANKLE_DAMPING = 3000.0
ANKLE_LEAK = 0.5  # s: T, how fast the ankle returns to the reference
FORCE_DAMPING = 1e4  # N s/m: D, how slowly the soles yield to a force-difference error
FORCE_LEAK = 0.2  # s: T, how fast the soles return to the reference
LIFT = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])  # raise the sole, keep its orientation
LIFT_DAMPING = 0.05  # m, of the leg Jacobian's damped inverse
MAX_CORRECTION = 0.2  # rad, per joint
SWING_LEAK = 0.1  # s: T of a swinging foot's ankle corrections
# K of the DCM feedback, 1 + k/ω with k ≈ 3.4 /s: ξ's error decays at k (ω ≈ 3.4 /s here)
DCM_GAIN = 2.0
# Sole tilt adaptation, tuned on the combined-perturbation trials of robustness seeds 7 and
# 17 (docs/method.md#stabilizer): gain 1 (the ankle takes up all of the tilt
# beyond the dead band; 1.5 overshoots and falls), a 5 ms filter (20 ms was too slow for a
# sole rolling over an edge) and a dead band above the 0.3-0.5 degrees a flat floor tilts a
# loaded sole under the stabilized M_gen.
TILT_DEAD_BAND = np.radians(0.5)  # rad
TILT_FILTER = 0.005  # s: time constant of the ankle's take-up of a tilt
TILT_MIN_FORCE = 100.0  # N: a sole carrying less is not yet resting on the ground
# rad taken up at most, about the tilt a 1 cm step under a sole's middle gives it.  A sole
# rolling over its own rim under a push is taken up too, and the ankle then rolls the light
# foot further rather than the body back: with 0.15 the tuning walk of push_recovery.py
# (--to 1.6,0.2,0) survived 250 N lateral pushes at 45 % of phases against 60 % without the
# adaptation; 0.08 keeps it within one trial of that, and 0.05 lost bump trials (35 of 40).
MAX_TILT = 0.08
MAX_ZMP_SHIFT = 0.08  # m: the DCM feedback asks at most this of the ZMP, about a sole's half length
COM_VELOCITY_FILTER = 0.01  # s: time constant of the measured CoM velocity's low-pass filter


@dataclass(frozen=True)
class StabilizerGains:
    """The stabilizer's two main gains.

    Attributes
    ----------
    ankle_damping : D of the ankle damping control, N m s/rad
    dcm_gain : K of the DCM feedback (dimensionless)
    attitude_rate_gains : g_r of the attitude feedback's rate term about roll and pitch, s;
        None: :func:`attitude_rate_gains` of the robot the stabilizer runs on
    """

    ankle_damping: float = ANKLE_DAMPING
    dcm_gain: float = DCM_GAIN
    attitude_rate_gains: tuple[float, float] | None = None

    def as_dict(self) -> dict:
        return asdict(self)


# Per walk generator (the motion's ``producer``), the gains tuned on three sequences
# that no reported figure uses (benchmarks/stabilizer_tuning.py, docs/results.md#stabilizer-tuning).
# A setting replaces the standing D = 3000, K = 2 only if it lowers the generator's mean peak
# force by more than 0.01 x weight.  With the bundled model none does (MP: 0.002 at K = 3).
TUNED_GAINS = {
    "primitives": StabilizerGains(),
    "ocp": StabilizerGains(),
    "kajita": StabilizerGains(),
}


def robot_gains(robot: Robot, producer: str = "primitives") -> StabilizerGains:
    """The gains tuned for the walk generator ``producer`` (the defaults for any other), for
    ``robot``: the ankle damping scaled by its torques' ratio to TALOS's, on which they were
    tuned (:class:`~cocomopl.robot.scale.Scale`), and the attitude rate gains of
    :func:`attitude_rate_gains`; each replaced by the description's ``defaults.stabilizer``
    (its ``attitude_rate_gain``, in s, about both axes)."""
    tuned = TUNED_GAINS.get(producer, StabilizerGains())
    override = dict(robot.override("stabilizer") or {})
    rate = override.pop("attitude_rate_gain", None)
    rates = attitude_rate_gains(robot) if rate is None else (rate, rate)
    return replace(tuned, ankle_damping=tuned.ankle_damping * robot.scale.torque,
                   attitude_rate_gains=tuple(float(x) for x in rates), **override)


def attitude_rate_gains(robot: Robot) -> tuple[float, float]:
    """The attitude feedback's rate gains (roll, pitch), s: TALOS's, scaled to keep the
    crossover of its loop through the hips (:data:`REFERENCE_HIP_AUTHORITY`).  TALOS gets
    exactly its own; G1, whose hips turn a light upper body, 0.025 and 0.0295 s."""
    roles = robot.leg_roles()["left"]
    kp = servo_stiffness(robot)[[roles["hip_roll"], roles["hip_pitch"]]]
    authority = 2.0 * kp / robot.upper_body_inertia
    roll, pitch = ATTITUDE_RATE_GAIN * np.round(np.array(REFERENCE_HIP_AUTHORITY) / authority, 3)
    return float(roll), float(pitch)


def leg_maps(robot: Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At each configuration ``q`` (n, nq), per sole:

    * lifts (n, 2, nu): leg-joint offsets that raise the sole by 1 m relative to the pelvis,
      orientation unchanged, to first order.  The leg Jacobian's damped inverse gives a
      little less rise than asked (86 % with the knees bent as in standing) and stays
      bounded as the knee stretches.
    * moments (n, 2, nu, 2): joint torques that add a ground moment of 1 N m about the
      world x and y axes at the sole (``τ = ID - Jᵀ f``, so ``-Jᵀ``).  Their transposes are
      the sole's rotation about those axes per radian of each joint, the pelvis held.
    * orientations (n, 2, 3, 3): the sole's rotation in the world.
    """
    model, data = robot.model, robot.model.createData()
    chains = [robot.leg_chain(side) for side in SIDES]
    lifts = np.zeros((len(q), 2, robot.nu))
    moments = np.zeros((len(q), 2, robot.nu, 2))
    orientations = np.zeros((len(q), 2, 3, 3))
    damping = (LIFT_DAMPING * robot.scale.length) ** 2 * np.eye(6)  # TALOS's, scaled to the robot
    for k, qk in enumerate(q):
        pin.computeJointJacobians(model, data, qk)
        pin.updateFramePlacements(model, data)
        for j, (side, chain) in enumerate(zip(SIDES, chains)):
            J = pin.getFrameJacobian(model, data, robot.foot_frames[side], pin.LOCAL_WORLD_ALIGNED)
            J_leg = J[:, [6 + i for i in chain]]
            # damped least squares: a stretched knee cannot shorten the leg at first order
            lifts[k, j, chain] = J_leg.T @ np.linalg.solve(J_leg @ J_leg.T + damping, LIFT)
            moments[k, j, chain] = -J_leg[3:5].T
            orientations[k, j] = data.oMf[robot.foot_frames[side]].rotation
    return lifts, moments, orientations


class Stabilizer(Hook):
    """Corrections to the commanded joint angles of one rollout (it keeps the ankle state):
    a hook of the rollout's loop (:mod:`cocomopl.sim.hooks`)."""

    def __init__(self, sim, reference: Motion, gains: StabilizerGains = StabilizerGains()):
        self.sim = sim
        self.dcm_gain = gains.dcm_gain
        self.ankle_damping = gains.ankle_damping
        self.robot = sim.robot
        rates = gains.attitude_rate_gains
        self.rate_gains = attitude_rate_gains(self.robot) if rates is None else tuple(rates)
        self.roles = self.robot.leg_roles()
        # the limits tuned on TALOS, scaled to the robot's weight and size
        scale = self.robot.scale
        self.force_damping = FORCE_DAMPING * scale.mass
        self.tilt_min_force = TILT_MIN_FORCE * scale.mass
        self.max_zmp_shift = MAX_ZMP_SHIFT * scale.length
        self.dt = float(sim.mj.opt.timestep)
        self._track(reference)
        self.com = None  # the measured CoM at the previous call, for its velocity
        self.com_velocity = np.zeros(2)
        self.dcm_error = np.zeros(2)  # measured DCM minus the reference's (world x, y), at the last call
        self.ankles = np.zeros(self.robot.nu)
        self.tilts = np.zeros((2, 2))  # ankle pitch and roll offsets taking up each sole's tilt
        self.z = 0.0

    def command(self, step: Step, command: np.ndarray) -> np.ndarray:
        return command + self.correction(step.data, step.clock)

    def replanned(self, step: Step, motion: Motion) -> None:
        """Track ``motion`` from now on, keeping the feedback's state."""
        self._track(motion)

    def _track(self, reference: Motion) -> None:
        keep = reference.kept_samples()
        self.t = reference.t[keep]
        self._times = self.t.tolist()  # for bisect, a tenth of searchsorted's time on one value
        self._stances = [SIDES[int(np.argmax(c))] if c.sum() == 1 else None for c in reference.contact[keep]]
        self.contact = reference.contact[keep]
        self.tau = reference.tau[keep]
        self.rpy = np.array([pin.rpy.matrixToRpy(pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()) for q in reference.q[keep]])
        self.forces = reference.wrenches[keep, :, 2]
        self.force_difference = self.forces[:, 0] - self.forces[:, 1]
        self.lifts, self.moments, self.sole_rotations = leg_maps(self.robot, reference.q[keep])
        model = self.robot.model
        data = model.createData()
        com = np.array([pin.centerOfMass(model, data, qk) for qk in reference.q[keep]])
        self.omega = np.sqrt(GRAVITY / np.mean(com[:, 2]))
        self.dcm = com[:, :2] + np.gradient(com[:, :2], self.t, axis=0) / self.omega

    def stance(self, time: float) -> str | None:
        """The side of the one sole the reference stands on at ``time``, None in double support."""
        return self._stances[self._sample(time)]

    def _sample(self, time: float) -> int:
        return min(max(bisect.bisect_right(self._times, time) - 1, 0), len(self._times) - 1)

    def correction(self, data: mujoco.MjData, time: float) -> np.ndarray:
        """Joint-angle offsets (nu,) to add to the reference command at ``time``."""
        k = self._sample(time)
        w, x, y, z = data.qpos[3:7]
        rpy = pin.rpy.matrixToRpy(pin.Quaternion(w, x, y, z).toRotationMatrix())
        error = rpy[:2] - self.rpy[k, :2]
        rate = data.qvel[3:5]  # body-frame roll and pitch rates of the free joint
        out = np.zeros(self.robot.nu)
        shift = self._zmp_shift(data, k)
        forces = self.sim.sole_wrenches(data)[:, 2]
        stance = self._stances[k]
        for j, side in enumerate(SIDES):
            roles = self.roles[side]
            ankles = [roles["ankle_pitch"], roles["ankle_roll"]]
            if self.contact[k, j]:
                out[roles["hip_roll"]] = ATTITUDE_GAIN * error[0] + self.rate_gains[0] * rate[0]
                out[roles["hip_pitch"]] = ATTITUDE_GAIN * error[1] + self.rate_gains[1] * rate[1]
                moment = self.forces[k, j] * np.array([shift[1], -shift[0]])  # of the sole's CoP moved by shift
                target = self.tau[k, ankles] + self.moments[k, j, ankles] @ moment
                torque_error = self.sim.joint_torques(data)[ankles] - target
                self.ankles[ankles] += self.dt * (-torque_error / self.ankle_damping - self.ankles[ankles] / ANKLE_LEAK)
            else:
                self.ankles[ankles] -= self.dt * self.ankles[ankles] / SWING_LEAK
            # in single support only: held in double support, a take-up kept both soles rolled
            # onto their toes as the robot came to rest after a start step played alone
            resting = stance == side and forces[j] > self.tilt_min_force
            target = self._tilt_take_up(data, k, j, ankles) if resting else np.zeros(2)
            self.tilts[j] += (target - self.tilts[j]) * min(self.dt / TILT_FILTER, 1.0)
            out[ankles] += self.tilts[j]
        error = (forces[0] - forces[1]) - self.force_difference[k]
        self.z += self.dt * (error / self.force_damping - self.z / FORCE_LEAK)
        out += self.ankles + 0.5 * self.z * (self.lifts[k, 0] - self.lifts[k, 1])
        return np.minimum(np.maximum(out, -MAX_CORRECTION), MAX_CORRECTION)  # np.clip, without its overhead

    def _tilt_take_up(self, data: mujoco.MjData, k: int, j: int, ankles: list[int]) -> np.ndarray:
        """Ankle offsets (pitch, roll) that turn sole ``j`` by its measured tilt from the
        reference at sample ``k`` (about the world's horizontal axes, beyond the dead band),
        the leg above the ankle held."""
        measured = data.site_xmat[self.sim.sole_sites[SIDES[j]]].reshape(3, 3)
        tilt = pin.log3(measured @ self.sole_rotations[k, j].T)[:2]
        size = float(np.linalg.norm(tilt))
        if size <= TILT_DEAD_BAND:
            return np.zeros(2)
        tilt *= min(size - TILT_DEAD_BAND, MAX_TILT) / size
        # the sole turns by J δ for ankle offsets δ, and J is the transpose of -moments
        return np.linalg.solve(-self.moments[k, j, ankles].T, tilt)

    def _zmp_shift(self, data: mujoco.MjData, k: int) -> np.ndarray:
        """Horizontal ZMP change (2,) that brings the measured DCM back to the reference's."""
        com = data.subtree_com[0, :2].copy()  # the world body's subtree: the whole robot
        if self.com is not None:
            velocity = (com - self.com) / self.dt
            self.com_velocity += (velocity - self.com_velocity) * min(self.dt / COM_VELOCITY_FILTER, 1.0)
        self.com = com
        self.dcm_error = com + self.com_velocity / self.omega - self.dcm[k]
        return np.minimum(np.maximum(self.dcm_gain * self.dcm_error, -self.max_zmp_shift), self.max_zmp_shift)
