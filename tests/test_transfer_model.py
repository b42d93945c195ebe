"""``benchmarks/transfer.py`` writes a robot's Menagerie-like model that the project reads
as a model file made elsewhere (``--sim-model``): G1's with Menagerie's point feet, joint
damping, armature and friction loss, its low-gain servos per leg role and heavier links."""

import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from cocomopl.robot import Robot
from cocomopl.sim.mujoco_model import build_sim_model, load_sim_model

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))
from transfer import LOOK_ALIKES, leg_role_of, menagerie_like, setting_of


@pytest.fixture(scope="module")
def g1() -> Robot:
    return Robot("g1")


def test_g1_look_alike_has_menageries_feet_joints_servos_and_masses(g1, tmp_path):
    look = LOOK_ALIKES["g1"]
    own = build_sim_model(g1, visuals=False)
    sim = load_sim_model(g1, menagerie_like(g1, tmp_path / "g1_like.xml", seed=0), 0.01)
    mj = sim.mj
    for side in ("left", "right"):
        geoms = sim.sole_geoms[side]
        assert len(geoms) == len(look.foot_points)
        assert all(mj.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE for g in geoms)
        data = mujoco.MjData(mj)
        data.qpos[:] = sim.qpos(g1.q_ref)
        mujoco.mj_kinematics(mj, data)
        sole = data.site_xpos[sim.sole_sites[side]]
        R = data.site_xmat[sim.sole_sites[side]].reshape(3, 3)
        corners = sorted(tuple(np.round(R.T @ (data.geom_xpos[g] - sole), 6)[:2]) for g in geoms)
        assert np.allclose(corners, sorted(look.foot_points))
        lowest = min(data.geom_xpos[g][2] - mj.geom_size[g][0] for g in geoms)
        assert abs(lowest - sole[2]) < 1e-9  # the points rest on the sole's plane, as the box did
    roles = leg_role_of(g1)
    assert sorted(set(roles.values())) == ["ankle", "hip", "knee"]
    assert sum(role == "knee" for role in roles.values()) == 2
    kp, kv = sim.servo_gains()
    for i, name in enumerate(g1.joint_names):
        assert (kp[i], kv[i]) == (setting_of(look.kp, name, roles.get(name, "")), setting_of(look.kv, name, roles.get(name, "")))
    hinges = sim.dof_index
    assert np.allclose(mj.dof_damping[hinges], 0.5) and np.allclose(mj.dof_armature[hinges], look.armature)
    assert np.allclose(mj.dof_frictionloss[hinges], look.friction_loss_nm[0])
    assert mj.body_mass.sum() == pytest.approx(look.mass_factor * own.mj.body_mass.sum())


def test_taloss_look_alike_has_menageries_servos_no_armature_and_the_projects_box_soles(robot, tmp_path):
    sim = load_sim_model(robot, menagerie_like(robot, tmp_path / "talos_like.xml", seed=0), 0.01)
    kp, kv = sim.servo_gains()
    by_name = dict(zip(robot.joint_names, kp))
    ankles = [roles[k] for roles in robot.leg_roles().values() for k in ("ankle_pitch", "ankle_roll")]
    knees = [roles["knee"] for roles in robot.leg_roles().values()]
    assert set(kp[ankles]) == {10000.0} and set(kp[knees]) == {1000.0} and not kv.any()
    assert set(kp[robot.joint_groups()["arms"]]) == {100.0} and by_name["torso_1_joint"] == 2000.0
    assert all(sim.mj.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX for g in sim.sole_geoms["left"])
    assert not sim.mj.dof_armature[sim.dof_index].any()
    legs = sim.dof_index[robot.leg_joint_indices()]
    assert not sim.mj.dof_damping[legs].any() and set(sim.mj.dof_damping[sim.dof_index[robot.joint_groups()["arms"]]]) == {1.0}
    friction = sim.mj.dof_frictionloss[sim.dof_index]
    assert friction.min() >= 1.0 and friction.max() <= 2.0 and len(set(friction)) == len(friction)


def test_a_setting_is_looked_up_by_name_then_role_then_group_then_all():
    values = {"knee_joint": 1.0, "knee": 2.0, "arms": 3.0, "all": 4.0}
    assert setting_of(values, "knee_joint", "knee", "") == 1.0
    assert setting_of(values, "other_knee", "knee", "") == 2.0
    assert setting_of(values, "elbow", "", "arms") == 3.0
    assert setting_of(values, "neck", "", "torso") == 4.0
    assert setting_of({"arms": 3.0}, "neck", "", "torso") is None


def test_an_out_that_cannot_be_written_is_refused_before_the_walks(tmp_path):
    import subprocess

    folder = tmp_path / "a_folder"
    folder.mkdir()
    result = subprocess.run([sys.executable, str(Path(__file__).parents[1] / "benchmarks" / "transfer.py"),
                             "--robot", "g1", "--out", str(folder)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and result.stdout == ""
    assert "Traceback" not in result.stderr
    assert result.stderr.strip().splitlines()[-1].startswith(f"transfer.py: error: {folder} is a directory")
    assert list(folder.iterdir()) == []


def test_without_the_files_servos_the_look_alike_keeps_the_projects_and_the_rest_of_menageries(g1, tmp_path):
    own = build_sim_model(g1, visuals=False)
    sim = load_sim_model(g1, menagerie_like(g1, tmp_path / "g1_own_servos.xml", seed=0, servos=False), 0.01)
    kp, kv = sim.servo_gains()
    own_kp, own_kv = own.servo_gains()
    assert np.array_equal(kp, own_kp) and np.array_equal(kv, own_kv)
    assert np.allclose(sim.mj.dof_damping[sim.dof_index], 0.5)
    assert len(sim.sole_geoms["left"]) == len(LOOK_ALIKES["g1"].foot_points)
