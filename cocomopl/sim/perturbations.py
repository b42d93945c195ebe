"""A simulated world that is not the model: link masses and centres of mass, joint friction
and damping, floor friction, tilt and bumps, and pushes.

A robot's model is never exact, and its floor is never the plan's.  :class:`Perturbation`
says how far the world may be off; :meth:`Perturbation.draw` draws one world from it (one
trial: each link's error drawn on its own, uniformly within the bounds), and
:func:`perturbed` makes the MuJoCo model of that world from the robot's, which is left as it
was.  A :class:`Push` is a force on the pelvis for a while, a hook of the rollout's loop
(:mod:`cocomopl.sim.hooks`).  The servos' own errors (gains, latency, encoder
noise) are :mod:`cocomopl.sim.servos`'.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from cocomopl.errors import Error
from cocomopl.sim.hooks import Hook, Step
from cocomopl.sim.mujoco_model import FRICTION


@dataclass(frozen=True)
class Push(Hook):
    """A horizontal force ``force_n`` (x, y; N, world axes) on the pelvis from ``time_s``
    (after the motion's start) for ``duration_s``."""

    time_s: float
    force_n: tuple[float, float]
    duration_s: float = 0.1

    def force_at(self, time: float) -> np.ndarray:
        """The force (3,) at ``time`` (s after the motion's start)."""
        on = self.time_s <= time < self.time_s + self.duration_s
        return np.array([*self.force_n, 0.0]) if on else np.zeros(3)

    def before_step(self, step: Step) -> None:
        step.data.xfrc_applied[step.sim.base_body, :3] += self.force_at(step.elapsed)


MAX_PUSH_N = 5000.0  # a larger force is a typing error, not a push


def parse_push(text: str) -> Push:
    """A :class:`Push` from ``"AT_S,FX_N,FY_N"``; an :class:`Error` in one line unless it is
    three finite numbers with the time 0 or more and the force within ``MAX_PUSH_N``."""
    parts = text.split(",")
    try:
        at, fx, fy = (float(p) for p in parts)
    except ValueError:
        raise Error(f"push {text!r} must be three numbers: AT_S,FX_N,FY_N") from None
    if not (math.isfinite(at) and at >= 0 and math.isfinite(fx) and math.isfinite(fy) and math.hypot(fx, fy) <= MAX_PUSH_N):
        raise Error(f"push {text!r}: the time must be 0 s or more and the force at most {MAX_PUSH_N:g} N")
    return Push(at, (fx, fy))


@dataclass(frozen=True)
class Perturbation:
    """Bounds of the world's errors; each is drawn per trial, uniformly.

    Attributes
    ----------
    mass : relative error of each link's mass and inertia, ``1 ± mass``
    com_offset_m : each link's centre of mass moved by up to this on each axis
    joint_friction_nm : each joint's friction loss (Coulomb), 0 to this, N m
    joint_damping : each joint's viscous damping, 0 to this, N m s/rad
    floor_friction : (low, high) of the floor's friction coefficient; None: the model's
    floor_tilt_deg : the floor tilted by up to this about each horizontal axis (as gravity
        tilted the other way)
    bump_m : boxes on the floor under the walk, each up to this high (0: none)
    """

    mass: float = 0.0
    com_offset_m: float = 0.0
    joint_friction_nm: float = 0.0
    joint_damping: float = 0.0
    floor_friction: tuple[float, float] | None = None
    floor_tilt_deg: float = 0.0
    bump_m: float = 0.0

    def __post_init__(self):
        checks = {"mass": (self.mass, 0.5), "com_offset_m": (self.com_offset_m, 0.05),
                  "joint_friction_nm": (self.joint_friction_nm, 50.0), "joint_damping": (self.joint_damping, 100.0),
                  "floor_tilt_deg": (self.floor_tilt_deg, 10.0), "bump_m": (self.bump_m, 0.05)}
        for name, (value, most) in checks.items():
            if not 0.0 <= value <= most:
                raise Error(f"perturbation {name} {value!r} is outside 0 to {most:g}")
        if self.floor_friction is not None and not 0.05 <= self.floor_friction[0] <= self.floor_friction[1] <= 3.0:
            raise Error(f"floor friction {self.floor_friction!r} must be (low, high) within 0.05 to 3")

    def draw(self, rng: np.random.Generator, nbody: int, ndof: int) -> World:
        """One world: per-link and per-joint values for a model of ``nbody`` bodies and ``ndof`` dofs."""
        tilt = np.radians(rng.uniform(-self.floor_tilt_deg, self.floor_tilt_deg, 2))
        return World(
            mass_factor=rng.uniform(1.0 - self.mass, 1.0 + self.mass, nbody),
            com_offset=rng.uniform(-self.com_offset_m, self.com_offset_m, (nbody, 3)),
            friction_loss=rng.uniform(0.0, self.joint_friction_nm, ndof),
            damping=rng.uniform(0.0, self.joint_damping, ndof),
            floor_friction=None if self.floor_friction is None else float(rng.uniform(*self.floor_friction)),
            tilt_rad=tilt,
            bump_heights=rng.uniform(0.0, self.bump_m, BUMPS) if self.bump_m else np.zeros(0),
        )


BUMPS = 12  # boxes on the floor under a walk
BUMP_START_M = 0.2  # where the first begins: ahead of the soles the robot starts on
BUMP_SPACING_M = 0.3
BUMP_SIZE_M = 0.1  # half length of a bump: 0.2 m long, 0.1 m gaps; a sole lands on one, on its edge, or between


@dataclass
class World:
    """One draw of :class:`Perturbation`: the values a trial's world has."""

    mass_factor: np.ndarray
    com_offset: np.ndarray
    friction_loss: np.ndarray
    damping: np.ndarray
    floor_friction: float | None
    tilt_rad: np.ndarray
    bump_heights: np.ndarray = field(default_factory=lambda: np.zeros(0))


def perturbed(sim, world: World):
    """A copy of ``sim`` (:class:`~cocomopl.sim.mujoco_model.SimModel`) in ``world``.

    Bumps need new geoms, so they are compiled into a copy of the model by ``MjSpec``;
    everything else is set on a copy of the compiled model.  The robot's bodies are those
    below the world body; the free joint's dofs keep no friction or damping.
    """
    out = copy.copy(sim)
    out.mj = _with_bumps(sim, world.bump_heights) if len(world.bump_heights) else copy.deepcopy(sim.mj)
    mj = out.mj
    n = sim.mj.nbody - 1  # the bodies below the world's, the bumps' not among them
    mj.body_mass[1 : n + 1] *= world.mass_factor[:n]
    mj.body_inertia[1 : n + 1] *= world.mass_factor[:n, None]
    mj.body_ipos[1 : n + 1] += world.com_offset[:n]
    mj.dof_frictionloss[6:] += world.friction_loss[6:]
    mj.dof_damping[6:] += world.damping[6:]
    if world.floor_friction is not None:
        floor = _floor_geoms(mj)
        mj.geom_friction[floor, 0] = world.floor_friction
    # a floor tilted by (roll, pitch) is gravity tilted by the opposite, the floor kept flat
    roll, pitch = world.tilt_rad
    mj.opt.gravity[:] = np.linalg.norm(sim.mj.opt.gravity) * np.array([np.sin(pitch) * np.cos(roll), -np.sin(roll), -np.cos(pitch) * np.cos(roll)])
    return out


def _floor_geoms(mj: mujoco.MjModel) -> np.ndarray:
    return np.flatnonzero((mj.geom_bodyid == 0) & (mj.geom_contype | mj.geom_conaffinity).astype(bool))


def _with_bumps(sim, heights: np.ndarray) -> mujoco.MjModel:
    """``sim``'s model with boxes of ``heights`` on the floor along +x (the walks' direction at
    the start), recompiled from its spec.  They hang from a body added last, so the robot's
    bodies, geoms, joints and actuators keep their indices."""
    spec = sim.spec.copy()
    bumps = spec.worldbody.add_body(name="cocomopl_bumps")
    for k, height in enumerate(heights):
        bumps.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[BUMP_SIZE_M, 0.3, height / 2 + 1e-4],
                       pos=[BUMP_START_M + BUMP_SIZE_M + BUMP_SPACING_M * k, 0.0, height / 2 - 1e-4],
                       friction=[FRICTION, 0.005, 0.0001],
                       rgba=[0.5, 0.4, 0.3, 1])
    return spec.compile()
