"""The plots' shared conventions: short titles, joints named by function, one colour per
side, a palette of many colours, legends beside the axes."""

from pathlib import Path

import matplotlib.image
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import same_color, to_hex

from cocomopl.analysis import plots, report_plots
from cocomopl.analysis.plots import SIDE_COLOURS, joint_label, palette, short_title
from cocomopl.analysis.viewer import write_html_viewer
from cocomopl.data import BUNDLED_DATASET, BUNDLED_MODEL
from cocomopl.motion_file import read_motion
from cocomopl.pipeline import generate_walk
from cocomopl.requests import StraightSteps, WalkRequest


@pytest.fixture(scope="module")
def walk():
    return generate_walk(WalkRequest(StraightSteps([0.15, 0.35, 0.35]), model=BUNDLED_MODEL))  # start, transition, stop


@pytest.fixture(scope="module")
def oc_step():
    return read_motion(BUNDLED_DATASET, "cyclic_250_L")


@pytest.fixture
def saved_figures(monkeypatch) -> dict:
    """The figures the plot functions save, by file name, kept for inspection after saving."""
    figures = {}
    save = plots.save_figure

    def keep(fig, path):
        figures[Path(path).name] = fig
        return save(fig, path)

    monkeypatch.setattr(plots, "save_figure", keep)
    monkeypatch.setattr(report_plots, "save_figure", keep)
    return figures


@pytest.mark.slow
def test_short_title_names_the_steps_not_each_step(walk, oc_step):
    assert "+" in walk.motion.name  # what the titles used to be
    title = short_title(walk.motion)
    assert title == "walk of 3 steps, 150–350 mm" and len(title) < 60
    assert short_title(oc_step) == "cyclic_250_L"


@pytest.mark.slow
def test_joint_label_names_leg_joints_by_function(walk):
    robot = walk.robot
    labels = [joint_label(robot, i) for i in range(robot.nu)]
    assert joint_label(robot, robot.leg_roles()["left"]["knee"]) == "left knee"
    assert [labels[i] for i in robot.leg_chain("right")] == [
        "right hip yaw", "right hip roll", "right hip pitch", "right knee", "right ankle pitch", "right ankle roll",
    ]
    assert joint_label(robot, robot.joint_names.index("arm_left_1_joint")) == "arm_left_1_joint"
    assert len(set(labels)) == robot.nu


@pytest.mark.parametrize("n", [16, 18, 30])
def test_palette_colours_are_distinct_and_not_the_sides(n):
    colours = palette(n)
    assert len(colours) == n and len(set(colours)) == n
    if n <= 18:
        assert not set(colours) & set(SIDE_COLOURS.values())


def _overlaps_an_axes(fig) -> list[str]:
    """Titles of the axes whose legend covers the data area of an axes of ``fig``."""
    renderer = FigureCanvasAgg(fig).get_renderer()  # closing the figure took its canvas
    boxes = [ax.get_window_extent(renderer) for ax in fig.axes]
    return [
        ax.get_title()
        for ax in fig.axes
        if ax.get_legend() is not None
        and any(ax.get_legend().get_window_extent(renderer).overlaps(box) for box in boxes)
    ]


@pytest.mark.slow
def test_motion_and_comparison_plots_share_conventions(walk, oc_step, saved_figures, tmp_path):
    robot = walk.robot
    paths = plots.plot_motion(robot, walk.motion, tmp_path / "motion")
    paths += report_plots.plot_comparison(robot, {"OC": oc_step, "generated": walk.motion}, tmp_path / "comparison",
                                          top_view=True, goals=[(0.85, 0.0, 0.0)])
    assert {p.name for p in paths} == {
        "joint_angles.png", "zmp.png", "contact_forces.png", "torques.png",
        "zmp_comparison.png", "force_comparison.png", "knee_torque_comparison.png", "leg_joint_comparison.png",
        "footsteps.png",
    }
    assert all(matplotlib.image.imread(p).shape[0] > 100 for p in paths)
    assert set(saved_figures) == {p.name for p in paths}

    # the left foot is drawn in the left colour in both sets of plots
    for name in ("zmp.png", "contact_forces.png", "force_comparison.png"):
        feet = {
            line.get_label().split()[0]: line.get_color()
            for ax in saved_figures[name].axes
            for line in ax.get_lines()
            if line.get_label() in ("left foot", "right foot", "left sole", "right sole")
        }
        assert feet.keys() == SIDE_COLOURS.keys(), name
        assert all(same_color(colour, SIDE_COLOURS[side]) for side, colour in feet.items()), name
    # and the soles in the top view: one filled sole per stance of the walk, in its side's colour
    soles = [patch for patch in saved_figures["footsteps.png"].axes[0].patches if patch.get_fill()]
    assert len(soles) == 2 + len(walk.motion.steps) + 1  # the start, a landing per step, the stop's closing step
    assert {to_hex(patch.get_facecolor()[:3]) for patch in soles} == set(SIDE_COLOURS.values())

    titles = {name: [ax.get_title() for ax in fig.axes if ax.get_title()] for name, fig in saved_figures.items()}
    assert all(t.startswith(short_title(walk.motion) + ":") for p in paths[:4] for t in titles[p.name])
    assert not any("+" in t for names in titles.values() for t in names)
    assert "left knee" in titles["knee_torque_comparison.png"] and "left knee" in titles["leg_joint_comparison.png"]
    legends = [ax.get_legend() for fig in saved_figures.values() for ax in fig.axes if ax.get_legend()]
    assert len(legends) >= len(paths)
    assert {name: _overlaps_an_axes(fig) for name, fig in saved_figures.items()} == {name: [] for name in saved_figures}


@pytest.mark.slow
def test_html_viewer_titles_a_walk_shortly_in_the_side_colours(walk, tmp_path):
    page = write_html_viewer(walk.robot, walk.motion, tmp_path / "walk.html").read_text()
    assert f"<title>{short_title(walk.motion)}</title>" in page
    assert all(colour in page for colour in SIDE_COLOURS.values())
