"""MP4 of a simulated motion from MuJoCo's offscreen renderer (EGL, set in ``cocomopl/__init__``:
no display, no GPU needed).

The camera frames the ground the walk covers -- the pelvis's path, the planned footsteps and
the goals, which are drawn on the floor -- looking down on it from the walk's left, so that
both the progress and the turns show.  It stands still when the whole walk fits in one view
within :data:`CAMERA_MAX_DISTANCE_M`, and follows the pelvis slowly otherwise.  A side
view that follows the pelvis closely, for a filmstrip of a few steps, is the other camera.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import imageio.v2 as imageio
import mujoco
import numpy as np
from tqdm import tqdm

from cocomopl.motion_file import atomic_path
from cocomopl.planning.footsteps import Landing
from cocomopl.sim.mujoco_model import SimModel

CAMERA_ELEVATION_DEG = -45.0  # looking down: the horizon stays above the picture, the steps show
CAMERA_SIDE_DEG = 90.0  # the view's angle from the walk's direction: from its left
CAMERA_FOVY_DEG = 25.0  # narrower than MuJoCo's 45: from farther, the robot leans less at the picture's edges
CAMERA_MAX_DISTANCE_M = 12.0  # farther, the robot is too small to see its steps: follow it instead
CAMERA_TRACK_FRAMES = 50  # time constant of a following camera (2 s at 25 frames per second)
FRAME_MARGIN_M = 0.2  # free room around the walk
HEAD_ROOM_M = 0.25  # above the highest body origin of the robot standing
MARK_HEIGHT_M = 0.002  # the floor marks' thickness: on the floor, under a sole that stands on them
SIDE_RGBA = {"left": (0.12, 0.47, 0.71, 0.55), "right": (0.84, 0.15, 0.16, 0.55)}  # the plots' side colours
GOAL_RGBA = (0.17, 0.63, 0.17, 0.8)
SIDE_VIEW_AZIMUTH_DEG = 120.0  # the side view: from the robot's left, a little ahead, when it faces +x
SIDE_VIEW_TURN_FRAMES = 10


def render_frames(
    sim: SimModel,
    qpos: np.ndarray,
    *,
    size: tuple[int, int] = (640, 480),
    footsteps: Sequence[Landing] = (),
    goals: Sequence[Sequence[float]] = (),
    side_view: bool = False,
) -> Iterator[np.ndarray]:
    """Yield an RGB image (height, width, 3) of each state of ``qpos`` (n, nq), with the
    ``footsteps`` (sole landings, left blue, right red) and the ``goals`` (x, y, yaw in m, m,
    rad: a green disk and an arrow) on the floor; ``size`` is (width, height) in pixels.

    The camera sees the whole walk from above its left (the module's docstring); with
    ``side_view`` it follows the pelvis from the side instead, turning with the walk's
    heading (the pelvis yaw, smoothed over about ``SIDE_VIEW_TURN_FRAMES`` frames so that
    the sway of each step does not shake the view).
    """
    model = copy.copy(sim.mj)  # the camera's field of view is the model's
    # multisampling takes 40 % of a software-rendered frame (65 against 40 ms at 640 x 480)
    # for edges that look the same at this size
    model.vis.quality.offsamples = 0
    data = mujoco.MjData(model)
    if side_view:
        views = _side_views(qpos)
    else:
        model.vis.global_.fovy = CAMERA_FOVY_DEG
        data.qpos[:] = qpos[0]
        mujoco.mj_kinematics(model, data)
        height = float(data.xpos[1:, 2].max()) + HEAD_ROOM_M
        views = _walk_views(qpos, footsteps, goals, height=height, aspect=size[0] / size[1])
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    marks = _floor_marks(sim, footsteps, goals)
    with mujoco.Renderer(model, height=size[1], width=size[0], max_geom=10000) as renderer:
        # shadows and reflections cost 3/4 of the time of a software-rendered frame
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        for q, (lookat, distance, azimuth, elevation) in zip(qpos, views):
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            camera.lookat[:], camera.distance, camera.azimuth, camera.elevation = lookat, distance, azimuth, elevation
            renderer.update_scene(data, camera)
            _add_marks(renderer.scene, marks)
            yield renderer.render()


def _side_views(qpos: np.ndarray) -> Iterator[tuple[np.ndarray, float, float, float]]:
    """(look-at point, distance, azimuth, elevation) of the side view for each state of ``qpos``."""
    for q, heading in zip(qpos, _smoothed(_unwrapped_yaw(qpos), SIDE_VIEW_TURN_FRAMES)):
        yield np.array([q[0], q[1], 0.8]), 3.2, SIDE_VIEW_AZIMUTH_DEG + math.degrees(heading), -15.0


def _walk_views(qpos: np.ndarray, footsteps: Sequence[Landing], goals: Sequence[Sequence[float]], *, height: float,
                aspect: float) -> Iterator[tuple[np.ndarray, float, float, float]]:
    """(look-at point, distance, azimuth, elevation) of the camera that sees the whole walk
    for each state of ``qpos``: fixed, or following the pelvis where the walk is too long."""
    path = qpos[:, :2]
    ground = np.array([*(f[:2] for f in footsteps), *(g[:2] for g in goals)]).reshape(-1, 2)
    azimuth = _view_azimuth(qpos)
    lookat, distance = _framing(_seen_points(path, ground, height), azimuth, CAMERA_FOVY_DEG, aspect)
    if distance <= CAMERA_MAX_DISTANCE_M:
        for _ in qpos:
            yield lookat, distance, azimuth, CAMERA_ELEVATION_DEG
        return
    track = zip(_smoothed(path[:, 0], CAMERA_TRACK_FRAMES), _smoothed(path[:, 1], CAMERA_TRACK_FRAMES))
    for x, y in track:
        yield np.array([x, y, lookat[2]]), CAMERA_MAX_DISTANCE_M, azimuth, CAMERA_ELEVATION_DEG


def _view_azimuth(qpos: np.ndarray) -> float:
    """The camera's azimuth (deg): :data:`CAMERA_SIDE_DEG` from the walk's direction (from its
    first to its last pelvis position; the first heading for a walk on the spot)."""
    travel = qpos[-1, :2] - qpos[0, :2]
    direction = math.atan2(travel[1], travel[0]) if np.hypot(*travel) > 0.2 else float(_unwrapped_yaw(qpos[:1])[0])
    return math.degrees(direction) - 180.0 + CAMERA_SIDE_DEG


def _framing(points: np.ndarray, azimuth_deg: float, fovy_deg: float, aspect: float) -> tuple[np.ndarray, float]:
    """Where to look (x, y, z) and from how far (m) for a camera at ``azimuth_deg`` and
    :data:`CAMERA_ELEVATION_DEG` whose vertical field of view is ``fovy_deg`` to see all of
    ``points`` (n, 3), centred."""
    az, el = math.radians(azimuth_deg), math.radians(CAMERA_ELEVATION_DEG)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.array([math.sin(az), -math.cos(az), 0.0])
    up = np.cross(right, forward)
    lookat = (points.min(axis=0) + points.max(axis=0)) / 2
    tan_y = math.tan(math.radians(fovy_deg) / 2)
    for _ in range(3):  # fit, then centre the picture on what it shows, and fit again
        relative = points - lookat
        # a point at ``relative`` is ``distance + relative . forward`` in front of the camera
        need = np.maximum(np.abs(relative @ right) / (aspect * tan_y), np.abs(relative @ up) / tan_y) - relative @ forward
        distance = float(need.max())
        depth = distance + relative @ forward
        columns, rows = relative @ right / depth, relative @ up / depth
        lookat = lookat + distance * (right * (columns.max() + columns.min()) + up * (rows.max() + rows.min())) / 2
    return lookat, distance


def _seen_points(path: np.ndarray, ground: np.ndarray, height: float) -> np.ndarray:
    """What the camera is to see (n, 3): the ``ground`` points (m, 2) and the robot's room
    around its pelvis ``path`` (k, 2), up to ``height``, each with :data:`FRAME_MARGIN_M`
    around it."""
    around = FRAME_MARGIN_M * np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]])
    floor = (np.concatenate([path, ground])[:, None] + around).reshape(-1, 2)
    body = (path[:, None] + around).reshape(-1, 2)
    return np.concatenate([np.column_stack([floor, np.zeros(len(floor))]),
                           np.column_stack([body, np.full(len(body), height)])])


def _floor_marks(sim: SimModel, footsteps: Sequence[Landing], goals: Sequence[Sequence[float]]) -> list[tuple]:
    """The footsteps' sole rectangles and the goals' disks and arrows as
    (type, size, position, rotation, rgba, arrow end or None) of MuJoCo scene geoms."""
    sole = sim.robot.sole
    half = np.array([(sole.front + sole.back) / 2, sole.half_width, MARK_HEIGHT_M / 2])
    marks = []
    for f in footsteps:
        c, s = math.cos(f.yaw), math.sin(f.yaw)
        rotation = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        centre = np.array([f.x, f.y, MARK_HEIGHT_M / 2]) + rotation @ [(sole.front - sole.back) / 2, 0, 0]
        marks.append((mujoco.mjtGeom.mjGEOM_BOX, half, centre, rotation.ravel(), SIDE_RGBA[f.side], None))
    for x, y, yaw in goals:
        marks.append((mujoco.mjtGeom.mjGEOM_CYLINDER, np.array([0.08, 0.0, MARK_HEIGHT_M / 2]),
                      np.array([x, y, MARK_HEIGHT_M / 2]), np.eye(3).ravel(), GOAL_RGBA, None))
        start = np.array([x, y, 2 * MARK_HEIGHT_M])
        marks.append((mujoco.mjtGeom.mjGEOM_ARROW, None, start, None, GOAL_RGBA,
                      start + 0.4 * np.array([math.cos(yaw), math.sin(yaw), 0.0])))
    return marks


def _add_marks(scene: mujoco.MjvScene, marks: list[tuple]) -> None:
    """Append ``marks`` (:func:`_floor_marks`) to the scene's geoms, as far as it has room."""
    for kind, size, position, rotation, rgba, end in marks[: scene.maxgeom - scene.ngeom]:
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(geom, kind, np.zeros(3) if size is None else size, position,
                            np.eye(3).ravel() if rotation is None else rotation, np.asarray(rgba, dtype=np.float32))
        if end is not None:
            mujoco.mjv_connector(geom, kind, 0.03, position, end)
        scene.ngeom += 1


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
    *,
    path: str | Path,
    fps: int = 25,
    size: tuple[int, int] = (640, 480),
    progress: bool = False,
    footsteps: Sequence[Landing] = (),
    goals: Sequence[Sequence[float]] = (),
) -> Path:
    """Write an MP4 of the states ``qpos`` (n, nq) at ``times`` (s), seen as by
    :func:`render_frames` with the ``footsteps`` and ``goals`` on the floor.  Written atomically."""
    path = Path(path)
    frames = np.arange(times[0], times[-1] + 1e-9, 1.0 / fps)
    indices = np.clip(np.searchsorted(times, frames), 0, len(times) - 1)
    images = tqdm(
        render_frames(sim, qpos[indices], size=size, footsteps=footsteps, goals=goals), total=len(indices),
        desc="rendering", unit="frame", disable=not progress, leave=False,
    )
    with (
        atomic_path(path, suffix=path.suffix) as tmp,
        imageio.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264", macro_block_size=8) as writer,
    ):
        for image in images:
            writer.append_data(image)
    return path
