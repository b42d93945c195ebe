"""Make the README pictures, docs/walk.png: a filmstrip of the default walk simulated in MuJoCo.

The default walk (M_gen, steps of 150 to 390 mm for TALOS, scaled to another robot) is
generated from the robot's bundled primitives and simulated with the stabiliser (and the
robot's default servo feedforward: on for G1), as ``cocomopl walk [--robot NAME]`` does.  The frames are
one stride, the two steps in the middle of the walk, seen from the side by a camera that
follows the pelvis (``render_frames``' side view; the robot walks to the right), side by side.  Takes about 35 s on
two cores, most of it the simulation.

Usage: ``python scripts/readme_picture.py [--robot g1 --out docs/walk-g1.png]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import imageio.v2 as imageio
import numpy as np

from cocomopl.motion import Motion
from cocomopl.pipeline import generate_walk, rollout_of
from cocomopl.requests import StraightSteps, WalkRequest
from cocomopl.sim.mujoco_model import build_sim_model
from cocomopl.sim.video import render_frames

FRAMES = 7  # poses of the stride: 3.5 a step, enough to tell lift-off, swing and touchdown apart
FRAME_SIZE = (240, 400)  # width, height (px): narrow, as the field of view is set vertically
GAP = 4  # px of white between frames


def middle_stride_times(motion: Motion, count: int) -> np.ndarray:
    """``count`` times (s) evenly over the two steps in the middle of ``motion``, the
    first step's start included and the second step's end left out (it repeats the pose)."""
    bounds = np.append(motion.t[motion.step_starts], motion.t[-1])
    first = len(motion.steps) // 2 - 1
    return np.linspace(bounds[first], bounds[first + 2], count, endpoint=False)


def filmstrip(frames: list[np.ndarray], gap: int) -> np.ndarray:
    """The RGB images ``frames`` (all the same size) side by side, ``gap`` px of white between."""
    spacer = np.full((frames[0].shape[0], gap, 3), 255, dtype=np.uint8)
    pieces = [piece for frame in frames for piece in (spacer, frame)][1:]
    return np.concatenate(pieces, axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/walk.png"), help="PNG to write (default: %(default)s)")
    parser.add_argument("--robot", default="talos", help="a bundled robot (default: %(default)s)")
    args = parser.parse_args()

    walk = generate_walk(WalkRequest(StraightSteps(), robot=args.robot))
    rollout = rollout_of(walk.robot, walk.motion)
    if rollout.fell:
        raise SystemExit(f"the default walk fell at {rollout.fall_time:.2f} s: no picture made")
    times = middle_stride_times(walk.motion, FRAMES)
    indices = np.clip(np.searchsorted(rollout.measured.t, times), 0, len(rollout.measured.t) - 1)
    # rollout_of's model has no meshes; this one has, for rendering
    sim = build_sim_model(walk.robot, visuals=True)
    frames = list(render_frames(sim, rollout.qpos[indices], size=FRAME_SIZE, side_view=True))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    imageio.imwrite(args.out, filmstrip(frames, GAP), optimize=True)
    print(f"wrote {args.out}: {len(frames)} frames, {args.out.stat().st_size / 1024:.0f} KB")


if __name__ == "__main__":
    main()
