"""What a user reads and looks at: counts in words, the walk's top view and video, the CSV's
centre of mass and soles, and the default outputs kept out of git."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from cocomopl.analysis.footprint import planned_landings, stances, start_soles
from cocomopl.analysis.report_plots import plot_comparison
from cocomopl.cli import build_parser, main
from cocomopl.errors import plural
from cocomopl.export.seqplay import export_motion
from cocomopl.motion_file import write_motions
from cocomopl.pipeline import generate_walk
from cocomopl.requests import Goals, StraightSteps, WalkRequest

from conftest import synthetic

ROOT = Path(__file__).resolve().parents[1]
GOAL = (0.4, 0.0, math.radians(10))  # near the straight walk's end, turned to be seen


@pytest.fixture(scope="module")
def straight_walk():
    return generate_walk(WalkRequest(StraightSteps([0.20, 0.20]))).motion


def test_counts_are_in_words():
    assert plural(1, "motion") == "1 motion"
    assert plural(0, "step junction") == "0 step junctions"
    assert plural(64, "motion") == "64 motions"


def test_check_of_one_motion_says_one_motion(robot, tmp_path, capsys):
    path = tmp_path / "one.h5"
    write_motions(path, {"still": synthetic(robot, np.arange(0, 0.5, 0.05), fz=robot.mass * 9.81 / 2)},
                  {"robot": robot.name})
    main(["dataset", "check", str(path)])
    assert f"{path}: 1 motion, 0 step junctions" in capsys.readouterr().out


@pytest.mark.slow
def test_info_and_check_count_the_same_junctions_under_their_names(small_dataset, capsys):
    """Generation measures the junctions between solved steps; the check measures these and
    their mirror images', twice as many, and each says which it counts."""
    main(["dataset", "info", str(small_dataset), "--json"])
    info = json.loads(capsys.readouterr().out)
    main(["dataset", "info", str(small_dataset)])
    info_table = capsys.readouterr().out
    main(["dataset", "check", str(small_dataset), "--json"])
    check = json.loads(capsys.readouterr().out)
    assert check["junctions"] == 2 * info["solved_step_junctions"] > 0
    assert f"{plural(info['solved_step_junctions'], 'step junction')} of the solved steps (without mirror images)" in info_table
    assert info["max_continuity_error"] == pytest.approx(check["worst"]["continuity"], rel=1e-6)


def test_default_outputs_are_ignored_by_git():
    ignored = set((ROOT / ".gitignore").read_text().split())
    parser = build_parser()
    for command in (["walk"], ["reproduce"], ["generate"], ["train"], ["dataset", "generate"]):
        out = parser.parse_args(command).out
        assert out in ignored or f"{out}/" in ignored, out


@pytest.mark.slow
def test_planned_landings_are_where_the_soles_stand(robot):
    """A walk's planned landings (its footsteps) are where its soles stand after each
    touchdown."""
    walk = generate_walk(WalkRequest(Goals([(0.6, 0.3, math.radians(45))]))).motion
    planned = planned_landings(robot, walk)
    touchdowns = stances(robot, walk, first=False)
    assert len(planned) >= 3 and [p.side for p in planned] == [s.side for s in touchdowns[: len(planned)]]
    for p, s in zip(planned, touchdowns):
        assert np.hypot(p.x - s.x, p.y - s.y) < 1e-6 and abs(p.yaw - s.yaw) < 1e-6


@pytest.mark.slow
def test_a_walk_without_footsteps_lands_where_it_touches_down(robot, straight_walk):
    straight = planned_landings(robot, straight_walk)
    assert [s.side for s in straight] == ["left", "right", "left"]  # two steps, then the stop closes up
    assert [round(s.x, 3) for s in straight] == pytest.approx([0.2, 0.4, 0.4], abs=2e-3)
    assert {s.side for s in start_soles(robot, straight_walk)} == {"left", "right"}


@pytest.mark.slow
def test_a_walk_report_has_a_top_view_with_the_goal(robot, straight_walk, tmp_path):
    files = plot_comparison(robot, {"generated": straight_walk, "simulated": straight_walk}, tmp_path, top_view=True,
                            goals=[GOAL])
    assert [f.name for f in files][-1] == "footsteps.png" and (tmp_path / "footsteps.png").stat().st_size > 10_000


@pytest.mark.slow
def test_video_frames_see_the_floor_the_footsteps_and_the_goal(robot, straight_walk):
    """No sky: the top of the picture is floor; the landings (blue, red) and the goal (green)
    are drawn on it, where the soles do not stand on them; the soles at the start and at the
    end are both in the picture."""
    from cocomopl.sim.mujoco_model import build_sim_model
    from cocomopl.sim.video import render_frames

    sim = build_sim_model(robot, visuals=False)
    qpos = np.array([sim.qpos(q) for q in straight_walk.q[[0, -1]]])
    first, last = render_frames(sim, qpos, size=(320, 240), footsteps=planned_landings(robot, straight_walk),
                                goals=[GOAL])
    pixels = []
    for image in (first, last):
        assert image[: image.shape[0] // 3].mean() > 100  # the floor's grey checkers, not the black sky
        r, g, b = (image[..., i].astype(int) for i in range(3))
        pixels.append([((r - b > 60) & (r - g > 60)).sum(), ((b - r > 60) & (b > 120)).sum(),
                       ((g - r > 60) & (g - b > 60)).sum()])  # red, blue, green
        assert (image.sum(axis=2) < 150).sum() > 200  # the black soles
    assert min(pixels[0]) > 50  # at the start every landing and the goal are free to see
    assert pixels[1][0] < pixels[0][0] / 4 and min(pixels[1][1:]) > 50  # at the end the soles stand on the last two


@pytest.mark.slow
def test_csv_has_the_centre_of_mass_and_the_soles(robot, straight_walk, tmp_path):
    (path,), _ = export_motion(robot, straight_walk, "csv", prefix=tmp_path / "walk")
    with open(path, newline="") as f:
        header, *rows = list(csv.reader(f))
    values = np.array(rows, dtype=float)
    column = {name: values[:, i] for i, name in enumerate(header)}
    sole = [f"{side}_sole_{a}" for side in ("left", "right") for a in
            ("x_m", "y_m", "z_m", "roll_rad", "pitch_rad", "yaw_rad")]
    assert header[-15:] == ["com_x_m", "com_y_m", "com_z_m", *sole]  # appended: the older columns keep their places
    assert header.index("right_contact") == len(header) - 16
    k = len(rows) // 2
    rpy = [column[f"waist_{a}_rad"][k] for a in ("roll", "pitch", "yaw")]
    q = np.concatenate([[column[f"waist_{a}_m"][k] for a in "xyz"], pin.Quaternion(pin.rpy.rpyToMatrix(np.array(rpy))).coeffs(),
                        [column[f"{j}_rad"][k] for j in robot.joint_names]])
    com = pin.centerOfMass(robot.model, robot.model.createData(), q)
    assert [column[f"com_{a}_m"][k] for a in "xyz"] == pytest.approx(com, abs=2e-6)  # 6 decimals written
    for side in ("left", "right"):
        stance = column[f"{side}_contact"] == 1
        assert stance.sum() > 10
        assert np.abs(column[f"{side}_sole_z_m"][stance]).max() < 2e-3  # on the floor
        assert column[f"{side}_sole_z_m"].max() > 0.02  # lifted in the swing
        assert np.abs(column[f"{side}_sole_yaw_rad"]).max() < 0.05  # a straight walk
    assert column["left_sole_y_m"].mean() > 0 > column["right_sole_y_m"].mean()
