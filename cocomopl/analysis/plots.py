"""PNG plots of one motion: joint angles, ZMP in the support polygon, contact forces, torques.

Also the conventions that every plot of the package follows: short titles, joints named by
function, one colour per side, a palette for many lines, legends beside the axes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cocomopl.dynamics import SIDES, sole_placements
from cocomopl.motion import Motion
from cocomopl.motion_file import atomic_path, writable_folder
from cocomopl.robot import Robot

# matplotlib's tab:blue and tab:red, in hex so that the HTML viewer can draw the same colours
SIDE_COLOURS = {"left": "#1f77b4", "right": "#d62728"}


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend (files only, no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> Path:
    """Save a PNG atomically (:func:`~cocomopl.motion_file.atomic_path`) and close the figure."""
    fig.tight_layout()
    try:
        with atomic_path(Path(path), suffix=".png") as tmp:
            # "tight" grows the image to hold the legends drawn beside the axes
            fig.savefig(tmp, dpi=110, bbox_inches="tight")
    finally:
        pyplot().close(fig)
    return path


def short_title(motion: Motion) -> str:
    """A plot title for ``motion``: the step's name for one step, else the step count and
    the range of step lengths, such as "walk of 9 steps, 150–390 mm".

    ``Motion.name`` joins every step's name, too long for a title once a walk has a few.
    """
    if len(motion.steps) == 1:
        return motion.steps[0].name
    if not motion.steps:
        return "motion"
    # a start step begins, and a stop step ends, with the feet together: not a step length
    mm = sorted({round(1000 * x) for s in motion.steps for x in (s.start_length, s.end_length) if x > 0})
    lengths = f"{mm[0]} mm" if len(mm) == 1 else f"{mm[0]}–{mm[-1]} mm"
    return f"walk of {len(motion.steps)} steps, {lengths}"


def _leg_joint_functions(robot: Robot) -> dict[int, str]:
    """Actuated-joint index -> "left hip yaw", ..., "right ankle roll" for the leg joints."""
    functions = {}
    axes = robot.axis_names()
    for side, roles in robot.leg_roles().items():
        chain = robot.leg_chain(side)
        # leg_roles finds the pitch and roll joints only; a joint above the knee that turns
        # about the vertical is the hip yaw
        for i in chain[: chain.index(roles["knee"])]:
            if axes[i] == "Z":
                functions[i] = f"{side} hip yaw"
        functions.update({i: f"{side} {role.replace('_', ' ')}" for role, i in roles.items()})
    return functions


def joint_label(robot: Robot, index: int) -> str:
    """The label of actuated joint ``index`` in plots.

    Parameters
    ----------
    robot : Robot
        The robot the joint belongs to.
    index : int
        Actuated-joint index, the order of ``robot.joint_names`` and ``q[7:]``.

    Returns
    -------
    str
        The function of a leg joint ("left knee", "right hip yaw"), the URDF name of any
        other joint ("arm_left_1_joint").
    """
    return _leg_joint_functions(robot).get(index, robot.joint_names[index])


def palette(n: int) -> list[str]:
    """``n`` distinct colours (hex) for lines that share a plot, none a side's colour.

    Up to 18, matplotlib's "tab20" without the side colours, its saturated half first so
    that a plot of few lines gets strong colours; beyond, ``n`` colours evenly spaced on
    the "turbo" colormap.
    """
    import matplotlib
    from matplotlib.colors import to_hex

    tab20 = [to_hex(c) for c in matplotlib.colormaps["tab20"].colors]
    distinct = [c for c in tab20[0::2] + tab20[1::2] if c not in SIDE_COLOURS.values()]
    if n <= len(distinct):
        return distinct[:n]
    return [to_hex(c) for c in matplotlib.colormaps["turbo"](np.linspace(0.0, 1.0, n))]


def legend_outside(ax, **kwargs) -> None:
    """Put the legend of ``ax`` right of it, where it covers no data; ``kwargs`` go to ``ax.legend``."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, **kwargs)


def _zmp_label(motion: Motion) -> str:
    # an OC motion stores its contact wrenches' ZMP; a generated one the ZMP it learned
    return "ZMP (learned)" if motion.producer == "primitives" else "ZMP (contact wrenches)"


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
    fig, axes = pyplot().subplots(2, 1, figsize=(12, 8), sharex=True)
    for ax, (title, idx) in zip(axes, _joint_groups(robot)):
        _phase_shading(ax, motion)
        for i, colour in zip(idx, palette(len(idx))):
            if held:
                ax.step(motion.t, values[:, i], where="post", color=colour, lw=1, label=joint_label(robot, i))
            else:
                ax.plot(motion.t, values[:, i], color=colour, lw=1, label=joint_label(robot, i))
        ax.set_ylabel(f"{what} ({unit})")
        ax.set_title(f"{short_title(motion)}: joint {what}s, {title} (grey: double support)")
        legend_outside(ax, fontsize=7)
    axes[1].set_xlabel("time (s)")
    return save_figure(fig, path)


