"""Metrics, comparison plots and the HTML viewer on inputs whose answers are known by hand,
and on one real OC step of the bundled dataset."""

import dataclasses
import json
import re
import shutil
import subprocess
from html.parser import HTMLParser

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.analysis import metrics
from cocomopl.analysis.report_plots import plot_comparison
from cocomopl.analysis.viewer import skeleton, write_html_viewer
from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.motion import Motion, RolloutRecord
from cocomopl.motion_file import read_motion

from conftest import synthetic

DATASET = BUNDLED_DATASET


def test_touchdown_delays_match_each_planned_touchdown_to_the_same_soles_nearest(robot):
    """Planned: the left sole lands at 0.05 s, the right at 0.5 s.  Measured (its clock
    starting 1 s later, which must not matter): the left lands at 0.07 s and again, after a
    bounce, at 0.30 s; the right lands at 0.48 s and at 0.9 s.  So 20 ms late and 20 ms early;
    the later touchdowns are nobody's; a left touchdown planned at 0.75 s that never comes
    is left out."""
    t = np.linspace(0.0, 1.0, 101)
    planned, measured = np.zeros((101, 2)), np.zeros((101, 2))
    planned[5:, 0], planned[50:, 1] = 100.0, 100.0
    planned[60:75, 0] = 0.0  # the left lifts off and lands again at 0.75 s
    measured[7:20, 0], measured[30:, 0] = 100.0, 100.0
    measured[48:60, 1], measured[90:, 1] = 100.0, 100.0
    reference, rollout = synthetic(robot, t, fz=planned), synthetic(robot, t + 1.0, fz=measured)
    delays = metrics.touchdown_delays(rollout, reference)
    assert np.allclose(np.sort(delays), [-0.02, 0.02])
    summary = metrics.summary(robot, rollout, reference)
    assert summary.touchdown_delay_median_s == pytest.approx(0.0)
    assert abs(summary.touchdown_delay_max_s) == pytest.approx(0.02)
    assert metrics.touchdown_delays(synthetic(robot, t), reference).size == 0


def test_landing_speed_of_a_body_dropping_onto_one_sole(robot):
    """The whole robot moves down at 0.3 m/s and forward at 0.4 m/s until its left sole
    touches: every point of it, the sole included, lands at 0.5 m/s; the right sole never lands."""
    t = np.linspace(0.0, 0.1, 11)
    fz = np.zeros((11, 2))
    fz[6:, 0] = 100.0
    motion = synthetic(robot, t, fz=fz)
    motion.v[:6, 0], motion.v[:6, 2] = 0.4, -0.3  # base frame = world frame in the reference posture
    assert np.allclose(metrics.landing_speeds(robot, motion), [0.5])
    assert metrics.landing_speeds(robot, synthetic(robot, t)).size == 0


def without_duplicates(motion: Motion) -> Motion:
    keep = motion.kept_samples()
    return dataclasses.replace(
        motion,
        t=motion.t[keep],
        q=motion.q[keep],
        v=motion.v[keep],
        tau=motion.tau[keep],
        wrenches=motion.wrenches[keep],
        contact=motion.contact[keep],
        zmp=motion.zmp[keep],
        impacts=np.zeros(0, dtype=int),
    )


@pytest.fixture(scope="module")
def oc_step() -> Motion:
    return read_motion(DATASET, "cyclic_250_L")


# ------------------------------------------------------------------ torques
def test_mean_torque_of_constant_torques_is_the_formula(robot):
    # 2 s at 10 ms with a touchdown duplicate at 1 s: its zero-length interval adds nothing
    t = np.sort(np.concatenate([np.linspace(0.0, 2.0, 201), [1.0]]))
    tau = np.full((len(t), robot.nu), 3.0)
    tau[:, 0] = -4.0
    impact = int(np.flatnonzero(t == 1.0)[0])
    tau[impact] = 1e3  # held over [1, 1): must not count
    motion = synthetic(robot, t, tau=tau, impacts=[impact])
    N, T = robot.nu, 2.0
    integral = (16.0 + 9.0 * (N - 1)) * T
    assert metrics.torque_integral(motion) == pytest.approx(integral)
    assert metrics.mean_torque(motion) == pytest.approx(np.sqrt(integral) / (N * T))
    assert metrics.rms_torque(motion) == pytest.approx(np.sqrt(integral / (N * T)))
    first = robot.joint_names[:1]
    assert metrics.mean_torque(motion, first) == pytest.approx(np.sqrt(16.0 * T) / T)
    with pytest.raises(Error, match="no joint named"):
        metrics.mean_torque(motion, ["no_such_joint"])


