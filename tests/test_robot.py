"""The robot description, the mirror map, and the dynamic symmetry it relies on."""

import re
from pathlib import Path

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
from cocomopl.robot.scale import REFERENCE_OMEGA, Scale


@pytest.fixture(scope="module")
def g1() -> Robot:
    return Robot("g1")


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


def assert_mirror_reflects_the_kinematics(robot: Robot, seed: int) -> None:
    """Every joint of a mirrored configuration sits where its partner's reflection is."""
    model = robot.model
    q = random_configuration(robot, seed)
    d, dm = model.createData(), model.createData()
    pin.forwardKinematics(model, d, q)
    pin.forwardKinematics(model, dm, mirror_configuration(robot, q))
    P = np.diag([1.0, -1.0, 1.0])
    for jid in range(1, model.njoints):
        assert np.allclose(P @ d.oMi[jid].translation, dm.oMi[robot.joint_partner[jid]].translation, atol=1e-9)


def assert_mirrored_dynamics_agree(robot: Robot, seed: int) -> None:
    """Inverse dynamics of a mirrored (q, v, a) is the mirrored generalized force."""
    rng = np.random.default_rng(seed)
    q = random_configuration(robot, seed + 1)
    v, a = rng.normal(size=robot.model.nv), rng.normal(size=robot.model.nv)
    d = robot.model.createData()
    tau = pin.rnea(robot.model, d, q, v, a).copy()
    tau_m = pin.rnea(robot.model, d, mirror_configuration(robot, q), mirror_velocity(robot, v), mirror_velocity(robot, a))
    assert np.allclose(mirror_velocity(robot, tau), tau_m, atol=1e-9)


@pytest.mark.parametrize("name", ["talos", "romeo", "g1"])
def test_mirror_map_reflects_the_kinematics(name):
    assert_mirror_reflects_the_kinematics(Robot(name), 2)


@pytest.mark.parametrize("name", ["talos", "romeo", "g1"])
def test_mirrored_dynamics_agree(name):
    assert_mirrored_dynamics_agree(Robot(name), 3)


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
    path.write_text('{"name": "x", "urdf": "missing.urdf", "pelvis": "b"}')
    with pytest.raises(Error, match="URDF not found"):
        Robot(str(path))


