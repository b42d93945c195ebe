"""The Kajita baseline: ZMP preview control of the cart-table, and the whole-body walk built on it."""

import json
import math
import re

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.analysis.feasibility import check_motion
from cocomopl.analysis.metrics import posture_statistics, swing_heights
from cocomopl.baselines.kajita import (
    DROP_SEARCH_RESOLUTION,
    LEGACY,
    KajitaSettings,
    default_durations,
    kajita_walk,
    smoothed,
    support_phases,
    swing_position,
    zmp_reference,
)
from cocomopl.baselines.preview_control import PreviewController
from cocomopl.dynamics import GRAVITY, SIDES, sole_placements
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.robot import Robot

DT = 0.005
HEIGHT = 0.85
SPECS = [StepSpec("start", 0.0, 0.2, "left"), StepSpec("stop", 0.2, 0.0, "right")]


@pytest.fixture(scope="module")
def controller():
    return PreviewController(DT, HEIGHT)


@pytest.fixture(scope="module")
def robot():
    return Robot("talos")


@pytest.fixture(scope="module")
def walk(robot):
    return kajita_walk(robot, SPECS, dt=0.025)


def test_gains_solve_the_riccati_equation(controller):
    A, B, Q, R = controller.augmented_system()
    P = controller.riccati
    BPB = R + B.T @ P @ B
    residual = A.T @ P @ A - P - A.T @ P @ B @ np.linalg.solve(BPB, B.T @ P @ A) + Q
    assert np.abs(residual).max() < 1e-6 * np.abs(P).max()
    gain = np.linalg.solve(BPB, B.T @ P @ A)[0]
    assert np.allclose(
        gain, np.concatenate([controller.gain_error, controller.gain_state])
    )
    closed_loop = A - B @ gain[None, :]
    assert np.abs(np.linalg.eigvals(closed_loop)).max() < 1.0
    assert len(controller.gain_preview) == round(1.6 / DT)


def test_com_converges_to_a_constant_reference(controller):
    reference = np.tile([0.05, -0.03], (int(3.0 / DT), 1))
    com, com_vel, com_acc, zmp = controller.track(reference, com_start=np.zeros(2))
    assert np.allclose(com[-1], reference[-1], atol=1e-4)
    assert np.abs(com_vel[-1]).max() < 1e-3
    assert np.allclose(zmp, com - HEIGHT / GRAVITY * com_acc)


def test_zmp_tracks_a_step_after_the_preview(controller):
    n, jump = int(5.0 / DT), int(2.0 / DT)
    reference = np.zeros((n, 2))
    reference[jump:] = [0.1, -0.08]
    com, _, _, zmp = controller.track(reference)
    error = np.abs(zmp - reference)
    # the preview moves the CoM ahead of the step, so the ZMP deviates far less than the step
    assert error.max() < 0.5 * np.abs(reference[-1]).min()
    assert error[jump + int(0.5 / DT) :].max() < 1e-3
    assert com[jump - 1, 0] > 0.01  # anticipation: the CoM moved before the step
    assert np.allclose(com[-1], reference[-1], atol=1e-3)


def test_swing_position_is_smooth_and_clears_the_ground():
    start, end = np.array([0.0, 0.1, 0.0]), np.array([0.3, 0.1, 0.0])
    s = np.linspace(0.0, 1.0, 201)
    path = np.array([swing_position(start, end, x, height=0.05) for x in s])
    assert np.allclose(path[0], start) and np.allclose(path[-1], end)
    assert np.isclose(path[:, 2].max(), 0.05) and path[:, 2].min() >= 0.0
    velocity = np.gradient(path, s, axis=0)
    assert np.abs(velocity[[0, -1]]).max() < 1e-2


def test_zmp_reference_is_on_the_stance_sole_in_single_support(robot):
    phases = support_phases(robot, SPECS, default_durations(SPECS))
    edges = np.concatenate([[0.0], np.cumsum([p.duration for p in phases])])
    for p, phase in enumerate(phases):
        if phase.kind != "ss":
            continue
        t = np.linspace(edges[p], edges[p + 1], 5)
        stance = phase.start[1 - SIDES.index(phase.swing)]
        zmp = zmp_reference(robot, phases, t)
        assert np.allclose(zmp[:, 1], stance[1])
        assert np.all(np.abs(zmp[:, 0] - stance[0]) < robot.sole.front)
    ends = zmp_reference(robot, phases, edges[[0, -1]])
    assert np.allclose(ends[:, 1], 0.0, atol=1e-6)


