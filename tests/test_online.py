"""The streaming generator (cocomopl.online): commands, continuity, the causal filter's plan."""

import json
import math
import subprocess
import sys
from itertools import pairwise
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.analysis.feasibility import check_motion, tolerances, violations
from cocomopl.data import model_path
from cocomopl.dynamics import (
    SIDES,
    inverse_dynamics_with_contacts,
    sole_placements,
    total_wrench_zmp,
    zmp_from_wrenches,
)
from cocomopl.errors import Error
from cocomopl.export.safety import check_safe
from cocomopl.kinematics import leg_joints, place_legs
from cocomopl.motion import Footstep, StepSpec
from cocomopl.online import VelocityCommand, WalkingGenerator, command_range, grid_of
from cocomopl.online.commands import command_footstep, read_commands
from cocomopl.pipeline import generate_walk
from cocomopl.planning.footsteps import footstep_specs
from cocomopl.primitives.model_file import load_model, model_robot
from cocomopl.requests import PLAN_DT, Commands, WalkRequest
from cocomopl.synthesis.dynamics_filter import pelvis_shift_response, plan_zmp_error
from cocomopl.synthesis.step_chain import generate_steps, in_next_step_frame
from cocomopl.synthesis.world import place_steps

from conftest import assert_one_line_error, run_cli

FOOTSTEPS = [Footstep(0.2, 0.05, 0.2), Footstep(0.1, 0.0, -0.2)]


@pytest.fixture(scope="module")
def omni():
    return load_model(model_path(omni=True)).prepare()


def walk(generator, *, standing_s: float = 0.5, max_s: float = 20.0) -> list:
    """Ticks until the generator has walked and stood still again for ``standing_s``."""
    references, still = [], 0
    while generator.time < max_s:
        references.append(generator.tick())
        walked = any(r.step is not None for r in references)
        still = still + 1 if walked and references[-1].step is None else 0
        if still * generator.dt >= standing_s:
            return references
    raise AssertionError(f"the walk did not end within {max_s} s")


@pytest.fixture(scope="module")
def footstep_walk(omni):
    generator = WalkingGenerator(omni, model_robot(omni), keep_knots=True)
    generator.walk_footsteps(FOOTSTEPS)
    return generator, walk(generator)


def test_a_footstep_walk_streams_the_steps_of_its_footstep_plan(omni, footstep_walk):
    generator, references = footstep_walk
    streamed = [s for s in dict.fromkeys(r.step for r in references) if s is not None]
    assert streamed == footstep_specs(FOOTSTEPS, "left")
    assert generator.knot_motion().steps == streamed
    assert references[0].step is None and references[-1].step is None  # from standing to standing


def test_streamed_ticks_are_continuous_and_within_the_velocity_limits(omni, footstep_walk):
    generator, references = footstep_walk
    robot = model_robot(omni)
    q = np.array([r.q for r in references])
    step = np.array([pin.difference(robot.model, a, b) for a, b in pairwise(q)]) / generator.dt
    assert np.all(np.abs(step[:, 6:]) <= robot.v_max)
    v = np.array([r.v for r in references])
    # the streamed velocities are those of the streamed positions
    assert np.abs(0.5 * (step[:-1] + step[1:]) - v[1:-1]).max() < 0.05 * np.abs(v).max()


def test_the_streamed_plan_follows_its_reference_zmp_inside_the_soles(omni, footstep_walk):
    generator, _ = footstep_walk
    robot = model_robot(omni)
    plan = generator.knot_motion()
    assert plan_zmp_error(robot, plan) < 0.005
    assert check_motion(robot, plan, 0.7)["zmp_margin"] > 0.0


def test_the_export_gate_passes_every_streamed_sample_of_a_short_walk(omni, footstep_walk):
    _, references = footstep_walk
    reasons, report = check_safe(model_robot(omni), grid_of(references))
    assert reasons == []
    assert report["samples"] == len(references)


def test_a_command_changes_no_reference_before_it_and_none_abruptly(omni):
    robot = model_robot(omni)
    forward = WalkingGenerator(omni, robot)
    forward.command(VelocityCommand(0.15))
    turned = WalkingGenerator(omni, robot)
    turned.command(VelocityCommand(0.15))
    before = [forward.tick() for _ in range(1000)]
    after = [turned.tick() for _ in range(400)]
    turned.command(VelocityCommand(0.0, 0.0, 0.3))
    after += [turned.tick() for _ in range(600)]
    q0, q1 = np.array([r.q for r in before]), np.array([r.q for r in after])
    assert np.array_equal(q0[:401], q1[:401])  # a command changes only the future
    changed = np.flatnonzero(np.abs(q0 - q1).max(axis=1) > 1e-9)
    assert len(changed) and changed[0] > 401
    jumps = [np.abs(np.diff(q[:, 7:], axis=0)).max() for q in (q0, q1)]
    assert jumps[1] < 1.2 * jumps[0]  # no larger tick-to-tick change than the walk's own
    turning = [r.step for r in after[-200:] if r.step is not None]  # after the filter's preview, 1.5 s
    assert any(abs(s.end_turn) > 0 for s in turning)


