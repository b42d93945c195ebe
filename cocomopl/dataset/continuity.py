"""Continuity between consecutive steps: does one step end where the next begins?"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.dynamics import sole_placements
from cocomopl.motion import Motion
from cocomopl.ocp.problems import turn_state
from cocomopl.robot import Robot


def end_in_next_frame(robot: Robot, prev: Motion) -> np.ndarray:
    """The last state of ``prev`` in the frame of the step that follows it.

    The next step stands on the foot that ``prev`` put down last; its frame is that sole's,
    turned as the step's footstep turned it (the same axes for a straight step).
    """
    step = prev.steps[-1]
    if step.kind == "stop":
        raise ValueError("no step follows a stop")
    landed = sole_placements(robot, prev.q[-1:])[0, 0 if step.swing_side == "left" else 1]
    q = prev.q[-1].copy()
    q[0:2] -= landed[0:2]
    yaw = step.end_turn if step.swing_side == "left" else -step.end_turn
    return turn_state(robot, np.concatenate([q, prev.v[-1]]), -yaw)


def step_mismatch(robot: Robot, prev: Motion, nxt: Motion) -> float:
    """Largest state difference between ``prev``'s end and ``nxt``'s start (rad, m, rad/s, m/s),
    measured in the tangent space of the configuration manifold."""
    x_end = end_in_next_frame(robot, prev)
    nq = robot.model.nq
    dq = pin.difference(robot.model, nxt.q[0], x_end[:nq])
    dv = x_end[nq:] - nxt.v[0]
    return float(max(np.abs(dq).max(), np.abs(dv).max()))
