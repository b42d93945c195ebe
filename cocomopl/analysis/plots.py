"""PNG plots of one motion: joint angles, ZMP in the support polygon, contact forces, torques."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from cocomopl.dynamics import SIDES, sole_placements
from cocomopl.motion import Motion
from cocomopl.motion_file import writable_folder
from cocomopl.robot import Robot


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (files only, no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> Path:
    """Save a PNG atomically (a temporary file renamed into place) and close the figure."""
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.tight_layout()
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, path)
    pyplot().close(fig)
    return path


def _zmp_label(motion: Motion) -> str:
    # an OC motion stores its contact wrenches' ZMP; a generated one the ZMP it learned
    return "ZMP (learned)" if motion.meta.get("producer") == "primitives" else "ZMP (contact wrenches)"


def _phase_shading(ax, motion: Motion) -> None:
    for kind, first, last in motion.phases:
        if kind == "ds":
            ax.axvspan(motion.t[first], motion.t[last], color="0.92", zorder=0)


def _joint_groups(robot: Robot) -> list[tuple[str, list[int]]]:
    legs = robot.leg_joint_indices()
    return [("legs", legs), ("torso, arms, head", [i for i in range(robot.nu) if i not in legs])]


def _plot_per_joint(
    robot: Robot, motion: Motion, values: np.ndarray, what: str, unit: str, path: Path, held: bool
) -> Path:
    """Two panels (legs; the rest) of one value per actuated joint against time.

    ``held`` values (torques) are constant over each knot interval and drawn as steps.
    """
    fig, axes = pyplot().subplots(2, 1, figsize=(10, 7), sharex=True)
    for ax, (title, idx) in zip(axes, _joint_groups(robot)):
        _phase_shading(ax, motion)
        for i in idx:
            if held:
                ax.step(motion.t, values[:, i], where="post", lw=1, label=motion.joint_names[i])
            else:
                ax.plot(motion.t, values[:, i], lw=1, label=motion.joint_names[i])
        ax.set_ylabel(f"{what} ({unit})")
        ax.set_title(f"{motion.name}: joint {what}s, {title} (grey: double support)")
        ax.legend(fontsize=6, ncol=4, loc="upper right")
    axes[1].set_xlabel("time (s)")
    return save_figure(fig, path)


def plot_joint_angles(robot: Robot, motion: Motion, path: Path) -> Path:
    return _plot_per_joint(robot, motion, motion.q[:, 7:], "angle", "rad", path, held=False)


def plot_torques(robot: Robot, motion: Motion, path: Path) -> Path:
    return _plot_per_joint(robot, motion, motion.tau, "torque", "N m", path, held=True)


def plot_zmp(robot: Robot, motion: Motion, path: Path) -> Path:
    soles = sole_placements(robot, motion.q)
    fig, ax = pyplot().subplots(figsize=(8, 5))
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
    ax.plot(motion.zmp[:, 0], motion.zmp[:, 1], "k.-", ms=3, lw=1, label=_zmp_label(motion))
    ax.plot([], [], color="tab:blue", label="left sole")
    ax.plot([], [], color="tab:red", label="right sole")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{motion.name}: ZMP and soles in contact")
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def plot_contact_forces(robot: Robot, motion: Motion, path: Path) -> Path:
    weight = robot.mass * 9.81
    fig, ax = pyplot().subplots(figsize=(10, 4))
    _phase_shading(ax, motion)
    for j, side in enumerate(SIDES):
        ax.step(motion.t, motion.wrenches[:, j, 2], where="post", label=f"{side} normal force")
    ax.axhline(weight, color="k", ls="--", lw=1, label=f"body weight ({weight:.0f} N)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("force (N)")
    ax.set_title(f"{motion.name}: vertical contact forces")
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def plot_motion(robot: Robot, motion: Motion, out_dir: Path) -> list[Path]:
    """Write the four PNGs of a motion into ``out_dir`` and return their paths."""
    out_dir = writable_folder(Path(out_dir), f"output folder {out_dir}")
    return [
        plot_joint_angles(robot, motion, out_dir / "joint_angles.png"),
        plot_zmp(robot, motion, out_dir / "zmp.png"),
        plot_contact_forces(robot, motion, out_dir / "contact_forces.png"),
        plot_torques(robot, motion, out_dir / "torques.png"),
    ]


def plot_model_selection(rows: list[dict], path: Path) -> Path:
    """Free energy and explained variance against the number of primitives, one line per kernel."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for kernel in sorted({r["kernel"] for r in rows}):
        mine = sorted((r for r in rows if r["kernel"] == kernel), key=lambda r: r["n_primitives"])
        S = [r["n_primitives"] for r in mine]
        axes[0].plot(S, [r["bound"] for r in mine], "o-", label=kernel)
        for group, style in (("joints", "-"), ("zmp", "--"), ("pelvis", ":")):
            axes[1].plot(S, [100 * r["explained_variance"][group] for r in mine], "o" + style, label=f"{kernel} {group}")
    axes[0].set(xlabel="number of primitives S", ylabel="free energy (eq. 6)", title="model comparison")
    axes[1].axhline(99.9, color="k", lw=0.8)
    axes[1].set(xlabel="number of primitives S", ylabel="explained variance (%)", title="explained variance")
    axes[0].legend()
    axes[1].legend(fontsize=7, ncol=2)
    return save_figure(fig, Path(path))
