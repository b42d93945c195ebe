"""Export to a robot: seqplay and CSV files, and the safety gate in front of them."""

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.dynamics import sole_placements
from cocomopl.errors import Error
from cocomopl.export.safety import FOOT_CLEARANCE, check_safe, safety_report
from cocomopl.export.seqplay import export_motion
from cocomopl.kinematics import double_support_posture
from cocomopl.motion_file import read_motion, write_motions

from test_cli_errors import assert_one_line_error, run_cli

DATASET = BUNDLED_DATASET


@pytest.fixture(scope="module")
def step():
    return read_motion(DATASET, "cyclic_250_L")


def test_seqplay_files_round_trip(robot, step, tmp_path):
    files = export_motion(robot, step, "seqplay", tmp_path / "walk")
    assert [f.suffix for f in files] == [".pos", ".zmp", ".hip", ".waist"]
    pos = np.loadtxt(tmp_path / "walk.pos")
    assert pos.shape[1] == 1 + robot.nu
    assert np.allclose(np.diff(pos[:, 0]), 0.005)  # the 5 ms control cycle
    keep = step.kept_samples()
    t = step.t[keep] - step.t[0]
    at_knots = np.searchsorted(pos[:, 0], t[:-1] - 1e-9)
    assert np.abs(pos[at_knots, 1:] - step.q[keep][:-1, 7:]).max() < 1e-5  # angles at the knots
    # the ZMP file is in the waist frame: back to the world, it is the motion's ZMP
    zmp, waist = np.loadtxt(tmp_path / "walk.zmp"), np.loadtxt(tmp_path / "walk.waist")
    world = np.array([w[:3] + pin.rpy.rpyToMatrix(w[3:]) @ z for z, w in zip(zmp[:, 1:], waist[:, 1:])])
    ok = np.all(np.isfinite(step.zmp[keep][:-1]), axis=1)
    assert np.abs(world[at_knots][ok] - step.zmp[keep][:-1][ok]).max() < 1e-5
    assert np.abs(waist[at_knots, 1:4] - step.q[keep][:-1, :3]).max() < 1e-5  # the pelvis position
    assert np.allclose(np.loadtxt(tmp_path / "walk.hip")[:, 1:], waist[:, 4:])


def test_csv_names_its_columns_with_units(robot, step, tmp_path):
    (path,) = export_motion(robot, step, "csv", tmp_path / "walk")
    header = path.read_text().splitlines()[0].split(",")
    assert header[0] == "t_s" and header[1] == f"{robot.joint_names[0]}_rad" and len(header) == 1 + robot.nu + 9
    assert np.loadtxt(path, delimiter=",", skiprows=1).shape[1] == len(header)


def test_export_into_an_unwritable_folder_raises_and_writes_nothing(robot, step, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    with pytest.raises(Error, match="cannot"):
        export_motion(robot, step, "seqplay", blocker / "walk")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


def test_a_solved_step_passes_the_gate(robot, step):
    assert check_safe(robot, step) == []
    report = safety_report(robot, step)
    assert report["zmp_margin"]["value"] > 0
    assert FOOT_CLEARANCE < report["foot_distance"]["value"] < 0.2  # the feet pass close, but clear
    assert report["joint_position_excess"]["value"] == 0.0 and report["torque_ratio"]["value"] <= 1.0


def test_the_gate_names_a_joint_beyond_its_limit(robot, step):
    q, tau = step.q.copy(), step.tau.copy()
    knee = robot.joint_names.index("leg_left_4_joint")
    q[10, 7 + knee] = robot.q_upper[knee] + 0.2
    ankle = robot.joint_names.index("leg_right_5_joint")
    tau[12, ankle] = 1.5 * robot.tau_max[ankle]
    reasons = check_safe(robot, dataclasses.replace(step, q=q, tau=tau))
    assert any("leg_left_4_joint" in r and "limits" in r for r in reasons)
    assert any("torque of leg_right_5_joint" in r and "1.50x" in r for r in reasons)


def test_the_gate_sees_feet_that_collide_on_the_ground(robot, step):
    crossed = double_support_posture(robot, (0.0, 0.03), (0.0, -0.03))  # soles 6 cm apart: they overlap
    reasons = check_safe(robot, dataclasses.replace(step, q=np.stack([crossed] * step.n)))
    assert any("feet" in r for r in reasons)


def test_the_gate_sees_a_swing_foot_that_hits_the_stance_foot_in_the_air(robot, step):
    q = step.q.copy()
    hip_roll = robot.joint_names.index("leg_left_2_joint")
    swing = ~step.contact[:, 0]
    q[swing, 7 + hip_roll] -= 0.2  # the left (swing) leg rolls inwards, into the right one
    swept = dataclasses.replace(step, q=q)
    feet = safety_report(robot, swept)["foot_distance"]
    assert feet["value"] < FOOT_CLEARANCE
    k = int(np.argmin(np.abs(step.t - feet["t"])))
    assert sole_placements(robot, q[k : k + 1])[0, 0, 2] > 0.01  # not a check in the ground plane only
    assert any("feet" in r for r in check_safe(robot, swept))


def test_cli_refuses_unsafe_unless_forced(robot, step, tmp_path):
    q = step.q.copy()
    q[10, 7] = robot.q_upper[0] + 0.3
    source = tmp_path / "unsafe.h5"
    write_motions(source, {"unsafe": dataclasses.replace(step, q=q)}, {"robot": robot.name})
    refused = run_cli("export", str(source), "--format", "seqplay", "--out", str(tmp_path / "out" / "walk"))
    assert_one_line_error(refused, "refused", robot.joint_names[0], "--force")
    assert not (tmp_path / "out").exists()
    forced = run_cli("export", str(source), "--format", "csv", "--out", str(tmp_path / "out" / "walk"), "--force")
    assert forced.returncode == 0 and (tmp_path / "out" / "walk.csv").exists()


def test_cli_bad_format_missing_file_unwritable_folder(tmp_path):
    out = str(tmp_path / "walk")
    assert_one_line_error(run_cli("export", DATASET, "--motion", "cyclic_250_L", "--format", "bvh", "--out", out), "bvh")
    assert_one_line_error(run_cli("export", "nope.h5", "--format", "csv", "--out", out), "not found")
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert_one_line_error(
        run_cli("export", DATASET, "--motion", "cyclic_250_L", "--format", "csv", "--out", str(blocker / "walk")), "cannot"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]
