"""Omnidirectional footsteps: the step parameters, their geometry and range, and step OCPs
that turn, side-step and step backward (issue #25, first part)."""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import replace
from types import SimpleNamespace

import h5py
import numpy as np
import pinocchio as pin
import pytest

from cocomopl.analysis.feasibility import check_motion
from cocomopl.data import BUNDLED_DATASET
from cocomopl.dataset.check import check_dataset
from cocomopl.errors import Error
from cocomopl.gait import (
    FEET_GAP,
    check_footstep,
    foot_separation,
    footstep_origin,
    footstep_pose,
    footsteps,
    sequence_specs,
)
from cocomopl.kinematics import double_support_posture, feet_distances, flat_placement, soles_distance
from cocomopl.motion import Footstep, StepSpec
from cocomopl.motion_file import read_motion_group, read_motions, write_motion_group
from cocomopl.ocp.problems import StepPlan, initial_guess, landing_point, landing_yaw, walk_phases
from cocomopl.ocp.solve import failed_checks, solve_plan, step_plan, to_motion, walk_segment, warm_up_plan
from cocomopl.primitives.estimator import MovementPrimitives
from cocomopl.primitives.model_file import load_model, save_model
from cocomopl.primitives.training import FOOTSTEP_PARAMETERS, load_training_steps, step_lengths, with_step_lengths
from cocomopl.robot import mirror_motion
from cocomopl.synthesis.step_chain import OutOfSupportWarning, generate_steps, in_next_step_frame
from cocomopl.synthesis.world import place_steps
from cocomopl.validation import check_steps

from conftest import SMALL, TURNED

# a steady turn of 15 degrees a step: the left sole toes out, the right one follows toeing in
TURN = (Footstep(0.2, 0.0, math.radians(15)), Footstep(0.2, 0.0, math.radians(-15)))
TURNING = StepSpec("transition", 0.2, 0.25, "left", start_width=0.02, end_width=0.1,
                   start_turn=math.radians(-10), end_turn=math.radians(20))


def sole_pose(robot, q: np.ndarray, side: str) -> np.ndarray:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    placement = data.oMf[robot.foot_frames[side]]
    return np.array([*placement.translation[:2], math.atan2(placement.rotation[1, 0], placement.rotation[0, 0])])


def test_a_straight_step_is_written_as_before_and_an_omnidirectional_one_round_trips(tmp_path):
    straight = StepSpec("cyclic", 0.2, 0.2)
    assert straight.straight and set(straight.as_dict()) == {"kind", "start_length", "end_length", "swing_side"}
    assert straight.name == "cyclic_200_L"
    assert not TURNING.straight and TURNING.name == "transition_200_250_w20_100_t-10_20_L"
    with h5py.File(BUNDLED_DATASET) as f:
        first = read_motion_group(f["motions"][next(iter(f["motions"]))])
    motion = replace(first, steps=[TURNING])
    with h5py.File(tmp_path / "m.h5", "w") as f:
        write_motion_group(f.create_group("m"), motion)
    with h5py.File(tmp_path / "m.h5") as f:
        assert read_motion_group(f["m"]).steps == [TURNING]


@pytest.mark.parametrize("bad", [{"end_turn": float("nan")}, {"start_width": float("inf")}, {"end_width": "0.1"}])
def test_a_step_with_a_footstep_that_is_not_a_finite_number_is_refused(bad):
    with pytest.raises(ValueError, match="finite numbers"):
        StepSpec("cyclic", 0.2, 0.2, **bad)


def test_a_mirrored_step_keeps_its_footsteps_and_lands_as_the_mirror_image(robot):
    separation = foot_separation(robot)
    mirrored = TURNING.mirrored()
    assert mirrored.omni_parameters() == TURNING.omni_parameters() and mirrored.mirrored() == TURNING
    left = footstep_pose(np.zeros(3), "left", (0.25, 0.1, math.radians(20)), separation=separation)
    right = footstep_pose(np.zeros(3), "right", (0.25, 0.1, math.radians(20)), separation=separation)
    np.testing.assert_allclose(right, left * [1, -1, -1])  # reflected in the sagittal plane
    assert left[1] > separation and left[2] > 0  # outward and toes out, to the left