def test_durations_must_match_the_phases(robot):
    with pytest.raises(Error, match="phase durations"):
        kajita_walk(robot, SPECS, durations=[np.array([0.4, 0.8]), np.array([0.15, 0.8])])


@pytest.mark.slow
def test_unreachable_footsteps_are_refused(robot):
    too_long = [
        StepSpec("start", 0.0, 0.55, "left"),
        StepSpec("stop", 0.55, 0.0, "right"),
    ]
    with pytest.raises(Error, match="out of the legs' reach"):
        kajita_walk(robot, too_long, dt=0.05, settings=KajitaSettings(pelvis_drop=0.0))


@pytest.mark.slow
def test_walk_keeps_the_given_timing_between_standing_prelude_and_postlude(walk):
    durations = np.concatenate(default_durations(SPECS))
    durations[0] += KajitaSettings().prelude
    durations[-1] += KajitaSettings().postlude
    spans = [walk.t[last] - walk.t[first] for _, first, last in walk.phases]
    assert np.allclose(spans, durations)
    # the clock starts when the phases do: the prelude runs at negative times
    assert walk.t[0] == pytest.approx(-KajitaSettings().prelude)
    assert walk.meta["walking_span_s"] == pytest.approx([0.0, np.concatenate(default_durations(SPECS)).sum()])
    assert [kind for kind, _, _ in walk.phases] == ["ds", "ss"] * 3 + ["ds"]
    assert np.abs(walk.v[0]).max() < 1e-2  # it starts from rest
    assert np.abs(walk.v[-1]).max() < 1e-2  # and ends at rest


@pytest.mark.slow
def test_stance_soles_stay_on_the_footsteps(robot, walk):
    phases = support_phases(robot, SPECS, default_durations(SPECS))
    planned = {tuple(np.round(p.end[j], 6)) for p in phases for j in range(2)}
    soles = sole_placements(robot, walk.q)
    for k in range(walk.n):
        for j in range(2):
            if walk.contact[k, j]:
                nearest = min(
                    np.linalg.norm(soles[k, j] - np.array(f)) for f in planned
                )
                assert nearest < 1e-3
    # the walk ends with the feet together, as far forward as the steps took them
    assert np.allclose(soles[-1, :, 0], 0.2 + 0.2, atol=1e-3)
    pin_data = robot.model.createData()
    for q in walk.q[::10]:
        pin.framesForwardKinematics(robot.model, pin_data, q)
        for side in SIDES:
            assert np.allclose(
                pin_data.oMf[robot.foot_frames[side]].rotation, np.eye(3), atol=1e-3
            )


@pytest.mark.slow
def test_swing_sole_clears_the_ground(robot, walk):
    soles = sole_placements(robot, walk.q)
    for kind, first, last in walk.phases:
        if kind == "ss":
            air = np.flatnonzero(~walk.contact[first + 1])[0]
            assert soles[first : last + 1, air, 2].max() > 0.04


@pytest.mark.slow
def test_com_follows_the_preview_and_zmp_stays_in_the_support(robot, walk):
    assert walk.producer == "kajita"
    assert walk.meta["zmp_reference_rms_m"] < 2e-3  # the whole body realises the reference, not just the cart-table
    assert walk.meta["sole_error_m"] < 1e-3
    report = check_motion(robot, walk, friction=1.0)
    assert report["inverse_dynamics_residual"] < 1e-6
    assert report["zmp_margin"] > 0.0
    assert report["torque_ratio"] < 1.0
    assert report["stance_foot_slip"] < 1e-3
    # the touchdown time appears twice, pre- and post-impact, with the same configuration
    assert np.all(walk.t[walk.impacts] == walk.t[walk.impacts + 1])
    assert np.allclose(walk.q[walk.impacts], walk.q[walk.impacts + 1])


def test_the_smoothing_window_is_jrl_walkgens():
    dt, window = 0.005, 0.05
    reference = np.zeros((200, 2))
    reference[100:] = [0.1, -0.2]
    out = smoothed(reference, dt, window)
    assert np.allclose(out[:100], 0.0) and np.allclose(out[-1], reference[-1])  # constants pass unchanged
    assert np.all(np.diff(out[:, 0]) >= -1e-12)  # a monotonic step stays monotonic
    # causal with symmetric weights: the step is half done half a window (less half a sample) after it
    half = 100 + round(window / dt / 2)
    assert 0.5 * (out[half - 1, 0] + out[half, 0]) == pytest.approx(0.05)
    assert smoothed(reference, dt, 0.0) is reference


