"""The robot description, the mirror map, and the dynamic symmetry it relies on."""

import numpy as np
import pinocchio as pin
import pytest

from cocomopl import Error
from cocomopl.robot import (
    Robot,
    mirror_configuration,
    mirror_joints,
    mirror_state,
    mirror_velocity,
    mirror_wrenches,
)


def random_configuration(robot: Robot, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = robot.q_ref.copy()
    q[:3] = rng.normal(0, 0.3, 3)
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(*rng.normal(0, 0.3, 3))).coeffs()
    q[7:] = np.clip(q[7:] + rng.normal(0, 0.3, robot.nu), robot.q_lower, robot.q_upper)
    return q


def test_talos_has_hrp2_structure(robot):
    assert robot.nu == 30
    assert robot.model.nv == 36
    assert robot.model.nq == 37
    assert "gripper_left_joint" not in robot.joint_names
    assert np.all(robot.tau_max > 0) and np.all(robot.v_max > 0)
    assert np.all(robot.q_lower < robot.q_upper)


def test_mirror_is_an_exact_involution(robot):
    rng = np.random.default_rng(0)
    q = random_configuration(robot, 1)
    v = rng.normal(size=robot.model.nv)
    x = np.concatenate([q, v])
    tau = rng.normal(size=(5, robot.nu))
    wrenches = rng.normal(size=(5, 2, 6))
    assert np.array_equal(mirror_state(robot, mirror_state(robot, x)), x)
    assert np.array_equal(mirror_joints(robot, mirror_joints(robot, tau)), tau)
    assert np.array_equal(mirror_wrenches(mirror_wrenches(wrenches)), wrenches)


@pytest.mark.parametrize("name", ["talos", "romeo"])
def test_mirror_map_reflects_the_kinematics(name):
    """Every joint of a mirrored configuration sits where its partner's reflection is."""
    robot = Robot(name)
    model = robot.model
    q = random_configuration(robot, 2)
    d, dm = model.createData(), model.createData()
    pin.forwardKinematics(model, d, q)
    pin.forwardKinematics(model, dm, mirror_configuration(robot, q))
    P = np.diag([1.0, -1.0, 1.0])
    for jid in range(1, model.njoints):
        partner = model.getJointId(robot.partner_name(model.names[jid]))
        assert np.allclose(P @ d.oMi[jid].translation, dm.oMi[partner].translation, atol=1e-9)


@pytest.mark.parametrize("name", ["talos", "romeo"])
def test_mirrored_dynamics_agree(name):
    """Inverse dynamics of a mirrored (q, v, a) is the mirrored generalized force."""
    robot = Robot(name)
    rng = np.random.default_rng(3)
    q = random_configuration(robot, 4)
    v, a = rng.normal(size=robot.model.nv), rng.normal(size=robot.model.nv)
    d = robot.model.createData()
    tau = pin.rnea(robot.model, d, q, v, a).copy()
    tau_m = pin.rnea(robot.model, d, mirror_configuration(robot, q), mirror_velocity(robot, v), mirror_velocity(robot, a))
    assert np.allclose(mirror_velocity(robot, tau), tau_m, atol=1e-9)


def test_second_robot_from_description_file(tmp_path):
    """Any URDF humanoid through a small JSON description: here Romeo's URDF, by path."""
    import json

    import example_robot_data

    from cocomopl.robot.description import DESCRIPTIONS_DIR

    desc = json.loads((DESCRIPTIONS_DIR / "romeo.json").read_text())
    desc.pop("example_robot_data")
    robots_dir = example_robot_data.getModelPath("romeo_description/urdf/romeo.urdf")
    desc["urdf"] = f"{robots_dir}/romeo_description/urdf/romeo.urdf"
    path = tmp_path / "my_romeo.json"
    path.write_text(json.dumps(desc))
    robot = Robot(str(path))
    assert robot.nu == 31
    assert robot.joint_names[robot.mirror_perm[0]] == "RHipYaw"
    assert robot.mirror_sign[0] == -1.0  # a yaw joint flips sign


def test_unknown_robot_is_a_clear_error():
    with pytest.raises(Error, match="unknown robot"):
        Robot("no_such_robot")


def test_missing_urdf_is_a_clear_error(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"name": "x", "urdf": "missing.urdf", "feet": {}, "sole": {}, "pelvis": "b"}')
    with pytest.raises(Error, match="URDF not found"):
        Robot(str(path))


def test_unreadable_description_is_a_clear_error(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(Error, match="cannot read robot description"):
        Robot(str(path))
