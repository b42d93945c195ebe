"""A MuJoCo model of the robot, built from the same URDF through the Pinocchio model.

The body tree, joint axes, limits, masses and inertias are written from the reduced,
left/right-symmetrised Pinocchio model of :class:`~cocomopl.robot.Robot`, so the
simulator and the optimal control see the same rigid bodies (``tests/test_sim.py``
compares their mass matrices).  The URDF's meshes are attached for rendering only:
the robot touches the world through one box per sole, the sole rectangle of the robot
description.  Every actuated joint has a position servo (stiff, as on HRP-2) saturated
at the URDF's effort limit, and the reflected rotor inertia (rotor inertia × gear ratio²,
from the description's SRDF) as armature.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from cocomopl.dynamics import SIDES
from cocomopl.errors import Error
from cocomopl.robot import Robot

TIMESTEP = 0.001  # s: a 1 kHz control and integration loop
FRICTION = 1.0  # sole-floor Coulomb coefficient
SOLE_THICKNESS = 0.01  # m, the contact box below the sole plane
# Servo stiffness: full torque at this joint error.  HRP-2's servos are stiff; this makes
# the knee 10 000 N m/rad and the elbow 600 N m/rad.
FULL_TORQUE_ERROR = 0.03  # rad
SERVO_DAMPING_TIME = 0.02  # s: kv = kp * this
# Contact softness: the time constant of a critically damped sole-floor constraint.  The
# robots' soles are rubber (HRP-2's ankles also have a rubber bush); at 10 ms TALOS standing
# sinks 0.2 mm (0.06 mm at 5 ms, 0.6 mm at 20 ms).  Softer contacts lower the touchdown
# peaks; README "Stage 3: simulation" measures what else they change.
CONTACT_TIME_CONSTANT = 0.01  # s
MAX_CONTACT_TIME_CONSTANT = 0.1  # s: softer soles sink centimetres


@dataclass
class SimModel:
    """A compiled MuJoCo model and where the robot's quantities live in it."""

    mj: mujoco.MjModel
    robot: Robot
    sole_geoms: dict[str, int]  # side -> geom id of the sole box
    sole_sites: dict[str, int]  # side -> site id at the sole frame
    base_body: int
    contact_time_constant: float  # s

    def qpos(self, q: np.ndarray) -> np.ndarray:
        """MuJoCo ``qpos`` from a Pinocchio configuration (quaternion x,y,z,w -> w,x,y,z)."""
        return np.concatenate([q[:3], [q[6], q[3], q[4], q[5]], q[7:]])

    def q(self, qpos: np.ndarray) -> np.ndarray:
        """Pinocchio configuration from MuJoCo ``qpos``."""
        return np.concatenate([qpos[:3], qpos[4:7], [qpos[3]], qpos[7:]])

    def qvel(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """MuJoCo ``qvel`` (free-joint linear velocity in the world frame) from Pinocchio's
        (linear velocity in the base frame)."""
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        return np.concatenate([R @ v[:3], v[3:]])

    def v(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """Pinocchio velocity from MuJoCo ``qpos``, ``qvel``."""
        R = pin.Quaternion(qpos[3], qpos[4], qpos[5], qpos[6]).toRotationMatrix()
        return np.concatenate([R.T @ qvel[:3], qvel[3:]])

    def sole_wrenches(self, data: mujoco.MjData) -> np.ndarray:
        """Contact wrench (2, 6) on each sole from the floor: world axes, about the sole frame."""
        out = np.zeros((2, 6))
        force = np.zeros(6)
        for i in range(data.ncon):
            contact = data.contact[i]
            for j, side in enumerate(SIDES):
                geom = self.sole_geoms[side]
                if geom not in (contact.geom1, contact.geom2):
                    continue
                mujoco.mj_contactForce(self.mj, data, i, force)
                # contact-frame force, normal from geom1 to geom2: on geom2 as is, on geom1 reversed
                f = contact.frame.reshape(3, 3).T @ force[:3] * (1.0 if contact.geom2 == geom else -1.0)
                arm = contact.pos - data.site_xpos[self.sole_sites[side]]
                out[j, :3] += f
                out[j, 3:] += np.cross(arm, f)
        return out


def _vec(x) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(x))


def _pose(M: pin.SE3) -> str:
    w, x, y, z = (lambda c: (c[3], c[0], c[1], c[2]))(pin.Quaternion(M.rotation).coeffs())
    return f'pos="{_vec(M.translation)}" quat="{_vec([w, x, y, z])}"'


def _inertial(inertia: pin.Inertia) -> str:
    I = inertia.inertia
    full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
    return f'<inertial pos="{_vec(inertia.lever)}" mass="{inertia.mass:.9g}" fullinertia="{_vec(full)}"/>'


def _hinge(robot: Robot, jid: int) -> str:
    model = robot.model
    axis = {"X": "1 0 0", "Y": "0 1 0", "Z": "0 0 1"}[model.joints[jid].shortname()[-1]]
    iq, iv = model.idx_qs[jid], model.idx_vs[jid]
    lower, upper = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
    return (
        f'<joint name="{model.names[jid]}" type="hinge" axis="{axis}" range="{lower:.9g} {upper:.9g}" '
        f'armature="{model.armature[iv]:.9g}"/>'
    )


def _sole(robot: Robot, side: str) -> str:
    frame = robot.model.frames[robot.foot_frames[side]]
    sole = robot.sole
    half = [(sole.front + sole.back) / 2, sole.half_width, SOLE_THICKNESS / 2]
    # the box's bottom face is the sole plane: in contact the sole frame is on the floor
    centre = frame.placement * pin.SE3(np.eye(3), np.array([(sole.front - sole.back) / 2, 0.0, half[2]]))
    return (
        f'<geom name="{side}_sole" type="box" size="{_vec(half)}" {_pose(centre)} class="sole"/>\n'
        f'<site name="{side}_sole" {_pose(frame.placement)} size="0.01"/>'
    )


def _is_attached(g: pin.GeometryObject) -> bool:
    """Whether the visual geometry goes into the MuJoCo model: MuJoCo reads STL, not DAE."""
    return bool(g.meshPath) and Path(g.meshPath).suffix.lower() == ".stl"


def mesh_files(visual: pin.GeometryModel) -> dict[str, Path]:
    """The STL files :func:`mjcf` attaches, each by its path relative to their common folder
    (the robot package's mesh folder, whose layout keeps same-named files apart)."""
    files = sorted({Path(g.meshPath).resolve() for g in visual.geometryObjects if _is_attached(g)})
    if not files:
        return {}
    root = Path(os.path.commonpath([f.parent for f in files]))
    return {f.relative_to(root).as_posix(): f for f in files}


def _visuals(visual: pin.GeometryModel | None, jid: int, meshes: dict[str, tuple[Path, np.ndarray]]) -> list[str]:
    out = []
    if visual is None:
        return out
    for g in visual.geometryObjects:
        if g.parentJoint != jid or not _is_attached(g):
            continue
        name = f"mesh{len(meshes)}"
        meshes[name] = (Path(g.meshPath).resolve(), g.meshScale)
        out.append(f'<geom type="mesh" mesh="{name}" {_pose(g.placement)} class="visual"/>')
    return out


def _body(robot: Robot, jid: int, visual, meshes: dict[str, tuple[Path, np.ndarray]]) -> str:
    model = robot.model
    children = [j for j in range(jid + 1, model.njoints) if model.parents[j] == jid]
    joint = "<freejoint/>" if jid == 1 else _hinge(robot, jid)
    parts = [joint, _inertial(model.inertias[jid])]
    parts += _visuals(visual, jid, meshes)
    parts += [_sole(robot, side) for side in SIDES if model.frames[robot.foot_frames[side]].parentJoint == jid]
    parts += [_body(robot, child, visual, meshes) for child in children]
    return f'<body name="{model.names[jid]}" {_pose(model.jointPlacements[jid])}>\n' + "\n".join(parts) + "\n</body>"


def _actuators(robot: Robot) -> str:
    lines = []
    for name, tau, lower, upper in zip(robot.joint_names, robot.tau_max, robot.q_lower, robot.q_upper):
        kp = tau / FULL_TORQUE_ERROR
        lines.append(
            f'<position name="{name}" joint="{name}" kp="{kp:.6g}" kv="{kp * SERVO_DAMPING_TIME:.6g}" '
            f'forcerange="{-tau:.6g} {tau:.6g}" ctrlrange="{lower:.9g} {upper:.9g}"/>'
        )
    return "\n".join(lines)


def _mesh_assets(visual: pin.GeometryModel, meshes: dict[str, tuple[Path, np.ndarray]], mesh_folder: str | None) -> str:
    """The ``<mesh>`` assets of ``meshes`` (name -> file, scale); see :func:`mjcf` for ``mesh_folder``."""
    if mesh_folder is None:
        file_of = {path: str(path) for path, _ in meshes.values()}
    else:
        file_of = {path: f"{mesh_folder}/{relative}" for relative, path in mesh_files(visual).items()}
    return "\n  ".join(
        f'<mesh name="{name}" file="{file_of[path]}" scale="{_vec(scale)}"/>' for name, (path, scale) in meshes.items()
    )


def mjcf(
    robot: Robot, visuals: bool = True, contact_time_constant: float = CONTACT_TIME_CONSTANT, mesh_folder: str | None = None
) -> str:
    """The MJCF text of the robot on a flat floor.

    Parameters
    ----------
    robot : the robot, as the OCPs use it
    visuals : attach the URDF's STL meshes for rendering
    contact_time_constant : sole-floor ``solref`` time constant, s
    mesh_folder : ``None`` names the mesh files by absolute path; a folder (relative to the
        XML file) names them ``mesh_folder/<path in mesh_files>``, for a copy of the meshes
    """
    solref = f"{contact_time_constant:.6g} 1"
    meshes: dict[str, tuple[Path, np.ndarray]] = {}
    visual = robot.visual_model() if visuals else None
    body = _body(robot, 1, visual, meshes)
    assets = _mesh_assets(visual, meshes, mesh_folder) if meshes else ""
    return f"""<mujoco model="{robot.name}">
<compiler angle="radian" autolimits="true" boundmass="0" boundinertia="0"/>
<option timestep="{TIMESTEP}" integrator="implicitfast"/>
<visual><global offwidth="1280" offheight="720"/><headlight ambient="0.4 0.4 0.4" diffuse="0.5 0.5 0.5"/></visual>
<default>
  <default class="sole"><geom contype="1" conaffinity="1" condim="3" friction="{FRICTION} 0.005 0.0001"
    solref="{solref}" rgba="0.2 0.2 0.2 1"/></default>
  <default class="visual"><geom contype="0" conaffinity="0" group="1" mass="0" rgba="0.55 0.6 0.7 1"/></default>
</default>
<asset>
  <texture name="grid" type="2d" builtin="checker" rgb1="0.9 0.9 0.9" rgb2="0.75 0.75 0.78" width="512" height="512"/>
  <material name="grid" texture="grid" texrepeat="8 8" reflectance="0.1"/>
  {assets}
</asset>
<worldbody>
<light pos="0 0 4" dir="0 0 -1" directional="true"/>
<geom name="floor" type="plane" size="0 0 0.05" material="grid" contype="1" conaffinity="1" condim="3"
  friction="{FRICTION} 0.005 0.0001" solref="{solref}"/>
{body}
</worldbody>
<actuator>
{_actuators(robot)}
</actuator>
</mujoco>"""


def check_contact_time_constant(value: float) -> float:
    """``value`` (s) if it is a usable contact time constant, else :class:`Error`: under two
    timesteps MuJoCo silently raises it, and over ``MAX_CONTACT_TIME_CONSTANT`` the soles sink
    centimetres."""
    if not 2 * TIMESTEP <= value <= MAX_CONTACT_TIME_CONSTANT:
        raise Error(f"contact time constant {value} s is outside {2 * TIMESTEP:g}-{MAX_CONTACT_TIME_CONSTANT:g} s")
    return value


def build_sim_model(robot: Robot, visuals: bool = True, contact_time_constant: float | None = None) -> SimModel:
    """Compile the MuJoCo model of ``robot``.

    Parameters
    ----------
    robot : the robot, as the OCPs use it
    visuals : attach the URDF's meshes for rendering (``False`` is faster)
    contact_time_constant : softness of the sole-floor contact in s (MuJoCo's ``solref``
        time constant, critically damped); ``None`` takes ``CONTACT_TIME_CONSTANT``

    Raises
    ------
    Error
        if the time constant is unusable (:func:`check_contact_time_constant`).
    """
    if contact_time_constant is None:
        contact_time_constant = CONTACT_TIME_CONSTANT
    check_contact_time_constant(contact_time_constant)
    mj = mujoco.MjModel.from_xml_string(mjcf(robot, visuals, contact_time_constant))
    names = [mj.joint(j).name for j in range(1, mj.njnt)]
    if names != robot.joint_names or mj.nu != robot.nu:
        raise RuntimeError("MuJoCo joint order differs from the robot's")  # a bug, not user input
    return SimModel(
        mj=mj,
        robot=robot,
        sole_geoms={side: mj.geom(f"{side}_sole").id for side in SIDES},
        sole_sites={side: mj.site(f"{side}_sole").id for side in SIDES},
        base_body=mj.body(robot.model.names[1]).id,
        contact_time_constant=contact_time_constant,
    )