@pytest.mark.slow
def test_the_second_stage_brings_the_multibody_zmp_onto_the_reference(robot, walk):
    drop = walk.meta["pelvis_drop"]
    single = kajita_walk(robot, SPECS, dt=0.025, settings=KajitaSettings(pelvis_drop=drop, second_stage=False))
    assert single.meta["zmp_reference_rms_m"] == pytest.approx(single.meta["first_stage_zmp_reference_rms_m"])
    assert walk.meta["first_stage_zmp_reference_rms_m"] == pytest.approx(single.meta["zmp_reference_rms_m"])
    assert walk.meta["zmp_reference_rms_m"] < 0.2 * single.meta["zmp_reference_rms_m"]
    # the correction is horizontal: the CoM height stays the cart-table's
    assert np.ptp(walk.q[:, 2]) < 1e-3


@pytest.mark.slow
def test_the_searched_com_height_is_the_highest_the_legs_reach(robot, walk):
    assert walk.meta["pelvis_drop_searched"]
    drop = walk.meta["pelvis_drop"]
    low, high = KajitaSettings().drop_search_range
    assert low + DROP_SEARCH_RESOLUTION < drop < high
    assert walk.meta["sole_error_m"] < 1e-3  # reached, at that height
    with pytest.raises(Error, match="out of the legs' reach"):
        kajita_walk(robot, SPECS, dt=0.025, settings=KajitaSettings(pelvis_drop=drop - 2 * DROP_SEARCH_RESOLUTION))
    posture = posture_statistics(robot, walk)
    assert posture["com_height_min_m"] <= walk.meta["com_height_m"] <= posture["com_height_max_m"]
    # the legacy variant's fixed 4 cm crouch walks lower, on more bent knees
    legacy = kajita_walk(robot, SPECS, dt=0.025, settings=LEGACY)
    assert legacy.meta["com_height_m"] < walk.meta["com_height_m"] - 0.05
    assert posture_statistics(robot, legacy)["knee_angle_mean_rad"] > posture["knee_angle_mean_rad"]


@pytest.mark.slow
def test_swing_heights_measure_the_planned_apex(robot, walk):
    apexes = swing_heights(robot, walk)
    assert len(apexes) == 3  # the start's swing and the stop's two
    assert np.allclose(apexes, KajitaSettings().swing_height, atol=2e-3)


@pytest.mark.slow
def test_a_turning_side_stepping_walk_puts_its_soles_and_zmp_on_the_turned_footsteps(robot):
    """The baseline takes any footsteps: the soles land turned as planned, the pelvis faces
    between them, and the ZMP reference sits on the turned stance sole's centre."""
    import math

    from cocomopl.gait import footsteps
    from cocomopl.motion import Footstep

    lead, trail = Footstep(0.15, 0.05, math.radians(12)), Footstep(0.15, 0.0, math.radians(-12))
    specs = [StepSpec.between("start", Footstep(0.0), lead, swing_side="left"),
             StepSpec.between("transition", lead, trail, swing_side="right"),
             StepSpec.between("stop", trail, Footstep(0.0), swing_side="left")]
    walk = kajita_walk(robot, specs, dt=0.02)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, walk.q[-1])
    end = footsteps(robot, specs)[-1]
    for side in SIDES:
        placement = data.oMf[robot.foot_frames[side]]
        np.testing.assert_allclose(placement.translation[:2], end["end"][side][:2], atol=1e-3)
        assert math.atan2(placement.rotation[1, 0], placement.rotation[0, 0]) == pytest.approx(end["yaw"]["end"][side], abs=1e-3)
    pelvis = pin.Quaternion(walk.q[-1, 3:7]).matrix()
    assert math.atan2(pelvis[1, 0], pelvis[0, 0]) == pytest.approx(end["yaw"]["end"]["left"], abs=1e-3)
    phases = support_phases(robot, specs, default_durations(specs))
    edges = np.concatenate([[0.0], np.cumsum([p.duration for p in phases])])
    ahead = 0.5 * (robot.sole.front - robot.sole.back)
    for p, phase in enumerate(phases):
        if phase.kind == "ss":
            j = 1 - SIDES.index(phase.swing)
            yaw = phase.start_yaw[j]
            centre = phase.start[j][:2] + ahead * np.array([math.cos(yaw), math.sin(yaw)])
            zmp = zmp_reference(robot, phases, np.linspace(edges[p], edges[p + 1], 3))
            np.testing.assert_allclose(zmp, np.tile(centre, (3, 1)), atol=1e-9)


