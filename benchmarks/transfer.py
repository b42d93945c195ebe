"""Do the paper's walks survive a MuJoCo model of the robot written like MuJoCo Menagerie's?

A look-alike is the project's own model rewritten with the conventions of the robot's
Menagerie file (``--robot``, :data:`LOOK_ALIKES`):

* **TALOS** (Menagerie's ``pal_talos`` with its position servos): kp 1000 N m/rad at the hips
  and knees and 10 000 at the ankles, 100 at the arms, 2000 and 500 at the torso, 200 and 1000
  at the head, none damped; joint damping 1 N m s/rad at the arms and torso, 0.5 at the head,
  none at the legs; no armature (the project's model reflects the rotors' 0.1 kg m² from the
  SRDF); each joint's friction loss drawn in 1-2 N m (``--seed``), every link 4 % heavier; the
  project's box soles.
* **G1** (Menagerie's ``unitree_g1``, whose joints are driven by torque motors): the low-gain PD
  a G1's joints run with, hips kp 100 and kv 2, knees 150 and 4, ankles 40 and 2, every other
  joint 100 and 2 (an assumption); Menagerie's joint damping 0.5 N m s/rad, armature 0.01 kg m²
  and friction loss 0.1 N m at every joint; its feet, four 1 mm spheres at the corners of a
  190 x 40 mm footprint (6 cm behind the ankle to 13 cm ahead) in place of the project's
  170 x 50 mm box soles; every link 4 % heavier, as TALOS's.

Each setting is looked up for a joint by its name, then its leg role (``hip``, ``knee``,
``ankle``), then its group (``torso``, ``arms``), then ``all``.

It walks M_gen, M_opt and the Kajita baseline of ``cocomopl reproduce --robot ROBOT`` on it
(``--sim-model``) with the stabilizer, under three servo settings:

* ``as_written``: the file's servos as they are;
* ``as_written_feedforward``: those and torque feedforward (``--feedforward``);
* ``damped``: kv = kp / 50 (``--kv-time-s 0.02``);
* ``damped_feedforward``: that and torque feedforward (``--feedforward``);
* ``project_servos_feedforward``: the look-alike with the project's own servos in place of the
  file's (:func:`~cocomopl.sim.mujoco_model.servo_stiffness`, kv = kp / 50) and torque
  feedforward: what the file's servos alone change.

It reports per walk and setting whether the robot fell, the peak vertical force over weight
and the mean torque; the contacts are 10 ms (``--contact-time-constant-s 0.01``).

    python benchmarks/transfer.py [--robot talos] [--seed 0] [--out menagerie_like.xml] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

# per servo setting: kv time (s) by joint key, torque feedforward, and the file's servos (False:
# the project's own)
SETTINGS = {"as_written": ({}, False, True), "as_written_feedforward": ({}, True, True),
            "damped": ({"all": 0.02}, False, True), "damped_feedforward": ({"all": 0.02}, True, True),
            "project_servos_feedforward": ({}, True, False)}


@dataclass(frozen=True)
class LookAlike:
    """A Menagerie file's conventions, written into the project's own model.  Per-joint
    settings are dicts keyed by joint name, leg role, group or ``all`` (:func:`setting_of`).

    Attributes
    ----------
    kp : servo stiffness, N m/rad
    kv : servo damping, N m s/rad
    friction_loss_nm : each joint's friction loss, drawn uniformly in (low, high)
    damping : joint viscous damping, N m s/rad; a joint it does not name keeps the project's
    armature : each joint's armature, kg m²; None: the project's
    mass_factor : every link's mass and inertia times this
    foot_points : corners (x, y) of a footprint of point contacts in the sole frame, m; None:
        the project's box soles
    """

    kp: dict
    kv: dict
    friction_loss_nm: tuple[float, float]
    damping: dict = field(default_factory=dict)
    armature: float | None = None
    mass_factor: float = 1.04
    foot_points: tuple[tuple[float, float], ...] | None = None


LOOK_ALIKES = {
    "talos": LookAlike(kp={"hip": 1000.0, "knee": 1000.0, "ankle": 10000.0, "arms": 100.0, "torso_1_joint": 2000.0,
                           "torso_2_joint": 500.0, "head_1_joint": 200.0, "head_2_joint": 1000.0},
                       kv={"all": 0.0}, friction_loss_nm=(1.0, 2.0),
                       damping={"arms": 1.0, "torso": 1.0, "head_1_joint": 0.5, "head_2_joint": 0.5}, armature=0.0),
    "g1": LookAlike(kp={"hip": 100.0, "knee": 150.0, "ankle": 40.0, "all": 100.0},
                    kv={"hip": 2.0, "knee": 4.0, "ankle": 2.0, "all": 2.0}, friction_loss_nm=(0.1, 0.1),
                    damping={"all": 0.5}, armature=0.01,
                    foot_points=((-0.06, 0.02), (-0.06, -0.02), (0.13, 0.02), (0.13, -0.02))),
}
FOOT_POINT_RADIUS_M = 0.001


def setting_of(values: dict, *keys: str) -> float | None:
    """The first of ``values`` named by ``keys`` (a joint's name, role and group), or its
    ``all``; None if none is."""
    return next((values[k] for k in (*keys, "all") if k in values), None)


def leg_role_of(robot) -> dict[str, str]:
    """Joint name -> ``hip``, ``knee`` or ``ankle`` for the legs' joints
    (:meth:`~cocomopl.robot.Robot.leg_joint_roles` without the axis)."""
    return {robot.joint_names[j]: role.split("_")[0] for j, role in robot.leg_joint_roles().items()}


def menagerie_like(robot, path: Path, seed: int, *, servos: bool = True) -> Path:
    """The project's own model rewritten with the conventions of ``robot``'s Menagerie file;
    without ``servos``, all but its servos (the project's are kept)."""
    from cocomopl.motion_file import atomic_path
    from cocomopl.sim.mujoco_model import mjcf

    look = LOOK_ALIKES[robot.name]
    rng = np.random.default_rng(seed)
    spec = mujoco.MjSpec.from_string(mjcf(robot, visuals=False))
    roles = leg_role_of(robot)
    groups = {robot.joint_names[i]: group for group, joints in robot.joint_groups().items() for i in joints}

    def keys(name: str) -> tuple[str, ...]:
        return (name, roles.get(name, ""), groups.get(name, ""))

    for actuator in spec.actuators if servos else ():
        kp, kv = setting_of(look.kp, *keys(actuator.target)), setting_of(look.kv, *keys(actuator.target))
        actuator.gainprm[0], actuator.biasprm[1], actuator.biasprm[2] = kp, -kp, -kv
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.frictionloss = float(rng.uniform(*look.friction_loss_nm))
            damping = setting_of(look.damping, *keys(joint.name))
            if damping is not None:
                joint.damping = [damping, 0.0, 0.0]  # MjSpec holds a polynomial: its first term is viscous
            if look.armature is not None:
                joint.armature = look.armature
    for body in spec.bodies:
        body.mass *= look.mass_factor
        body.fullinertia = look.mass_factor * np.asarray(body.fullinertia)
    if look.foot_points is not None:
        _point_feet(spec, robot, look.foot_points)
    with atomic_path(path, ".xml") as written:  # no half-written model file is left behind
        written.write_text(spec.to_xml())
    return path


def _point_feet(spec: mujoco.MjSpec, robot, corners) -> None:
    """Each sole's colliding geoms replaced by spheres at ``corners`` (x, y) of the sole frame,
    resting on the sole's plane."""
    for side in robot.foot_frames:
        body = spec.joint(robot.joint_names[robot.leg_chain(side)[-1]]).parent
        sole = next(site for site in body.sites if site.name == f"{side}_sole")
        colliding = [g for g in body.geoms if g.contype or g.conaffinity]
        template = colliding[0]
        for geom in colliding:
            spec.delete(geom)
        for k, (x, y) in enumerate(corners):
            point = np.asarray(sole.pos) + pin.Quaternion(*sole.quat).toRotationMatrix() @ np.array([x, y, FOOT_POINT_RADIUS_M])
            body.add_geom(name=f"{side}_foot_point_{k}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[FOOT_POINT_RADIUS_M, 0, 0],
                          pos=point, contype=template.contype, conaffinity=template.conaffinity, condim=template.condim,
                          friction=template.friction, solref=template.solref)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="talos", choices=sorted(LOOK_ALIKES), help="whose look-alike to write and walk")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", help="also keep the model file written (default: a temporary one)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    sys.path.insert(0, str(Path(__file__).parent))
    from robustness import prepare_walks

    from cocomopl.analysis.metrics import summary
    from cocomopl.errors import Error
    from cocomopl.motion_file import check_output
    from cocomopl.pipeline import SimSettings, rollout_of
    from cocomopl.robot import Robot
    from cocomopl.sim.servos import ServoSettings

    try:  # a wrong --out is refused before the walks are made
        if args.out is not None:
            check_output(args.out)
    except Error as exc:
        parser.error(str(exc))
    walks = prepare_walks(args.robot)
    robot = Robot(walks["M_gen"].robot)
    with tempfile.TemporaryDirectory() as folder:
        try:
            path = menagerie_like(robot, Path(args.out or Path(folder) / "menagerie_like.xml"), args.seed)
        except (Error, OSError) as exc:
            parser.error(f"cannot write {args.out}: {exc}")
        files = {True: path, False: menagerie_like(robot, Path(folder) / "project_servos.xml", args.seed, servos=False)}
        out = {"robot": robot.name, "seed": args.seed, "model": asdict(LOOK_ALIKES[robot.name]), "walks": {}}
        for name, motion in walks.items():
            for setting, (kv_time, feedforward, file_servos) in SETTINGS.items():
                settings = SimSettings(contact_time_constant=0.01, feedforward=feedforward, sim_model=files[file_servos],
                                       servos=ServoSettings(kv_time_s=kv_time))
                rollout = rollout_of(robot, motion, settings)
                figures = summary(robot, rollout.measured, motion)
                out["walks"].setdefault(name, {})[setting] = {
                    "fell": rollout.fell, "fall_time_s": rollout.fall_time,
                    "peak_force_over_weight": figures.peak_force_over_weight, "mean_torque": figures.mean_torque}
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{'walk':8s} {'setting':24s} {'fell':>5s} {'peak F/W':>8s}")
    for name, by_setting in out["walks"].items():
        for setting, row in by_setting.items():
            print(f"{name:8s} {setting:24s} {row['fell']!s:>5s} {row['peak_force_over_weight']:8.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
