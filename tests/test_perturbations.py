"""A world that is not the model: perturbed masses, joints and floor, pushes, and a perturbation of one's own."""

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.motion_file import read_motion
from cocomopl.sim.hooks import Hook
from cocomopl.sim.mujoco_model import build_sim_model
from cocomopl.sim.perturbations import Perturbation, Push, perturbed
from cocomopl.sim.rollout import simulate


@pytest.fixture(scope="module")
def sim(robot):
    return build_sim_model(robot, visuals=False)


def _world(sim, perturbation, seed=0):
    return perturbation.draw(np.random.default_rng(seed), sim.mj.nbody, sim.mj.nv)


def test_a_perturbed_world_is_a_copy_within_its_bounds(robot, sim):
    mass = sim.mj.body_mass.copy()
    world = _world(sim, Perturbation(mass=0.1, joint_friction_nm=2.0, floor_friction=(0.4, 0.6), floor_tilt_deg=2.0))
    other = perturbed(sim, world).mj
    ratio = other.body_mass[1:] / mass[1:]
    assert np.all((ratio >= 0.9) & (ratio <= 1.1)) and np.ptp(ratio) > 0.05  # each link its own error
    assert np.array_equal(sim.mj.body_mass, mass)  # the model given is untouched
    assert np.all(other.dof_frictionloss[:6] == 0) and np.all((other.dof_frictionloss[6:] >= 0) & (other.dof_frictionloss[6:] <= 2))
    assert 0.4 <= other.geom_friction[0, 0] <= 0.6
    gravity = other.opt.gravity
    assert np.linalg.norm(gravity) == pytest.approx(9.81)
    assert 0 < np.degrees(np.arccos(-gravity[2] / 9.81)) <= 2.0 * np.sqrt(2) + 1e-9


@pytest.mark.slow
def test_bumps_leave_the_robots_indices_and_it_stands_on_them(robot, sim):
    world = _world(sim, Perturbation(bump_m=0.01))
    bumpy = perturbed(sim, world)
    assert bumpy.mj.nbody == sim.mj.nbody + 1 and bumpy.mj.ngeom == sim.mj.ngeom + len(world.bump_heights)
    assert all(bumpy.mj.geom(g).name == f"{side}_sole" for side, (g,) in bumpy.sole_geoms.items())
    assert 0 < world.bump_heights.max() <= 0.01
    rollout = simulate(bumpy, read_motion(BUNDLED_DATASET, "start_250_L"), stabilizer=True)
    assert not rollout.fell


@pytest.mark.slow
def test_a_push_moves_the_robot_and_a_hard_one_topples_it(robot, sim, standing):
    still = standing(2.0)
    quiet = simulate(sim, still, stabilizer=True).measured
    pushed = simulate(sim, still, stabilizer=True, pushes=[Push(0.5, (0.0, 60.0))])
    assert not pushed.fell
    sideways = np.abs(pushed.measured.q[:, 1] - quiet.q[:, 1]).max()
    assert sideways > 1e-3  # the pelvis went sideways, and came back
    assert abs(pushed.measured.q[-1, 1] - quiet.q[-1, 1]) < 0.5 * sideways
    assert pushed.measured.simulation.pushes == [{"time_s": 0.5, "force_n": (0.0, 60.0), "duration_s": 0.1}]
    assert simulate(sim, still, stabilizer=True, pushes=[Push(0.5, (0.0, 3000.0))]).fell


class Wind(Hook):
    """A steady sideways force on the pelvis from a time on: a perturbation written as one hook."""

    def __init__(self, start_s: float, force_n: float):
        self.start_s, self.force_n = start_s, force_n

    def before_step(self, step):
        if step.elapsed >= self.start_s:
            step.data.xfrc_applied[step.sim.base_body, 1] += self.force_n


@pytest.mark.slow
def test_a_perturbation_of_ones_own_is_one_hook(sim, standing):
    still = standing(1.0)
    quiet = simulate(sim, still, stabilizer=True).measured
    windy = simulate(sim, still, stabilizer=True, hooks=[Wind(0.3, 40.0)]).measured
    before = quiet.t < 0.3
    assert np.array_equal(windy.q[before], quiet.q[before])  # nothing changes before it blows
    assert windy.q[-1, 1] - quiet.q[-1, 1] > 1e-3  # then the pelvis gives way to it
    # a push is such a hook: the same force as a Push, to the bit
    gust = simulate(sim, still, stabilizer=True, pushes=[Push(0.3, (0.0, 40.0), duration_s=0.2)]).measured
    both = simulate(sim, still, stabilizer=True, hooks=[Wind(0.3, 40.0), Wind(0.5, -40.0)]).measured
    assert np.array_equal(gust.q, both.q)


@pytest.mark.slow
def test_a_hook_reaches_the_rollout_through_the_simulation_settings(robot, sim, standing):
    from cocomopl.pipeline import SimSettings, simulate_walk

    still = standing(1.0)
    rollout, metrics = simulate_walk(robot, still, SimSettings(hooks=(Wind(0.3, 40.0),)))
    direct = simulate(sim, still, stabilizer=True, hooks=[Wind(0.3, 40.0)]).measured
    assert np.array_equal(rollout.measured.q, direct.q)
    assert not metrics.fell and metrics.duration_s == pytest.approx(direct.duration)


@pytest.mark.parametrize("bounds, message", [
    ({"mass": -0.1}, "perturbation mass -0.1"),
    ({"floor_tilt_deg": 45.0}, "floor_tilt_deg 45.0"),
    ({"floor_friction": (0.8, 0.4)}, "floor friction"),
])
def test_bad_perturbations_are_refused_in_one_line(bounds, message):
    with pytest.raises(Error, match=message) as raised:
        Perturbation(**bounds)
    assert "\n" not in str(raised.value)
