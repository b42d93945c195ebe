"""PNG plots of one motion: joint angles, ZMP in the support polygon, contact forces, torques."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from cocomopl.dynamics import SIDES, sole_placements
from cocomopl.errors import Error
from cocomopl.motion import Motion
from cocomopl.robot import Robot


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)
    return path


def _phase_shading(ax, motion: Motion) -> None:
    for kind, first, last in motion.phases:
        if kind == "ds":
            ax.axvspan(motion.t[first], motion.t[last], color="0.92", zorder=0)


def plot_joint_angles(robot: Robot, motion: Motion, path: Path) -> Path:
    plt = _pyplot()
    legs, others = range(0, 12), range(12, robot.nu)  # URDF order: legs come first
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for ax, idx, title in ((axes[0], legs, "legs"), (axes[1], others, "torso, arms, head")):
        _phase_shading(ax, motion)
        for i in idx:
            ax.plot(motion.t, motion.q[:, 7 + i], lw=1, label=motion.joint_names[i])
        ax.set_ylabel("angle (rad)")
        ax.set_title(f"{motion.name}: joint angles, {title} (grey: double support)")
        ax.legend(fontsize=6, ncol=4, loc="upper right")
    axes[1].set_xlabel("time (s)")
    fig.tight_layout()
    out = _save(fig, path)
    plt.close(fig)
    return out


def plot_zmp(robot: Robot, motion: Motion, path: Path) -> Path:
    plt = _pyplot()
    soles = sole_placements(robot, motion.q)
    fig, ax = plt.subplots(figsize=(8, 5))
    corners = robot.sole.corners()
    drawn = set()
    for k in range(motion.n):
        for j, side in enumerate(SIDES):
            if motion.contact[k, j]:
                key = (side, round(soles[k, j, 0], 3), round(soles[k, j, 1], 3))
                if key in drawn:
                    continue
                drawn.add(key)
                poly = np.vstack([corners, corners[:1]]) + soles[k, j, :2]
                ax.plot(poly[:, 0], poly[:, 1], color="tab:blue" if side == "left" else "tab:red", lw=1)
    ax.plot(motion.zmp[:, 0], motion.zmp[:, 1], "k.-", ms=3, lw=1, label="ZMP (contact wrenches)")
    ax.plot([], [], color="tab:blue", label="left sole")
    ax.plot([], [], color="tab:red", label="right sole")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{motion.name}: ZMP and soles in contact")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = _save(fig, path)
    plt.close(fig)
    return out


def plot_contact_forces(robot: Robot, motion: Motion, path: Path) -> Path:
    plt = _pyplot()
    weight = robot.mass * 9.81
    fig, ax = plt.subplots(figsize=(10, 4))
    _phase_shading(ax, motion)
    for j, side in enumerate(SIDES):
        ax.step(motion.t, motion.wrenches[:, j, 2], where="post", label=f"{side} normal force")
    ax.axhline(weight, color="k", ls="--", lw=1, label=f"body weight ({weight:.0f} N)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("force (N)")
    ax.set_title(f"{motion.name}: vertical contact forces")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = _save(fig, path)
    plt.close(fig)
    return out


def plot_torques(robot: Robot, motion: Motion, path: Path) -> Path:
    plt = _pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    for ax, idx, title in ((axes[0], range(0, 12), "legs"), (axes[1], range(12, robot.nu), "torso, arms, head")):
        _phase_shading(ax, motion)
        for i in idx:
            ax.step(motion.t, motion.tau[:, i], where="post", lw=1, label=motion.joint_names[i])
        ax.set_ylabel("torque (N m)")
        ax.set_title(f"{motion.name}: joint torques, {title}")
        ax.legend(fontsize=6, ncol=4, loc="upper right")
    axes[1].set_xlabel("time (s)")
    fig.tight_layout()
    out = _save(fig, path)
    plt.close(fig)
    return out


def plot_motion(robot: Robot, motion: Motion, out_dir: Path) -> list[Path]:
    """Write the four PNGs of a motion into ``out_dir`` and return their paths."""
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise Error(f"cannot create output folder {out_dir}: {exc.strerror}") from None
    if not os.access(out_dir, os.W_OK):
        raise Error(f"output folder {out_dir} is not writable")
    return [
        plot_joint_angles(robot, motion, out_dir / "joint_angles.png"),
        plot_zmp(robot, motion, out_dir / "zmp.png"),
        plot_contact_forces(robot, motion, out_dir / "contact_forces.png"),
        plot_torques(robot, motion, out_dir / "torques.png"),
    ]
