"""The dynamics filter: its cart-table correction and its leg inverse kinematics."""

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.kinematics import leg_joints, place_legs
from cocomopl.synthesis.dynamics_filter import GRAVITY, rms_zmp_error, zmp_correction


def test_correction_cancels_a_cart_table_zmp_error():
    # a CoM wobble that starts and ends at rest, and the ZMP error it would cause
    t = np.linspace(0.0, 4.0, 161)
    wobble = 0.02 * np.sin(np.pi * t / 4.0) ** 2 * np.sin(2 * np.pi * t)
    height = 0.85
    acceleration = np.gradient(np.gradient(wobble, t), t)
    error = np.stack([wobble - height / GRAVITY * acceleration, np.zeros_like(t)], axis=1)
    shift = zmp_correction(t, error, height)
    assert np.abs(shift[5:-5, 0] + wobble[5:-5]).max() < 2e-3  # undoes the wobble (2 cm)
    assert np.abs(shift[:, 1]).max() < 1e-9  # no error, no correction
    assert np.abs(shift[[0, -1]]).max() < 1e-6  # the walk's ends stay at rest


def test_legs_reach_their_sole_targets(robot):
    q = robot.q_ref.copy()
    targets = {}
    for side, frame in robot.foot_frames.items():
        placement = robot.frame_placement(q, frame)
        targets[side] = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.05, 0.02), placement.translation + np.array([0.04, 0.01, 0.02]))
    moved = place_legs(robot, q, targets, legs=leg_joints(robot))
    for side, frame in robot.foot_frames.items():
        error = pin.log6(targets[side].actInv(robot.frame_placement(moved, frame))).vector
        assert np.abs(error).max() < 1e-6
    legs = np.concatenate([leg_joints(robot)[s][0] for s in ("left", "right")])
    others = np.setdiff1d(np.arange(7, robot.model.nq), legs)
    assert np.array_equal(moved[others], q[others])  # only the legs (and pelvis height) move
    assert np.array_equal(moved[3:7], q[3:7]) and np.array_equal(moved[:2], q[:2])


def test_under_the_filters_height_weight_a_far_footstep_is_reached(robot):
    from cocomopl.kinematics import HEIGHT_WEIGHT, IK_REACHED
    from cocomopl.synthesis.dynamics_filter import FILTER_HEIGHT_WEIGHT

    # the right sole asked 0.45 m forward of the left: only a sinking pelvis gets it there
    q = robot.q_ref.copy()
    targets = {side: robot.frame_placement(q, frame) for side, frame in robot.foot_frames.items()}
    targets["right"] = pin.SE3(targets["right"].rotation, targets["right"].translation + np.array([0.45, 0.0, 0.0]))
    sunk, error = {}, {}
    for weight in (HEIGHT_WEIGHT, FILTER_HEIGHT_WEIGHT):
        moved = place_legs(robot, q, targets, legs=leg_joints(robot), height_weight=weight)
        sunk[weight] = q[2] - moved[2]
        reached = robot.frame_placement(moved, robot.foot_frames["right"]).translation
        error[weight] = np.linalg.norm(targets["right"].translation - reached)
    assert sunk[FILTER_HEIGHT_WEIGHT] > 0.1 and sunk[HEIGHT_WEIGHT] > 0.1  # both give way
    # but only the filter's weight puts the sole on its footstep by the filter's own test
    assert error[FILTER_HEIGHT_WEIGHT] < IK_REACHED < error[HEIGHT_WEIGHT]


def test_a_soft_touchdown_adds_no_torque_spike_to_inverse_dynamics(robot):
    from cocomopl.dynamics import inverse_dynamics_with_contacts

    # both soles down, one elbow swinging smoothly; a touchdown declared halfway (its time twice)
    t = np.arange(21) * 0.025
    q = np.tile(robot.q_ref, (len(t), 1))
    elbow = robot.joint_names.index("arm_right_4_joint")
    q[:, 7 + elbow] += 0.3 * np.sin(2 * np.pi * t)
    contact = np.ones((len(t), 2), dtype=bool)
    free = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=np.array([], dtype=int))[1][:, elbow]
    k = 7  # where the elbow both moves and accelerates
    t2, q2, c2 = np.insert(t, k, t[k]), np.insert(q, k, q[k], axis=0), np.insert(contact, k, contact[k], axis=0)
    v, tau, _ = inverse_dynamics_with_contacts(robot, t2, q2, contact=c2, impacts=np.array([k]))
    # the post-impact velocity is the central difference of the positions around the touchdown
    np.testing.assert_allclose(v[k + 1, 6 + elbow], (q[k + 1, 7 + elbow] - q[k - 1, 7 + elbow]) / 0.05, atol=1e-9)
    # so its interval keeps a real acceleration: the torque stays nearer the impact-free one
    # than under zero acceleration, the rule that made arm torques spike after touchdowns
    zero_acceleration = pin.rnea(robot.model, robot.model.createData(), q2[k + 1], v[k + 2], np.zeros(robot.model.nv))
    assert abs(tau[k + 1, elbow] - free[k]) < 0.6 * abs(zero_acceleration[6 + elbow] - free[k])


def test_zmp_error_is_horizontal_and_skips_impact_and_airborne_samples():
    reference = np.zeros((5, 3))
    zmp = reference + np.array([0.03, 0.04, 0.5])  # the height is not an error
    zmp[2] = [9.0, 9.0, 0.0]  # a pre-impact sample repeats its interval's wrench: not a ZMP sample
    zmp[3] = np.nan  # no contact force: no ZMP
    assert rms_zmp_error(zmp, reference, np.array([2])) == pytest.approx(np.sqrt((0.03**2 + 0.04**2) / 2))
