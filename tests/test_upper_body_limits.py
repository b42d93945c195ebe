"""The upper body's limit correction: its difference operators, its linearisation, its result."""

import numpy as np
import pytest

from cocomopl.dynamics import inverse_dynamics_with_contacts
from cocomopl.synthesis.upper_body_limits import MARGIN, difference_operators, limit_upper_body


def swinging_arms(robot, amplitude: float, frequency: float):
    """Both soles down, the elbows and shoulders swinging; a touchdown declared at sample 9
    (its time twice), as a walk's are."""
    t = np.arange(41) * 0.025
    q = np.tile(robot.q_ref, (len(t), 1))
    for name in ("arm_left_4_joint", "arm_right_4_joint", "arm_left_1_joint"):
        q[:, 7 + robot.joint_names.index(name)] += amplitude * np.sin(np.pi * t / t[-1]) ** 2 * np.sin(2 * np.pi * frequency * t)
    k = 9
    t, q = np.insert(t, k, t[k]), np.insert(q, k, q[k], axis=0)
    return t, q, np.ones((len(t), 2), dtype=bool), np.array([k])


def test_the_upper_body_of_talos_is_its_torso_arms_and_head(robot):
    names = {robot.joint_names[i] for i in robot.upper_body_joint_indices()}
    assert names == {n for n in robot.joint_names if n.startswith(("torso_", "arm_", "head_"))}


def test_difference_operators_reproduce_inverse_dynamics_velocities_and_accelerations(robot):
    t, q, contact, impacts = swinging_arms(robot, 0.3, 1.0)
    V, A, instant = difference_operators(t, impacts)
    v, _, _ = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=impacts)
    upper = robot.upper_body_joint_indices()
    angles = np.zeros((instant[-1] + 1, len(upper)))
    angles[instant] = q[:, 7 + upper]
    np.testing.assert_allclose(V @ angles, v[:, 6 + upper], atol=1e-9)
    # interval accelerations: forward differences of the velocities, repeated on a segment's last sample
    dt = np.diff(t)
    interval = np.flatnonzero(dt > 0)
    np.testing.assert_allclose((A @ angles)[interval], (np.diff(v, axis=0)[interval] / dt[interval, None])[:, 6 + upper], atol=1e-9)


def test_a_small_upper_body_change_moves_the_torque_as_the_inertia_rows_predict(robot):
    import pinocchio as pin

    t, q, contact, impacts = swinging_arms(robot, 0.3, 1.0)
    _V, A, instant = difference_operators(t, impacts)
    upper = robot.upper_body_joint_indices()
    elbow = list(upper).index(robot.joint_names.index("arm_right_4_joint"))
    change = np.zeros((instant[-1] + 1, len(upper)))
    change[20, elbow] = 1e-5
    moved = q.copy()
    moved[:, 7 + upper] += change[instant]
    tau0 = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=impacts)[1][:, upper]
    tau1 = inverse_dynamics_with_contacts(robot, t, moved, contact=contact, impacts=impacts)[1][:, upper]
    k = 20
    M = pin.crba(robot.model, robot.model.createData(), q[k])
    M = np.triu(M) + np.triu(M, 1).T
    predicted = M[np.ix_(6 + upper, 6 + upper)] @ (A[k] @ change).ravel()
    assert np.abs(predicted).max() > 1e-3  # the change is felt
    np.testing.assert_allclose(tau1[k] - tau0[k], predicted, rtol=0.02, atol=1e-5)


@pytest.mark.parametrize("amplitude,frequency", [(0.25, 3.0), (0.4, 2.5)])
def test_arms_over_their_limits_are_brought_within_them_and_the_legs_do_not_move(robot, amplitude, frequency):
    t, q, contact, impacts = swinging_arms(robot, amplitude, frequency)
    upper = robot.upper_body_joint_indices()
    v, tau, _ = inverse_dynamics_with_contacts(robot, t, q, contact=contact, impacts=impacts)
    before = max(np.max(np.abs(tau[:, upper]) / robot.tau_max[upper]), np.max(np.abs(v[:, 6 + upper]) / robot.v_max[upper]))
    assert before > 1.1  # the swing asks too much of the arms
    corrected, report = limit_upper_body(robot, t, q, contact=contact, impacts=impacts)
    v, tau, _ = inverse_dynamics_with_contacts(robot, t, corrected, contact=contact, impacts=impacts)
    assert np.max(np.abs(tau[:, upper]) / robot.tau_max[upper]) <= MARGIN * 1.01
    assert np.max(np.abs(v[:, 6 + upper]) / robot.v_max[upper]) <= MARGIN * 1.01
    assert report["torque_ratio_after"] <= MARGIN * 1.01 and report["velocity_ratio_after"] <= MARGIN * 1.01
    others = np.setdiff1d(np.arange(robot.model.nq), 7 + upper)
    assert np.array_equal(corrected[:, others], q[:, others])  # base and legs untouched
    # one angle per instant: a touchdown's duplicate sample moves with its twin
    assert np.array_equal(corrected[impacts], corrected[impacts + 1])


def test_arms_beyond_their_position_limits_are_brought_back(robot):
    t, q, contact, impacts = swinging_arms(robot, 0.6, 0.5)  # elbows and a shoulder swing past their stops
    upper = robot.upper_body_joint_indices()
    excess = lambda angles: np.max(np.maximum(robot.q_lower[upper] - angles, angles - robot.q_upper[upper]))  # noqa: E731
    assert excess(q[:, 7 + upper]) > 0.05
    corrected, report = limit_upper_body(robot, t, q, contact=contact, impacts=impacts)
    assert excess(corrected[:, 7 + upper]) <= 1e-6
    assert report["position_excess_rad_before"] > 0.05 and report["position_excess_rad_after"] <= 1e-6


def test_an_upper_body_within_its_limits_is_left_alone(robot):
    t, q, contact, impacts = swinging_arms(robot, 0.05, 0.5)
    corrected, report = limit_upper_body(robot, t, q, contact=contact, impacts=impacts)
    assert np.array_equal(corrected, q)
    assert report["qps_solved"] == 0 and report["largest_change_rad"] == 0.0


def test_limits_no_change_can_meet_are_reported_not_forced(robot):
    import copy

    # a head whose torque limit is below what gravity alone asks of it
    weak = copy.copy(robot)
    weak.tau_max = robot.tau_max.copy()
    weak.tau_max[robot.joint_names.index("head_1_joint")] = 1e-4
    t, q, contact, impacts = swinging_arms(robot, 0.25, 3.0)
    corrected, report = limit_upper_body(weak, t, q, contact=contact, impacts=impacts)
    assert np.all(np.isfinite(corrected))
    assert report["torque_ratio_after"] > 1.0  # says the limit is still broken