def plot_joint_angles(robot: Robot, motion: Motion, path: Path) -> Path:
    """Joint angles (rad) against time, legs and the rest in two panels; returns ``path``."""
    return _plot_per_joint(robot, motion, motion.q[:, 7:], "angle", "rad", path, held=False)


def plot_torques(robot: Robot, motion: Motion, path: Path) -> Path:
    """Joint torques (N m) against time, legs and the rest in two panels; returns ``path``."""
    return _plot_per_joint(robot, motion, motion.tau, "torque", "N m", path, held=True)


def plot_zmp(robot: Robot, motion: Motion, path: Path) -> Path:
    """The ZMP path over the soles in contact, seen from above; returns ``path``."""
    soles = sole_placements(robot, motion.q)
    fig, ax = pyplot().subplots(figsize=(9, 5))
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
                ax.plot(poly[:, 0], poly[:, 1], color=SIDE_COLOURS[side], lw=1)
    ax.plot(motion.zmp[:, 0], motion.zmp[:, 1], "k.-", ms=3, lw=1, label=_zmp_label(motion))
    for side in SIDES:
        ax.plot([], [], color=SIDE_COLOURS[side], label=f"{side} sole")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{short_title(motion)}: ZMP and soles in contact")
    legend_outside(ax, fontsize=8)
    return save_figure(fig, path)


def plot_contact_forces(robot: Robot, motion: Motion, path: Path) -> Path:
    """Vertical contact force of each foot against time; returns ``path``."""
    weight = robot.mass * 9.81
    fig, ax = pyplot().subplots(figsize=(11, 4))
    _phase_shading(ax, motion)
    for j, side in enumerate(SIDES):
        ax.step(motion.t, motion.wrenches[:, j, 2], where="post", color=SIDE_COLOURS[side], label=f"{side} foot")
    ax.axhline(weight, color="k", ls="--", lw=1, label=f"body weight ({weight:.0f} N)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("force (N)")
    ax.set_title(f"{short_title(motion)}: vertical contact forces")
    legend_outside(ax, fontsize=8)
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
    """Free energy and explained variance against the number of primitives, one colour per
    kernel (the same in both panels), one line style per explained group."""
    kernels = sorted({r["kernel"] for r in rows})
    fig, axes = pyplot().subplots(2, 1, figsize=(9, 7), sharex=True)
    for kernel, colour in zip(kernels, palette(len(kernels))):
        mine = sorted((r for r in rows if r["kernel"] == kernel), key=lambda r: r["n_primitives"])
        S = [r["n_primitives"] for r in mine]
        axes[0].plot(S, [r["bound"] for r in mine], "o-", color=colour, label=kernel)
        for group, style in (("joints", "-"), ("zmp", "--"), ("pelvis", ":")):
            ev = [100 * r["explained_variance"][group] for r in mine]
            axes[1].plot(S, ev, "o" + style, color=colour, label=f"{kernel} {group}")
    axes[0].set(ylabel="free energy (eq. 6)", title="model comparison")
    axes[1].axhline(99.9, color="k", lw=0.8)
    axes[1].set(xlabel="number of primitives S", ylabel="explained variance (%)", title="explained variance")
    legend_outside(axes[0])
    legend_outside(axes[1], fontsize=7)
    return save_figure(fig, Path(path))


def plot_robot_posture(robot: Robot, path: Path) -> Path:
    """The robot standing in its reference posture, from the side and from the front: its
    joints joined along the kinematic tree (legs by side colour), its soles on the floor."""
    import pinocchio as pin

    plt = pyplot()
    model, data = robot.model, robot.model.createData()
    pin.forwardKinematics(model, data, robot.q_ref)
    origin = np.array([data.oMi[j].translation for j in range(model.njoints)])
    legs = {side: {j + 2 for j in robot.leg_chain(side)} for side in SIDES}
    soles = [robot.frame_placement(robot.q_ref, robot.foot_frames[side]) for side in SIDES]
    fig, axes = plt.subplots(1, 2, figsize=(9, 6), sharey=True)
    for ax, (h, label) in zip(axes, ((0, "x (m), from the side"), (1, "y (m), from the front"))):
        for j in range(2, model.njoints):
            parent = model.parents[j]
            colour = next((SIDE_COLOURS[s] for s in SIDES if j in legs[s]), "0.3")
            ax.plot(origin[[parent, j], h], origin[[parent, j], 2], "-o", color=colour, ms=3, lw=1.5)
        for side, sole in zip(SIDES, soles):
            corners = np.column_stack([robot.sole.corners(), np.zeros(4)]) @ sole.rotation.T + sole.translation
            ring = np.vstack([corners, corners[:1]])
            ax.plot(ring[:, h], ring[:, 2], color=SIDE_COLOURS[side], lw=3)
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_xlabel(label)
        ax.set_aspect("equal")
    axes[0].set_ylabel("z (m)")
    fig.suptitle(f"{robot.name}: reference posture and soles")
    return save_figure(fig, path)
