"""The paper's comparison figures for several motions side by side (PNG).

Each function takes ``{label: Motion}`` -- planned and measured motions of the same walk,
e.g. ``{"OC planned": ..., "OC simulated": ..., "MP simulated": ...}`` -- and the PNG path,
and returns the path.  Each motion is drawn on its own clock, so align them first: a
rollout's time 0 is its reference's first sample, so a reference that starts earlier (the
Kajita baseline's standing prelude, at negative times) needs its rollout shifted by its
first time.  The first motion is drawn in black as the reference; torques and forces,
which hold over each sample interval, as steps.
"""

from __future__ import annotations

from pathlib import Path

from cocomopl.analysis.metrics import GRAVITY, knee_joints, vertical_forces
from cocomopl.analysis.plots import SIDE_COLOURS, joint_label, legend_outside, palette, pyplot, save_figure
from cocomopl.dynamics import SIDES
from cocomopl.motion import Motion
from cocomopl.motion_file import writable_folder
from cocomopl.robot import Robot


def _colours(motions: dict[str, Motion]) -> dict[str, str]:
    return dict(zip(motions, ["k", *palette(len(motions) - 1)]))


def plot_zmp_comparison(motions: dict[str, Motion], path: Path) -> Path:
    """ZMP x and y against time, one line per motion (the paper's Fig. 6)."""
    colours = _colours(motions)
    fig, axes = pyplot().subplots(2, 1, figsize=(11, 6), sharex=True)
    for label, motion in motions.items():
        for axis, ax in enumerate(axes):
            ax.plot(motion.t, motion.zmp[:, axis], color=colours[label], lw=1, label=label)
    for ax, name in zip(axes, "xy"):
        ax.set_ylabel(f"ZMP {name} (m)")
    axes[0].set_title("ZMP, world frame")
    legend_outside(axes[0], fontsize=8)
    axes[1].set_xlabel("time (s)")
    return save_figure(fig, Path(path))


def plot_force_comparison(robot: Robot, motions: dict[str, Motion], path: Path) -> Path:
    """Vertical contact force of each foot, one panel per motion, top to bottom (Fig. 8)."""
    weight = robot.mass * GRAVITY
    fig, axes = pyplot().subplots(len(motions), 1, figsize=(11, 2.4 * len(motions) + 0.6), sharex=True, squeeze=False)
    for ax, (label, motion) in zip(axes[:, 0], motions.items()):
        forces = vertical_forces(motion)
        for j, side in enumerate(SIDES):
            ax.step(motion.t, forces[:, j], where="post", color=SIDE_COLOURS[side], lw=1, label=f"{side} foot")
        ax.axhline(weight, color="k", ls="--", lw=1, label=f"body weight ({weight:.0f} N)")
        ax.set_ylabel("force (N)")
        ax.set_title(label, fontsize=10)
    legend_outside(axes[0, 0], fontsize=8)
    axes[-1, 0].set_xlabel("time (s)")
    return save_figure(fig, Path(path))


def plot_knee_torque_comparison(robot: Robot, motions: dict[str, Motion], path: Path) -> Path:
    """Torque of each knee against time, one line per motion (Fig. 9)."""
    colours = _colours(motions)
    knees = knee_joints(robot)
    fig, axes = pyplot().subplots(2, 1, figsize=(11, 6), sharex=True)
    for ax, side in zip(axes, SIDES):
        for label, motion in motions.items():
            ax.step(motion.t, motion.tau[:, knees[side]], where="post", color=colours[label], lw=1, label=label)
        ax.set_ylabel("torque (N m)")
        ax.set_title(joint_label(robot, knees[side]), fontsize=10)
    legend_outside(axes[0], fontsize=8)
    axes[1].set_xlabel("time (s)")
    return save_figure(fig, Path(path))


def plot_leg_joint_comparison(robot: Robot, motions: dict[str, Motion], path: Path) -> Path:
    """Leg joint angles against time, one panel per joint (left leg in the left column)."""
    colours = _colours(motions)
    legs = {side: robot.leg_chain(side) for side in SIDES}
    rows = max(len(idx) for idx in legs.values())
    fig, axes = pyplot().subplots(rows, 2, figsize=(13, 1.8 * rows + 0.6), sharex=True, squeeze=False)
    for column, side in enumerate(SIDES):
        for row, i in enumerate(legs[side]):
            ax = axes[row, column]
            for label, motion in motions.items():
                ax.plot(motion.t, motion.q[:, 7 + i], color=colours[label], lw=1, label=label)
            ax.set_title(joint_label(robot, i), fontsize=9)
            ax.set_ylabel("rad")
    # right of the right column: the motions are the same in every panel
    legend_outside(axes[0, -1], fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    return save_figure(fig, Path(path))


def plot_comparison(robot: Robot, motions: dict[str, Motion], out_dir: Path) -> list[Path]:
    """Write the four comparison PNGs into ``out_dir`` and return their paths."""
    out_dir = writable_folder(Path(out_dir), f"output folder {out_dir}")
    return [
        plot_zmp_comparison(motions, out_dir / "zmp_comparison.png"),
        plot_force_comparison(robot, motions, out_dir / "force_comparison.png"),
        plot_knee_torque_comparison(robot, motions, out_dir / "knee_torque_comparison.png"),
        plot_leg_joint_comparison(robot, motions, out_dir / "leg_joint_comparison.png"),
    ]
