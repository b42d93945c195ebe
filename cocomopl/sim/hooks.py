"""What the rollout's loop calls at each control step: hooks and replanners.

The loop (:func:`cocomopl.sim.rollout.simulate`) steps MuJoCo, records and detects a fall;
everything else is a hook.  At each 1 kHz control step it builds a :class:`Step`, takes the
reference's joint command (:class:`~cocomopl.sim.rollout.Reference`), passes it through
each hook's :meth:`Hook.command` in turn (the stabilizer adds its corrections, the servo
channel delays it and adds the encoder noise), sends it to the servos, clears the external
forces and calls each hook's :meth:`Hook.before_step` (a push adds its force), then steps
the physics.  At each recorded sample it asks the :class:`Replanner`, if any, for a new
walk; where there is one, the reference and every hook follow it (:meth:`Hook.replanned`).

A new controller or perturbation is one :class:`Hook` subclass given to ``simulate(...,
hooks=[...])``: it overrides the methods it needs, and the others do nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import mujoco
import numpy as np

from cocomopl.dynamics import SIDES

if TYPE_CHECKING:
    from cocomopl.motion import Motion
    from cocomopl.sim.mujoco_model import SimModel
    from cocomopl.sim.stabilizer import Stabilizer


@dataclass(frozen=True)
class Step:
    """One control step of the loop, as the hooks see it.

    Attributes
    ----------
    sim : the model the loop runs
    data : its state before the step; hooks may write its inputs (``ctrl``, ``xfrc_applied``)
    clock : s on the reference's clock, held at its first sample while the robot settles
    elapsed : s since the motion's start, negative while the robot settles
    sample : whether this step is recorded (and the replanner asked)
    """

    sim: SimModel
    data: mujoco.MjData
    clock: float
    elapsed: float
    sample: bool

    def soles(self) -> dict[str, np.ndarray]:
        """The soles' measured world poses (x, y, yaw), by side."""
        out = {}
        for side in SIDES:
            site = self.sim.sole_sites[side]
            rotation = self.data.site_xmat[site].reshape(3, 3)
            out[side] = np.array([*self.data.site_xpos[site][:2], np.arctan2(rotation[1, 0], rotation[0, 0])])
        return out


class Hook:
    """A controller or a perturbation that the loop calls at each control step; each method
    does nothing here, and a hook overrides those it needs."""

    def command(self, step: Step, command: np.ndarray) -> np.ndarray:
        """The joint command (nu,) to send on, given the one so far (hooks are called in order)."""
        return command

    def before_step(self, step: Step) -> None:
        """Act on the world just before the physics steps (e.g. add to ``step.data.xfrc_applied``,
        which the loop clears at each step)."""

    def replanned(self, step: Step, motion: Motion) -> None:
        """Follow ``motion`` from ``step`` on: the replanner changed the walk."""


class Replanner(Protocol):
    """Changes the walk while it is played: recovery by stepping
    (:class:`~cocomopl.sim.recovery.StepRecovery`) or footstep re-aiming
    (:class:`~cocomopl.sim.reaiming.Reaiming`).  A rollout has at most one."""

    motion: Motion  # the walk last planned: the one being followed

    def start(self, stabilizer: Stabilizer | None) -> None:
        """Called once before the loop with the rollout's stabilizer (None: none); an
        :class:`~cocomopl.errors.Error` if it cannot replan without one."""

    def replan(self, step: Step) -> Motion | None:
        """At a recorded sample: the walk planned again, or None to keep following it."""

    def metadata(self) -> dict[str, list[dict]]:
        """The changes made, under their field of the measured motion's
        :class:`~cocomopl.motion.RolloutRecord` (``recoveries``, ``reaimed``)."""
