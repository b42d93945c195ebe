"""The servo model a rollout runs with: per-group gains, control latency and encoder noise.

A real robot's joint servos are not the simulator's ideal ones.  Their gains are set per
joint group, the command a controller computes reaches the motor drives a few milliseconds
later, and each servo closes its loop on an encoder reading with noise.  This module holds
those settings (:class:`ServoSettings`) and applies them to a MuJoCo model's position
servos (:func:`with_gains`) and to the commands of a rollout (:class:`CommandChannel`, the
last hook of the rollout's loop, :mod:`cocomopl.sim.hooks`); the rollout
(:func:`~cocomopl.sim.rollout.simulate`) uses both.

A position servo's torque is ``kp (command - q) - kv qdot``, so an encoder reading
``q + n`` acts exactly like the command ``command - n``: the noise is applied that way.
"""

from __future__ import annotations

import copy
from collections import deque
from dataclasses import asdict, dataclass, field

import numpy as np

from cocomopl.errors import Error
from cocomopl.sim.hooks import Hook, Step

GROUPS = ("legs", "torso", "arms")
ALL = "all"
MAX_LATENCY_S = 0.1  # longer delays are not a servo's but a broken controller's
MAX_GAIN_SCALE = 100.0
MAX_KV_TIME_S = 1.0
MAX_ENCODER_NOISE_RAD = 0.1


@dataclass(frozen=True)
class ServoSettings:
    """How the robot's joint servos differ from the model's.

    Attributes
    ----------
    kp_scale : factor on the model's stiffness kp, per joint group (``legs``, ``torso``,
        ``arms``, or ``all``); groups not named keep theirs
    kv_time_s : the servos' damping as a time constant, ``kv = kp * kv_time_s`` (s), per group;
        groups not named keep the model's kv
    latency_s : delay between a command and the servos receiving it, s (rounded to the
        control loop's timestep)
    encoder_noise_rad : standard deviation of the Gaussian noise on each servo's joint
        reading, rad, drawn anew every control step
    seed : of the noise
    """

    kp_scale: dict[str, float] = field(default_factory=dict)
    kv_time_s: dict[str, float] = field(default_factory=dict)
    latency_s: float = 0.0
    encoder_noise_rad: float = 0.0
    seed: int = 1

    def __post_init__(self):
        for what, values, limits in (("kp scale", self.kp_scale, (0.0, MAX_GAIN_SCALE)),
                                     ("kv time constant", self.kv_time_s, (0.0, MAX_KV_TIME_S))):
            for group, value in values.items():
                if group not in (*GROUPS, ALL):
                    raise Error(f"servo group {group!r} is not one of {', '.join((*GROUPS, ALL))}")
                if not limits[0] <= value <= limits[1] or (what == "kp scale" and value == 0):
                    raise Error(f"{what} {value!r} of the {group} is outside {limits[0]:g} to {limits[1]:g}"
                                + (" (and must be above 0)" if what == "kp scale" else " s"))
        if not 0.0 <= self.latency_s <= MAX_LATENCY_S:
            raise Error(f"latency {self.latency_s!r} s is outside 0 to {MAX_LATENCY_S:g} s")
        if not 0.0 <= self.encoder_noise_rad <= MAX_ENCODER_NOISE_RAD:
            raise Error(f"encoder noise {self.encoder_noise_rad!r} rad is outside 0 to {MAX_ENCODER_NOISE_RAD:g} rad")

    def as_dict(self) -> dict:
        return asdict(self)

    def per_joint(self, groups: dict[str, np.ndarray], n: int) -> tuple[np.ndarray, np.ndarray]:
        """The kp factors (n,) and the kv time constants (n,; NaN: the model's own) of the robot's joints."""
        kp, kv = np.ones(n), np.full(n, np.nan)
        for values, out in ((self.kp_scale, kp), (self.kv_time_s, kv)):
            if ALL in values:
                out[:] = values[ALL]
            for group, value in values.items():
                if group != ALL:
                    out[groups[group]] = value
        return kp, kv


def with_gains(sim, settings: ServoSettings):
    """A copy of ``sim`` (:class:`~cocomopl.sim.mujoco_model.SimModel`) whose robot servos have
    the gains of ``settings``; ``sim`` itself is left as it was."""
    if not (settings.kp_scale or settings.kv_time_s):
        return sim
    out = copy.copy(sim)
    out.mj = copy.deepcopy(sim.mj)
    kp_factor, kv_time = settings.per_joint(sim.robot.joint_groups(), sim.robot.nu)
    a = sim.actuators
    kp = out.mj.actuator_gainprm[a, 0] * kp_factor
    kv = np.where(np.isnan(kv_time), -out.mj.actuator_biasprm[a, 2], kp * np.nan_to_num(kv_time))
    out.mj.actuator_gainprm[a, 0] = kp
    out.mj.actuator_biasprm[a, 1] = -kp
    out.mj.actuator_biasprm[a, 2] = -kv
    return out


class CommandChannel(Hook):
    """The way from the controller's joint commands to the servos: delayed by the latency
    (in whole control steps) and offset by the encoder noise."""

    def __init__(self, settings: ServoSettings, timestep: float, n: int):
        self.delay = round(settings.latency_s / timestep)
        self.noise = settings.encoder_noise_rad
        self.rng = np.random.default_rng(settings.seed)
        self.queue: deque[np.ndarray] = deque()
        self.n = n

    def command(self, step: Step, command: np.ndarray) -> np.ndarray:
        return self.received(command)

    def received(self, command: np.ndarray) -> np.ndarray:
        """The command the servos act on now, given the one the controller just computed."""
        if not self.queue:  # before the first command arrives the servos hold the first one
            self.queue.extend([command] * self.delay)
        self.queue.append(command)
        received = self.queue.popleft()
        return received - self.rng.normal(0.0, self.noise, self.n) if self.noise else received