def test_footstep_origin_inverts_footstep_pose():
    rng = np.random.default_rng(0)
    for side in ("left", "right"):
        for _ in range(20):
            other = rng.uniform([-1, -1, -np.pi], [1, 1, np.pi])
            step = rng.uniform([-0.15, -0.02, -0.4], [0.4, 0.15, 0.4])
            landed = footstep_pose(other, side, step, separation=0.17)
            np.testing.assert_allclose(footstep_origin(landed, side, step, separation=0.17), other, atol=1e-12)


def test_a_straight_footstep_is_exactly_the_old_arithmetic():
    assert footstep_pose(np.array([0.3, -0.085, 0.0]), "left", (0.25, 0.0, 0.0),
                         separation=0.17).tolist() == [0.3 + 0.25, -0.085 + 0.17, 0.0]


def test_footsteps_out_of_range_or_colliding_are_refused_in_one_line(robot):
    check_footstep(robot, "left", (0.2, 0.0, math.radians(25)))  # a forward step leaves the heels room to turn
    check_footstep(robot, "right", (-0.15, 0.15, math.radians(-25)))
    for args, message in [((0.5, 0.0, 0.0), "length 500 mm is outside -150..400 mm"),
                          ((0.2, 0.2, 0.0), "width 200 mm is outside"),
                          ((0.2, 0.0, math.radians(30)), "turn 30 deg is outside -25..25 deg"),
                          ((0.0, -0.03, 0.0), "puts the left foot"),
                          ((0.0, 0.0, math.radians(25)), "puts the left foot")]:
        with pytest.raises(Error, match=message) as info:
            check_footstep(robot, "left", args)
        assert "\n" not in str(info.value)


def test_a_footstep_a_rounding_past_a_bound_is_allowed_and_one_further_is_refused(robot):
    """A footstep file's landings are rounded world poses: a footstep 150 mm back, at the
    range's bound, is read back a micrometre past it, and still walks."""
    check_footstep(robot, "right", (-0.150001, 0.053, math.radians(13.2)))
    check_steps([StepSpec("transition", 0.2, -0.150001)])  # and a motion file of that walk reads back
    with pytest.raises(Error, match=re.escape("length -151 mm is outside -150..400 mm")):
        check_footstep(robot, "right", (-0.151, 0.053, math.radians(13.2)))
    with pytest.raises(Error, match=re.escape("turn 25.1 deg is outside")):
        check_footstep(robot, "right", (0.2, 0.05, math.radians(25.1)))
    with pytest.raises(Error, match=re.escape("length -0.151, not a number of metres in -0.15..0.8")):
        check_steps([StepSpec("transition", 0.2, -0.151)])


def test_soles_distance_measures_the_gap_between_the_feet(robot):
    separation = foot_separation(robot)
    beside = soles_distance(robot, {"right": flat_placement(0, 0, 0), "left": flat_placement(0, separation, 0)})
    closer = soles_distance(robot, {"right": flat_placement(0, 0, 0), "left": flat_placement(0, separation - 0.01, 0)})
    assert beside > FEET_GAP and closer == pytest.approx(beside - 0.01, abs=1e-6)


