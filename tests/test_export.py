"""Export to a robot: seqplay and CSV files, and the safety gate in front of them."""

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.export.safety import check_safe, foot_collision
from cocomopl.export.seqplay import export_motion
from cocomopl.motion_file import read_motion, write_motions
from cocomopl.ocp.posture import double_support_posture
from test_cli_errors import assert_one_line_error, run_cli

DATASET = "cocomopl/data/dataset.h5"


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
    assert np.allclose(np.loadtxt(tmp_path / "walk.hip")[:, 1:], waist[:, 4:])


def test_csv_names_its_columns_with_units(robot, step, tmp_path):
    (path,) = export_motion(robot, step, "csv", tmp_path / "walk")
    header = path.read_text().splitlines()[0].split(",")
    assert header[0] == "t_s" and header[1] == f"{robot.joint_names[0]}_rad" and len(header) == 1 + robot.nu + 9
    assert np.loadtxt(path, delimiter=",", skiprows=1).shape[1] == len(header)


def test_a_solved_step_passes_the_gate(robot, step):
    assert check_safe(robot, step) == []


def test_the_gate_names_a_joint_beyond_its_limit(robot, step):
    q = step.q.copy()
    knee = robot.joint_names.index("leg_left_4_joint")
    q[10, 7 + knee] = robot.q_upper[knee] + 0.2
    reasons = check_safe(robot, dataclasses.replace(step, q=q))
    assert any("leg_left_4_joint" in r and "limits" in r for r in reasons)


def test_the_gate_sees_feet_that_collide(robot, step):
    crossed = double_support_posture(robot, (0.0, 0.03), (0.0, -0.03))  # soles 6 cm apart: they overlap
    motion = dataclasses.replace(step, q=np.stack([crossed] * step.n))
    assert foot_collision(robot, motion) and "feet" in foot_collision(robot, motion)[0]
    assert foot_collision(robot, step) == []


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
