"""Export to a robot: seqplay and CSV files, the safety gate in front of them, and the
robot's MuJoCo model as MJCF."""

import csv
import dataclasses
import itertools
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from cocomopl.dynamics import sole_placements
from cocomopl.errors import Error
from cocomopl.export import mjcf as mjcf_export
from cocomopl.export.mjcf import export_mjcf, export_model
from cocomopl.export.safety import FOOT_CLEARANCE, check_safe, safety_report
from cocomopl.export.seqplay import export_motion, written
from cocomopl.export.table import read_csv
from cocomopl.kinematics import double_support_posture
from cocomopl.motion_file import temp_name, write_motions
from cocomopl.pipeline import generate_walk
from cocomopl.requests import StraightSteps, WalkRequest
from cocomopl.sim.mujoco_model import build_sim_model

from conftest import assert_one_line_error, run_cli


@pytest.fixture(scope="module")
def walk():
    """A short generated walk, a start and a stop step from rest to rest, as a robot would play it."""
    return generate_walk(WalkRequest(StraightSteps([0.20, 0.20]))).motion


@pytest.fixture(scope="module")
def walk_file(walk, tmp_path_factory):
    path = tmp_path_factory.mktemp("walk") / "walk.h5"
    write_motions(path, {"walk": walk}, {"robot": walk.robot})
    return path


def bumped(motion, joint: int, height: float, t0: float, width: float = 0.4):
    """``motion`` with a smooth bump of ``height`` rad on ``joint`` around ``t0``: slow enough
    to pass the export's low-pass nearly unchanged."""
    q = motion.q.copy()
    q[:, 7 + joint] += height * np.exp(-(((motion.t - t0) / (width / 4)) ** 2))
    return dataclasses.replace(motion, q=q)


@pytest.mark.slow
def test_seqplay_files_round_trip(robot, walk, tmp_path):
    files, _ = export_motion(robot, walk, "seqplay", prefix=tmp_path / "walk")
    assert [f.suffix for f in files] == [".pos", ".zmp", ".hip", ".waist"]
    pos = np.loadtxt(tmp_path / "walk.pos")
    assert pos.shape[1] == 1 + robot.nu
    assert np.allclose(np.diff(pos[:, 0]), 0.005)  # the 5 ms control cycle
    keep = walk.kept_samples()
    at_knots = np.searchsorted(pos[:, 0], walk.t[keep] - walk.t[0] - 1e-9)
    # the simulator's reference: the knots' angles through a 15 Hz low-pass
    assert np.abs(pos[at_knots, 1:] - walk.q[keep, 7:]).max() < 0.02
    # the ZMP file is in the waist frame: back to the world, it is the motion's ZMP at its knots
    zmp, waist = np.loadtxt(tmp_path / "walk.zmp"), np.loadtxt(tmp_path / "walk.waist")
    world = np.array([w[:3] + pin.rpy.rpyToMatrix(w[3:]) @ z for z, w in zip(zmp[:, 1:], waist[:, 1:])])
    assert np.abs(world[at_knots] - walk.zmp[keep]).max() < 1e-4
    assert np.abs(waist[at_knots, 1:4] - walk.q[keep, :3]).max() < 0.01  # the pelvis position
    assert np.allclose(np.loadtxt(tmp_path / "walk.hip")[:, 1:], waist[:, 4:])


def read_table(path):
    """Header and (rows, columns) values of a CSV, read without the exporter's code."""
    with open(path, newline="") as f:
        header, *rows = list(csv.reader(f))
    return header, np.array(rows, dtype=float)


@pytest.mark.slow
def test_csv_names_its_columns_with_units(robot, walk, tmp_path):
    (path,), _ = export_motion(robot, walk, "csv", prefix=tmp_path / "walk")
    header, values = read_table(path)
    assert header[0] == "t_s" and header[1] == f"{robot.joint_names[0]}_rad"
    units = ("_s", "_rad", "_m", "_rad_s", "_Nm", "_N", "_contact")  # a contact flag is 0 or 1
    assert all(name.endswith(units) for name in header)
    for suffix in ("_rad", "_rad_s", "_Nm"):  # angles, velocities, torques of every joint
        assert all(f"{joint}{suffix}" in header for joint in robot.joint_names)
    assert [n for n in header if n.endswith("_N")] == [f"{s}_f{a}_N" for s in ("left", "right") for a in "xyz"]
    assert len(header) == 1 + 3 * robot.nu + 9 + 6 + 6 + 2 + 3 + 12 and values.shape[1] == len(header)