def test_total_wrench_zmp_is_the_zmp_of_the_contact_wrenches(omni):
    robot = model_robot(omni)
    motion = place_steps(robot, generate_steps(omni, footstep_specs(FOOTSTEPS[:1], "left")), dt=0.025)
    v, _, wrenches = inverse_dynamics_with_contacts(robot, motion.t, motion.q, contact=motion.contact,
                                                    impacts=motion.impacts)
    data = robot.model.createData()
    expected = zmp_from_wrenches(sole_placements(robot, motion.q), wrenches)
    for k in range(1, motion.n - 1):
        if k in motion.impacts or k - 1 in motion.impacts or motion.t[k + 1] == motion.t[k]:
            continue
        a = (v[k + 1] - v[k]) / (motion.t[k + 1] - motion.t[k])
        assert np.allclose(total_wrench_zmp(robot, data, motion.q[k], v[k], a), expected[k, :2], atol=1e-9)


def test_pelvis_shift_response_predicts_a_small_static_shift(omni):
    robot = model_robot(omni)
    kappa, height = pelvis_shift_response(robot, robot.q_ref)
    assert 0.5 < kappa < 1.0 and height > 0.5
    data = robot.model.createData()
    soles = {side: robot.frame_placement(robot.q_ref, robot.foot_frames[side]) for side in SIDES}
    rest = np.zeros(robot.model.nv)
    before = total_wrench_zmp(robot, data, robot.q_ref, rest, rest)
    for axis in range(2):
        q = robot.q_ref.copy()
        q[axis] += 0.002
        q = place_legs(robot, q, soles, legs=leg_joints(robot))
        moved = total_wrench_zmp(robot, data, q, rest, rest) - before
        assert moved[axis] == pytest.approx(kappa * 0.002, rel=0.05)


def test_velocity_commands_become_footsteps_with_the_conventions_of_stepspec(omni):
    limits, period = omni.footstep_range(), 0.9
    left = command_footstep(VelocityCommand(0.2, 0.05, 0.2), "left", period=period, limits=limits)
    right = command_footstep(VelocityCommand(0.2, 0.05, 0.2), "right", period=period, limits=limits)
    assert left.length == right.length == pytest.approx(0.18)
    assert left.turn == pytest.approx(0.18) and right.turn == pytest.approx(-0.18)  # left toes out, right in
    assert left.width > 0.05 and right.width < left.width  # the left foot steps out to go left
    edges = command_range(period=period, limits=limits)
    beyond = VelocityCommand(10 * edges["forward"][1], 10 * edges["sideways"][1], 10 * edges["yaw_rate"][1])
    saturated = command_footstep(beyond, "left", period=period, limits=limits)
    assert saturated.length == limits["length"][1] and saturated.turn == limits["turn"][1]
    assert saturated.width <= limits["width"][1]
    assert command_footstep(VelocityCommand(), "left", period=period, limits=limits) == Footstep(0.0, 0.0, 0.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"dt": 0.0}, "control period"), ({"dt": 0.1}, "control period"), ({"plan_dt": 0.2}, "knot spacing"),
    ({"preview_s": 0.01}, "preview"), ({"passes": 0}, "filter passes"), ({"passes": True}, "filter passes"),
    ({"preview_s": True}, "preview"), ({"dt": "5 ms"}, "control period"),
])
def test_bad_generator_settings_are_refused_in_one_line(omni, kwargs, message):
    with pytest.raises(Error, match=message):
        WalkingGenerator(omni, model_robot(omni), **kwargs)


def test_a_velocity_command_must_be_finite():
    for bad in (math.nan, math.inf, "fast", True):
        with pytest.raises(Error, match="finite number"):
            VelocityCommand(forward=bad)
    assert VelocityCommand().is_stop and not VelocityCommand(yaw_rate=0.1).is_stop


def test_the_knot_motion_needs_the_knots_kept(omni):
    generator = WalkingGenerator(omni, model_robot(omni))
    with pytest.raises(Error, match="keep_knots"):
        generator.knot_motion()