def test_mean_torque_of_an_oc_step_ignores_the_touchdown_duplicate(oc_step):
    assert len(oc_step.impacts) == 1
    value = metrics.mean_torque(oc_step)
    assert np.isfinite(value) and value > 0
    assert metrics.mean_torque(without_duplicates(oc_step)) == pytest.approx(value, rel=1e-12)


def test_summary_means_torques_over_the_reference_span_only(robot):
    # a rollout stands on after its reference ends; those torques must not dilute the mean
    reference = synthetic(robot, np.linspace(0.0, 1.0, 41), tau=np.full((41, robot.nu), 3.0))
    t = np.arange(0.0, 1.5 + 1e-9, 0.005)
    measured = synthetic(robot, t + 2.0, tau=np.where(t[:, None] < 1.0, 3.0, 100.0) * np.ones(robot.nu))
    report = metrics.summary(robot, measured, reference)
    assert report.mean_torque == pytest.approx(3.0 / np.sqrt(robot.nu))
    assert report.mean_torque == pytest.approx(metrics.mean_torque(reference))
    assert report.rms_torque == pytest.approx(3.0)
    assert report.duration_s == pytest.approx(1.5)
    assert metrics.summary(robot, measured).mean_torque > 3.0 / np.sqrt(robot.nu)


def test_a_window_keeps_a_touchdown_whole_or_not_at_all():
    oc_step = read_motion(DATASET, "stop_250_L")  # two touchdowns inside
    impact = int(oc_step.impacts[0])
    t0, touchdown = oc_step.t[0], oc_step.t[impact]
    before = metrics.windowed(oc_step, t0, touchdown - 1e-3)
    assert before.n == impact and len(before.impacts) == 0
    at = metrics.windowed(oc_step, t0, touchdown)
    assert at.n == impact + 2 and list(at.impacts) == [impact]  # both duplicates
    assert all(last < at.n for _, _, last in at.phases)
    after = metrics.windowed(oc_step, touchdown, oc_step.t[-1])
    assert after.t[0] == touchdown and after.impacts[0] == 0  # starts at the pre-impact sample
    later = metrics.windowed(oc_step, touchdown + 1e-3, oc_step.t[-1])
    assert later.t[0] > touchdown and list(later.impacts) == list(oc_step.impacts[1:] - impact - 2)  # from the first sample after both duplicates
    assert all(0 <= first <= last < later.n for _, first, last in later.phases)
    assert list(later.step_starts) == [0] and later.steps == oc_step.steps
    assert metrics.windowed(oc_step, t0, oc_step.t[-1]) is oc_step


