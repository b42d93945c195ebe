"""A motion as one self-contained interactive HTML page: a 3-D stick figure to orbit, zoom
and scrub through, with the soles, the ZMP and the ground projection of the CoM.

The kinematics are computed here with Pinocchio and embedded as JSON; a small inline
script draws them on a 2-D canvas with a perspective projection.  The page loads nothing
from the network, so it opens from a mail attachment or a CI artefact as well.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pinocchio as pin

from cocomopl.analysis.plots import SIDE_COLOURS, short_title
from cocomopl.dynamics import SIDES
from cocomopl.motion import Motion
from cocomopl.motion_file import atomic_path
from cocomopl.robot import Robot

FPS = 40.0  # frames per second of the page: 25 ms, the knot spacing of the OC motions
DECIMALS = 4  # 0.1 mm: invisible on screen, keeps the page small


def _points(model: pin.Model, data: pin.Data, tip_frames: list[int]) -> np.ndarray:
    """World positions (m, 3) of the skeleton points after forward kinematics."""
    return np.array(
        [data.oMi[j].translation for j in range(1, model.njoints)] + [data.oMf[f].translation for f in tip_frames]
    )


def skeleton(robot: Robot) -> tuple[list[tuple[int, int]], list[str], list[int]]:
    """The stick figure: which points are joined, on which side, and the tip frames.

    The points are the origins of the model's joints (``model.joints[1:]``), then, for each
    joint without children, its farthest body frame at the reference posture (TALOS: the
    soles, fingertips and head camera), so that feet, hands and head have a length.

    Returns
    -------
    segments : (parent point, child point) index pairs
    sides : per segment "left", "right" or "centre", from the side of its child point in
        the reference posture
    tip_frames : frame ids of the tips, points ``njoints - 1`` onwards
    """
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, robot.q_ref)
    children = {j: [] for j in range(model.njoints)}
    for j in range(2, model.njoints):
        children[model.parents[j]].append(j)
    segments = [(model.parents[j] - 1, j - 1) for j in range(2, model.njoints)]
    tip_frames = []
    for j in (j for j in range(2, model.njoints) if not children[j]):
        frames = [
            f
            for f in range(model.nframes)
            if model.frames[f].parentJoint == j and model.frames[f].type == pin.FrameType.BODY
        ]
        tip = max(frames, key=lambda f: np.linalg.norm(data.oMf[f].translation - data.oMi[j].translation))
        segments.append((j - 1, model.njoints - 1 + len(tip_frames)))
        tip_frames.append(tip)
    points = _points(model, data, tip_frames)
    # the reference posture stands at the origin facing +x: left is +y
    lateral = points[:, 1] - robot.q_ref[1]
    sides = ["left" if lateral[c] > 0.01 else "right" if lateral[c] < -0.01 else "centre" for _, c in segments]
    return segments, sides, tip_frames


def viewer_data(robot: Robot, motion: Motion, fps: float = FPS) -> dict:
    """Everything the page draws, per frame at ``fps``: world positions (m) of the skeleton
    points, the sole rectangles' corners, the ZMP (None where undefined) and the CoM, the
    contact flags.  Configurations between knots are interpolated on the configuration
    manifold (``pinocchio.interpolate``), the ZMP linearly."""
    model, data = robot.model, robot.model.createData()
    segments, sides, tip_frames = skeleton(robot)
    keep = motion.kept_samples()
    t, q, zmp, contact = motion.t[keep], motion.q[keep], motion.zmp[keep], motion.contact[keep]
    times = t[0] + np.arange(0.0, motion.duration + 1e-9, 1.0 / fps)
    knot = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    share = np.clip((times - t[knot]) / (t[knot + 1] - t[knot]), 0.0, 1.0)
    corners = np.column_stack([robot.sole.corners(), np.zeros(4)])
    frames = {"points": [], "soles": [], "zmp": [], "com": [], "contact": []}
    for k, s in zip(knot, share):
        qk = pin.interpolate(model, q[k], q[k + 1], s)
        pin.framesForwardKinematics(model, data, qk)
        points = _points(model, data, tip_frames)
        soles = [
            corners @ data.oMf[f].rotation.T + data.oMf[f].translation
            for f in (robot.foot_frames[side] for side in SIDES)
        ]
        p = (1 - s) * zmp[k, :2] + s * zmp[k + 1, :2]
        frames["points"].append(np.round(points, DECIMALS).tolist())
        frames["soles"].append(np.round(soles, DECIMALS).tolist())
        frames["zmp"].append(np.round(p, DECIMALS).tolist() if np.all(np.isfinite(p)) else None)
        frames["com"].append(np.round(pin.centerOfMass(model, data, qk), DECIMALS).tolist())
        frames["contact"].append(contact[k if s < 0.5 else k + 1].tolist())
    return {"fps": fps, "t": np.round(times - t[0], 6).tolist(), "segments": segments, "sides": sides, **frames}


def write_html_viewer(robot: Robot, motion: Motion, path: Path, *, title: str | None = None, fps: float = FPS) -> Path:
    """Write the interactive 3-D page of ``motion`` to ``path`` (atomically) and return it.

    Drag to orbit, wheel to zoom, space or the button to play and pause, the slider to
    scrub.  The camera follows the pelvis.
    """
    path = Path(path)
    payload = json.dumps(viewer_data(robot, motion, fps), separators=(",", ":")).replace("</", "<\\/")
    fields = {
        "__TITLE__": html.escape(title or short_title(motion)),
        "__LEFT__": SIDE_COLOURS["left"],
        "__RIGHT__": SIDE_COLOURS["right"],
        "__DATA__": payload,
    }
    page = _PAGE
    for placeholder, text in fields.items():
        page = page.replace(placeholder, text)
    with atomic_path(path, suffix=".html") as tmp:
        tmp.write_text(page, encoding="utf-8")
    return path


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>__TITLE__</title>
<style>
  body { margin: 0; font: 14px sans-serif; background: #fafafa; }
  header, footer { padding: 6px 10px; }
  canvas { display: block; width: 100%; height: 78vh; background: #fff; cursor: grab; }
  #slider { width: 60%; vertical-align: middle; }
  .key { display: inline-block; width: 10px; height: 10px; margin: 0 3px 0 10px; }
</style>
</head>
<body>
<header><b>__TITLE__</b>
  <span class="key" style="background:__LEFT__"></span>left
  <span class="key" style="background:__RIGHT__"></span>right
  <span class="key" style="background:#ff7f0e"></span>ZMP
  <span class="key" style="background:#2ca02c"></span>CoM (and its ground projection)
  &mdash; drag to orbit, wheel to zoom, space to play/pause</header>
<canvas id="view"></canvas>
<footer>
  <button id="play">pause</button>
  <input id="slider" type="range" min="0" value="0">
  <span id="time"></span>
  <select id="speed"><option>0.25</option><option>0.5</option><option selected>1</option></select>&times;
</footer>
<script type="application/json" id="motion-data">__DATA__</script>
<script>
"use strict";
const D = JSON.parse(document.getElementById("motion-data").textContent);
const n = D.t.length;
const canvas = document.getElementById("view"), g = canvas.getContext("2d");
const slider = document.getElementById("slider"), label = document.getElementById("time");
const button = document.getElementById("play"), speed = document.getElementById("speed");
const colour = { left: "__LEFT__", right: "__RIGHT__", centre: "#333" };
let yaw = -1.2, pitch = 0.3, distance = 2.6, frame = 0, playing = true, last = null, drag = null;
slider.max = n - 1;

// camera on a sphere around the target: dir points from the target to the eye
function camera(target) {
  const cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
  const dir = [cy * cp, sy * cp, sp], right = [-sy, cy, 0], up = [-sp * cy, -sp * sy, cp];
  const focal = 0.9 * Math.min(canvas.width, canvas.height);
  return p => {
    const d = [p[0] - target[0], p[1] - target[1], p[2] - target[2]];
    const depth = Math.max(distance - (d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2]), 0.05);
    return [canvas.width / 2 + focal * (d[0] * right[0] + d[1] * right[1]) / depth,
            canvas.height / 2 - focal * (d[0] * up[0] + d[1] * up[1] + d[2] * up[2]) / depth];
  };
}

function path(points, project, close) {
  g.beginPath();
  points.forEach((p, i) => { const s = project(p); i ? g.lineTo(s[0], s[1]) : g.moveTo(s[0], s[1]); });
  if (close) g.closePath();
}

function dot(p, project, r, fill) {
  const s = project(p);
  g.beginPath(); g.arc(s[0], s[1], r, 0, 2 * Math.PI); g.fillStyle = fill; g.fill();
}

function draw() {
  const k = Math.min(Math.floor(frame), n - 1), pts = D.points[k], pelvis = pts[0];
  const project = camera([pelvis[0], pelvis[1], 0.6]);
  g.clearRect(0, 0, canvas.width, canvas.height);
  g.lineWidth = 1; g.strokeStyle = "#ddd";
  const x0 = Math.round(pelvis[0] * 4) / 4, y0 = Math.round(pelvis[1] * 4) / 4;
  for (let i = -8; i <= 8; i++) {
    path([[x0 + i / 4, y0 - 2, 0], [x0 + i / 4, y0 + 2, 0]], project); g.stroke();
    path([[x0 - 2, y0 + i / 4, 0], [x0 + 2, y0 + i / 4, 0]], project); g.stroke();
  }
  ["left", "right"].forEach((side, j) => {
    path(D.soles[k][j], project, true);
    g.fillStyle = colour[side] + (D.contact[k][j] ? "88" : "22"); g.fill();
    g.strokeStyle = colour[side]; g.stroke();
  });
  g.lineWidth = 3; g.lineCap = "round";
  D.segments.forEach(([a, b], i) => { path([pts[a], pts[b]], project); g.strokeStyle = colour[D.sides[i]]; g.stroke(); });
  pts.forEach(p => dot(p, project, 2.5, "#333"));
  const com = D.com[k];
  g.lineWidth = 1; g.setLineDash([4, 4]); g.strokeStyle = "#2ca02c";
  path([com, [com[0], com[1], 0]], project); g.stroke(); g.setLineDash([]);
  dot(com, project, 5, "#2ca02c"); dot([com[0], com[1], 0], project, 4, "#2ca02c");
  if (D.zmp[k]) dot([D.zmp[k][0], D.zmp[k][1], 0], project, 5, "#ff7f0e");
  slider.value = k;
  label.textContent = "t = " + D.t[k].toFixed(3) + " s (" + (k + 1) + "/" + n + ")";
}

function tick(now) {
  if (playing && last !== null) frame = (frame + (now - last) / 1000 * D.fps * Number(speed.value)) % n;
  last = now;
  draw();
  requestAnimationFrame(tick);
}

function resize() {
  canvas.width = canvas.clientWidth * devicePixelRatio;
  canvas.height = canvas.clientHeight * devicePixelRatio;
}

function toggle() { playing = !playing; button.textContent = playing ? "pause" : "play"; }

button.onclick = toggle;
window.onkeydown = e => { if (e.code === "Space") { toggle(); e.preventDefault(); } };
slider.oninput = () => { frame = Number(slider.value); if (playing) toggle(); };
canvas.onmousedown = e => { drag = [e.clientX, e.clientY]; };
window.onmouseup = () => { drag = null; };
window.onmousemove = e => {
  if (!drag) return;
  yaw -= (e.clientX - drag[0]) * 0.01;
  pitch = Math.min(Math.max(pitch + (e.clientY - drag[1]) * 0.01, -0.2), 1.5);
  drag = [e.clientX, e.clientY];
};
canvas.onwheel = e => { distance = Math.min(Math.max(distance * Math.exp(e.deltaY * 0.001), 0.5), 20); e.preventDefault(); };
window.onresize = resize;
resize();
requestAnimationFrame(tick);
</script>
</body>
</html>
"""
