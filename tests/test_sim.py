"""The MuJoCo model agrees with the Pinocchio model, and position-controlled rollouts behave."""

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.gait import foot_separation
from cocomopl.kinematics import double_support_posture
from cocomopl.motion_file import read_motion, write_motions
from cocomopl.sim.mujoco_model import build_sim_model, load_sim_model, mjcf
from cocomopl.sim.rollout import placed_on_floor, simulate
from cocomopl.sim.stabilizer import TILT_DEAD_BAND, Stabilizer, StabilizerGains, leg_maps

from conftest import synthetic

DATASET = BUNDLED_DATASET


@pytest.fixture(scope="module")
def sim(robot):
    return build_sim_model(robot, visuals=False)


def _random_configuration(robot, rng):
    q = pin.randomConfiguration(robot.model, np.r_[-np.ones(7), robot.q_lower], np.r_[np.ones(7), robot.q_upper])
    q[3:7] = rng.normal(size=4)
    q[3:7] /= np.linalg.norm(q[3:7])
    return q


def test_mass_matrix_com_and_soles_agree_with_pinocchio(robot, sim):
    rng = np.random.default_rng(0)
    data, mj_data = robot.model.createData(), mujoco.MjData(sim.mj)
    assert sum(sim.mj.body_mass) == pytest.approx(robot.mass, rel=1e-12)
    for _ in range(3):
        q = _random_configuration(robot, rng)
        mj_data.qpos[:] = sim.qpos(q)
        mujoco.mj_forward(sim.mj, mj_data)
        M_mj = np.zeros((sim.mj.nv, sim.mj.nv))
        mujoco.mj_fullM(sim.mj, mj_data, M_mj)
        M = pin.crba(robot.model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        # MuJoCo's free-joint linear velocity is in the world frame, Pinocchio's in the base frame
        T = np.eye(sim.mj.nv)
        T[:3, :3] = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        T_inv = np.linalg.inv(T)
        assert np.abs(M_mj - T_inv.T @ M @ T_inv).max() < 1e-6 * np.abs(M).max()  # masses, inertias, armature
        pin.framesForwardKinematics(robot.model, data, q)
        for side in ("left", "right"):
            assert np.allclose(mj_data.site_xpos[sim.sole_sites[side]], data.oMf[robot.foot_frames[side]].translation, atol=1e-9)
        assert np.allclose(mj_data.subtree_com[sim.base_body], pin.centerOfMass(robot.model, data, q), atol=1e-9)


def test_limits_and_armature_agree_with_the_urdf(robot, sim):
    joints = range(1, sim.mj.njnt)  # joint 0 is the free joint
    assert np.allclose([sim.mj.jnt_range[j] for j in joints], np.stack([robot.q_lower, robot.q_upper], 1))
    assert np.allclose(sim.mj.actuator_forcerange, np.stack([-robot.tau_max, robot.tau_max], 1))
    assert np.allclose(sim.mj.dof_armature[6:], robot.model.armature[6:])
    assert sim.mj.opt.timestep == pytest.approx(0.001)


def test_state_conversions_round_trip(robot, sim):
    rng = np.random.default_rng(1)
    q = _random_configuration(robot, rng)
    v = rng.normal(size=robot.model.nv)
    assert np.allclose(sim.q(sim.qpos(q)), q)
    assert np.allclose(sim.v(sim.qpos(q), sim.qvel(q, v)), v)


@pytest.mark.slow
@pytest.mark.parametrize("stabilizer", [True, False])
def test_standing_robot_carries_its_weight_on_its_soles(robot, sim, standing, stabilizer):
    rollout = simulate(sim, standing(0.5), stabilizer=stabilizer)
    assert not rollout.fell
    weight = robot.mass * 9.81
    total = rollout.measured.wrenches[..., 2].sum(axis=1)
    assert np.abs(total[-20:] / weight - 1).max() < 0.02  # at rest the floor carries exactly the weight
    assert rollout.measured.contact[-1].all()
    for side in ("left", "right"):  # the soft contact (rubber soles) gives a little, under a millimetre
        sole_height = robot.frame_placement(rollout.measured.q[-1], robot.foot_frames[side]).translation[2]
        assert -1e-3 < sole_height < 0.0
    # and the ZMP of the measured wrenches lies between the feet
    zmp = rollout.measured.zmp[-1]
    assert abs(zmp[1]) < foot_separation(robot) / 2


@pytest.mark.slow
def test_an_oc_step_walks_and_its_measurement_round_trips(robot, sim, tmp_path):
    reference = read_motion(DATASET, "start_250_L")
    rollout = simulate(sim, reference, stabilizer=True)
    assert not rollout.fell
    measured = rollout.measured
    assert measured.t[-1] == pytest.approx(reference.duration + 1.0, abs=0.01)  # and it stood for 1 s after
    assert measured.producer == "mujoco" and measured.simulation.stabilizer is True
    # the left foot stepped about 250 mm forward (the start step's length)
    assert measured.q[-1, 0] - measured.q[0, 0] == pytest.approx(reference.q[-1, 0] - reference.q[0, 0], abs=0.05)
    write_motions(tmp_path / "m.h5", {"sim": measured}, {"robot": robot.name})
    back = read_motion(tmp_path / "m.h5")
    assert np.array_equal(back.q, measured.q) and np.array_equal(back.wrenches, measured.wrenches)


def test_sole_lift_offsets_raise_the_sole_vertically_and_keep_it_flat(robot):
    q = double_support_posture(robot, (0.0, foot_separation(robot)), (0.0, 0.0))  # knees bent
    lifts = leg_maps(robot, q[None])[0][0]
    for j, side in enumerate(("left", "right")):
        offsets = lifts[j]
        assert set(np.flatnonzero(offsets)) <= set(robot.leg_chain(side))  # only its own leg moves
        before = robot.frame_placement(q, robot.foot_frames[side])
        q_up = q.copy()
        q_up[7:] += 0.005 * offsets  # 5 mm up
        after = robot.frame_placement(q_up, robot.foot_frames[side])
        rise = after.translation - before.translation
        assert 0.8 * 0.005 < rise[2] <= 0.005  # damping shortens the rise a little, never overshoots
        assert np.abs(rise[:2]).max() < 2e-4
        assert np.abs(pin.log3(before.rotation.T @ after.rotation)).max() < 2e-3


def test_ankle_moment_torques_do_the_work_of_the_ground_moment(robot):
    # τ = -J_legᵀ m: turning the leg joints by δq turns the sole by J_leg δq, and the joint
    # torques then do work τ·δq = -m·δθ, as a ground moment m resisting the turn would
    q = double_support_posture(robot, (0.0, foot_separation(robot)), (0.0, 0.0))
    moments = leg_maps(robot, q[None])[1][0]
    rng = np.random.default_rng(2)
    for j, side in enumerate(("left", "right")):
        dq = np.zeros(robot.nu)
        dq[robot.leg_chain(side)] = 1e-6 * rng.normal(size=len(robot.leg_chain(side)))
        before = robot.frame_placement(q, robot.foot_frames[side])
        q_turned = q.copy()
        q_turned[7:] += dq
        after = robot.frame_placement(q_turned, robot.foot_frames[side])
        turn = pin.log3(after.rotation @ before.rotation.T)  # world frame
        m = np.array([3.0, -2.0])
        assert (moments[j] @ m) @ dq == pytest.approx(-m @ turn[:2], rel=1e-3)


def test_a_tilted_stance_sole_is_taken_up_by_its_ankle_and_let_go_when_unloaded(robot, sim, standing):
    """The ground turns the right sole 3.4 degrees from the plan: in single support on it, once
    it carries load, the ankle offsets turn the planned sole onto the measured one but for the
    dead band, the leg above the ankle held; unloaded, or in double support, they let go."""
    reference = standing(1.0)
    reference.contact[:, 0] = False  # standing on the right sole
    roles = robot.leg_roles()["right"]
    q = reference.q[0].copy()
    q[7 + roles["ankle_pitch"]] += 0.05
    q[7 + roles["ankle_roll"]] -= 0.03
    data = mujoco.MjData(sim.mj)
    data.qpos[:] = sim.qpos(q)
    mujoco.mj_kinematics(sim.mj, data)
    measured = data.site_xmat[sim.sole_sites["right"]].reshape(3, 3)
    load = np.zeros((2, 6))
    ground = type("Ground", (), {"__getattr__": lambda self, name: getattr(sim, name),
                                 "sole_wrenches": lambda self, data: load})()

    def settled(control):
        for _ in range(50):  # ten times the take-up's filter
            control.correction(data, 0.0)
        return control.tilts

    load[:, 2] = 400.0
    control = Stabilizer(ground, reference)
    tilts = settled(control)
    taken_up = reference.q[0].copy()
    taken_up[7 + roles["ankle_pitch"]] += tilts[1, 0]
    taken_up[7 + roles["ankle_roll"]] += tilts[1, 1]
    residual = pin.log3(measured.T @ robot.frame_placement(taken_up, robot.foot_frames["right"]).rotation)
    assert np.linalg.norm(residual) == pytest.approx(TILT_DEAD_BAND, abs=2e-3)
    assert np.linalg.norm([0.05, 0.03]) > 5 * TILT_DEAD_BAND
    assert np.allclose(tilts[0], 0.0)  # the swinging sole
    load[:, 2] = 0.0
    assert np.abs(settled(control)).max() < 1e-3 * np.linalg.norm([0.05, 0.03])
    load[:, 2] = 400.0
    assert np.allclose(settled(Stabilizer(ground, standing(1.0))), 0.0)  # double support


def _push_excursion(robot, sim, reference, dcm_gain: float, push_n: float, ankle_damping: float) -> float:
    """Largest forward CoM excursion (m) of a robot standing on ``reference`` pushed at the pelvis."""
    data = mujoco.MjData(sim.mj)
    placed_on_floor(sim, data, reference.q[0])
    control = Stabilizer(sim, reference, StabilizerGains(ankle_damping=ankle_damping, dcm_gain=dcm_gain))
    start, excursion = data.subtree_com[0, 0], 0.0
    for i in range(1000):  # 1 s, pushed from 0.1 s to 0.2 s
        data.ctrl[:] = reference.q[0, 7:] + control.correction(data, i * sim.mj.opt.timestep)
        data.xfrc_applied[sim.base_body, 0] = push_n if 100 <= i < 200 else 0.0
        mujoco.mj_step(sim.mj, data)
        excursion = max(excursion, data.subtree_com[0, 0] - start)
    return excursion


@pytest.mark.slow
def test_dcm_feedback_resists_a_push(robot, sim, standing):
    """The DCM feedback acts through the ankle damping control, as fast as its D lets it: at
    the default D (3000 N m s/rad, for soft landings) it hardly moves the ankles within this
    1 s test (docs/method.md, "Stabilizer"), so the mechanism is tested at D = 300."""
    reference = standing(1.0)
    reference.wrenches[:, :, 2] = robot.mass * 9.81 / 2  # the DCM feedback works through the soles' loads
    without = _push_excursion(robot, sim, reference, 0.0, 150.0, ankle_damping=300.0)
    with_feedback = _push_excursion(robot, sim, reference, 2.0, 150.0, ankle_damping=300.0)
    assert without > 0.005  # the push moves the robot
    assert with_feedback < 0.85 * without


def test_reference_filter_keeps_the_gait_and_removes_the_knot_rate(robot):
    from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ, Reference

    # 25 ms knots of a 1 Hz swing with a 40 Hz zigzag on top, standing still at both ends
    t = np.arange(0.0, 4.0 + 1e-9, 0.025)
    moving = (t > 1.0) & (t < 3.0)
    slow = np.where(moving, 0.3 * np.sin(2 * np.pi * (t - 1.0)), 0.0)
    zigzag = np.where(moving, 0.01 * (-1.0) ** np.arange(len(t)), 0.0)
    q = np.tile(robot.q_ref, (len(t), 1))
    q[:, 7] += slow + zigzag
    motion = synthetic(robot, t, q=q)
    dt = 0.001
    plain, filtered = Reference(motion, dt, None).at, Reference(motion, dt, REFERENCE_CUTOFF_HZ).at
    grid = np.arange(0.0, 4.0, dt)
    a, b = (np.array([f(x)[0] for x in grid]) - robot.q_ref[7] for f in (plain, filtered))
    np.testing.assert_allclose(a[::25], (slow + zigzag)[:-1], atol=1e-12)  # unfiltered: the knots
    # standing postures are kept, the 1 Hz swing passes, the zigzag (20 Hz, the knots' Nyquist rate) goes
    assert abs(b[0]) < 1e-6 and abs(b[-1]) < 1e-6
    swing = np.sin(2 * np.pi * (grid - 1.0)) * ((grid > 1.0) & (grid < 3.0))
    assert np.abs(b - 0.3 * swing)[(grid > 1.2) & (grid < 2.8)].max() < 0.003
    residual = a - 0.3 * swing
    assert np.abs(b - 0.3 * swing)[(grid > 1.2) & (grid < 2.8)].max() < 0.3 * np.abs(residual).max()


def test_torque_feedforward_makes_the_servos_track_the_plan(robot, sim):
    """A position servo sags under its load by tau / kp and lags by its damping; offsetting
    the commands by the plan's torques and velocities removes nearly all of it (measured: the
    RMS joint error of this OC step falls from 12 to 0.7 mrad)."""
    reference = read_motion(DATASET, "start_250_L")
    errors = {}
    for feedforward in (False, True):
        measured = simulate(sim, reference, stabilizer=False, feedforward=feedforward).measured
        assert measured.simulation.feedforward is feedforward
        playing = measured.t <= reference.duration
        planned = np.column_stack([np.interp(measured.t[playing], reference.t - reference.t[0], x) for x in reference.q[:, 7:].T])
        errors[feedforward] = np.sqrt(np.mean((measured.q[playing, 7:] - planned) ** 2))
    assert errors[True] < 0.2 * errors[False]


def _other_model_file(robot, path, drop_actuators: bool = False):
    """The project's own MuJoCo model rewritten as someone else might have written it: no sole
    geoms, servos in reverse order under other names with 0.8 times the gains, masses and
    inertias 4 % more, friction loss 1 N m on every joint, and a joint the robot does not have."""
    spec = mujoco.MjSpec.from_string(mjcf(robot, visuals=False))
    for side in ("left", "right"):
        spec.delete(spec.geom(f"{side}_sole"))
        spec.delete(spec.site(f"{side}_sole"))
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    if not drop_actuators:
        for name, tau in reversed(list(zip(robot.joint_names, robot.tau_max))):
            servo = spec.add_actuator(name=f"servo_{name}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            kp = 0.8 * tau / 0.03
            servo.set_to_position(kp=kp, kv=kp / 50)
    for body in spec.bodies:
        body.mass *= 1.04
        body.fullinertia = 1.04 * np.asarray(body.fullinertia)
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.frictionloss = 1.0
    extra = spec.body(robot.model.names[1]).add_body(name="antenna", pos=[0, 0, 0.3])
    extra.add_joint(name="antenna_joint", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
    extra.add_geom(size=[0.02, 0, 0], mass=0.1, contype=0, conaffinity=0)
    path.write_text(spec.to_xml())
    return path


@pytest.mark.slow
def test_a_model_file_made_elsewhere_is_matched_by_joint_name_and_walked(robot, standing, tmp_path):
    sim = load_sim_model(robot, _other_model_file(robot, tmp_path / "other.xml"))
    assert [sim.mj.actuator(int(a)).name for a in sim.actuators] == [f"servo_{n}" for n in robot.joint_names]
    assert [sim.mj.joint(int(np.flatnonzero(sim.mj.jnt_qposadr == i)[0])).name for i in sim.qpos_index] == robot.joint_names
    assert all(len(sim.sole_geoms[side]) == 1 for side in ("left", "right"))  # the description's soles added
    assert sim.mj.neq == 1  # the antenna, which no servo drives, is held
    assert np.allclose(sim.mj.actuator_forcerange[sim.actuators, 1], robot.tau_max)  # the URDF's torque limits
    rng = np.random.default_rng(3)
    q = _random_configuration(robot, rng)
    v = rng.normal(size=robot.model.nv)
    assert np.allclose(sim.q(sim.qpos(q)), q) and np.allclose(sim.v(sim.qpos(q), sim.qvel(q, v)), v)
    rollout = simulate(sim, read_motion(DATASET, "start_250_L"), stabilizer=True)
    assert not rollout.fell
    weight = 1.04 * robot.mass * 9.81
    assert np.abs(rollout.measured.wrenches[-20:, :, 2].sum(axis=1) / weight - 1).max() < 0.03  # stands on the added soles
    stiff = simulate(sim, standing(0.3), stabilizer=False).measured  # the file's servos, in the robot's order
    sag = np.abs(stiff.q[-1, 7:] - standing(0.3).q[0, 7:])
    knee = robot.joint_names.index("leg_left_4_joint")
    assert sag[knee] == pytest.approx(np.abs(stiff.tau[-1, knee]) / (0.8 * robot.tau_max[knee] / 0.03), rel=0.3, abs=2e-4)


def test_a_model_file_without_actuators_gets_the_projects_servos(robot, tmp_path):
    sim = load_sim_model(robot, _other_model_file(robot, tmp_path / "bare.xml", drop_actuators=True))
    assert np.allclose(sim.servo_gains()[0], robot.tau_max / 0.03)


@pytest.mark.parametrize("damage, message", [
    (lambda text: text.replace('"leg_left_4_joint"', '"knee"'), "no joint leg_left_4_joint"),
    (lambda text: "<mujoco><worldbody>", "not a MuJoCo model"),
    (lambda text: text.replace('joint="leg_left_4_joint"', 'joint="antenna_joint"'), "has no position servo"),
])
def test_a_model_file_of_another_robot_is_refused_in_one_line(robot, tmp_path, damage, message):
    from cocomopl.errors import Error

    path = _other_model_file(robot, tmp_path / "other.xml")
    path.write_text(damage(path.read_text()))
    with pytest.raises(Error, match=message) as raised:
        load_sim_model(robot, path)
    assert "\n" not in str(raised.value)


@pytest.mark.slow
def test_the_projects_own_model_read_as_a_model_file_walks_exactly_as_built(robot, sim, tmp_path):
    path = tmp_path / "own.xml"
    path.write_text(mjcf(robot, visuals=False))
    reference = read_motion(DATASET, "start_250_L")
    built = simulate(sim, reference, stabilizer=True).measured
    read = simulate(load_sim_model(robot, path), reference, stabilizer=True).measured
    assert read.simulation.sim_model == str(path)
    assert np.allclose(read.q, built.q, atol=1e-9) and np.allclose(read.wrenches, built.wrenches, atol=1e-6)


def test_sim_settings_reach_the_rollout(robot, standing, tmp_path):
    from cocomopl.pipeline import SimSettings, rollout_of
    from cocomopl.sim.servos import ServoSettings

    path = tmp_path / "robot.xml"
    path.write_text(mjcf(robot, visuals=False))
    settings = SimSettings(stabilizer=False, contact_time_constant=0.02, reference_cutoff_hz=0.0, feedforward=True,
                           sim_model=path, servos=ServoSettings(latency_s=0.002))
    record = rollout_of(robot, standing(0.2), settings).measured.simulation
    assert record.stabilizer is False and record.stabilizer_gains is None
    assert record.contact_time_constant_s == pytest.approx(0.02)
    assert record.reference_cutoff_hz == 0.0
    assert record.feedforward is True
    assert record.sim_model == str(path)
    assert record.servos["latency_s"] == pytest.approx(0.002)
