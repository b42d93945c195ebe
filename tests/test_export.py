"""Export to a robot: seqplay and CSV files, the safety gate in front of them, and the
robot's MuJoCo model as MJCF."""

import csv
import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.dynamics import sole_placements
from cocomopl.errors import Error
from cocomopl.export import mjcf as mjcf_export
from cocomopl.export.mjcf import export_mjcf, export_model
from cocomopl.export.safety import FOOT_CLEARANCE, check_safe, safety_report
from cocomopl.export.seqplay import export_motion
from cocomopl.kinematics import double_support_posture
from cocomopl.motion_file import read_motion, write_motions
from cocomopl.sim.mujoco_model import build_sim_model

from conftest import assert_one_line_error, run_cli

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


def read_csv(path):
    """Header and (rows, columns) values of a CSV, read without the exporter's code."""
    with open(path, newline="") as f:
        header, *rows = list(csv.reader(f))
    return header, np.array(rows, dtype=float)


def test_csv_names_its_columns_with_units(robot, step, tmp_path):
    (path,) = export_motion(robot, step, "csv", tmp_path / "walk")
    header, values = read_csv(path)
    assert header[0] == "t_s" and header[1] == f"{robot.joint_names[0]}_rad"
    units = ("_s", "_rad", "_m", "_rad_s", "_Nm", "_N")
    assert all(name.endswith(units) for name in header)
    for suffix in ("_rad", "_rad_s", "_Nm"):  # angles, velocities, torques of every joint
        assert all(f"{joint}{suffix}" in header for joint in robot.joint_names)
    assert [n for n in header if n.endswith("_N")] == [f"{s}_f{a}_N" for s in ("left", "right") for a in "xyz"]
    assert len(header) == 1 + 3 * robot.nu + 9 + 6 and values.shape[1] == len(header)


def test_csv_round_trips_angles_velocities_torques_and_forces(robot, step, tmp_path):
    (path,) = export_motion(robot, step, "csv", tmp_path / "walk")
    header, values = read_csv(path)

    def block(suffix):
        return values[:, [header.index(f"{joint}{suffix}") for joint in robot.joint_names]]

    t, angles, velocities, torques = values[:, 0], block("_rad"), block("_rad_s"), block("_Nm")
    forces = values[:, [header.index(f"{s}_f{a}_N") for s in ("left", "right") for a in "xyz"]].reshape(-1, 2, 3)
    keep = step.kept_samples()
    knots = step.t[keep] - step.t[0]
    at_knots = np.searchsorted(t, knots - 1e-9)
    assert np.abs(t[at_knots] - knots).max() < 1e-6
    assert np.abs(angles[at_knots] - step.q[keep, 7:]).max() < 1e-5
    # velocities are the motion's, so they match the angles' slope up to the OC's integration error
    slope = np.diff(angles, axis=0) / np.diff(t)[:, None]
    mean_velocity = (velocities[1:] + velocities[:-1]) / 2
    assert np.linalg.norm(slope - mean_velocity) < 0.25 * np.linalg.norm(mean_velocity)
    # torques and forces hold each kept knot's value until the next knot
    for k, (start, end) in enumerate(zip(knots[:-1], knots[1:])):
        rows = (t >= start - 1e-9) & (t < end - 1e-9)
        assert rows.any()
        assert np.abs(torques[rows] - step.tau[keep[k]]).max() < 1e-5
        assert np.abs(forces[rows] - step.wrenches[keep[k], :, :3]).max() < 1e-5


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


@pytest.fixture(scope="module")
def talos_mjcf(tmp_path_factory):
    """TALOS exported over a stale export, and the summary :func:`export_model` returns."""
    folder = tmp_path_factory.mktemp("mjcf") / "out"
    (folder / "talos-meshes").mkdir(parents=True)
    (folder / "talos-meshes" / "stale.stl").write_text("")
    (folder / "talos.xml").write_text("stale")
    return export_model("talos", "mjcf", folder / "talos.xml")


def forward(model, qpos):
    """MuJoCo's data and dense mass matrix at ``qpos``."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    mass_matrix = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass_matrix)
    return data, mass_matrix


def test_mjcf_loads_anywhere_as_the_simulated_model(robot, talos_mjcf, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # mesh paths must not depend on the working folder
    exported = mujoco.MjModel.from_xml_path(talos_mjcf["output"])
    simulated = build_sim_model(robot, visuals=False)
    assert (exported.nq, exported.nv, exported.nu) == (simulated.mj.nq, simulated.mj.nv, simulated.mj.nu)
    assert (talos_mjcf["nq"], talos_mjcf["nv"], talos_mjcf["nu"]) == (robot.model.nq, robot.model.nv, robot.nu)
    actuated = [exported.joint(exported.actuator(i).trnid[0]).name for i in range(exported.nu)]
    assert actuated == [simulated.mj.joint(simulated.mj.actuator(i).trnid[0]).name for i in range(exported.nu)]
    assert actuated == robot.joint_names
    assert abs(exported.body_mass.sum() - robot.mass) < 1e-6 * robot.mass
    assert exported.nmesh > 0 and not (mjcf_export.mesh_folder(Path(talos_mjcf["output"])) / "stale.stl").exists()
    # same rigid bodies: the same mass matrix and sole positions at the reference posture
    data, mass_matrix = forward(exported, simulated.qpos(robot.q_ref))
    assert np.allclose(mass_matrix, forward(simulated.mj, simulated.qpos(robot.q_ref))[1], rtol=1e-9, atol=1e-12)
    for side in ("left", "right"):
        sole = robot.frame_placement(robot.q_ref, robot.foot_frames[side]).translation
        assert np.allclose(data.site(f"{side}_sole").xpos, sole, atol=1e-6)


def test_mjcf_into_an_unwritable_folder_raises_and_writes_nothing(robot, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    with pytest.raises(Error, match="cannot"):
        export_mjcf(robot, blocker / "talos.xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


def test_a_failed_mjcf_export_leaves_the_previous_one(robot, tmp_path, monkeypatch):
    (tmp_path / "talos-meshes").mkdir()
    (tmp_path / "talos-meshes" / "old.stl").write_text("old")
    (tmp_path / "talos.xml").write_text("old")
    copies = []

    def copy_then_fail(source, target):
        copies.append(target)
        if len(copies) == 3:
            raise OSError("disk full")
        Path(target).write_text("new")

    monkeypatch.setattr(mjcf_export.shutil, "copyfile", copy_then_fail)
    with pytest.raises(OSError, match="disk full"):
        export_mjcf(robot, tmp_path / "talos.xml")
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == [
        "talos-meshes", "talos-meshes/old.stl", "talos.xml"
    ]
    assert (tmp_path / "talos.xml").read_text() == "old"


def test_export_model_refuses_an_unknown_format_and_a_folder(tmp_path):
    with pytest.raises(Error, match="urdf.*mjcf"):
        export_model("talos", "urdf", tmp_path / "talos.urdf")
    with pytest.raises(Error, match="directory"):
        export_model("talos", "mjcf", tmp_path)
    assert list(tmp_path.iterdir()) == []