@pytest.mark.slow
def test_csv_velocities_and_torques_are_those_of_the_written_angles(robot, walk, tmp_path):
    (path,), report = export_motion(robot, walk, "csv", prefix=tmp_path / "walk")
    header, values = read_table(path)

    def block(suffix):
        return values[:, [header.index(f"{joint}{suffix}") for joint in robot.joint_names]]

    t, angles, velocities = values[:, 0], block("_rad"), block("_rad_s")
    assert np.abs(velocities[1:-1] - (angles[2:] - angles[:-2]) / (t[2:] - t[:-2])[:, None]).max() < 1e-3
    # the written torques are the inverse dynamics the gate recomputes from the written angles
    # (to 0.5 %: the gate differentiates the written 5 ms grid, the torques are the knots' resampled)
    assert report["written_torque_ratio"]["value"] == pytest.approx(report["torque_ratio"]["value"], rel=5e-3)
    # forces hold each kept knot's value until the next knot
    forces = values[:, [header.index(f"{s}_f{a}_N") for s in ("left", "right") for a in "xyz"]].reshape(-1, 2, 3)
    keep = walk.kept_samples()
    knots = walk.t[keep] - walk.t[0]
    for k, (start, end) in enumerate(itertools.pairwise(knots)):
        rows = (t >= start - 1e-9) & (t < end - 1e-9)
        assert rows.any() and np.abs(forces[rows] - walk.wrenches[keep[k], :, :3]).max() < 1e-5


