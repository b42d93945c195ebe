"""The effect of the torque-rate term: one cyclic step solved with and without it.

Writes a PNG of the knee and hip-pitch torques of the stance and swing legs, and prints the
largest torque jump between knots and the integral of squared torques for each weight.

Usage::

    python benchmarks/torque_rate.py [--length-mm 250] [--out docs/torque_rate.png] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import cocomopl  # noqa: F401  (one OpenMP thread per process)


def main() -> int:
    from cocomopl.analysis.plots import pyplot, save_figure
    from cocomopl.data import BUNDLED_DATASET
    from cocomopl.dataset.generate import phase_durations
    from cocomopl.motion import StepSpec
    from cocomopl.motion_file import read_motion
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.ocp.solve import solve_step, to_motion
    from cocomopl.robot import Robot

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--length-mm", type=int, default=250)
    parser.add_argument("--out", default="docs/torque_rate.png")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    robot = Robot("talos")
    length = args.length_mm / 1000
    cyclic = read_motion(BUNDLED_DATASET, f"cyclic_{args.length_mm}_L")
    base = replace(OCPSettings(), **phase_durations(cyclic))
    x0 = np.concatenate([cyclic.q[0], cyclic.v[0]])
    warm = list(np.hstack([cyclic.q, cyclic.v]))
    results, motions = [], {}
    for weight in (0.0, base.w_torque_rate):
        settings = replace(base, w_torque_rate=weight)
        solution = solve_step(robot, StepSpec("cyclic", length, length), {length: x0}, settings=settings, guess=warm)
        motion = to_motion(robot, solution, settings)
        tau = motion.tau[:-1]
        motions[weight] = motion
        results.append(
            {
                "w_torque_rate": weight,
                "converged": solution.stats["converged"],
                "max_torque_jump_Nm": float(np.abs(np.diff(tau, axis=0)).max()),
                "rms_torque_rate_Nm_per_s": float(np.sqrt(np.mean((np.diff(tau, axis=0) / settings.dt) ** 2))),
                "squared_torque_integral": float((tau**2).sum(axis=1) @ np.diff(motion.t)),
            }
        )
    plt = pyplot()
    joints = ["leg_right_4_joint", "leg_right_3_joint", "leg_left_4_joint", "leg_left_3_joint"]
    fig, axes = plt.subplots(len(joints), 1, figsize=(9, 9), sharex=True)
    for ax, joint in zip(axes, joints):
        i = robot.joint_names.index(joint)
        for weight, style in zip(motions, ("-", "-")):
            m = motions[weight]
            ax.step(m.t, m.tau[:, i], where="post", ls=style, label=f"w_torque_rate = {weight:g}")
        ax.set_ylabel(f"{joint}\n(N m)", fontsize=8)
    axes[0].set_title(f"cyclic {args.length_mm} mm step: torques with and without the torque-rate term")
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time (s)")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, out)
    report = {"figure": str(out), "results": results}
    if args.json:
        print(json.dumps(report))
    else:
        for r in results:
            print(
                f"w_torque_rate {r['w_torque_rate']:<8g} max jump {r['max_torque_jump_Nm']:6.1f} N m   "
                f"rms rate {r['rms_torque_rate_Nm_per_s']:7.1f} N m/s   int tau^2 dt {r['squared_torque_integral']:7.0f}"
            )
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
