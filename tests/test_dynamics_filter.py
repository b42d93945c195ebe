"""The dynamics filter: its cart-table correction and its leg inverse kinematics."""

import numpy as np
import pinocchio as pin

from cocomopl.synthesis.dynamics_filter import GRAVITY, leg_joints, place_legs, zmp_correction


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
        targets[side] = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.05, 0.02), placement.translation + [0.04, 0.01, 0.02])
    moved = place_legs(robot, q, targets, leg_joints(robot))
    for side, frame in robot.foot_frames.items():
        error = pin.log6(targets[side].actInv(robot.frame_placement(moved, frame))).vector
        assert np.abs(error).max() < 1e-6
    legs = np.concatenate([leg_joints(robot)[s][0] for s in ("left", "right")])
    others = np.setdiff1d(np.arange(7, robot.model.nq), legs)
    assert np.array_equal(moved[others], q[others])  # only the legs (and pelvis height) move
    assert np.array_equal(moved[3:7], q[3:7]) and np.array_equal(moved[:2], q[:2])
