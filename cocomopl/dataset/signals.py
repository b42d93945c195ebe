"""The 36 training signals of a step, as a position-controlled humanoid takes them.

Per sample: the 30 joint angles (rad), the ZMP in the pelvis (waist) frame (m, as OpenHRP
seqplay's ``.zmp``), and the pelvis roll, pitch, yaw (rad) in the step frame.  Pre-impact
duplicates are dropped, so time increases strictly.  ``phase_time`` runs from 0 to the
number of phases, each phase (double support, single support, ...) taking one unit: the
per-phase time normalisation that aligns events across steps of different durations.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from cocomopl.dynamics import pelvis_placements
from cocomopl.motion import Motion
from cocomopl.robot import Robot

ZMP_NAMES = ["zmp_x", "zmp_y", "zmp_z"]
PELVIS_NAMES = ["pelvis_roll", "pelvis_pitch", "pelvis_yaw"]


def signal_names(robot: Robot) -> list[str]:
    return list(robot.joint_names) + ZMP_NAMES + PELVIS_NAMES


def phase_time(motion: Motion, samples: np.ndarray) -> np.ndarray:
    """Per-phase normalised time of the given samples."""
    out = np.empty(len(samples))
    for i, k in enumerate(samples):
        for p, (_, first, last) in enumerate(motion.phases):
            if first <= k <= last:
                out[i] = p + (motion.t[k] - motion.t[first]) / (motion.t[last] - motion.t[first])
                break
        else:
            out[i] = len(motion.phases)
    return out


def training_signals(robot: Robot, motion: Motion) -> dict:
    """``values`` (n', 36), ``t`` (n',), ``phase_time`` (n',) and ``names`` (36,)."""
    keep = motion.kept_samples()
    q = motion.q[keep]
    pelvis = pelvis_placements(robot, q)
    zmp = motion.zmp[keep]
    zmp_local = np.array([P.actInv(z) for P, z in zip(pelvis, zmp)])
    rpy = np.array([pin.rpy.matrixToRpy(P.rotation) for P in pelvis])
    values = np.hstack([q[:, 7:], zmp_local, rpy])
    return {
        "values": values,
        "t": motion.t[keep],
        "phase_time": phase_time(motion, keep),
        "names": signal_names(robot),
    }
