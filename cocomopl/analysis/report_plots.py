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

import math
from collections.abc import Sequence
from pathlib import Path

from cocomopl.analysis.footprint import planned_landings, sole_outline, stances, start_soles
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


def plot_footprint(robot: Robot, motions: dict[str, Motion], path: Path, *, goals: Sequence[Sequence[float]] = ()) -> Path:
    """The walk from above, world frame: the landings that the first motion plans (outlines,
    numbered in order, beside its soles' start) and those of any other motion that plans
    footsteps (a replanned walk: dashed), every other motion's soles in stance (filled, at
    mid-stance), each motion's pelvis path, and the ``goals`` (x, y, yaw in m, m, rad) as
    arrows."""
    colours = _colours(motions)
    fig, ax = pyplot().subplots(figsize=(8, 6))
    for n, (label, motion) in enumerate(motions.items()):
        colour = colours[label]
        if n == 0 or (motion.plan is not None and motion.plan.footsteps is not None):
            landings = planned_landings(robot, motion)
            for k, landing in enumerate(landings):
                ax.fill(*sole_outline(robot, landing).T, fill=False, ec=colour, lw=1, ls="-" if n == 0 else "--",
                        label=f"{label}: planned landings" if k == 0 else None)
                if n == 0:
                    ax.annotate(str(k + 1), (landing.x, landing.y), ha="center", va="center", fontsize=7, color=colour)
            if n == 0:
                for k, start in enumerate(start_soles(robot, motion)):
                    ax.fill(*sole_outline(robot, start).T, fill=False, ec="0.5", lw=1, ls=":",
                            label="soles at the start" if k == 0 else None)
        else:
            for k, stance in enumerate(stances(robot, motion)):
                ax.fill(*sole_outline(robot, stance).T, color=SIDE_COLOURS[stance.side], alpha=0.35, ec=colour, lw=0.8,
                        label=f"{label}: soles in stance" if k == 0 else None)
        ax.plot(motion.q[:, 0], motion.q[:, 1], color=colour, lw=1, alpha=0.7, label=f"{label}: pelvis")
    for k, (x, y, yaw) in enumerate(goals):
        ax.plot(x, y, "o", color="tab:green", ms=6, label="goal (feet midpoint)" if k == 0 else None)
        ax.annotate("", (x + 0.2 * math.cos(yaw), y + 0.2 * math.sin(yaw)), (x, y),
                    arrowprops={"arrowstyle": "->", "color": "tab:green", "lw": 1.5})
    # a figure as wide as the walk is: an equal-aspect straight walk would leave most of it empty
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    fig.set_size_inches(8, min(8.0, max(3.0, 6.5 * (y1 - y0) / (x1 - x0) + 1.0)))
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("footsteps from above (soles: left blue, right red)", fontsize=10)
    legend_outside(ax, fontsize=8)
    return save_figure(fig, Path(path))


def plot_comparison(
    robot: Robot, motions: dict[str, Motion], out_dir: Path, *, top_view: bool = False,
    goals: Sequence[Sequence[float]] = (),
) -> list[Path]:
    """Write the four comparison PNGs into ``out_dir`` and return their paths; with
    ``top_view`` also ``footsteps.png`` (:func:`plot_footprint`, with the ``goals``)."""
    out_dir = writable_folder(Path(out_dir), f"output folder {out_dir}")
    return [
        plot_zmp_comparison(motions, out_dir / "zmp_comparison.png"),
        plot_force_comparison(robot, motions, out_dir / "force_comparison.png"),
        plot_knee_torque_comparison(robot, motions, out_dir / "knee_torque_comparison.png"),
        plot_leg_joint_comparison(robot, motions, out_dir / "leg_joint_comparison.png"),
        *([plot_footprint(robot, motions, out_dir / "footsteps.png", goals=goals)] if top_view else []),
    ]