@pytest.mark.slow  # the benchmark runs in a new process
def test_the_online_benchmark_refuses_an_unknown_robot_in_one_line():
    benchmark = Path(__file__).parents[1] / "benchmarks" / "online.py"
    result = subprocess.run([sys.executable, str(benchmark), "--robot", "nobody", "--json"], capture_output=True,
                            text=True, timeout=300)
    assert_one_line_error(result, "nobody")
    assert result.returncode == 2 and result.stdout == ""


HEADER = "t_s,forward_m_s,sideways_m_s,yaw_rate_deg_s\n"


def test_a_command_file_walks_its_commands_and_passes_the_checks(tmp_path):
    script = tmp_path / "script.csv"
    # turn on the spot, stand, walk on: a start after a turned stop
    script.write_text(HEADER + "0,0,0,15\n2,0,0,0\n3,0.15,0,0\n5,0,0,0\n")
    out = tmp_path / "walk.h5"
    result = run_cli("generate", "--commands", str(script), "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    walk = generate_walk(WalkRequest(Commands(tuple((t, c.forward, c.sideways, c.yaw_rate)
                                                    for t, c in read_commands(script)))))
    kinds = [s.kind for s in walk.motion.steps]
    assert kinds[0] == "start" and kinds[-1] == "stop" and kinds.count("start") == 2
    assert any(s.end_turn != 0 for s in walk.motion.steps)  # the turn command was walked
    yaw = np.unwrap([pin.rpy.matrixToRpy(pin.XYZQUATToSE3(q[:7]).rotation)[2] for q in walk.motion.q])
    assert np.abs(np.diff(yaw)).max() < math.radians(2)  # the walk on starts where the stop ended
    assert violations(check_motion(walk.robot, walk.motion, 0.7), tolerances(PLAN_DT)) == []
    assert run_cli("dataset", "check", str(out)).returncode == 0


@pytest.mark.parametrize("text, words", [
    ("t,forward\n0,0\n", ["header"]),
    (HEADER + "0,fast,0,0\n", ["row 2", "forward_m_s", "'fast'"]),
    (HEADER + "0,0.1,0,0\n0,0,0,0\n", ["row 3", "after the row before"]),
    (HEADER + "0,0.1,0,0\n", ["last command must be a stop"]),
    (HEADER + "0,0.1,0\n1,0,0,0\n", ["row 2", "3 values"]),
    (HEADER, ["no rows"]),
])
def test_bad_command_files_are_refused_in_one_line(tmp_path, text, words):
    script = tmp_path / "script.csv"
    script.write_text(text)
    result = run_cli("generate", "--commands", str(script), "--out", str(tmp_path / "walk.h5"))
    assert_one_line_error(result, *words)
    assert not (tmp_path / "walk.h5").exists()


def test_a_command_beyond_the_footsteps_is_refused_naming_it(tmp_path):
    script = tmp_path / "script.csv"
    script.write_text(HEADER + "0,0.1,0,0\n1,2.0,0,0\n3,0,0,0\n")
    result = run_cli("generate", "--commands", str(script), "--out", str(tmp_path / "walk.h5"))
    assert_one_line_error(result, "command 2", "forward 2 m/s", "outside")
    assert not (tmp_path / "walk.h5").exists()


def test_a_step_after_a_turned_stop_is_conditioned_in_the_frame_the_stop_ends_in(omni):
    turn = math.radians(10)
    yaw = omni.signal_names.index("pelvis_yaw")
    end = np.zeros(len(omni.signal_names))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        stop = StepSpec.between("stop", Footstep(0.2, 0.0, turn), Footstep(0.0), swing_side=side)
        assert in_next_step_frame(omni, stop, end)[yaw] == pytest.approx(-sign * turn)


@pytest.mark.slow  # a new process, MuJoCo live
def test_the_live_loop_example_runs_and_reports():
    loop = Path(__file__).parents[1] / "scripts" / "online_loop.py"
    result = subprocess.run([sys.executable, str(loop), "--seconds", "1", "--json"], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert not report["fell"] and report["seconds"] == pytest.approx(1.0, abs=0.01)
    assert report["tick_median_s"] > 0
    bad = subprocess.run([sys.executable, str(loop), "--seconds", "0"], capture_output=True, text=True, timeout=300)
    assert_one_line_error(bad, "--seconds")


def test_a_walk_started_and_stopped_before_it_moves_still_walks_its_step(omni):
    walk = generate_walk(WalkRequest(Commands(((0.0, 0.1, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)))))
    assert [s.kind for s in walk.motion.steps] == ["start", "stop"]
