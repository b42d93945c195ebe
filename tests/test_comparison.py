"""The comparison protocol: every walk measured over the same walking window."""

import dataclasses

import numpy as np
import pytest

from cocomopl.analysis import metrics
from cocomopl.analysis.comparison import MEASURES, common_window, per_measure, walking_span, window_figures
from cocomopl.baselines.kajita import KajitaSettings, kajita_walk
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.robot import Robot

SPECS = [StepSpec("start", 0.0, 0.2, "left"), StepSpec("stop", 0.2, 0.0, "right")]


@pytest.fixture(scope="module")
def robot():
    return Robot("talos")


@pytest.fixture(scope="module")
def walks(robot):
    """A Kajita walk, standing before and after its walking, and a walk that does not stand:
    the same walk with its prelude and postlude cut off, as a generated walk would be."""
    kajita = kajita_walk(robot, SPECS, dt=0.05, settings=KajitaSettings(pelvis_drop=0.0))
    start, end = kajita.meta["walking_span_s"]
    bare = dataclasses.replace(metrics.windowed(kajita, start, end), producer="test", meta={})
    return {"Kajita": kajita, "bare": bare}


@pytest.mark.slow
def test_the_window_is_where_all_walks_walk(walks):
    kajita, bare = walks["Kajita"], walks["bare"]
    assert kajita.t[0] < 0.0 and kajita.t[-1] > kajita.meta["walking_span_s"][1]  # it stands before and after
    assert walking_span(kajita) == tuple(kajita.meta["walking_span_s"])
    assert walking_span(bare) == (bare.t[0], bare.t[-1])
    assert common_window(walks) == pytest.approx(tuple(kajita.meta["walking_span_s"]))
    shorter = metrics.windowed(bare, 0.0, 1.0)
    assert common_window({**walks, "shorter": shorter}) == pytest.approx((0.0, shorter.t[-1]))
    later = dataclasses.replace(shorter, t=shorter.t + 10.0)
    with pytest.raises(Error, match="do not walk at the same time"):
        common_window({"a": shorter, "b": later})


@pytest.mark.slow
def test_every_walk_is_measured_over_the_same_window(robot, walks):
    window = common_window(walks)
    # the plans stand in for their rollouts: what is measured is the window, not the simulator
    figures = window_figures(robot, walks, walks, window=window)
    for name, motion in walks.items():
        inside = metrics.windowed(motion, *window)
        assert figures[name]["duration_s"] == pytest.approx(window[1] - window[0])
        assert figures[name]["mean_torque"] == pytest.approx(metrics.mean_torque(inside))
        assert figures[name]["planned"]["mean_torque"] == pytest.approx(metrics.mean_torque(inside))
        assert figures[name]["knee_angle_mean_rad"] == pytest.approx(metrics.posture_statistics(robot, inside)["knee_angle_mean_rad"])
    # the Kajita walk's standing prelude and postlude count for nothing: both walks are the same walk there
    for measure in MEASURES:
        assert figures["Kajita"][measure] == pytest.approx(figures["bare"][measure], rel=1e-9)
    # whereas over its own duration its standing dilutes its mean torque
    assert metrics.mean_torque(walks["Kajita"]) < 0.9 * figures["Kajita"]["mean_torque"]


def test_per_measure_says_which_walk_is_lower():
    figures = {"A": dict.fromkeys(MEASURES, 1.0), "B": dict.fromkeys(MEASURES, 2.0)}
    figures["A"]["peak_force_over_weight"] = 3.0
    out = per_measure(figures, "A", "B")
    assert out["mean_torque"] == {"A": 1.0, "B": 2.0, "lower": "A", "relative_difference": -0.5}
    assert out["peak_force_over_weight"]["lower"] == "B"
    assert out["peak_force_over_weight"]["relative_difference"] == pytest.approx(0.5)
    assert set(out) == set(MEASURES)


@pytest.mark.slow
def test_windowed_motion_is_a_motion(walks):
    inside = metrics.windowed(walks["Kajita"], *walks["Kajita"].meta["walking_span_s"])
    assert np.all(np.diff(inside.t) >= 0) and inside.step_starts[0] == 0
    assert all(0 <= first <= last < inside.n for _, first, last in inside.phases)
    assert np.all(inside.t[inside.impacts] == inside.t[inside.impacts + 1])