@pytest.mark.slow
def test_export_into_an_unwritable_folder_raises_and_writes_nothing(robot, walk, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    with pytest.raises(Error, match="cannot"):
        export_motion(robot, walk, "seqplay", prefix=blocker / "walk")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


@pytest.mark.slow
def test_a_generated_walk_passes_the_gate_with_margins(robot, walk):
    reasons, report = check_safe(robot, written(robot, walk))
    assert reasons == []
    assert report["zmp_margin"]["value"] > 0
    assert FOOT_CLEARANCE < report["foot_distance"]["value"] < 0.2  # the feet pass close, but clear
    assert report["joint_position_excess"]["value"] <= 1e-3 and report["torque_ratio"]["value"] <= 1.0
    assert report["joint_velocity_ratio"]["value"] <= 1.0 and report["samples"] > 500


@pytest.mark.slow
def test_the_g1_default_walks_reference_zmp_stays_inside_its_soles():
    from cocomopl.analysis.feasibility import polygon_margin, support_polygon

    walk = generate_walk(WalkRequest(StraightSteps(), robot="g1"))
    motion, g1 = walk.motion, walk.robot
    # the primitives smooth the ZMP's jump at each touchdown; on the G1's 50 mm soles the
    # sample before one left the stance sole by 33 mm, and the gate refused the walk, before
    # it was held inside
    margins = [polygon_margin(support_polygon(g1, motion.q[k], motion.contact[k]), motion.zmp[k, :2])
               for k in range(motion.n) if motion.contact[k].any()]
    assert min(margins) >= 0.0


@pytest.mark.slow
def test_the_gate_names_a_joint_beyond_its_limit(robot, walk):
    knee = robot.joint_names.index("leg_left_4_joint")
    q = walk.q.copy()
    q[:, 7 + knee] = robot.q_upper[knee] + 0.2
    reasons, _ = check_safe(robot, written(robot, dataclasses.replace(walk, q=q)))
    assert any("leg_left_4_joint goes 0.200 rad beyond its limits" in r for r in reasons)


@pytest.mark.slow
def test_stored_velocities_and_torques_do_not_fool_the_gate(robot, walk):
    """The gate recomputes both from the written angles: zeroing the stored ones changes nothing."""
    quiet = dataclasses.replace(walk, v=np.zeros_like(walk.v), tau=np.zeros_like(walk.tau))
    assert safety_report(robot, written(robot, quiet)) == safety_report(robot, written(robot, walk))
    elbow = robot.joint_names.index("arm_left_4_joint")
    fast = bumped(walk, elbow, -1.2, t0=1.0, width=0.1)  # a jerk of the elbow: velocity and torque
    reasons, _ = check_safe(robot, written(robot, dataclasses.replace(fast, v=walk.v, tau=walk.tau)))
    assert any("arm_left_4_joint" in r and ("velocity" in r or "torque" in r) for r in reasons)


@pytest.mark.slow
def test_the_gate_sees_feet_that_collide_on_the_ground(robot, walk):
    crossed = double_support_posture(robot, (0.0, 0.03), (0.0, -0.03))  # soles 6 cm apart: they overlap
    reasons, _ = check_safe(robot, written(robot, dataclasses.replace(walk, q=np.stack([crossed] * walk.n))))
    assert any("feet" in r for r in reasons)


@pytest.mark.slow
def test_the_gate_sees_a_swing_foot_that_hits_the_stance_foot_in_the_air(robot, walk):
    hip_roll = robot.joint_names.index("leg_left_2_joint")
    first_left_swing = walk.phases[1]
    t0 = walk.t[(first_left_swing[1] + first_left_swing[2]) // 2]
    swept = bumped(walk, hip_roll, -0.25, t0)  # the left (swing) leg rolls inwards, into the right one
    reasons, report = check_safe(robot, written(robot, swept))
    assert report["foot_distance"]["value"] < FOOT_CLEARANCE and any("feet" in r for r in reasons)
    k = int(np.argmin(np.abs(swept.t - t0)))
    assert sole_placements(robot, swept.q[k : k + 1])[0, 0, 2] > 0.01  # not a check in the ground plane only


@pytest.mark.slow
def test_nan_is_never_exported_even_when_forced(robot, walk, tmp_path):
    q = walk.q.copy()
    q[40, 7 + 3] = np.nan
    with pytest.raises(Error, match="NaN"):
        export_motion(robot, dataclasses.replace(walk, q=q), "csv", prefix=tmp_path / "walk", force=True)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_what_is_exported_passes_the_gate_read_back(robot, walk, tmp_path, seed):
    """Property: a written file holds no NaN or Inf and no sample the gate, run again on the
    file itself, would refuse.  Random edits of a safe walk, some of them unsafe."""
    rng = np.random.default_rng(seed)
    joint = int(rng.integers(robot.nu))
    edited = bumped(walk, joint, float(rng.normal(0.0, 0.6)), t0=float(rng.uniform(0.5, walk.t[-1] - 0.5)),
                    width=float(rng.uniform(0.05, 0.6)))
    try:
        (path,), _ = export_motion(robot, edited, "csv", prefix=tmp_path / "walk")
    except Error as exc:
        assert "refused" in str(exc) and not tmp_path.joinpath("walk.csv").exists()
        return
    text = path.read_text()
    assert "nan" not in text.lower() and "inf" not in text.lower()
    assert check_safe(robot, read_csv(text, robot.joint_names))[0] == []


@pytest.mark.slow
def test_cli_refuses_unsafe_unless_forced_and_names_the_robot_it_checks(robot, walk, tmp_path):
    source = tmp_path / "unsafe.h5"
    knee = robot.joint_names.index("leg_left_4_joint")
    q = walk.q.copy()
    q[:, 7 + knee] = robot.q_upper[knee] + 0.3
    write_motions(source, {"unsafe": dataclasses.replace(walk, q=q)}, {"robot": robot.name})
    refused = run_cli("export", str(source), "--format", "seqplay", "--out", str(tmp_path / "out" / "walk"))
    assert_one_line_error(refused, "refused", "leg_left_4_joint", "--force")
    assert not (tmp_path / "out").exists()
    forced = run_cli("export", str(source), "--format", "csv", "--out", str(tmp_path / "out" / "walk"), "--force")
    assert forced.returncode == 0 and (tmp_path / "out" / "walk.csv").exists()
    other = run_cli("export", str(source), "--format", "csv", "--out", str(tmp_path / "o2" / "walk"), "--robot", "romeo")
    assert_one_line_error(other, "talos", "romeo")


@pytest.mark.slow
def test_cli_prints_what_the_gate_checked(walk_file, tmp_path):
    done = run_cli("export", str(walk_file), "--format", "csv", "--out", str(tmp_path / "walk"))
    assert done.returncode == 0, done.stderr
    assert "safety gate passed: checked" in done.stdout and "mm inside the support polygon" in done.stdout


@pytest.mark.slow
def test_cli_bad_format_missing_file_unwritable_folder(walk_file, tmp_path):
    out = str(tmp_path / "walk")
    assert_one_line_error(run_cli("export", str(walk_file), "--format", "bvh", "--out", out), "bvh")
    assert_one_line_error(run_cli("export", "nope.h5", "--format", "csv", "--out", out), "not found")
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    assert_one_line_error(run_cli("export", str(walk_file), "--format", "csv", "--out", str(blocker / "walk")), "cannot")
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


def _stands(model, data) -> tuple[float, float, float]:
    """Step ``data`` 0.5 s with its servo commands as they are: how far the base height strays
    (m), how high the soles end (m), and the floor's normal force over the robot's weight."""
    height, strayed = data.qpos[2], 0.0
    for _ in range(round(0.5 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        strayed = max(strayed, abs(data.qpos[2] - height))
    force, normal = np.zeros(6), 0.0
    for i in range(data.ncon):
        assert {model.geom(data.contact[i].geom1).name, model.geom(data.contact[i].geom2).name} in (
            {"floor", "left_sole"}, {"floor", "right_sole"})
        mujoco.mj_contactForce(model, data, i, force)
        normal += force[0]
    soles = max(abs(data.site(f"{side}_sole").xpos[2]) for side in ("left", "right"))
    return strayed, soles, normal / (model.body_mass.sum() * -model.opt.gravity[2])


def test_mjcf_stands_as_loaded_and_at_its_home_keyframe(robot, talos_mjcf):
    """As MuJoCo users load a model: as it is (every joint and servo command at zero) or reset
    to the keyframe ``home`` (the reference posture, with the servo commands that hold it),
    stepped, it stands on its soles and the floor carries its weight."""
    model = mujoco.MjModel.from_xml_path(talos_mjcf["output"])
    home = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, home, model.key("home").id)
    np.testing.assert_allclose(home.qpos, build_sim_model(robot, visuals=False).qpos(robot.q_ref), atol=1e-8)
    np.testing.assert_allclose(home.ctrl, robot.q_ref[7:], atol=1e-8)
    for data in (mujoco.MjData(model), home):
        strayed, soles, load = _stands(model, data)
        assert strayed < 0.002 and soles < 0.002 and abs(load - 1) < 0.01, (strayed, soles, load)


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


def test_a_killed_mjcf_exports_leftover_is_removed_by_the_next(robot, tmp_path, monkeypatch):
    """What a SIGKILL leaves (a temporary meshes folder with a dead writer's pid) goes at the next export there."""
    finished = subprocess.Popen([sys.executable, "-c", ""])
    finished.wait()
    monkeypatch.setattr(os, "getpid", lambda: finished.pid)
    stranded = temp_name(tmp_path / "talos-meshes")
    monkeypatch.undo()
    stranded.mkdir()
    (stranded / "half.stl").write_text("")
    monkeypatch.setattr(mjcf_export.shutil, "copyfile", lambda source, target: Path(target).write_text(""))
    export_mjcf(robot, tmp_path / "talos.xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["talos-meshes", "talos.xml"]


def test_export_model_refuses_an_unknown_format_and_a_folder(tmp_path):
    with pytest.raises(Error, match=r"urdf.*mjcf"):
        export_model("talos", "urdf", tmp_path / "talos.urdf")
    with pytest.raises(Error, match="directory"):
        export_model("talos", "mjcf", tmp_path)
    assert list(tmp_path.iterdir()) == []