def test_unreadable_description_is_a_clear_error(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(Error, match="cannot read robot description"):
        Robot(str(path))


def talos_from_urdf(tmp_path, edit=lambda urdf: urdf, *, relative: bool = False) -> str:
    """TALOS's description written for its URDF and SRDF copied into ``tmp_path``, the URDF
    first passed through ``edit`` (its text); with ``relative`` the files are named relative
    to the description's folder."""
    import json
    import shutil

    from example_robot_data.robots_loader import TalosLoader

    from cocomopl.robot.description import DESCRIPTIONS_DIR

    loader = TalosLoader()
    (tmp_path / "talos.urdf").write_text(edit(Path(loader.df_path).read_text()))
    shutil.copy(loader.srdf_path, tmp_path / "talos.srdf")
    desc = json.loads((DESCRIPTIONS_DIR / "talos.json").read_text())
    desc.pop("example_robot_data")
    desc["urdf"], desc["srdf"] = ("talos.urdf", "talos.srdf") if relative else (
        str(tmp_path / "talos.urdf"), str(tmp_path / "talos.srdf"))
    path = tmp_path / "mytalos.json"
    path.write_text(json.dumps(desc))
    return str(path)


def testmirror_partners_are_found_by_structure_not_by_name(robot):
    """Each left joint's partner is its right namesake, each joint on the sagittal plane its own."""
    names = robot.model.names
    for jid in range(2, robot.model.njoints):
        partner = names[robot.joint_partner[jid]]
        expected = names[jid].replace("left", "@").replace("right", "left").replace("@", "right")
        assert partner == expected
    assert robot.placement_asymmetry == 0.0  # TALOS's placements mirror to 3e-13 m: left as they are


def test_joint_groups_follow_the_kinematic_chains():
    """Arms are the joints off the sagittal plane that carry no sole, whatever their names."""
    for name, arms, torso in (("talos", "arm_", ("torso", "head")), ("romeo", ("Shoulder", "Elbow", "Wrist"), ("Trunk", "Neck", "Head"))):
        robot = Robot(name)
        groups = {g: [robot.joint_names[i] for i in idx] for g, idx in robot.joint_groups().items()}
        assert groups["arms"] and all(any(a in n for a in np.atleast_1d(arms)) for n in groups["arms"])
        assert groups["torso"] and all(n.startswith(torso) for n in groups["torso"])
        assert sorted(n for names in groups.values() for n in names) == sorted(robot.joint_names)


def test_an_axis_written_negative_is_mirrored_with_its_sign(tmp_path, robot):
    """A knee turning about -y (not one of Pinocchio's X/Y/Z joints) loads; its partner turns
    the opposite way, and the mirror map still reflects the kinematics and the dynamics."""
    import re

    def flip_left_knee(urdf: str) -> str:
        joint = re.search(r'<joint name="leg_left_4_joint".*?</joint>', urdf, re.DOTALL).group(0)
        return urdf.replace(joint, joint.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 -1 0"/>'))

    flipped = Robot(talos_from_urdf(tmp_path, flip_left_knee))
    knee = flipped.joint_names.index("leg_left_4_joint")
    assert flipped.model.joints[knee + 2].shortname() == "JointModelRevoluteUnaligned"
    assert flipped.mirror_sign[knee] == -robot.mirror_sign[knee]
    assert flipped.leg_roles() == robot.leg_roles()
    assert_mirror_reflects_the_kinematics(flipped, 5)


def test_a_relative_srdf_is_read_beside_the_description(tmp_path, monkeypatch, robot):
    (tmp_path / "elsewhere").mkdir()
    path = talos_from_urdf(tmp_path, relative=True)
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert np.array_equal(Robot(path).q_ref, robot.q_ref)


def test_a_joint_with_no_mirror_image_is_refused_naming_it(tmp_path):
    import re

    def shift_left_elbow(urdf: str) -> str:
        joint = re.search(r'<joint name="arm_left_4_joint".*?</joint>', urdf, re.DOTALL).group(0)
        origin = re.search(r'xyz="([^"]*)"', joint)
        x, y, z = map(float, origin.group(1).split())
        return urdf.replace(joint, joint.replace(origin.group(0), f'xyz="{x + 0.005} {y} {z}"'))

    with pytest.raises(Error, match=r"'arm_left_4_joint' has no mirror image: .* 'arm_right_4_joint', is 5 mm from it"):
        Robot(talos_from_urdf(tmp_path, shift_left_elbow))


def test_placements_a_few_micrometres_apart_are_made_mirror_images():
    """The Unitree G1's shoulders are 10 um from their partners' reflections: afterwards every
    pair mirrors to round-off, each joint moved halfway."""
    import example_robot_data

    from cocomopl.robot.description import joint_axis, mirror_partners, symmetrize_placements

    model = example_robot_data.load("g1").model
    partner = mirror_partners(model, np.array([joint_axis(model, j) for j in range(2, model.njoints)]), "g1")
    assert symmetrize_placements(model, partner) == pytest.approx(5e-6, rel=1e-6)
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    P = np.diag([1.0, -1.0, 1.0])
    for jid in range(2, model.njoints):
        mirrored = data.oMi[partner[jid]]
        assert np.allclose(P @ mirrored.translation, data.oMi[jid].translation, atol=1e-12, rtol=0)
        assert np.allclose(P @ mirrored.rotation @ P, data.oMi[jid].rotation, atol=1e-12, rtol=0)


def test_the_g1_stands_on_soles_derived_from_its_collision_spheres(g1):
    """The G1's description names no soles and no posture: its soles are found 35 mm under
    the ankle rolls (its four contact spheres' bottoms) and it stands on them, knees bent."""
    robot = g1
    assert (robot.sole.front, robot.sole.back, robot.sole.half_width) == pytest.approx((0.12, 0.05, 0.025), abs=1e-12)
    for side, frame in robot.foot_frames.items():
        sole = robot.model.frames[frame]
        assert robot.model.names[sole.parentJoint] == f"{side}_ankle_roll_joint"
        assert np.allclose(sole.placement.translation, [0.0, 0.0, -0.035], atol=1e-12)
        standing = robot.frame_placement(robot.q_ref, frame)
        assert abs(standing.translation[2]) < 1e-5 and np.allclose(standing.rotation, np.eye(3), atol=1e-5)
    assert all(0.3 < robot.q_ref[7 + roles["knee"]] < 1.5 for roles in robot.leg_roles().values())
    neutral = pin.neutral(robot.model)
    height = neutral[2] - robot.frame_placement(neutral, robot.foot_frames["left"]).translation[2]
    assert robot.q_ref[2] == pytest.approx(0.94 * height, abs=1e-9)


def test_soles_derived_from_talos_s_collision_mesh_lie_within_its_measured_soles(tmp_path, robot):
    import json

    from cocomopl.robot.description import DESCRIPTIONS_DIR

    desc = json.loads((DESCRIPTIONS_DIR / "talos.json").read_text())
    del desc["feet"], desc["sole"]
    (tmp_path / "talos.json").write_text(json.dumps(desc))
    derived = Robot(str(tmp_path / "talos.json"))
    given = robot.model.frames[robot.foot_frames["left"]].placement.translation
    found = derived.model.frames[derived.foot_frames["left"]].placement.translation
    assert np.allclose(found, given, atol=1e-3)  # the sole plane 107 mm under the ankle
    for size in ("front", "back", "half_width"):
        assert 0.85 * getattr(robot.sole, size) < getattr(derived.sole, size) <= getattr(robot.sole, size)


def test_a_pelvis_height_above_straight_legs_is_one_line(tmp_path):
    import json

    (tmp_path / "tall.json").write_text(json.dumps({"name": "g1", "example_robot_data": "g1", "pelvis": "pelvis",
                                                     "pelvis_height": 2.0}))
    with pytest.raises(Error, match=r"pelvis_height 2 m is not within \(0, 0\.792\] m"):
        Robot(str(tmp_path / "tall.json"))


@pytest.mark.slow  # runs the command line or a second process
def test_a_file_made_for_a_robot_of_ones_own_reads_back_without_its_description(tmp_path):
    """A motion file records the description of a robot that is not bundled, so any reader
    rebuilds the robot from the file alone; a bundled robot's files name it only."""
    import json
    import subprocess
    import sys

    from cocomopl.motion_file import write_motions

    from conftest import synthetic

    description = tmp_path / "mybot.json"
    description.write_text(json.dumps({"name": "mybot", "example_robot_data": "g1", "pelvis": "pelvis"}))
    mybot = Robot(str(description))
    write_motions(tmp_path / "mybot.h5", {"stand": synthetic(mybot, [0.0, 0.1])}, {"robot": "mybot"})
    description.unlink()
    read_back = ("from cocomopl.motion_file import read_motions; import sys; m, a = read_motions(sys.argv[1]); "
                 "print(m['stand'].robot, len(m['stand'].joint_names))")
    result = subprocess.run([sys.executable, "-c", read_back, str(tmp_path / "mybot.h5")], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["mybot", "29"]

    talos = Robot("talos")
    write_motions(tmp_path / "talos.h5", {"stand": synthetic(talos, [0.0, 0.1])}, {"robot": "talos"})
    import h5py

    with h5py.File(tmp_path / "talos.h5") as f:
        assert "robot_description" not in f.attrs
    with h5py.File(tmp_path / "mybot.h5") as f:
        assert json.loads(f.attrs["robot_description"])["example_robot_data"] == "g1"


@pytest.mark.slow  # runs a second process
def test_a_changed_copy_of_a_bundled_description_under_its_name_is_recorded_in_files(tmp_path):
    """A bundled robot's description copied with another default and the same name (TALOS
    with its own velocity weight) is another model of that robot: its files record the
    description and read back without it, where the bundled description would be refused."""
    import json
    import subprocess
    import sys

    from cocomopl.robot.description import read_description

    copied = tmp_path / "talos.json"
    copied.write_text(json.dumps({**read_description("talos"), "defaults": {"ocp": {"w_upper_velocity": 0.5}}}))
    make = ("from cocomopl.motion_file import write_motions; from cocomopl.robot import Robot; import sys; "
            "sys.path.insert(0, sys.argv[3]); from conftest import synthetic; r = Robot(sys.argv[1]); "
            "write_motions(sys.argv[2], {'stand': synthetic(r, [0.0, 0.1])}, {'robot': 'talos'})")
    tests = str(Path(__file__).parent)
    made = subprocess.run([sys.executable, "-c", make, str(copied), str(tmp_path / "copy.h5"), tests],
                          capture_output=True, text=True)
    assert made.returncode == 0, made.stderr
    read_back = ("from cocomopl.motion_file import read_motions; import sys; m, a = read_motions(sys.argv[1]); "
                 "print(m['stand'].robot)")
    result = subprocess.run([sys.executable, "-c", read_back, str(tmp_path / "copy.h5")], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["talos"]
    import h5py

    with h5py.File(tmp_path / "copy.h5") as f:
        assert json.loads(f.attrs["robot_description"])["defaults"] == {"ocp": {"w_upper_velocity": 0.5}}


@pytest.mark.slow  # runs the command line or a second process
def test_robot_check_prints_what_is_derived_and_draws_the_posture(tmp_path):
    import json

    from conftest import assert_one_line_error, run_cli

    result = run_cli("robot", "check", "g1", "--png", str(tmp_path / "g1.png"), "--json")
    assert result.returncode == 0, result.stderr
    check = json.loads(result.stdout)
    assert check["robot"] == "g1" and check["actuated_joints"] == 29
    assert check["groups"]["torso"] == ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"]
    assert ["left_knee_joint", "right_knee_joint"] in check["mirror_pairs"]
    assert check["soles"]["source"] == "derived" and check["soles"]["half_width_m"] == pytest.approx(0.025)
    assert check["posture"]["pelvis_height_m"] == pytest.approx(0.94 * check["posture"]["straight_pelvis_height_m"])
    assert (tmp_path / "g1.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (tmp_path / "bad.json").write_text('{"name": "bad", "example_robot_data": "g1"}')
    assert_one_line_error(run_cli("robot", "check", str(tmp_path / "bad.json")), "lacks the key 'pelvis'")
    assert_one_line_error(run_cli("robot", "check", "no_such_robot"), "unknown robot 'no_such_robot'")


def test_alexander_loads_from_a_description_written_from_the_docs(tmp_path):
    """Alexander's URDF has no collision geometry and no sole frames: three keys, its soles
    found from its visual meshes and its posture derived, its mirror exact."""
    import json

    (tmp_path / "alexander.json").write_text(json.dumps(
        {"name": "alexander", "example_robot_data": "alexander", "pelvis": "PELVIS_LINK"}))
    robot = Robot(str(tmp_path / "alexander.json"))
    assert robot.nu == 13 and [robot.joint_names[i] for i in robot.joint_groups()["torso"]] == ["SPINE_Z"]
    assert 0.1 < robot.sole.front < 0.2 and 0.02 < robot.sole.back < 0.1 and 0.02 < robot.sole.half_width < 0.08
    for frame in robot.foot_frames.values():
        assert abs(robot.frame_placement(robot.q_ref, frame).translation[2]) < 1e-5
    assert_mirrored_dynamics_agree(robot, 6)


def test_ocp_settings_scale_with_the_robot_and_talos_keeps_the_defaults(robot, g1):
    from cocomopl.ocp.settings import OCPSettings, robot_settings

    assert robot.scale == Scale() and robot_settings(robot.scale) == OCPSettings()
    scaled = robot_settings(g1.scale)
    # a 25 mm half-wide sole keeps 18 mm of it for the ZMP, as TALOS keeps 47 of its 67 mm
    assert scaled.zmp_margin == pytest.approx(0.02 * 0.372) and g1.sole.half_width - scaled.zmp_margin > 0.017
    assert scaled.clearance == pytest.approx(0.05 * 0.731)
    assert scaled.w_load_transfer * g1.mass**2 == pytest.approx(OCPSettings().w_load_transfer * robot.mass**2, rel=2e-3)
    # double supports keep the Froude number, in whole knots: 0.15 s x sqrt(0.731) = 0.128 s -> 5 knots
    assert scaled.ds_duration == pytest.approx(0.125)
    for key in ("ds_duration", "ss_duration", "start_ds_duration", "rest_duration"):
        knots = getattr(scaled, key) / scaled.dt
        assert knots == pytest.approx(round(knots))
        if key != "ss_duration":
            default = getattr(OCPSettings(), key)
            assert abs(getattr(scaled, key) / default - g1.scale.time) <= scaled.dt / 2 / default
    # the single support lets a lateral error grow in proportion to the soles' width:
    # exp(omega T) is 0.372 of TALOS's, omega scaling as 1 / sqrt(leg length)
    omega = REFERENCE_OMEGA / g1.scale.time
    growth = np.exp(omega * scaled.ss_duration) / np.exp(REFERENCE_OMEGA * OCPSettings().ss_duration)
    assert scaled.ss_duration == pytest.approx(0.425) and growth == pytest.approx(g1.scale.width, rel=omega * scaled.dt)


def test_the_footstep_range_scales_with_the_leg_and_talos_keeps_its_own(robot, g1):
    from cocomopl.dataset.design import allowed_footsteps
    from cocomopl.gait import FOOTSTEP_RANGE, check_footstep, footstep_range

    assert footstep_range(robot) == FOOTSTEP_RANGE
    limits = footstep_range(g1)
    # lengths and widths shrink as G1's steps do (its leg is 0.731 of TALOS's), turns stay
    assert limits["length"] == (-0.11, 0.29) and limits["width"] == (-0.035, 0.12)
    assert limits["turn"] == FOOTSTEP_RANGE["turn"]
    check_footstep(g1, "left", (0.29, 0.12, 0.0))
    with pytest.raises(Error, match=re.escape("length 350 mm is outside -110..290 mm")):
        check_footstep(g1, "left", (0.35, 0.0, 0.0))
    check_footstep(robot, "left", (0.35, 0.0, 0.0))
    drawn = allowed_footsteps(g1, 200, seed=5)
    for column, key in enumerate(("length", "width", "turn")):
        low, high = limits[key]
        assert low - 1e-9 <= drawn[:, column].min() and drawn[:, column].max() <= high + 1e-9
        assert (drawn[:, column] < 0).any() and (drawn[:, column] > 0).any()  # either sign


def test_walk_and_training_lengths_scale_with_the_leg_and_talos_keeps_the_papers(robot, g1):
    from cocomopl.dataset.plan import (
        DEFAULT_EXTRA_TRANSITIONS_M,
        DEFAULT_LENGTHS_M,
        default_lengths,
        default_transitions,
    )
    from cocomopl.gait import M_GEN, M_OPT, m_gen, m_opt

    assert m_gen(robot) == M_GEN and m_opt(robot) == M_OPT and default_lengths(robot) == DEFAULT_LENGTHS_M
    assert default_transitions(DEFAULT_LENGTHS_M, robot) == DEFAULT_EXTRA_TRANSITIONS_M
    lengths = default_lengths(g1)
    assert lengths == (0.11, 0.15, 0.18, 0.22, 0.26, 0.29)
    # every M_gen and M_opt length is a trained one, and the extra transitions join trained lengths
    assert set(m_gen(g1)) <= set(lengths) and set(m_opt(g1)) <= set(lengths)
    assert default_transitions(lengths, g1) == ((0.11, 0.18), (0.18, 0.26))


def test_a_derived_posture_stands_the_soles_as_at_neutral_or_as_far_apart_as_asked(g1):
    def separation(r):
        return float(np.diff([r.frame_placement(r.q_ref, r.foot_frames[side]).translation[1]
                              for side in ("right", "left")])[0])

    neutral = pin.neutral(g1.model)
    assert separation(g1) == pytest.approx(float(np.diff([g1.frame_placement(neutral, g1.foot_frames[side]).translation[1]
                                                          for side in ("right", "left")])[0]), abs=1e-4)
    narrow = Robot({**g1.description, "name": "g1-narrow", "foot_separation": 0.124})
    assert separation(narrow) == pytest.approx(0.124, abs=1e-4)
    for frame in narrow.foot_frames.values():  # flat on the floor
        assert narrow.frame_placement(narrow.q_ref, frame).rotation == pytest.approx(np.eye(3), abs=1e-4)


def test_armature_is_the_models_given_or_scaled_from_talos(robot, g1):
    assert robot.armature_source == "the model's" and np.all(robot.model.armature[6:] == 0.1)
    assert g1.armature_source == "derived"
    assert g1.model.armature[6:] == pytest.approx(0.1 * g1.scale.mass * g1.scale.length**2)
    given = Robot({**g1.description, "name": "g1-armature", "armature": 0.005})
    assert given.armature_source == "given" and np.all(given.model.armature[6:] == 0.005)


@pytest.mark.slow  # runs the command line or a second process
def test_robot_init_writes_a_description_that_loads_or_nothing(tmp_path):
    import json

    from conftest import assert_one_line_error, run_cli

    result = run_cli("robot", "init", "alexander", "--out", str(tmp_path / "alexander.json"), "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads((tmp_path / "alexander.json").read_text()) == {
        "name": "alexander", "example_robot_data": "alexander", "pelvis": "PELVIS_LINK"}
    assert json.loads(result.stdout)["soles"]["source"] == "derived"
    # Bolt stands on point feet: refused, naming why, and nothing written
    assert_one_line_error(run_cli("robot", "init", "bolt", "--out", str(tmp_path / "bolt.json")),
                          "floor contacts do not surround")
    assert not (tmp_path / "bolt.json").exists()


def test_a_robot_facing_backwards_in_its_base_frame_is_refused_and_zero_link_inertias_symmetrise(tmp_path):
    """iCub's base frame faces it -x (its knees flex its soles forwards), and its URDF gives
    some links no rotational inertia, which averaging with the mirror image leaves round-off
    below zero."""
    from cocomopl.robot.description import link_inertia

    with pytest.raises(Error, match=re.escape("robot 'icub' faces -x in its base frame")) as info:
        Robot({"name": "icub", "example_robot_data": "icub", "pelvis": "root_link"})
    assert "\n" not in str(info.value)
    almost_zero = np.diag([-5e-20, -5e-20, 0.0])
    inertia = link_inertia(0.5, np.zeros(3), almost_zero)
    assert inertia.mass == 0.5 and np.all(np.linalg.eigvalsh(inertia.inertia) >= 0)
    assert np.abs(inertia.inertia).max() < 1e-19


@pytest.mark.parametrize(("fields", "words"), [
    ({"feet": {"left": "l", "right": "r"}}, "give both 'feet' and 'sole'"),
    ({"feet": {"left": "l"}, "sole": {"front": 0.1, "back": 0.1, "half_width": 0.05}}, "'feet' must name"),
    ({"feet": {"left": "l", "right": "r"}, "sole": {"front": 0.1, "back": -0.1, "half_width": 0.05}}, "'sole' must give"),
    ({"pelvis_height": "high"}, "'pelvis_height' must be a positive number"),
    ({"max_step_length": 0}, "'max_step_length' must be a positive number"),
    ({"symmetrize": "no"}, "'symmetrize' must be true or false"),
    ({"armature": -0.01}, "'armature' must be a positive number of kg m^2"),
    ({"foot_separation": "wide"}, "'foot_separation' must be a positive number"),
    ({"defaults": []}, "defaults must be a JSON object"),
    ({"defaults": {"speed": 1}}, "defaults has no key 'speed'"),
    ({"defaults": {"ocp": [0.5]}}, "defaults.ocp must be a JSON object of OCP settings"),
    ({"defaults": {"kajita": 1.6}}, "defaults.kajita must be a JSON object of Kajita baseline settings"),
    ({"defaults": {"walk": [0.1, -0.1]}}, "defaults.walk must be a list of positive step lengths in m"),
    ({"defaults": {"training_lengths": []}}, "defaults.training_lengths must be a list of positive step lengths"),
    ({"defaults": {"footstep_range": {"length": [0.3, 0.1]}}}, "defaults.footstep_range.length must be [low, high]"),
    ({"defaults": {"footstep_range": {"side": [0, 1]}}}, "defaults.footstep_range must be an object of length, width, turn"),
    ({"defaults": {"stabilizer": {"ankle_damping": 0}}}, "defaults.stabilizer must be an object of positive"),
    ({"defaults": {"simulation": {"feedforward": "yes"}}}, "defaults.simulation must be an object of feedforward: true or false"),
    ({"defaults": {"simulation": {"latency": 0.01}}}, "defaults.simulation must be an object of feedforward"),
])
def test_a_description_key_holding_nonsense_is_one_line_naming_it(tmp_path, fields, words):
    import json

    (tmp_path / "bad.json").write_text(json.dumps({"name": "bad", "example_robot_data": "g1", "pelvis": "pelvis", **fields}))
    with pytest.raises(Error, match=re.escape(words)):
        Robot(str(tmp_path / "bad.json"))


@pytest.mark.parametrize(("ocp", "words"), [
    ({"ss_time": 0.5}, "defaults.ocp.ss_time is not an OCP setting"),
    ({"dt": 0}, "defaults.ocp.dt must be a positive number, not 0"),
    ({"zmp_margin": -0.01}, "defaults.ocp.zmp_margin must be a number of at least 0"),
    ({"w_torque": True}, "defaults.ocp.w_torque must be a number of at least 0"),
    ({"max_iterations": 10.5}, "defaults.ocp.max_iterations must be a positive whole number"),
    ({"ss_bounds": [0.9, 0.5]}, "defaults.ocp.ss_bounds must be two increasing positive numbers"),
])
def test_an_ocp_setting_a_description_cannot_set_is_one_line_naming_it(ocp, words):
    from cocomopl.ocp.settings import robot_settings

    with pytest.raises(Error, match=re.escape(words)) as info:
        robot_settings(Scale(), ocp)
    assert "\n" not in str(info.value)


def test_the_attitude_rate_loop_crosses_over_where_taloss_does(robot, g1):
    """The rate term is a damper kp g_r on the inertia the hips turn: kp g_r / I is TALOS's on
    G1 (to the 0.1 % of the rounded ratio), though G1's hips turn an upper body of a sixth to a
    seventh of TALOS's inertia."""
    from cocomopl.sim.mujoco_model import servo_stiffness
    from cocomopl.sim.stabilizer import ATTITUDE_RATE_GAIN, attitude_rate_gains

    def crossover(r: Robot) -> np.ndarray:
        sides, kp = r.leg_roles(), servo_stiffness(r)
        hips = sum(kp[[sides[side]["hip_roll"], sides[side]["hip_pitch"]]] for side in sides)
        return hips * np.array(attitude_rate_gains(r)) / r.upper_body_inertia

    assert attitude_rate_gains(robot) == (ATTITUDE_RATE_GAIN, ATTITUDE_RATE_GAIN)
    assert np.all(robot.upper_body_inertia > 5 * g1.upper_body_inertia)
    assert np.allclose(crossover(g1), crossover(robot), rtol=5e-3)
    assert max(attitude_rate_gains(g1)) < ATTITUDE_RATE_GAIN


def test_leg_servos_hold_a_robots_weight_no_more_stiffly_than_taloss(robot, g1):
    """kp over the robot's torque ratio (mass x leg length) is at most TALOS's for every leg
    joint's role: TALOS keeps full torque at 30 mrad everywhere, G1's strong hips and knees are
    capped, and joints off the legs keep full torque at 30 mrad."""
    from cocomopl.sim.mujoco_model import FULL_TORQUE_ERROR, servo_stiffness

    assert np.array_equal(servo_stiffness(robot), robot.tau_max / FULL_TORQUE_ERROR)
    taloss = {role: servo_stiffness(robot)[joint] for joint, role in robot.leg_joint_roles().items()}
    assert len(taloss) == 6
    kp, full = servo_stiffness(g1), g1.tau_max / FULL_TORQUE_ERROR
    roles = g1.leg_joint_roles()
    assert sorted(roles) == g1.leg_joint_indices() and sorted(set(roles.values())) == sorted(taloss)
    for joint, role in roles.items():
        assert kp[joint] <= taloss[role] * g1.scale.torque * (1 + 1e-12) and kp[joint] <= full[joint]
    capped = [g1.joint_names[j] for j in roles if kp[j] < full[j]]
    assert {"left_knee_joint", "right_hip_pitch_joint", "left_hip_roll_joint"} <= set(capped)
    others = g1.upper_body_joint_indices()
    assert np.array_equal(kp[others], full[others])


def test_a_description_overrides_the_scaled_defaults_it_names_and_keeps_the_others(tmp_path, g1):
    import json

    from cocomopl.dataset.plan import default_lengths
    from cocomopl.gait import footstep_range, m_gen, m_opt
    from cocomopl.jobs import check_robot
    from cocomopl.ocp.settings import robot_settings
    from cocomopl.sim.stabilizer import robot_gains

    defaults = {"ocp": {"ss_duration": 0.5, "ss_bounds": [0.4, 0.6], "w_load_transfer": 0},
                "walk": [0.1, 0.2, 0.1], "training_lengths": [0.2, 0.1, 0.15],
                "footstep_range": {"width": [-0.02, 0.1]}, "stabilizer": {"dcm_gain": 3, "attitude_rate_gain": 0.02}}
    path = tmp_path / "mybot.json"
    path.write_text(json.dumps({"name": "mybot", "example_robot_data": "g1", "pelvis": "pelvis", "defaults": defaults}))
    mybot = Robot(str(path))
    settings = robot_settings(mybot.scale, mybot.override("ocp"))
    scaled = robot_settings(g1.scale)
    assert (settings.ss_duration, settings.ss_bounds, settings.w_load_transfer) == (0.5, (0.4, 0.6), 0)
    assert settings.zmp_margin == scaled.zmp_margin and settings.ds_duration == scaled.ds_duration
    assert m_gen(mybot) == m_opt(mybot) == (0.1, 0.2, 0.1) and default_lengths(mybot) == (0.1, 0.15, 0.2)
    assert footstep_range(mybot) == footstep_range(g1) | {"width": (-0.02, 0.1)}
    assert robot_gains(mybot).dcm_gain == 3 and robot_gains(mybot).ankle_damping == robot_gains(g1).ankle_damping
    assert robot_gains(mybot).attitude_rate_gains == (0.02, 0.02) != robot_gains(g1).attitude_rate_gains
    check = check_robot(str(path))
    assert check.defaults["given"] == sorted(defaults) and check.defaults["ocp"]["ss_duration"] == 0.5
    assert "the description sets footstep_range, ocp, stabilizer, training_lengths, walk" in check.to_table()
    assert check.defaults["stabilizer"]["dcm_gain"] == 3 and list(check.defaults["stabilizer"]["attitude_rate_gains"]) == [0.02, 0.02]
    assert "DCM gain 3, attitude rate gains 0.02/0.02 s" in check.to_table()


def test_the_servos_torque_feedforward_is_the_robots_default_unless_told(robot, g1):
    """G1's description turns the feedforward on (its motors take a feed-forward torque beside
    their position target); TALOS's leaves it off, as the paper's HRP-2 ran; either way an
    explicit setting wins, and `robot check` says which it is."""
    from cocomopl.jobs import check_robot
    from cocomopl.pipeline import SimSettings, servo_feedforward

    assert servo_feedforward(SimSettings(), g1) is True and servo_feedforward(SimSettings(), robot) is False
    assert servo_feedforward(SimSettings(feedforward=False), g1) is False
    assert servo_feedforward(SimSettings(feedforward=True), robot) is True
    assert "servo torque feedforward on in simulation" in check_robot("g1").to_table()
    assert "servo torque feedforward off in simulation" in check_robot("talos").to_table()


def test_step_lengths_scale_to_what_the_legs_stand_across(robot, g1):
    import json

    from cocomopl.dataset.plan import default_lengths
    from cocomopl.robot.description import DESCRIPTIONS_DIR, REACH_MARGIN_M

    assert robot.scale.stride is None and g1.scale.stride is None  # they stand across their longest step
    assert Robot("romeo").scale.stride is None  # at its description's pelvis height, 0.86 m
    # crouched at the derived pelvis height (6 % below straight legs, knees at 0.84 rad), its
    # ankles are 0.08 rad from their limit, and with the leg length alone its longest step
    # would be 320 mm, which it cannot stand across
    description = json.loads((DESCRIPTIONS_DIR / "romeo.json").read_text())
    romeo = Robot({key: value for key, value in description.items() if key not in ("pelvis_height", "defaults")})
    lengths = default_lengths(romeo)
    assert romeo.scale.stride is not None and max(lengths) < romeo.scale.length * 0.4
    assert romeo.stands_across(max(lengths) + REACH_MARGIN_M)
    assert not romeo.stands_across(max(lengths) + 0.01 + REACH_MARGIN_M)


@pytest.mark.slow  # runs the command line
def test_files_record_the_robots_fingerprint_and_another_models_files_are_refused(robot, tmp_path):
    import h5py

    from cocomopl.data import dataset_path, model_path
    from cocomopl.motion_file import read_motions
    from cocomopl.primitives.model_file import load_model, model_robot

    from conftest import assert_one_line_error, run_cli

    path = tmp_path / "walk.h5"
    assert run_cli("generate", "--lengths-mm", "200,200", "--out", str(path)).returncode == 0
    with h5py.File(path, "a") as f:
        assert f.attrs["robot_model"] == robot.fingerprint  # a digest of the model it was made with
        f.attrs["robot_model"] = "0" * 16  # as if the URDF or the description had changed since
    assert_one_line_error(run_cli("dataset", "check", str(path)), "made for another model of talos")
    read_motions(dataset_path())  # the bundled files predate the fingerprint: read as they are
    model = load_model(model_path())
    model.metadata_["robot_model"] = "0" * 16
    with pytest.raises(Error, match="the model was made for another model of talos"):
        model_robot(model)


def test_the_descriptions_stabilizer_and_simulation_keys_are_the_settings_they_set():
    """The robot layer checks ``defaults.stabilizer`` and ``defaults.simulation`` when a
    description is read, without importing the simulation: its key lists must stay the
    settings' own fields (the attitude rate gain given once for roll and pitch)."""
    from dataclasses import fields

    from cocomopl.pipeline import SimSettings
    from cocomopl.robot.description import SIMULATION_KEYS, STABILIZER_KEYS
    from cocomopl.sim.stabilizer import StabilizerGains

    gains = [f.name for f in fields(StabilizerGains)]
    assert [key if key != "attitude_rate_gain" else "attitude_rate_gains" for key in STABILIZER_KEYS] == gains
    assert set(SIMULATION_KEYS) <= {f.name for f in fields(SimSettings)}


def test_a_robot_whose_leg_servos_are_capped_gets_the_feedforward_unless_its_description_says(tmp_path, robot):
    """G1's leg servos are held below full torque at 30 mrad (softer than TALOS's for its
    weight and size), so a G1 description that says nothing turns the feedforward on; one that
    says false keeps it off; TALOS's servos are not capped."""
    import json

    from cocomopl.pipeline import SimSettings, servo_feedforward
    from cocomopl.sim.mujoco_model import leg_servos_capped

    def described(name: str, **defaults) -> Robot:
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps({"name": name, "example_robot_data": "g1", "pelvis": "pelvis", "defaults": defaults}))
        return Robot(str(path))

    silent, off = described("g1_silent"), described("g1_off", simulation={"feedforward": False})
    assert leg_servos_capped(silent) and not leg_servos_capped(robot)
    assert servo_feedforward(SimSettings(), silent) is True
    assert servo_feedforward(SimSettings(), off) is False
    assert servo_feedforward(SimSettings(feedforward=False), silent) is False