# ------------------------------------------------------------------ contact forces
def test_standing_still_with_the_weight_split_carries_half_on_each_foot(robot):
    weight = robot.mass * metrics.GRAVITY
    motion = synthetic(robot, np.linspace(0, 1, 41), fz=weight / 2)
    np.testing.assert_allclose(metrics.peak_force_over_weight(motion, robot.mass), [0.5, 0.5])
    np.testing.assert_allclose(metrics.max_force_rate(motion), [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(metrics.force_rate_rms(motion, None), [0.0, 0.0])
    assert metrics.foot_slip(robot, motion) == 0.0
    assert not metrics.fell(robot, motion)


def test_a_linear_force_ramp_has_its_slope_as_rate(robot):
    slope = 2000.0  # N/s
    t = np.linspace(0.0, 0.5, 101)  # 5 ms, as a simulator records
    fz = np.column_stack([slope * t, np.full_like(t, 300.0)])
    motion = synthetic(robot, t, fz=fz)
    np.testing.assert_allclose(metrics.force_rates(motion, None)[:, 0], slope)
    np.testing.assert_allclose(metrics.max_force_rate(motion, None), [slope, 0.0], atol=1e-9)
    np.testing.assert_allclose(metrics.force_rate_rms(motion, None), [slope, 0.0], atol=1e-9)
    np.testing.assert_allclose(metrics.force_variation(motion, None), [slope * 0.5, 0.0], atol=1e-9)
    # a moving average does not change a ramp's slope (away from the ends, where it is shortened)
    smoothed = metrics.force_rates(motion, 0.02)[:, 0]
    np.testing.assert_allclose(smoothed[5:-5], slope)
    assert metrics.max_force_rate(motion, 0.02)[0] == pytest.approx(slope)


def test_force_variation_of_loading_and_unloading_a_foot_twice(robot):
    # a foot takes the weight W twice, each time overshooting to 1.2 W for 50 ms:
    # 2 (2 W + 2 * 0.2 W), the plateaus wider than the moving average
    weight = robot.mass * metrics.GRAVITY
    load = {0.5: 0, 0.6: 1.2, 0.65: 1.2, 0.75: 1, 1.5: 1, 1.6: 0}
    times = [t + shift for shift in (0.0, 2.0) for t in load]
    t = np.arange(0.0, 4.0, 0.005)
    fz = weight * np.interp(t, times, 2 * list(load.values()))
    expected = [2 * (2 + 2 * 0.2) * weight, 0.0]
    motion = synthetic(robot, t, fz=np.column_stack([fz, np.zeros_like(t)]))
    np.testing.assert_allclose(metrics.force_variation(motion, None), expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(metrics.force_variation(motion, 0.02), expected, rtol=1e-9, atol=1e-9)
    # standing still as long again dilutes the RMS rate, not the variation
    padded = synthetic(robot, np.arange(0.0, 8.0, 0.005), fz=np.pad(motion.wrenches[:, :, 2], ((0, 800), (0, 0))))
    np.testing.assert_allclose(metrics.force_variation(padded, None), expected, rtol=1e-9, atol=1e-9)
    dilution = np.sqrt(motion.duration / padded.duration)
    assert metrics.force_rate_rms(padded, None)[0] == pytest.approx(metrics.force_rate_rms(motion, None)[0] * dilution)


def test_passing_the_weight_between_feet_moves_each_foot_but_not_their_sum(robot):
    # the weight W goes from the left sole to the right and back, then the body bounces:
    # the sum rises to 1.1 W and returns, 0.2 W of variation, while each sole varies by 2 W
    weight = robot.mass * metrics.GRAVITY
    t = np.arange(0.0, 3.0, 0.005)
    left = weight * np.interp(t, [0.5, 1.0, 1.5, 2.0], [1, 0, 0, 1])
    bounce = weight * np.interp(t, [2.2, 2.4, 2.5, 2.7], [0, 0.1, 0.1, 0])  # plateau wider than the average
    motion = synthetic(robot, t, fz=np.column_stack([left + bounce, weight - left]))
    np.testing.assert_allclose(metrics.force_variation(motion, None), [2.2 * weight, 2 * weight], rtol=1e-9)
    assert metrics.total_force_variation(motion, None) == pytest.approx(0.2 * weight, rel=1e-9)
    assert metrics.total_force_variation(motion) == pytest.approx(0.2 * weight, rel=1e-9)


def test_smoothing_bounds_the_rate_of_a_jump_on_any_sample_spacing(robot):
    # a 600 N jump between two samples 1 µs apart: raw rate 6e8 N/s, smoothed at most 600 N / w
    t = np.sort(np.concatenate([np.arange(0.0, 0.4, 0.005), [0.2 + 1e-6]]))
    fz = np.column_stack([np.where(t > 0.2, 600.0, 0.0), np.zeros_like(t)])
    motion = synthetic(robot, t, fz=fz)
    assert metrics.max_force_rate(motion, None)[0] == pytest.approx(600.0 / 1e-6, rel=1e-6)
    for window in (0.01, 0.02, 0.04):
        assert metrics.max_force_rate(motion, window)[0] <= 600.0 / window * (1 + 1e-9)
        assert metrics.max_force_rate(motion, window)[0] >= 0.5 * 600.0 / window


# ------------------------------------------------------------------ tracking
def test_zmp_rms_error_of_a_sinusoid_against_a_still_reference(robot):
    amplitude, period = 0.03, 0.5
    t = np.arange(0.0, 2.0 + 1e-9, 0.005)
    zmp = np.zeros((len(t), 3))
    zmp[:, 0] = amplitude * np.sin(2 * np.pi * t / period) + 0.01  # + a known offset in x
    zmp[:, 1] = 0.02  # and in y
    zmp[t > 1.5] = np.nan  # no foot pushes: left out (three whole periods remain)
    measured = synthetic(robot, t + 7.0, zmp=zmp)  # the measured clock starts elsewhere
    reference = synthetic(robot, np.arange(0.0, 2.5, 0.025))
    keep = np.isfinite(zmp[:, 0])
    expected = np.sqrt(np.mean(np.sum(zmp[keep, :2] ** 2, axis=1)))
    assert metrics.zmp_rms_error(measured, reference) == pytest.approx(expected)
    # over whole periods: mean of sin^2 is 1/2, the cross term vanishes
    assert expected == pytest.approx(np.sqrt(amplitude**2 / 2 + 0.01**2 + 0.02**2), rel=2e-3)


def test_tracking_error_of_one_offset_joint(robot):
    t = np.arange(0.0, 1.0 + 1e-9, 0.005)
    q = np.tile(robot.q_ref, (len(t), 1))
    q[:, 7 + 3] += 0.05
    measured = synthetic(robot, t, q=q)
    reference = synthetic(robot, np.arange(0.0, 0.6 + 1e-9, 0.025))  # shorter: only its span counts
    error = metrics.tracking_error(measured, reference)
    assert error.max == pytest.approx(0.05)
    assert error.rms == pytest.approx(0.05 / np.sqrt(robot.nu))
    assert error.per_joint_rms[robot.joint_names[3]] == pytest.approx(0.05)
    assert error.per_joint_rms[robot.joint_names[0]] == pytest.approx(0.0)


# ------------------------------------------------------------------ knees, falls, slip
def test_knees_are_the_talos_knees_and_their_torques(robot):
    knees = metrics.knee_joints(robot)
    names = {side: robot.joint_names[i] for side, i in knees.items()}
    assert names == {"left": "leg_left_4_joint", "right": "leg_right_4_joint"}
    # the knee is the leg joint bent most when standing half-sitting
    for side, i in knees.items():
        legs = [j for j in robot.leg_joint_indices() if (j in range(6)) == (side == "left")]
        assert i == max(legs, key=lambda j: abs(robot.q_ref[7 + j]))
    tau = np.arange(4 * robot.nu, dtype=float).reshape(4, robot.nu)
    torques = metrics.knee_torques(robot, synthetic(robot, np.arange(4.0), tau=tau))
    np.testing.assert_array_equal(torques["left"], tau[:, knees["left"]])
    np.testing.assert_array_equal(torques["right"], tau[:, knees["right"]])


def test_falls_by_flag_height_or_tilt(robot):
    t = np.linspace(0.0, 1.0, 11)
    flagged = RolloutRecord(reference_producer="test", stabilizer=False, stabilizer_gains=None, reference_cutoff_hz=0.0,
                            feedforward=False, fell=True, fall_time_s=0.5, timestep_s=0.001, sim_model=None,
                            contact_time_constant_s=0.005, servos=None, pushes=[])
    assert metrics.fell(robot, dataclasses.replace(synthetic(robot, t), simulation=flagged))
    dropped = np.tile(robot.q_ref, (len(t), 1))
    dropped[-1, 2] *= 0.5
    assert metrics.fell(robot, synthetic(robot, t, q=dropped))
    tilted = np.tile(robot.q_ref, (len(t), 1))
    tilted[-1, 3:7] = pin.Quaternion(pin.utils.rotate("x", np.radians(60.0))).coeffs()  # x, y, z, w
    assert metrics.fell(robot, synthetic(robot, t, q=tilted))
    tilted[-1, 3:7] = pin.Quaternion(pin.utils.rotate("y", np.radians(20.0))).coeffs()
    assert not metrics.fell(robot, synthetic(robot, t, q=tilted))


def test_foot_slip_counts_only_loaded_runs(robot):
    t = np.linspace(0.0, 1.0, 20)
    q = np.tile(robot.q_ref, (20, 1))
    q[:10, 0] = np.linspace(0.0, 0.012, 10)  # both soles slide 12 mm while loaded
    q[10:15, 0] = 0.5  # a long move while lifted (force below the threshold)
    q[15:, 0] = 0.5
    q[15:, 1] = np.linspace(0.0, 0.004, 5)  # 4 mm sideways in the next loaded run
    fz = np.full((20, 2), 400.0)
    fz[10:15] = 0.02 * robot.mass * metrics.GRAVITY
    assert metrics.foot_slip(robot, synthetic(robot, t, q=q, fz=fz)) == pytest.approx(0.012, abs=1e-9)


def test_end_balance_margin_of_standing_on_both_or_one_foot(robot):
    t = np.linspace(0.0, 1.0, 5)
    pdata = robot.model.createData()
    com = pin.centerOfMass(robot.model, pdata, robot.q_ref)
    pin.framesForwardKinematics(robot.model, pdata, robot.q_ref)
    left = pdata.oMf[robot.foot_frames["left"]].translation
    right = pdata.oMf[robot.foot_frames["right"]].translation
    both = metrics.end_balance_margin(robot, synthetic(robot, t, fz=400.0))
    # the CoM stands between the feet: its distance to the nearer side edge of the soles
    expected = min(left[1] + robot.sole.half_width - com[1], com[1] - (right[1] - robot.sole.half_width))
    assert both == pytest.approx(
        min(expected, robot.sole.front - (com[0] - left[0]), com[0] - left[0] + robot.sole.back), abs=1e-5
    )
    # on the left foot alone, the CoM is outside by its distance to the sole's inner edge
    alone = metrics.end_balance_margin(robot, synthetic(robot, t, fz=np.array([400.0, 0.0])))
    assert alone == pytest.approx(-(left[1] - robot.sole.half_width - com[1]), abs=1e-5)  # soles tilt by mrad
    assert np.isnan(metrics.end_balance_margin(robot, synthetic(robot, t)))


# ------------------------------------------------------------------ summary
def test_summary_of_an_oc_step_against_itself_is_json_and_exact(robot, oc_step):
    report = metrics.summary(robot, oc_step, oc_step)
    payload = report.to_json()
    assert json.loads(json.dumps(payload, allow_nan=False)) == payload
    assert list(payload) == [f.name for f in dataclasses.fields(report)]
    for key in (
        "fell",
        "peak_force_over_weight",
        "max_force_rate",
        "mean_torque",
        "zmp_rms_error",
        "duration_s",
        "foot_slip_m",
        "tracking_rms_rad",
        "knee_torque_peak",
        "force_rate_rms",
        "force_variation_over_weight",
        "total_force_variation_over_weight",
    ):
        assert key in payload
    assert report.fell is False
    assert report.zmp_rms_error == pytest.approx(0.0, abs=1e-12)
    assert report.tracking_rms_rad == 0.0 and report.completed == 1.0
    assert report.mean_torque == report.reference_mean_torque > 0
    # a walking step carries the body weight and a bit more while decelerating it
    assert 0.9 < report.peak_force_over_weight < 2.0
    assert report.foot_slip_m < 0.005  # the OC stance sole is fixed up to the Euler drift
    # a stop step ends at rest in double support: its CoM is well inside the soles
    stop = read_motion(DATASET, "stop_250_L")
    assert metrics.summary(robot, stop).end_balance_margin_m > 0.05
    assert metrics.summary(robot, oc_step).zmp_rms_error is None


# ------------------------------------------------------------------ plots and viewer
@pytest.mark.slow
def test_comparison_plots_are_written(robot, oc_step, tmp_path):
    import matplotlib.image

    paths = plot_comparison(
        robot, {"OC": oc_step, "OC without duplicates": without_duplicates(oc_step)}, tmp_path / "out"
    )
    assert len(paths) == 4
    for path in paths:
        assert matplotlib.image.imread(path).shape[0] > 100


class _Scripts(HTMLParser):
    def __init__(self):
        super().__init__()
        self.scripts, self._current = {}, None

    def handle_starttag(self, tag, attrs):
        if tag == "script":
            self._current = dict(attrs).get("id", "inline")
            self.scripts[self._current] = ""

    def handle_data(self, data):
        if self._current is not None:
            self.scripts[self._current] += data

    def handle_endtag(self, tag):
        if tag == "script":
            self._current = None


def test_html_viewer_embeds_forward_kinematics(robot, oc_step, tmp_path):
    path = write_html_viewer(robot, oc_step, tmp_path / "step.html", title="a <step>", fps=40.0)
    text = path.read_text()
    assert "&lt;step&gt;" in text and not re.search(r"(src|href)=\"?https?:", text)  # nothing from the network
    parser = _Scripts()
    parser.feed(text)
    data = json.loads(parser.scripts["motion-data"])
    assert len(data["t"]) == round(oc_step.duration * 40) + 1
    assert len(data["points"]) == len(data["com"]) == len(data["zmp"]) == len(data["t"])
    # frame 10 is at 0.25 s, knot 10 of the 25 ms OC step (before the touchdown duplicate)
    model, pdata = robot.model, robot.model.createData()
    q = oc_step.q[10]
    pin.framesForwardKinematics(model, pdata, q)
    _, _, tips = skeleton(robot)
    expected = [pdata.oMi[j].translation for j in range(1, model.njoints)] + [pdata.oMf[f].translation for f in tips]
    np.testing.assert_allclose(data["points"][10], expected, atol=1e-4)
    np.testing.assert_allclose(data["com"][10], pin.centerOfMass(model, pdata, q), atol=1e-4)
    sole = pdata.oMf[robot.foot_frames["left"]]
    corner = sole.rotation @ np.array([*robot.sole.corners()[0], 0.0]) + sole.translation
    np.testing.assert_allclose(data["soles"][10][0][0], corner, atol=1e-4)
    np.testing.assert_allclose(data["zmp"][10], oc_step.zmp[10, :2], atol=1e-4)
    assert all(0 <= a < len(expected) and 0 <= b < len(expected) for a, b in data["segments"])


# A stand-in for the browser: a canvas context that records the drawn points, a clock
# driven by hand.  Prints the points, the time label and whether playback advanced.
_BROWSER = r"""
const html = require("fs").readFileSync(process.argv[1], "utf8");
const code = html.match(/<script>([\s\S]*?)<\/script>/)[1];
const drawn = [];
const context = new Proxy({}, {
  get: (o, k) => (k in o ? o[k] : (...a) => { if (["moveTo", "lineTo", "arc"].includes(k)) drawn.push(a.slice(0, 2)); }),
  set: (o, k, v) => { o[k] = v; return true; },
});
const elements = {};
const element = id => ({ value: "1", clientWidth: 800, clientHeight: 600, getContext: () => context,
  textContent: id === "motion-data" ? html.match(/id="motion-data">([\s\S]*?)<\/script>/)[1] : "" });
global.document = { getElementById: id => elements[id] || (elements[id] = element(id)) };
global.window = {}; global.devicePixelRatio = 1;
const callbacks = [];
global.requestAnimationFrame = f => callbacks.push(f);
eval(code);
callbacks.shift()(0); callbacks.shift()(500);
const played = elements.time.textContent;
elements.view.onmousedown({ clientX: 0, clientY: 0 }); window.onmousemove({ clientX: 40, clientY: 20 });
elements.view.onwheel({ deltaY: 100, preventDefault() {} });
elements.slider.value = "3"; elements.slider.oninput(); callbacks.shift()(900);
console.log(JSON.stringify({ drawn, played, scrubbed: elements.time.textContent, button: elements.play.textContent }));
"""


@pytest.mark.skipif(shutil.which("node") is None, reason="needs Node.js to run the page's script")
def test_html_viewer_script_draws_plays_and_scrubs(robot, oc_step, tmp_path):
    path = write_html_viewer(robot, oc_step, tmp_path / "step.html", fps=40.0)
    result = subprocess.run(
        ["node", "-e", _BROWSER, str(path)], check=False, capture_output=True, text=True, timeout=30
    )
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    drawn = np.array(out["drawn"], dtype=float)
    assert len(drawn) > 100 and np.all(np.isfinite(drawn))
    # the robot stands inside the 800 x 600 canvas
    figure = drawn[-(robot.model.njoints + 10) :]
    assert np.all((figure > 0) & (figure < [800, 600]))
    assert out["played"].startswith("t = 0.500 s (21/")  # 0.5 s of playback at 40 fps
    assert out["scrubbed"].startswith("t = 0.075 s (4/") and out["button"] == "play"


def test_a_point_outside_a_polygon_is_moved_to_its_nearest_boundary_point_and_inset():
    from cocomopl.analysis.feasibility import nearest_inside, polygon_margin

    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # counter-clockwise
    inside = np.array([0.3, 0.6])
    assert nearest_inside(square, inside, 0.01) is inside
    moved = nearest_inside(square, np.array([0.4, -0.5]), 0.0)
    assert moved == pytest.approx([0.4, 0.0]) and polygon_margin(square, moved) == pytest.approx(0.0, abs=1e-15)
    corner = nearest_inside(square, np.array([2.0, 3.0]), 0.01)  # nearest to the corner (1, 1)
    assert np.linalg.norm(corner - [1.0, 1.0]) == pytest.approx(0.01) and polygon_margin(square, corner) > 0