def test_the_phases_of_a_turning_stop_close_the_feet_up_parallel(robot):
    separation = foot_separation(robot)
    stop = StepSpec("stop", 0.2, 0.0, start_width=0.05, start_turn=math.radians(15))
    phases = walk_phases([stop], separation, SMALL)
    first, second = [p for p in phases if p.kind == "ss"]
    # the left sole starts where the right one's footstep (the stop's start footstep) came from
    np.testing.assert_allclose(footstep_pose(np.array([*first.swing_from, first.yaw_from]), "right",
                                             (0.2, 0.05, math.radians(15)), separation=separation), [0, 0, 0],
                                             atol=1e-12)
    # then lands the same footstep again and the right sole closes up beside it, parallel
    landed = footstep_pose(np.zeros(3), "left", (0.2, 0.05, math.radians(15)), separation=separation)
    np.testing.assert_allclose([*first.swing_to, first.yaw_to], landed)
    np.testing.assert_allclose([*landing_point(phases), landing_yaw(phases)],
                               footstep_pose(landed, "right", (0.0, 0.0, 0.0), separation=separation))
    assert second.yaw_to == pytest.approx(landed[2])


@pytest.mark.slow
@pytest.mark.parametrize("footstep", [(0.2, 0.0, 20.0), (0.0, 0.12, 0.0), (-0.12, 0.0, 0.0)],
                         ids=["turning", "sideways", "backward"])
def test_a_start_step_turns_side_steps_or_steps_back_and_its_mirror_image_the_other_way(robot, footstep):
    length, width, turn = footstep[0], footstep[1], math.radians(footstep[2])
    separation = foot_separation(robot)
    spec = StepSpec("start", 0.0, length, end_width=width, end_turn=turn)
    x0 = robot.state_from_posture(double_support_posture(robot, (0.0, separation), (0.0, 0.0)))
    solution = solve_plan(robot, StepPlan(spec, walk_phases([spec], separation, SMALL), x0), SMALL)
    assert solution.stats["converged"]
    assert failed_checks(robot, solution, SMALL)[0] == []  # dynamics, friction, ZMP in the (turned) soles
    motion = to_motion(robot, solution, SMALL)
    landed = footstep_pose(np.zeros(3), "left", (length, width, turn), separation=separation)
    np.testing.assert_allclose(sole_pose(robot, motion.q[-1], "left"), landed, atol=2e-3)
    np.testing.assert_allclose(sole_pose(robot, motion.q[-1], "right"), [0, 0, 0], atol=2e-3)
    mirrored = mirror_motion(robot, motion)
    assert mirrored.steps == [spec.mirrored()]
    np.testing.assert_allclose(sole_pose(robot, mirrored.q[-1], "right"), landed * [1, -1, -1], atol=2e-3)
    again = mirror_motion(robot, mirrored)
    np.testing.assert_allclose(again.q, motion.q, atol=1e-12)
    np.testing.assert_allclose(again.tau, motion.tau, atol=1e-12)


def gait_state_geometry(robot, footstep: Footstep) -> np.ndarray:
    """A standing state with the soles as a gait state ``S`` of ``footstep`` has them: the
    right sole at the origin, the left one where the right one's footstep came from."""
    left = footstep_origin(np.zeros(3), "right", footstep, separation=foot_separation(robot))
    return robot.state_from_posture(double_support_posture(robot, left[:2], (0.0, 0.0), yaws=(left[2], 0.0)))


def test_a_transition_between_footsteps_is_held_to_the_next_gait_state_where_the_sole_landed(robot):
    a, b = Footstep(0.2, 0.0, math.radians(15)), Footstep(0.15, 0.05, math.radians(-10))
    states = {f.gait_key: gait_state_geometry(robot, f) for f in (a, b)}
    plan = step_plan(robot, StepSpec.between("transition", a, b), states, settings=SMALL)
    nq = robot.model.nq
    np.testing.assert_allclose(sole_pose(robot, plan.x0[:nq], "left"),
                               footstep_origin(np.zeros(3), "right", a, separation=foot_separation(robot)), atol=1e-4)
    landed = footstep_pose(np.zeros(3), "left", b, separation=foot_separation(robot))
    # the next step stands on the left sole that landed, and its swing sole is the right one
    np.testing.assert_allclose(sole_pose(robot, plan.x_target[:nq], "left"), landed, atol=1e-4)
    np.testing.assert_allclose(sole_pose(robot, plan.x_target[:nq], "right"), [0, 0, 0], atol=1e-4)


