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
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from cocomopl.dynamics import SIDES
from cocomopl.errors import Error
from cocomopl.robot import Robot
from cocomopl.robot.scale import REFERENCE_LEG_TORQUES_NM

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
    """A compiled MuJoCo model and where the robot's quantities live in it.

    The robot floats on the model's first joint, a free joint (``qpos[:7]``, ``qvel[:6]``);
    its actuated joints, in the robot's order, are at ``qpos_index`` and ``dof_index`` and
    driven by the position servos ``actuators``.  A model file of the robot made elsewhere
    (:func:`load_sim_model`) may order them otherwise and have more joints: the actuators
    ``held_actuators`` hold such joints at ``held_commands``.
    """

    mj: mujoco.MjModel
    robot: Robot
    sole_geoms: dict[str, tuple[int, ...]]  # side -> geom ids that touch the floor
    sole_sites: dict[str, int]  # side -> site id at the sole frame
    base_body: int
    contact_time_constant: float  # s
    qpos_index: np.ndarray | None = None  # (nu,) default: 7, 8, ...
    dof_index: np.ndarray | None = None  # (nu,) default: 6, 7, ...
    actuators: np.ndarray | None = None  # (nu,) default: 0, 1, ...
    held_actuators: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    held_commands: np.ndarray = field(default_factory=lambda: np.zeros(0))
    source: str = "built from the robot description"
    spec: mujoco.MjSpec | None = None  # what ``mj`` was compiled from, to add to (floor bumps)

    def __post_init__(self):
        nu = self.robot.nu
        self.qpos_index = np.arange(7, 7 + nu) if self.qpos_index is None else np.asarray(self.qpos_index)
        self.dof_index = np.arange(6, 6 + nu) if self.dof_index is None else np.asarray(self.dof_index)
        self.actuators = np.arange(nu) if self.actuators is None else np.asarray(self.actuators)

    def qpos(self, q: np.ndarray) -> np.ndarray:
        """MuJoCo ``qpos`` from a Pinocchio configuration (quaternion x,y,z,w -> w,x,y,z);
        joints the robot does not have keep the model's reference positions."""
        out = self.mj.qpos0.copy()
        out[:7] = [*q[:3], q[6], q[3], q[4], q[5]]
        out[self.qpos_index] = q[7:]
        return out

    def q(self, qpos: np.ndarray) -> np.ndarray:
        """Pinocchio configuration from MuJoCo ``qpos``."""
        return np.concatenate([qpos[:3], qpos[4:7], [qpos[3]], qpos[self.qpos_index]])

    def qvel(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """MuJoCo ``qvel`` (free-joint linear velocity in the world frame) from Pinocchio's
        (linear velocity in the base frame)."""
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        out = np.zeros(self.mj.nv)
        out[:6] = [*(R @ v[:3]), *v[3:6]]
        out[self.dof_index] = v[6:]
        return out

    def v(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """Pinocchio velocity from MuJoCo ``qpos``, ``qvel``."""
        R = pin.Quaternion(qpos[3], qpos[4], qpos[5], qpos[6]).toRotationMatrix()
        return np.concatenate([R.T @ qvel[:3], qvel[3:6], qvel[self.dof_index]])

    def command(self, data: mujoco.MjData, joints: np.ndarray) -> None:
        """Send joint position commands (nu,), in the robot's order, to the servos."""
        data.ctrl[self.actuators] = joints
        data.ctrl[self.held_actuators] = self.held_commands

    def joint_torques(self, data: mujoco.MjData) -> np.ndarray:
        """The servos' torques (nu,), in the robot's order."""
        return data.actuator_force[self.actuators]

    def servo_gains(self) -> np.ndarray:
        """(kp, kv) of the robot's joint servos, (2, nu)."""
        model = self.mj
        return np.stack([model.actuator_gainprm[self.actuators, 0], -model.actuator_biasprm[self.actuators, 2]])

    def sole_wrenches(self, data: mujoco.MjData) -> np.ndarray:
        """Contact wrench (2, 6) on each sole from the floor: world axes, about the sole frame."""
        # On Python floats, contact by contact, with the same operations as NumPy's: the
        # stabilizer asks every tick for a handful of contacts, for which NumPy's per-call
        # overhead costs more than the arithmetic.
        out = [[0.0] * 6 for _ in SIDES]
        contacts = data.contact
        frames, points = contacts.frame.tolist(), contacts.pos.tolist()
        soles = [data.site_xpos[self.sole_sites[side]].tolist() for side in SIDES]
        force = np.zeros(6)
        for i, (first, second) in enumerate(zip(contacts.geom1.tolist(), contacts.geom2.tolist())):
            for j, side in enumerate(SIDES):
                geoms = self.sole_geoms[side]
                if first not in geoms and second not in geoms:
                    continue
                mujoco.mj_contactForce(self.mj, data, i, force)
                # contact-frame force, normal from geom1 to geom2: on geom2 as is, on geom1 reversed
                f = _to_world(frames[i], force[:3].tolist(), 1.0 if second in geoms else -1.0)
                arm = [p - s for p, s in zip(points[i], soles[j])]
                total = out[j]
                for a, value in enumerate(f + _cross(arm, f)):
                    total[a] += value
        return np.array(out)


def _to_world(frame: list[float], force: list[float], sign: float) -> list[float]:
    """``sign * frame.reshape(3, 3).T @ force``: a contact-frame force (its frame's rows are
    its axes in the world) in world axes."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = frame
    f0, f1, f2 = force
    return [(r0 * f0 + r3 * f1 + r6 * f2) * sign, (r1 * f0 + r4 * f1 + r7 * f2) * sign,
            (r2 * f0 + r5 * f1 + r8 * f2) * sign]


def _cross(a: list[float], b: list[float]) -> list[float]:
    """``np.cross`` of two 3-vectors, the same operations on Python floats."""
    (a0, a1, a2), (b0, b1, b2) = a, b
    return [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]


def _vec(x) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(x))


def _pose(M: pin.SE3) -> str:
    return f'pos="{_vec(M.translation)}" quat="{_vec(_wxyz(M.rotation))}"'


def _inertial(inertia: pin.Inertia) -> str:
    I = inertia.inertia
    full = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
    return f'<inertial pos="{_vec(inertia.lever)}" mass="{inertia.mass:.9g}" fullinertia="{_vec(full)}"/>'


def _hinge(robot: Robot, jid: int) -> str:
    model = robot.model
    axis = _vec(robot.joint_axes[jid - 2])
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


def _body(robot: Robot, jid: int, visual, meshes: dict[str, tuple[Path, np.ndarray]],
          placement: pin.SE3 | None = None) -> str:
    """The body of joint ``jid`` and its subtree, at ``placement`` in its parent (default: the model's)."""
    model = robot.model
    children = [j for j in range(jid + 1, model.njoints) if model.parents[j] == jid]
    joint = "<freejoint/>" if jid == 1 else _hinge(robot, jid)
    parts = [joint, _inertial(model.inertias[jid])]
    parts += _visuals(visual, jid, meshes)
    parts += [_sole(robot, side) for side in SIDES if model.frames[robot.foot_frames[side]].parentJoint == jid]
    parts += [_body(robot, child, visual, meshes) for child in children]
    placement = model.jointPlacements[jid] if placement is None else placement
    return f'<body name="{model.names[jid]}" {_pose(placement)}>\n' + "\n".join(parts) + "\n</body>"


def servo_stiffness(robot: Robot) -> np.ndarray:
    """kp (nu,) of the project's position servos, N m/rad: full torque at :data:`FULL_TORQUE_ERROR`,
    but a leg joint no stiffer than TALOS's joint of its role scaled by the robot's torque ratio
    (mass x leg length), so that its servos hold the robot's weight no more stiffly than TALOS's
    hold TALOS's.  TALOS's are its own; G1's hips and knees, strong for its 33 kg, get 31-58 %
    of full torque at 30 mrad."""
    kp = robot.tau_max / FULL_TORQUE_ERROR
    for joint, role in robot.leg_joint_roles().items():
        kp[joint] = min(kp[joint], REFERENCE_LEG_TORQUES_NM[role] * robot.scale.torque / FULL_TORQUE_ERROR)
    return kp


def leg_servos_capped(robot: Robot) -> bool:
    """Whether :func:`servo_stiffness` holds any of ``robot``'s leg servos below full torque at
    :data:`FULL_TORQUE_ERROR`: they then give more under the robot's own loads than TALOS's
    give under TALOS's.  Not for TALOS or Romeo; for G1 and Alexander."""
    legs = sorted(robot.leg_joint_roles())
    return bool(np.any(servo_stiffness(robot)[legs] < robot.tau_max[legs] / FULL_TORQUE_ERROR))


def _servos(robot: Robot):
    """Per actuated joint, the project's position servo: name, kp, kv, torque limit, command range."""
    for name, kp, tau, lower, upper in zip(robot.joint_names, servo_stiffness(robot), robot.tau_max, robot.q_lower, robot.q_upper):
        yield name, kp, kp * SERVO_DAMPING_TIME, tau, (lower, upper)


def _actuators(robot: Robot) -> str:
    return "\n".join(
        f'<position name="{name}" joint="{name}" kp="{kp:.6g}" kv="{kv:.6g}" '
        f'forcerange="{-tau:.6g} {tau:.6g}" ctrlrange="{limits[0]:.9g} {limits[1]:.9g}"/>'
        for name, kp, kv, tau, limits in _servos(robot)
    )


def _mesh_assets(visual: pin.GeometryModel, meshes: dict[str, tuple[Path, np.ndarray]], mesh_folder: str | None) -> str:
    """The ``<mesh>`` assets of ``meshes`` (name -> file, scale); see :func:`mjcf` for ``mesh_folder``."""
    if mesh_folder is None:
        file_of = {path: str(path) for path, _ in meshes.values()}
    else:
        file_of = {path: f"{mesh_folder}/{relative}" for relative, path in mesh_files(visual).items()}
    return "\n  ".join(
        f'<mesh name="{name}" file="{file_of[path]}" scale="{_vec(scale)}"/>' for name, (path, scale) in meshes.items()
    )


def standing_height(robot: Robot) -> float:
    """The height (m) of the upright base at which the robot, every joint at zero, rests its
    lowest sole corner on the floor."""
    q = pin.neutral(robot.model)
    corners = np.c_[robot.sole.corners(), np.zeros(4)]  # in the sole frame
    soles = [robot.frame_placement(q, robot.foot_frames[side]) for side in SIDES]
    return -min(float((M.rotation @ corners.T)[2].min() + M.translation[2]) for M in soles)


def _home(robot: Robot) -> str:
    """The keyframe ``home``: the reference posture standing on the floor, the servos holding it."""
    q = robot.q_ref
    return (f'<keyframe>\n<key name="home" qpos="{_vec([*q[:3], q[6], q[3], q[4], q[5], *q[7:]])}" '
            f'ctrl="{_vec(q[7:])}"/>\n</keyframe>')


def mjcf(
    robot: Robot, *, visuals: bool = True, contact_time_constant: float = CONTACT_TIME_CONSTANT,
    mesh_folder: str | None = None, home: bool = False,
) -> str:
    """The MJCF text of the robot on a flat floor.

    Parameters
    ----------
    robot : the robot, as the OCPs use it
    visuals : attach the URDF's STL meshes for rendering
    contact_time_constant : sole-floor ``solref`` time constant, s
    mesh_folder : ``None`` names the mesh files by absolute path; a folder (relative to the
        XML file) names them ``mesh_folder/<path in mesh_files>``, for a copy of the meshes
    home : for a model file used on its own (:mod:`cocomopl.export.mjcf`): the base at
        :func:`standing_height`, so that the model as loaded (every joint and servo command at
        zero) stands on the floor, and the keyframe ``home``, the reference posture standing
        on the floor with the servo commands that hold it.  The simulator sets every state
        and command itself and builds without them.
    """
    solref = f"{contact_time_constant:.6g} 1"
    meshes: dict[str, tuple[Path, np.ndarray]] = {}
    visual = robot.visual_model() if visuals else None
    base = pin.SE3(np.eye(3), np.array([0.0, 0.0, standing_height(robot)])) if home else None
    body = _body(robot, 1, visual, meshes, base)
    assets = _mesh_assets(visual, meshes, mesh_folder) if meshes else ""
    keyframe = "\n" + _home(robot) if home else ""
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
</actuator>{keyframe}
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
    spec = mujoco.MjSpec.from_string(mjcf(robot, visuals=visuals, contact_time_constant=contact_time_constant))
    mj = spec.compile()
    names = [mj.joint(j).name for j in range(1, mj.njnt)]
    if names != robot.joint_names or mj.nu != robot.nu:
        raise RuntimeError("MuJoCo joint order differs from the robot's")  # a bug, not user input
    return SimModel(
        mj=mj,
        robot=robot,
        sole_geoms={side: (mj.geom(f"{side}_sole").id,) for side in SIDES},
        sole_sites={side: mj.site(f"{side}_sole").id for side in SIDES},
        base_body=mj.body(robot.model.names[1]).id,
        contact_time_constant=contact_time_constant,
        spec=spec,
    )


GEOMETRY_TOLERANCE_M = 0.005  # how far a model file's soles may sit from the robot description's


def load_sim_model(robot: Robot, path: str | Path, contact_time_constant: float | None = None) -> SimModel:
    """A MuJoCo model file of ``robot`` made elsewhere (e.g. MuJoCo Menagerie's TALOS), ready to walk.

    The robot's joints are found in the file by name, in any order.  The file's actuators are
    used as given: each of the robot's joints needs a position servo (``<position>``, or a
    general actuator with a fixed gain and an affine bias of the same form), and one without a
    torque limit gets the URDF's; a file with no actuator at all gets the project's servos
    (:func:`build_sim_model`).  Joints the robot does not have (head, grippers) are held where
    the file's reference posture puts them: by their servo if they have one, else by a joint
    equality.  A foot body with no geom that collides
    gets the description's sole box; each sole gets a site at the sole frame.  A file with no
    floor plane gets the project's floor.  ``contact_time_constant`` (s), if given, sets the
    floor's and the soles' contact softness (``solref``); else the file's stand and the geoms
    added take ``CONTACT_TIME_CONSTANT``.

    Raises
    ------
    Error
        In one line, if the file cannot be read or compiled, or is not a model of ``robot``
        (a joint missing, no free joint first, a servo missing or not a position servo, soles
        more than ``GEOMETRY_TOLERANCE_M`` from where the description puts them).
    """
    path = Path(path)
    if contact_time_constant is not None:
        check_contact_time_constant(contact_time_constant)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:  # MuJoCo's error for files it cannot read
        raise Error(f"{path}: not a MuJoCo model it can compile ({str(exc).splitlines()[0]})") from None
    mj = _compiled(spec, path)
    names = {mj.joint(j).name for j in range(mj.njnt)}
    missing = [name for name in robot.joint_names if name not in names]
    if missing:
        raise Error(f"{path}: no joint {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}: "
                    f"not a model of robot {robot.name} (joints are matched by name)")
    if mj.njnt == 0 or mj.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE or mj.jnt_qposadr[0] != 0:
        raise Error(f"{path}: the robot must float on the model's first joint, a free joint")
    solref = None if contact_time_constant is None else [contact_time_constant, 1.0]
    _add_floor(spec, solref)
    feet = {side: robot.model.names[robot.model.frames[robot.foot_frames[side]].parentJoint] for side in SIDES}
    for side, joint in feet.items():
        _add_sole(spec, robot, side, joint, solref)
    _drive(spec, mj, robot, path)
    mj = _compiled(spec, path)
    if contact_time_constant is None:  # what the floor has: the file's, or the project's if it had none
        floor = np.flatnonzero(mj.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)[0]
        contact_time_constant = float(mj.geom_solref[floor, 0])
    sim = _sim_of(mj, robot, contact_time_constant, feet, str(path))
    sim.spec = spec
    _check_soles(sim, path)
    return sim


def _compiled(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as exc:
        raise Error(f"{path}: not a MuJoCo model it can compile ({str(exc).splitlines()[0]})") from None


def _add_floor(spec: mujoco.MjSpec, solref: list[float] | None) -> None:
    """The project's floor, unless the file has a plane to stand on; ``solref``, if given, on its planes."""
    planes = [g for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    for plane in planes:
        if solref is not None:
            plane.solref = solref
    if not planes:
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                                friction=[FRICTION, 0.005, 0.0001], solref=solref or [CONTACT_TIME_CONSTANT, 1.0])


def _add_sole(spec: mujoco.MjSpec, robot: Robot, side: str, joint: str, solref) -> None:
    """A site at ``side``'s sole frame on the body of ``joint``; the description's sole box
    if that body has no colliding geom; ``solref`` on its colliding geoms if given."""
    body = spec.joint(joint).parent
    frame = robot.model.frames[robot.foot_frames[side]]
    colliding = [g for g in body.geoms if g.contype or g.conaffinity]  # defaults applied, as compiled
    if not colliding:
        sole = robot.sole
        half = [(sole.front + sole.back) / 2, sole.half_width, SOLE_THICKNESS / 2]
        centre = frame.placement * pin.SE3(np.eye(3), np.array([(sole.front - sole.back) / 2, 0.0, half[2]]))
        colliding = [body.add_geom(name=f"cocomopl_{side}_sole", type=mujoco.mjtGeom.mjGEOM_BOX, size=half,
                                   pos=centre.translation, quat=_wxyz(centre.rotation), friction=[FRICTION, 0.005, 0.0001],
                                   contype=1, conaffinity=1, condim=3)]
        solref = solref or [CONTACT_TIME_CONSTANT, 1.0]
    for g in colliding:
        if solref is not None:
            g.solref = solref
    body.add_site(name=f"cocomopl_{side}_sole", pos=frame.placement.translation, quat=_wxyz(frame.placement.rotation),
                  size=[0.01, 0.01, 0.01])


def _wxyz(R: np.ndarray) -> list[float]:
    q = pin.Quaternion(R)
    return [q.w, q.x, q.y, q.z]


def _drive(spec: mujoco.MjSpec, mj: mujoco.MjModel, robot: Robot, path: Path) -> None:
    """Servos for the robot's joints (the project's, if the file has no actuator) and holds
    for the file's other joints."""
    if mj.nu == 0:
        for name, kp, kv, tau, limits in _servos(robot):
            actuator = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            actuator.set_to_position(kp=kp, kv=kv)
            actuator.forcelimited, actuator.forcerange = mujoco.mjtLimited.mjLIMITED_TRUE, [-tau, tau]
            actuator.ctrllimited, actuator.ctrlrange = mujoco.mjtLimited.mjLIMITED_TRUE, list(limits)
        mj = _compiled(spec, path)
    servos = _joint_servos(mj)
    missing = [name for name in robot.joint_names if name not in servos]
    if missing:
        raise Error(f"{path}: joint {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''} has no position servo "
                    "(a file with actuators must drive every joint of the robot)")
    by_id = {actuator.id: actuator for actuator in spec.actuators}
    for name, tau in zip(robot.joint_names, robot.tau_max):
        if not mj.actuator_forcelimited[servos[name]]:  # a servo without a torque limit gets the URDF's
            actuator = by_id[servos[name]]
            actuator.forcelimited, actuator.forcerange = mujoco.mjtLimited.mjLIMITED_TRUE, [-tau, tau]
    others = {mj.joint(j).name for j in range(1, mj.njnt)} - set(robot.joint_names) - set(servos)
    for name in sorted(others):  # no servo: held at the reference posture by a joint equality
        spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=name, objtype=mujoco.mjtObj.mjOBJ_JOINT)


def _joint_servos(mj: mujoco.MjModel) -> dict[str, int]:
    """Joint name -> id of the position servo that drives it (gain kp, bias -kp q - kv qdot)."""
    out = {}
    for a in range(mj.nu):
        if mj.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            continue
        kp = mj.actuator_gainprm[a, 0]
        position = (mj.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED and mj.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
                    and kp > 0 and np.isclose(mj.actuator_biasprm[a, 1], -kp) and mj.actuator_biasprm[a, 0] == 0)
        if position and mj.actuator_gear[a, 0] == 1:
            out[mj.joint(mj.actuator_trnid[a, 0]).name] = a
    return out


def _sim_of(mj: mujoco.MjModel, robot: Robot, contact_time_constant: float, feet: dict[str, str], source: str) -> SimModel:
    servos = _joint_servos(mj)
    joint_id = {name: mj.joint(name).id for name in robot.joint_names}
    held = np.array(sorted(a for name, a in servos.items() if name not in joint_id), dtype=int)
    sole_geoms = {}
    for side, joint in feet.items():
        body = mj.jnt_bodyid[mj.joint(joint).id]
        sole_geoms[side] = tuple(int(g) for g in np.flatnonzero(mj.geom_bodyid == body)
                                 if mj.geom_contype[g] or mj.geom_conaffinity[g])
    return SimModel(
        mj=mj,
        robot=robot,
        sole_geoms=sole_geoms,
        sole_sites={side: mj.site(f"cocomopl_{side}_sole").id for side in SIDES},
        base_body=int(mj.jnt_bodyid[0]),
        contact_time_constant=contact_time_constant,
        qpos_index=np.array([mj.jnt_qposadr[joint_id[n]] for n in robot.joint_names]),
        dof_index=np.array([mj.jnt_dofadr[joint_id[n]] for n in robot.joint_names]),
        actuators=np.array([servos[n] for n in robot.joint_names]),
        held_actuators=held,
        held_commands=mj.qpos0[mj.jnt_qposadr[mj.actuator_trnid[held, 0]]] if len(held) else np.zeros(0),
        source=source,
    )


def _check_soles(sim: SimModel, path: Path) -> None:
    """Refuse a file whose soles are not where the description puts them, at its reference posture."""
    robot = sim.robot
    data = mujoco.MjData(sim.mj)
    data.qpos[:] = sim.qpos(robot.q_ref)
    mujoco.mj_kinematics(sim.mj, data)
    pdata = robot.model.createData()
    pin.framesForwardKinematics(robot.model, pdata, robot.q_ref)
    off = max(np.linalg.norm(data.site_xpos[sim.sole_sites[s]] - pdata.oMf[robot.foot_frames[s]].translation) for s in SIDES)
    if off > GEOMETRY_TOLERANCE_M:
        raise Error(f"{path}: its feet are {1000 * off:.0f} mm from where robot {robot.name}'s description puts them: "
                    "not a model of this robot, or its bodies' frames differ from the URDF's links")
