"""MP4 of a simulated motion from MuJoCo's offscreen renderer (EGL, set in ``cocomopl/__init__``:
no display, no GPU needed)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import imageio.v2 as imageio
import mujoco
import numpy as np
from tqdm import tqdm

from cocomopl.motion_file import atomic_path
from cocomopl.sim.mujoco_model import SimModel

CAMERA_AZIMUTH_DEG = 120.0  # from the robot's left, a little ahead, when it faces +x
CAMERA_TURN_FRAMES = 10


def render_frames(sim: SimModel, qpos: np.ndarray, size: tuple[int, int] = (640, 480)) -> Iterator[np.ndarray]:
    """Yield an RGB image (height, width, 3) of each state of ``qpos`` (n, nq), seen from
    the side by a camera that follows the pelvis and turns with the walk's heading (the
    pelvis yaw, smoothed over about ``CAMERA_TURN_FRAMES`` frames so the sway of each step
    does not shake the view); ``size`` is (width, height) in pixels."""
    data = mujoco.MjData(sim.mj)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.distance, camera.elevation = 3.2, -15.0
    heading = _unwrapped_yaw(qpos)
    heading = _smoothed(heading, CAMERA_TURN_FRAMES)
    with mujoco.Renderer(sim.mj, height=size[1], width=size[0]) as renderer:
        # shadows and reflections cost 3/4 of the time of a software-rendered frame
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        for q in qpos:
            data.qpos[:] = q
            mujoco.mj_kinematics(sim.mj, data)
            camera.lookat[:] = [data.qpos[0], data.qpos[1], 0.8]
            camera.azimuth = CAMERA_AZIMUTH_DEG + np.degrees(next(heading))
            renderer.update_scene(data, camera)
            yield renderer.render()


def _unwrapped_yaw(qpos: np.ndarray) -> np.ndarray:
    """The free joint's yaw (rad) per state, continuous through +-pi."""
    w, x, y, z = qpos[:, 3:7].T
    return np.unwrap(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def _smoothed(values: np.ndarray, frames: int) -> Iterator[float]:
    """An exponential moving average of ``values`` with a time constant of ``frames``."""
    state = float(values[0])
    for value in values:
        state += (float(value) - state) / frames
        yield state


def render_video(
    sim: SimModel,
    times: np.ndarray,
    qpos: np.ndarray,
    path: str | Path,
    fps: int = 25,
    size: tuple[int, int] = (640, 480),
    progress: bool = False,
) -> Path:
    """Write an MP4 of the states ``qpos`` (n, nq) at ``times`` (s), seen as by
    :func:`render_frames`.  Written atomically."""
    path = Path(path)
    frames = np.arange(times[0], times[-1] + 1e-9, 1.0 / fps)
    indices = np.clip(np.searchsorted(times, frames), 0, len(times) - 1)
    images = tqdm(
        render_frames(sim, qpos[indices], size), total=len(indices), desc="rendering", unit="frame",
        disable=not progress, leave=False,
    )
    with (
        atomic_path(path, suffix=path.suffix) as tmp,
        imageio.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264", macro_block_size=8) as writer,
    ):
        for image in images:
            writer.append_data(image)
    return path