def test_a_turning_warm_up_walk_ends_at_rest_and_its_segments_are_in_their_step_frames(robot):
    footstep = Footstep(0.2, 0.05, math.radians(15))
    separation = foot_separation(robot)
    plan = warm_up_plan(robot, footstep, SMALL)
    nq = robot.model.nq
    impacts = [p for p in plan.phases if p.kind == "impact"]
    for side in ("left", "right"):
        last = next(p for p in reversed(impacts) if p.swing == side)
        np.testing.assert_allclose(sole_pose(robot, plan.x_target[:nq], side), [*last.swing_to, last.yaw_to], atol=1e-4)
    assert np.all(plan.x_target[nq:] == 0)
    walk = SimpleNamespace(plan=plan, xs=initial_guess(robot, plan.phases, plan.x0, settings=SMALL))
    # the second cyclic step stands on the right sole, the stop's first step on the left one (mirrored)
    for kind in ("cyclic", "stop"):
        first = walk_segment(robot, walk, kind)[0][:nq]
        np.testing.assert_allclose(sole_pose(robot, first, "right"), [0, 0, 0], atol=2e-3)
        np.testing.assert_allclose(sole_pose(robot, first, "left"),
                                   footstep_origin(np.zeros(3), "right", footstep, separation=separation),
                                   atol=2e-3)


@pytest.mark.slow  # solves the turning dataset (about 2 minutes on 2 cores)
def test_a_turning_footstep_is_solved_mirrored_and_passes_every_check_of_the_dataset(robot, turning_dataset):
    motions, attrs = read_motions(turning_dataset, dataset=True)
    rest = Footstep(0.0)
    specs = [StepSpec.between("cyclic", TURNED, TURNED), StepSpec.between("start", rest, TURNED),
             StepSpec.between("stop", TURNED, rest)]
    assert sorted(motions) == sorted(n for s in specs for n in (s.name, s.mirrored().name))
    assert attrs["footsteps_m_rad"] == [list(TURNED)] and attrs["all_converged"]
    report = check_dataset(robot, motions, SMALL.friction, dt=SMALL.dt)
    assert report["ok"] and report["junctions"] == 8, report["worst"]  # continuity at every junction included
    separation = foot_separation(robot)
    # the left sole toes out 15 degrees; the right one, mirrored, lands turned the other way
    step = motions[StepSpec.between("cyclic", TURNED, TURNED).name]
    np.testing.assert_allclose(sole_pose(robot, step.q[-1], "left"),
                               footstep_pose(np.zeros(3), "left", TURNED, separation=separation),
                               atol=2e-3)
    mirrored = motions[StepSpec.between("cyclic", TURNED, TURNED, swing_side="right").name]
    np.testing.assert_allclose(sole_pose(robot, mirrored.q[-1], "right"),
                               footstep_pose(np.zeros(3), "right", TURNED, separation=separation), atol=2e-3)


@pytest.mark.slow  # solves the turning dataset (about 2 minutes on 2 cores)
def test_turning_feet_swing_clear_of_each_other(robot, turning_dataset):
    """The feet's meshes keep the gap a landing needs (FEET_GAP) all through every turning
    step, swings included: the stop's closing foot turns past the other, whose heel points
    into its path (a clearance on the swing sole's centre alone let 400 mm steps turning 25
    degrees swing through the stance foot)."""
    motions, _ = read_motions(turning_dataset, dataset=True)
    for name, motion in motions.items():
        assert feet_distances(robot, motion.q).min() >= FEET_GAP - 1e-3, name


def test_step_parameters_of_a_footstep_read_back_and_a_model_of_straight_steps_refuses_a_turn():
    z = step_lengths(TURNING, FOOTSTEP_PARAMETERS)
    back = with_step_lengths(StepSpec("transition", 0.0, 0.0), z)
    np.testing.assert_allclose([back.start_length, back.end_length, *back.omni_parameters()],
                               [TURNING.start_length, TURNING.end_length, *TURNING.omni_parameters()], atol=1e-15)
    straight = StepSpec("cyclic", 0.2, 0.2)
    assert step_lengths(straight).tolist() == [0.2, 0.2]
    assert step_lengths(straight, FOOTSTEP_PARAMETERS).tolist() == [0.2, 0.2, 0, 0, 0, 0]
    with pytest.raises(Error, match="turns or side-steps, and the model knows straight steps only"):
        step_lengths(TURNING)


