"""Step OCPs: the solutions obey the dynamics, the constraints and each other (continuity).

Everything is checked on the small dataset of conftest.py, recomputed with Pinocchio.
"""

import numpy as np
import pytest

from cocomopl.analysis.feasibility import check_motion, tolerances
from cocomopl.dataset.continuity import step_mismatch
from cocomopl.dataset.plan import successors
from cocomopl.dataset.signals import training_signals
from cocomopl.dynamics import finite_difference_accelerations, inverse_dynamics_residual
from cocomopl.motion_file import read_motions
from cocomopl.robot import mirror_motion

from conftest import SMALL

TOLERANCES = tolerances(SMALL.dt)


@pytest.fixture(scope="module")
def motions(small_dataset):
    return read_motions(small_dataset)[0]


def test_dataset_holds_solved_and_mirrored_steps(motions):
    names = set(motions)
    for kind in ("cyclic_200", "start_200", "stop_200"):
        assert {f"{kind}_L", f"{kind}_R"} <= names


def test_every_motion_obeys_inverse_dynamics(robot, motions):
    for name, m in motions.items():
        report = check_motion(robot, m, SMALL.friction)
        assert report["inverse_dynamics_residual"] < TOLERANCES["inverse_dynamics_residual"], name


def test_zmp_stays_in_the_support_polygon(robot, motions):
    for name, m in motions.items():
        assert check_motion(robot, m, SMALL.friction)["zmp_margin"] >= 0.0, name


def test_limits_friction_and_unilateral_forces(robot, motions):
    for name, m in motions.items():
        r = check_motion(robot, m, SMALL.friction)
        assert r["torque_ratio"] <= TOLERANCES["torque_ratio"], name
        assert r["joint_position_excess"] <= TOLERANCES["joint_position_excess"], name
        assert r["joint_velocity_ratio"] <= 1.0, name
        assert r["friction_ratio"] <= 1.0, name
        assert r["min_normal_force"] >= 0.0, name
        assert r["stance_foot_slip"] <= TOLERANCES["stance_foot_slip"], name


def test_mirror_of_mirror_is_identity_and_mirrored_motion_is_dynamic(robot, motions):
    m = motions["cyclic_200_L"]
    mm = mirror_motion(robot, mirror_motion(robot, m))
    for key in ("q", "v", "tau", "wrenches", "zmp"):
        assert np.array_equal(getattr(mm, key), getattr(m, key))
    mirrored = motions["cyclic_200_R"]
    a = finite_difference_accelerations(mirrored.t, mirrored.v)
    keep = np.flatnonzero(np.diff(mirrored.t) > 0)
    res = inverse_dynamics_residual(
        robot, mirrored.q[keep], mirrored.v[keep], a[keep], mirrored.tau[keep], mirrored.wrenches[keep]
    )
    assert np.abs(res).max() < 1e-6


def test_consecutive_steps_join(robot, motions):
    by_spec = {m.steps[0]: m for m in motions.values()}
    pairs = [(s, n) for s in by_spec for n in successors(s, list(by_spec))]
    assert len(pairs) >= 4  # start->cyclic, cyclic->cyclic, cyclic->stop, both feet
    for spec, nxt in pairs:
        assert step_mismatch(robot, by_spec[spec], by_spec[nxt]) < TOLERANCES["continuity"], (spec, nxt)


def test_cyclic_step_ends_as_its_own_mirror_image(robot, motions):
    m = motions["cyclic_200_L"]
    assert step_mismatch(robot, m, motions["cyclic_200_R"]) < TOLERANCES["continuity"]


def test_training_signals_are_36_and_all_vary(robot, motions):
    sig = training_signals(robot, motions["cyclic_200_L"])
    assert sig["values"].shape[1] == 36
    assert np.all(np.diff(sig["t"]) > 0)
    zmp_pelvis = sig["values"][:, 30:33]
    assert np.all(zmp_pelvis.std(axis=0) > 1e-4)  # all three ZMP coordinates vary in the pelvis frame
    assert sig["phase_time"][0] == 0.0 and sig["phase_time"][-1] == 2.0
