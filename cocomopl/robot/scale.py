"""How a robot's size compares with TALOS's, on which every default was tuned.

The defaults that depend on a robot's size (the OCPs' margins, gaps, weights and durations,
the stabilizer's gains and limits, the default walk and training lengths) are TALOS's numbers
scaled by three ratios of the robot's to TALOS's: its mass, its leg length and its soles' half
width (docs/robots.md#settings-scaled-to-the-robot).  Each ratio is rounded to 0.1 %, so that
TALOS gets exactly its own numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# TALOS: its mass (kg), its pelvis height above the soles with straight legs (m) and its
# soles' half width (m)
REFERENCE_MASS_KG = 90.27
REFERENCE_LEG_LENGTH_M = 1.083
REFERENCE_SOLE_HALF_WIDTH_M = 0.0672
# TALOS's rotor inertia reflected through its gears, at every joint (its SRDF's rotor parameters)
REFERENCE_ARMATURE_KG_M2 = 0.1
# TALOS's pendulum rate sqrt(g / h) at its CoM height h in its posture (0.877 m), 1/s
REFERENCE_OMEGA = 3.345
# TALOS's longest default step (its training lengths and M_gen), m
REFERENCE_LONGEST_STEP_M = 0.4
# TALOS's leg joints' torque limits (its URDF), N m, by role: another robot's leg servos are
# no stiffer for its weight and size than these scaled by its torque ratio (sim.mujoco_model)
REFERENCE_LEG_TORQUES_NM = {"hip_yaw": 100.0, "hip_roll": 160.0, "hip_pitch": 160.0, "knee": 300.0,
                            "ankle_pitch": 160.0, "ankle_roll": 100.0}


@dataclass(frozen=True)
class Scale:
    """A robot's size relative to TALOS's.

    Attributes
    ----------
    mass : the robot's mass over TALOS's
    length : its leg length over TALOS's
    width : its soles' half width over TALOS's
    stride : its default step lengths over TALOS's where its legs cannot stand across TALOS's
        longest step scaled by ``length`` (:attr:`~cocomopl.robot.Robot.scale`); None: ``length``
    """

    mass: float = 1.0
    length: float = 1.0
    width: float = 1.0
    stride: float | None = None

    @classmethod
    def of(cls, mass: float, leg_length: float, sole_half_width: float) -> Scale:
        """The scale of a robot of ``mass`` (kg), ``leg_length`` (m) and ``sole_half_width`` (m)."""
        return cls(mass=round(mass / REFERENCE_MASS_KG, 3), length=round(leg_length / REFERENCE_LEG_LENGTH_M, 3),
                   width=round(sole_half_width / REFERENCE_SOLE_HALF_WIDTH_M, 3))

    @property
    def time(self) -> float:
        """Durations' ratio: the square root of the lengths', so that a walk keeps its Froude
        number and the pendulum its phase per step."""
        return math.sqrt(self.length)

    @property
    def torque(self) -> float:
        """Torques' ratio: weight times length."""
        return self.mass * self.length

    def duration(self, seconds: float, dt: float) -> float:
        """``seconds`` of TALOS's scaled to the robot, a whole number of knots ``dt`` (s);
        TALOS's own, as they are."""
        if self.length == 1.0:
            return seconds
        return _knots(seconds * self.time, dt)

    def single_support(self, seconds: float, dt: float) -> float:
        """A single support of ``seconds`` of TALOS's scaled to the robot, in whole knots ``dt``.

        Through a single support a lateral error of the CoM grows as ``exp(omega T)``
        (``omega``, the pendulum's rate, scales as ``1 / time``), and the stance sole's half
        width is what the ankle has to stop it with.  So the growth is kept in proportion to
        the soles' width: ``omega T = omega_TALOS T_TALOS + ln(width)``.  G1's soles, 37 % as
        wide as TALOS's, give it 0.425 s where the leg length alone gives 0.675 s.
        """
        if self.length == 1.0 and self.width == 1.0:
            return seconds
        return _knots(self.time * (seconds + math.log(self.width) / REFERENCE_OMEGA), dt)

    def length_m(self, metres: float, resolution: float = 0.01) -> float:
        """A step length of ``metres`` of TALOS's scaled to the robot (by ``stride`` if it
        is set, else by the leg length), rounded to ``resolution`` (m); TALOS's own, as they are."""
        ratio = self.length if self.stride is None else self.stride
        if ratio == 1.0:
            return metres
        return round(round(metres * ratio / resolution) * resolution, 6)


def _knots(seconds: float, dt: float) -> float:
    """``seconds`` rounded to a whole number of knots ``dt``, at least one."""
    return round(dt * max(1, round(seconds / dt)), 9)