@pytest.fixture(scope="module")
def turning_model(turning_dataset):
    steps = load_training_steps(turning_dataset)
    return steps, MovementPrimitives(n_primitives=3, kernel="matern52", n_grid=30, max_iterations=20).fit(steps)


@pytest.mark.slow  # solves the turning dataset (about 2 minutes on 2 cores)
def test_a_model_of_footsteps_predicts_its_training_turns_and_round_trips_through_its_file(tmp_path, turning_model):
    steps, model = turning_model
    assert model.lengths_.shape[-1] == FOOTSTEP_PARAMETERS
    turn = StepSpec.between("cyclic", TURNED, TURNED)
    step = model.predict(turn)
    assert step.distance == 0.0 and step.in_support
    X, X_hat = model.reconstruct(steps)
    k = steps.specs.index(turn)
    assert np.sqrt(np.mean((X[k] - X_hat[k]) ** 2)) < 0.5 * np.sqrt(np.mean((X[k] - X.mean(axis=0)) ** 2))
    save_model(tmp_path / "m.npz", model, {"dataset": {}})
    again = load_model(tmp_path / "m.npz")
    np.testing.assert_array_equal(again.predict(turn).values, step.values)


def test_the_footsteps_of_a_turning_walk_chain_and_a_straight_walk_keeps_its_old_arithmetic(robot):
    separation = foot_separation(robot)
    left, right = TURN
    specs = [StepSpec.between("start", Footstep(0.0), left),
             StepSpec.between("transition", left, right, swing_side="right"),
             StepSpec.between("stop", right, Footstep(0.0))]
    feet = footsteps(robot, specs)
    # the right sole lands the right footstep from where the left one landed, and so on
    pose = {side: np.array([*feet[0]["end"][side][:2], feet[0]["yaw"]["end"][side]]) for side in ("left", "right")}
    np.testing.assert_allclose(pose["left"],
                               footstep_pose(np.array([0, -separation / 2, 0]), "left", left, separation=separation))
    landed = footstep_pose(pose["left"], "right", right, separation=separation)
    np.testing.assert_allclose([*feet[1]["end"]["right"][:2], feet[1]["yaw"]["end"]["right"]], landed)
    assert feet[1]["yaw"]["end"]["right"] == pytest.approx(math.radians(30))  # a steady turn: 15 degrees a step
    # the stop lands its footstep again and closes the other sole up beside it, parallel
    assert feet[2]["yaw"]["end"]["left"] == feet[2]["yaw"]["end"]["right"] == pytest.approx(math.radians(15))
    straight = footsteps(robot, sequence_specs([0.15, 0.25, 0.25]))
    assert [f["end"]["left"][0] for f in straight] == [0.15, 0.15, 0.65] and straight[-1]["end"]["right"][0] == 0.65
    assert {f["end"]["left"][1] for f in straight} == {separation / 2} and {f["end"]["right"][1] for f in straight} == {-separation / 2}
    assert all(yaw == 0.0 for f in straight for when in ("start", "end") for yaw in f["yaw"][when].values())