def test_taloss_kajita_settings_are_its_own_and_g1s_are_scaled_to_it(robot):
    """TALOS's scale is exactly 1, so its settings are jrl-walkgen's unchanged; G1's heights
    scale with its leg length and its durations with the cart-table's time, sqrt(length)."""
    assert KajitaSettings().scaled_to(robot) == KajitaSettings()
    assert LEGACY.scaled_to(robot) == LEGACY
    g1 = Robot("g1")
    length, time = g1.scale.length, math.sqrt(g1.scale.length)
    base, scaled = KajitaSettings(), KajitaSettings().scaled_to(g1)
    for name in ("preview_time", "prelude", "postlude", "zmp_smoothing"):
        assert getattr(scaled, name) == pytest.approx(getattr(base, name) * time)
    assert scaled.swing_height == pytest.approx(base.swing_height * length)
    assert scaled.drop_search_range == pytest.approx([v * length for v in base.drop_search_range])
    assert LEGACY.scaled_to(g1).pelvis_drop == pytest.approx(LEGACY.pelvis_drop * length)
    assert (scaled.weight_error, scaled.weight_input, scaled.control_dt) == (base.weight_error, base.weight_input, base.control_dt)


def test_the_scaled_preview_servo_answers_in_the_robots_time_as_taloss_does(robot):
    """A ZMP reference stepping by one length unit: G1's CoM, with its scaled settings and its
    CoM height, follows in G1's time and size as TALOS's does in TALOS's, to 1 % of the step
    (what is left is the controller's fixed 5 ms period: the same with the weights scaled
    so that the ZMP error and the jerk weigh as on TALOS)."""
    g1 = Robot("g1")

    def answer(r: Robot, height: float) -> tuple[np.ndarray, np.ndarray]:
        s, length, time = KajitaSettings().scaled_to(r), r.scale.length, math.sqrt(r.scale.length)
        controller = PreviewController(s.control_dt, height * length, preview_time=s.preview_time,
                                       weight_error=s.weight_error, weight_input=s.weight_input)
        grid = np.arange(0.0, 6.0 * time, s.control_dt)
        reference = np.where(grid > 2.0 * time, length, 0.0)
        return grid / time, controller.track(np.column_stack([reference, reference]))[0][:, 0] / length

    talos_time, talos_com = answer(robot, HEIGHT)
    g1_time, g1_com = answer(g1, HEIGHT)
    assert np.abs(np.interp(talos_time, g1_time, g1_com) - talos_com).max() < 0.01
    # the preview moves the CoM before the reference steps, and it arrives
    assert 0.0 < talos_com[talos_time < 2.0].max() < 0.5 and talos_com[-1] == pytest.approx(1.0, abs=1e-2)


def _described(tmp_path, kajita) -> Robot:
    path = tmp_path / "g1k.json"
    path.write_text(json.dumps({"name": "g1k", "example_robot_data": "g1", "pelvis": "pelvis",
                                "defaults": {"kajita": kajita}}))
    return Robot(str(path))


def test_a_description_sets_kajita_settings_in_place_of_the_scaled_ones(tmp_path):
    r = _described(tmp_path, {"preview_time": 2.0, "drop_search_range": [-0.02, 0.05], "pelvis_drop": None})
    s = KajitaSettings().scaled_to(r)
    assert s.preview_time == 2.0 and s.drop_search_range == (-0.02, 0.05) and s.pelvis_drop is None
    assert s.prelude == pytest.approx(KajitaSettings().prelude * math.sqrt(r.scale.length))  # not given: scaled


@pytest.mark.parametrize(("kajita", "words"), [
    ({"preview": 1.0}, "defaults.kajita.preview is not a Kajita setting"),
    ({"preview_time": 0}, "defaults.kajita.preview_time must be a positive number (SI units), not 0"),
    ({"prelude": -1.0}, "defaults.kajita.prelude must be a number of seconds, at least 0"),
    ({"ik_iterations": 2.5}, "defaults.kajita.ik_iterations must be a positive whole number"),
    ({"second_stage": "yes"}, "defaults.kajita.second_stage must be true or false"),
    ({"drop_search_range": [0.1, 0.0]}, "defaults.kajita.drop_search_range must be [low, high] in m, low < high"),
])
def test_a_kajita_setting_a_description_cannot_set_is_one_line_naming_it(tmp_path, kajita, words):
    r = _described(tmp_path, kajita)
    with pytest.raises(Error, match=re.escape(words)) as info:
        KajitaSettings().scaled_to(r)
    assert "\n" not in str(info.value)


def test_robot_check_refuses_a_kajita_setting_it_cannot_apply(tmp_path):
    from conftest import assert_one_line_error, run_cli

    _described(tmp_path, {"preview": 1.0})
    assert_one_line_error(run_cli("robot", "check", str(tmp_path / "g1k.json")), "defaults.kajita.preview is not a Kajita setting")
