"""A walking stabilizer for a position-controlled humanoid, after HRP-2's.

Two small corrections are added to the commanded joint angles, on the legs in contact:

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

Both act only on feet the reference has in contact; a swinging foot's corrections decay
with the same leak.  ``cocomopl simulate --no-stabilizer`` switches it off.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin

from cocomopl.dynamics import SIDES
from cocomopl.motion import Motion

ATTITUDE_GAIN = 1.0  # rad of hip command per rad of pelvis attitude error
ATTITUDE_RATE_GAIN = 0.05  # s: damping of the attitude feedback
ANKLE_DAMPING = 300.0  # N m s/rad: D, how slowly an ankle yields to a torque error
ANKLE_LEAK = 0.5  # s: T, how fast the ankle returns to the reference
MAX_CORRECTION = 0.2  # rad, per joint


class Stabilizer:
    """Corrections to the commanded joint angles of one rollout (it keeps the ankle state)."""

    def __init__(self, sim, reference: Motion):
        self.robot = sim.robot
        self.roles = self.robot.leg_roles()
        self.dt = float(sim.mj.opt.timestep)
        keep = reference.kept_samples()
        self.t = reference.t[keep]
        self.contact = reference.contact[keep]
        self.tau = reference.tau[keep]
        self.rpy = np.array([pin.rpy.matrixToRpy(pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()) for q in reference.q[keep]])
        self.ankles = np.zeros(self.robot.nu)

    def _sample(self, time: float) -> int:
        return int(np.clip(np.searchsorted(self.t, time, side="right") - 1, 0, len(self.t) - 1))

    def correction(self, data: mujoco.MjData, time: float) -> np.ndarray:
        """Joint-angle offsets (nu,) to add to the reference command at ``time``."""
        k = self._sample(time)
        w, x, y, z = data.qpos[3:7]
        rpy = pin.rpy.matrixToRpy(pin.Quaternion(w, x, y, z).toRotationMatrix())
        error = rpy[:2] - self.rpy[k, :2]
        rate = data.qvel[3:5]  # body-frame roll and pitch rates of the free joint
        out = np.zeros(self.robot.nu)
        for j, side in enumerate(SIDES):
            roles = self.roles[side]
            ankles = [roles["ankle_pitch"], roles["ankle_roll"]]
            if self.contact[k, j]:
                out[roles["hip_roll"]] = ATTITUDE_GAIN * error[0] + ATTITUDE_RATE_GAIN * rate[0]
                out[roles["hip_pitch"]] = ATTITUDE_GAIN * error[1] + ATTITUDE_RATE_GAIN * rate[1]
                torque_error = data.actuator_force[ankles] - self.tau[k, ankles]
                self.ankles[ankles] += self.dt * (-torque_error / ANKLE_DAMPING - self.ankles[ankles] / ANKLE_LEAK)
            else:
                self.ankles[ankles] -= self.dt * self.ankles[ankles] / ANKLE_LEAK
        out += self.ankles
        return np.clip(out, -MAX_CORRECTION, MAX_CORRECTION)