@pytest.mark.slow  # solves the turning dataset (about 2 minutes on 2 cores)
def test_a_step_is_conditioned_on_the_end_of_the_last_in_its_own_turned_frame(turning_model):
    _, model = turning_model
    end = np.arange(len(model.signal_names), dtype=float)
    yaw = model.signal_names.index("pelvis_yaw")
    left, right = TURN
    after_left = in_next_step_frame(model, StepSpec.between("start", Footstep(0.0), left), end)
    after_right = in_next_step_frame(model, StepSpec.between("transition", left, right, swing_side="right"), end)
    after_splay = in_next_step_frame(model, StepSpec.between("cyclic", left, left, swing_side="right"), end)
    assert after_left[yaw] == pytest.approx(end[yaw] - math.radians(15))  # the left sole toed out: turned left
    assert after_right[yaw] == pytest.approx(end[yaw] - math.radians(15))  # the right one toed in: turned left too
    assert after_splay[yaw] == pytest.approx(end[yaw] + math.radians(15))  # the right one toed out: turned right
    np.testing.assert_array_equal(np.delete(after_left, yaw), np.delete(end, yaw))
    assert in_next_step_frame(model, StepSpec("cyclic", 0.2, 0.2), end) is end


@pytest.mark.slow  # solves the turning dataset (about 2 minutes on 2 cores)
def test_a_turning_walk_is_placed_on_its_turned_footsteps(robot, turning_model):
    _, model = turning_model
    specs = [StepSpec.between("start", Footstep(0.0), TURNED),
             StepSpec.between("cyclic", TURNED, TURNED, swing_side="right"),
             StepSpec.between("stop", TURNED, Footstep(0.0))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutOfSupportWarning)
        walk = place_steps(robot, generate_steps(model, specs), dt=0.025)
    feet = footsteps(robot, specs)
    # every touchdown puts the sole on its planned, turned footstep
    for k, impact in enumerate(walk.impacts[:2]):
        side = specs[k].swing_side
        planned = [*feet[k]["end"][side][:2], feet[k]["yaw"]["end"][side]]
        np.testing.assert_allclose(sole_pose(robot, walk.q[impact + 1], side), planned, atol=1e-3)
    for side in ("left", "right"):
        planned = [*feet[-1]["end"][side][:2], feet[-1]["yaw"]["end"][side]]
        np.testing.assert_allclose(sole_pose(robot, walk.q[-1], side), planned, atol=1e-3)
    assert check_motion(robot, walk, SMALL.friction)["inverse_dynamics_residual"] < 1e-6


def test_a_motion_file_takes_backward_and_turning_steps_within_the_range_and_refuses_others():
    check_steps([StepSpec("start", 0.0, -0.12), TURNING, TURNING.mirrored()])
    for bad, words in [(StepSpec("start", 0.0, -0.3), "length -0.3, not a number of metres in -0.15..0.8"),
                       (replace(TURNING, end_turn=math.radians(40)), "has a turn of 0.698132, outside -0.436332..0.436332"),
                       (replace(TURNING, start_width=0.3), "has a width of 0.3, outside -0.05..0.165")]:
        with pytest.raises(Error, match=words):
            check_steps([bad])


def test_a_motion_file_is_checked_against_its_own_robots_footstep_range(tmp_path):
    """A G1 step as wide as TALOS may step is outside G1's range (scaled to its legs): a G1
    motion file holding one is refused naming G1's bounds, read as TALOS's it would pass."""
    from cocomopl.data import dataset_path
    from cocomopl.gait import FOOTSTEP_RANGE, footstep_range
    from cocomopl.robot import Robot

    g1 = Robot("g1")
    low, high = footstep_range(g1)["width"]
    wide = StepSpec("cyclic", 0.2, 0.2, start_width=FOOTSTEP_RANGE["width"][1], end_width=FOOTSTEP_RANGE["width"][1])
    assert high < wide.start_width
    check_steps([wide])  # within TALOS's range, the default
    with h5py.File(dataset_path(robot="g1")) as f:
        motion = replace(read_motion_group(f["motions"]["cyclic_150_L"], g1), steps=[wide])
    with h5py.File(tmp_path / "wide.h5", "w") as f:
        write_motion_group(f.create_group("m"), motion)
    with h5py.File(tmp_path / "wide.h5") as f, pytest.raises(Error, match=f"width of {wide.start_width:g}, outside {low:g}..{high:g}"):
        read_motion_group(f["m"], g1)
