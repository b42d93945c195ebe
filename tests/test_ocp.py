"""Step OCPs: the solutions obey the dynamics, the constraints and each other (continuity).

Everything is checked on the small dataset of conftest.py, recomputed with Pinocchio.
"""

import copy

import numpy as np
import pytest

from cocomopl.analysis.feasibility import FORCE_RESOLUTION, check_motion, tolerances, violations
from cocomopl.analysis.metrics import landing_speeds
from cocomopl.dataset.continuity import step_mismatch
from cocomopl.dataset.plan import successors
from cocomopl.dataset.signals import training_signals
from cocomopl.dynamics import finite_difference_accelerations, inverse_dynamics_residual, sole_placements
from cocomopl.errors import Error
from cocomopl.motion import StepSpec
from cocomopl.motion_file import read_motions
from cocomopl.robot import mirror_motion

from conftest import SMALL

TOLERANCES = tolerances(SMALL.dt)


@pytest.fixture(scope="module")
def motions(small_dataset):
    return read_motions(small_dataset)[0]


def test_dataset_holds_solved_and_mirrored_steps(motions):
    names = set(motions)
    for kind in ("cyclic_200", "start_200", "stop_200"):
        assert {f"{kind}_L", f"{kind}_R"} <= names


def test_every_motion_obeys_inverse_dynamics(robot, motions):
    for name, m in motions.items():
        report = check_motion(robot, m, SMALL.friction)
        assert report["inverse_dynamics_residual"] < TOLERANCES["inverse_dynamics_residual"], name


def test_zmp_stays_in_the_support_polygon(robot, motions):
    for name, m in motions.items():
        assert check_motion(robot, m, SMALL.friction)["zmp_margin"] >= 0.0, name


def test_a_diverged_motion_fails_the_zmp_check_instead_of_raising(robot, motions):
    """A solve that diverges throws the robot kilometres away, where the soles' hull loses
    all precision: its ZMP margin is -inf (failed), so the step is rejected, not crashed on."""
    m = copy.deepcopy(next(iter(motions.values())))
    m.q[:, :2] += 1e15
    report = check_motion(robot, m, SMALL.friction)
    assert report["zmp_margin"] == -np.inf
    assert "zmp_margin" in violations(report, TOLERANCES)


def test_limits_friction_and_unilateral_forces(robot, motions):
    for name, m in motions.items():
        r = check_motion(robot, m, SMALL.friction)
        assert r["torque_ratio"] <= TOLERANCES["torque_ratio"], name
        assert r["joint_position_excess"] <= TOLERANCES["joint_position_excess"], name
        assert r["joint_velocity_ratio"] <= 1.0, name
        assert r["friction_ratio"] <= TOLERANCES["friction_ratio"], name
        assert r["min_normal_force"] >= 0.0, name
        assert r["stance_foot_slip"] <= TOLERANCES["stance_foot_slip"], name


def test_a_sole_pulling_by_more_than_the_force_resolution_fails_and_numerical_zeros_pass(robot, motions):
    """A contact force no larger than ``FORCE_RESOLUTION`` is zero (an unloading sole carries
    a few mN of either sign at a penalised solver's optimum); a pull or a slip beyond it fails."""
    motion = motions["cyclic_200_R"]
    k = int(np.flatnonzero(motion.contact.all(axis=1))[0])  # in double support
    tiny = 0.6 * FORCE_RESOLUTION
    for force, failing in (([tiny, 0.0, -tiny], []), ([0.0, 0.0, -1.0], ["min_normal_force"]),
                           ([0.5, 0.0, 0.0], ["friction_ratio"])):
        edited = copy.deepcopy(motion)
        edited.wrenches[k, 0] = [*force, 0.0, 0.0, 0.0]
        report = check_motion(robot, edited, SMALL.friction)
        assert [name for name in ("min_normal_force", "friction_ratio") if name in violations(report, TOLERANCES)] == failing


def test_swing_soles_keep_to_their_lanes(robot, motions):
    """Each sole's lateral position stays within 2 cm of where it starts: a swinging sole
    passes beside the stance sole and lands in its lane, the closing step of a stop too
    (a constraint placed relative to the origin instead of the stance sole once pushed
    that step's sole 18 cm out and slammed it back at 1.7 m/s)."""
    for name, m in motions.items():
        y = sole_placements(robot, m.q)[:, :, 1]
        assert np.abs(y - y[0]).max() < 0.02, name


def test_soles_land_at_rest(robot, motions):
    """Every touchdown of every step lands at under 1 cm/s: the impulse model would absorb
    any landing speed for free, a stiff position-controlled robot does not (docs/method.md,
    "Soft landings")."""
    for name, m in motions.items():
        speeds = landing_speeds(robot, m)
        assert len(speeds) >= 1, name
        assert speeds.max() < 0.01, (name, speeds)


def test_mirror_of_mirror_is_identity_and_mirrored_motion_is_dynamic(robot, motions):
    m = motions["cyclic_200_L"]
    mm = mirror_motion(robot, mirror_motion(robot, m))
    for key in ("q", "v", "tau", "wrenches", "zmp"):
        assert np.array_equal(getattr(mm, key), getattr(m, key))
    mirrored = motions["cyclic_200_R"]
    a = finite_difference_accelerations(mirrored.t, mirrored.v)
    keep = np.flatnonzero(np.diff(mirrored.t) > 0)
    res = inverse_dynamics_residual(
        robot, mirrored.q[keep], mirrored.v[keep], a=a[keep], tau=mirrored.tau[keep], wrenches=mirrored.wrenches[keep]
    )
    assert np.abs(res).max() < 1e-6


def test_consecutive_steps_join(robot, motions):
    by_spec = {m.steps[0]: m for m in motions.values()}
    pairs = [(s, n) for s in by_spec for n in successors(s, list(by_spec))]
    assert len(pairs) >= 4  # start->cyclic, cyclic->cyclic, cyclic->stop, both feet
    for spec, nxt in pairs:
        assert step_mismatch(robot, by_spec[spec], by_spec[nxt]) < TOLERANCES["continuity"], (spec, nxt)


def test_cyclic_step_ends_as_its_own_mirror_image(robot, motions):
    m = motions["cyclic_200_L"]
    assert step_mismatch(robot, m, motions["cyclic_200_R"]) < TOLERANCES["continuity"]


def test_training_signals_are_36_and_all_vary(robot, motions):
    sig = training_signals(robot, motions["cyclic_200_L"])
    assert sig["values"].shape[1] == 36
    assert np.all(np.diff(sig["t"]) > 0)
    zmp_pelvis = sig["values"][:, 30:33]
    assert np.all(zmp_pelvis.std(axis=0) > 1e-4)  # all three ZMP coordinates vary in the pelvis frame
    assert sig["phase_time"][0] == 0.0 and sig["phase_time"][-1] == 2.0


def test_phase_timing_is_searched_and_the_cheapest_kept(robot, monkeypatch):
    """The solver has no time variable: the single-support duration is searched outside it,
    and the cheapest cyclic step's timing fixes the start and stop steps' (the solver is
    stubbed, its cost least at 0.7 s: only the search and what it keeps are tested)."""
    from dataclasses import replace
    from types import SimpleNamespace

    from cocomopl.ocp import solve as ocp_solve

    solved = []  # (kind, single-support duration) of each OCP handed to the solver

    def solve_with_retries(robot, spec, states, *, settings, guesses, extra_iterations=0):
        solved.append((spec.kind, settings.ss_duration))
        cost = 1.0 + (settings.ss_duration - 0.7) ** 2
        return SimpleNamespace(stats={"cost": cost, "iterations": 10}), [{"guess": "warm start", "converged": True}]

    monkeypatch.setattr(ocp_solve, "warm_up_walk", lambda robot, footstep, settings, **_: SimpleNamespace(xs=["walk"]))
    monkeypatch.setattr(ocp_solve, "walk_segment", lambda robot, walk, kind: walk.xs)
    monkeypatch.setattr(ocp_solve, "solve_with_retries", solve_with_retries)
    settings = replace(SMALL, ss_duration=0.6, ss_search_step=0.1, ss_bounds=(0.5, 0.9))
    solutions, info = ocp_solve.solve_length(robot, 0.2, settings)
    searched = {round(c["ss_duration"], 6): c["cost"] for c in info["duration_search"]}
    assert list(searched) == [0.6, 0.7, 0.8]  # up while the cost falls, and one step past the least
    assert info["durations"][1] == pytest.approx(0.7)
    assert solutions["cyclic"].stats["cost"] == min(searched.values())
    assert sorted(solved[3:]) == [("start", pytest.approx(0.7)), ("stop", pytest.approx(0.7))]


def test_the_upper_body_has_its_own_posture_and_velocity_weights(robot):
    """The posture cost weighs the joints that carry no sole by ``w_upper_posture`` and their
    velocities by ``w_upper_velocity``; the legs and the base by the others."""
    from dataclasses import replace

    import crocoddyl

    from cocomopl.ocp.action_models import posture_cost

    settings = replace(SMALL, w_posture=1.0, w_upper_posture=3.0, w_velocity=0.1, w_upper_velocity=0.7)
    state = crocoddyl.StateMultibody(robot.model)
    weights = np.sqrt(posture_cost(robot, state, robot.nu, x_ref=state.zero(), settings=settings).activation.weights)
    nv, upper = robot.model.nv, robot.upper_body_joint_indices()
    legs = np.setdiff1d(np.arange(robot.nu), upper)
    joints, velocities = weights[6:nv], weights[nv + 6:]
    assert np.allclose(joints[upper], 3.0) and np.allclose(joints[legs], 1.0)
    assert np.allclose(velocities[upper], 0.7) and np.allclose(velocities[legs], 0.1)
    assert np.allclose(weights[nv:nv + 6], 0.1)  # the base's velocities


@pytest.mark.parametrize("continued_converges", [True, False])
def test_when_every_guess_stops_unconverged_the_closest_is_continued(robot, monkeypatch, continued_converges):
    """A step whose guesses all run out of iterations gets one more chance: the attempt of least
    cost continues from its own states and controls (the solver is stubbed)."""
    from types import SimpleNamespace

    from cocomopl.ocp import solve as ocp_solve

    costs = {"warm start": 2.0, "kinematic": 1.0, "static": 3.0}

    def solve_step(robot, spec, states, *, settings, guess, max_iterations):
        label = guess if isinstance(guess, str) else "warm start"
        return SimpleNamespace(plan=label, xs=[label], us=[label], stats={"cost": costs[label], "converged": False})

    continued = []

    def solve_plan(robot, plan, settings, *, guess, controls, max_iterations):
        continued.append((plan, guess, controls, max_iterations))
        return SimpleNamespace(plan=plan, xs=guess, us=controls, stats={"cost": 0.5, "converged": continued_converges})

    monkeypatch.setattr(ocp_solve, "solve_step", solve_step)
    monkeypatch.setattr(ocp_solve, "solve_plan", solve_plan)
    monkeypatch.setattr(ocp_solve, "failed_checks", lambda robot, solution, settings: ([], 0.0))
    spec = StepSpec("transition", 0.2, 0.3, "left")
    solution, attempts = ocp_solve.solve_with_retries(robot, spec, {}, settings=SMALL, guesses=[["x"], "kinematic", "static"],
                                                      extra_iterations=77)
    assert continued == [("kinematic", ["kinematic"], ["kinematic"], 77)]
    assert [a["guess"] for a in attempts] == ["warm start", "kinematic", "static", "kinematic, continued"]
    assert (solution is not None) == continued_converges
    none, _ = ocp_solve.solve_with_retries(robot, spec, {}, settings=SMALL, guesses=["static"])
    assert none is None and len(continued) == 1  # without extra iterations, no continuation


@pytest.mark.parametrize("neighbour_works", [True, False])
def test_a_cyclic_step_is_solved_afresh_only_where_its_neighbours_walk_fails(robot, monkeypatch, neighbour_works):
    """Continuation warm-starts a footstep from its neighbour's walk; where that leads its cyclic
    step to fail, the footstep's own kinematic walk is tried (the solver is stubbed: only the order of the tries is tested)."""
    from dataclasses import replace
    from types import SimpleNamespace

    from cocomopl.ocp import solve as ocp_solve

    walks = []

    def warm_up_walk(robot, footstep, settings, *, guess=None, controls=None, neighbour=None):
        walks.append(neighbour)
        return SimpleNamespace(xs=["neighbour's" if neighbour is not None else "own"])

    def solve_with_retries(robot, spec, states, *, settings, guesses):
        ok = neighbour_works or guesses[0] == ["own"]
        return (SimpleNamespace(stats={"cost": 1.0, "iterations": 10}) if ok else None), [{"guess": "warm start", "converged": ok}]

    monkeypatch.setattr(ocp_solve, "warm_up_walk", warm_up_walk)
    monkeypatch.setattr(ocp_solve, "walk_segment", lambda robot, walk, kind: walk.xs)
    monkeypatch.setattr(ocp_solve, "solve_with_retries", solve_with_retries)
    neighbour = np.zeros((3, 2))
    solutions, info = ocp_solve.solve_length(robot, 0.2, replace(SMALL, ss_search_step=0.0), kinds=("cyclic",),
                                             neighbour_walk=neighbour)
    assert solutions["cyclic"] is not None
    assert walks == ([neighbour] if neighbour_works else [neighbour, None])
    assert info["duration_search"] == [{"ss_duration": SMALL.ss_duration, "cost": 1.0, "continued": neighbour_works}]


@pytest.mark.parametrize("own_cost", [0.5, 2.0])
def test_a_continued_cyclic_step_that_needs_the_whole_budget_is_also_solved_afresh(robot, monkeypatch, own_cost):
    """A neighbour's walk that leads the cyclic step through the whole iteration budget may have
    led it onto another branch: the footstep's own walk is tried too, and the lower cost kept
    (the solver is stubbed)."""
    from dataclasses import replace
    from types import SimpleNamespace

    from cocomopl.ocp import solve as ocp_solve

    settings = replace(SMALL, ss_search_step=0.0)
    walks = []

    def warm_up_walk(robot, footstep, settings, *, guess=None, controls=None, neighbour=None):
        walks.append(neighbour)
        return SimpleNamespace(xs=["neighbour's" if neighbour is not None else "own"])

    def solve_with_retries(robot, spec, states, *, settings, guesses):
        continued = guesses[0] == ["neighbour's"]
        stats = {"cost": 1.0, "iterations": settings.max_iterations} if continued else {"cost": own_cost, "iterations": 40}
        return SimpleNamespace(stats=stats), [{"guess": "warm start", "converged": True}]

    monkeypatch.setattr(ocp_solve, "warm_up_walk", warm_up_walk)
    monkeypatch.setattr(ocp_solve, "walk_segment", lambda robot, walk, kind: walk.xs)
    monkeypatch.setattr(ocp_solve, "solve_with_retries", solve_with_retries)
    neighbour = np.zeros((3, 2))
    solutions, info = ocp_solve.solve_length(robot, 0.2, settings, kinds=("cyclic",), neighbour_walk=neighbour)
    assert walks == [neighbour, None]
    assert solutions["cyclic"].stats["cost"] == min(1.0, own_cost)
    assert info["duration_search"] == [{"ss_duration": SMALL.ss_duration, "cost": min(1.0, own_cost),
                                        "continued": own_cost > 1.0}]


@pytest.mark.slow
def test_a_continued_walk_takes_only_the_upper_body_from_its_neighbour(robot):
    """Continuation's guess: the neighbour's torso, arm and head joints (positions and
    velocities) on this footstep's kinematic guess, whose base and legs carry the soles to
    this footstep's contacts."""
    from cocomopl.ocp.solve import continued_guess, initial_states, warm_up_plan

    plan = warm_up_plan(robot, 0.2, SMALL)
    kinematic = np.array(initial_states(robot, plan, SMALL, guess="kinematic"))
    neighbour = np.array(initial_states(robot, warm_up_plan(robot, 0.1, SMALL), SMALL, guess="kinematic"))
    neighbour[:, 7:] += 0.05  # every joint position and velocity moved
    xs = np.array(continued_guess(robot, plan, SMALL, neighbour=neighbour))
    nq = robot.model.nq
    legs = np.array(robot.leg_joint_indices())
    upper = robot.upper_body_joint_indices()
    np.testing.assert_array_equal(xs[0], plan.x0)
    np.testing.assert_array_equal(xs[1:, 7 + upper], neighbour[1:, 7 + upper])
    np.testing.assert_array_equal(xs[1:, nq + 6 + upper], neighbour[1:, nq + 6 + upper])
    np.testing.assert_array_equal(xs[:, 7 + legs], kinematic[:, 7 + legs])
    np.testing.assert_array_equal(xs[:, :7], kinematic[:, :7])
    np.testing.assert_array_equal(xs[:, nq:nq + 6], kinematic[:, nq:nq + 6])


def test_descent_finds_the_grid_minimum():
    from cocomopl.ocp.solve import descend

    assert descend(lambda x: (x - 0.9) ** 2, 0.6, 0.1, bounds=(0.5, 1.2)) == pytest.approx(0.9)
    assert descend(lambda x: (x - 0.2) ** 2, 0.6, 0.1, bounds=(0.5, 1.2)) == pytest.approx(0.5)
    assert descend(lambda x: x, 0.6, 0.0, bounds=(0.5, 1.2)) == 0.6


def _resolved_cyclic(robot, motions, **changes):
    """The small dataset's cyclic step solved again, warm-started from itself, with
    ``changes`` to its OCP settings."""
    from dataclasses import replace

    from cocomopl.motion import StepSpec
    from cocomopl.ocp.solve import solve_step, to_motion

    cyclic = motions["cyclic_200_L"]
    x0 = np.concatenate([cyclic.q[0], cyclic.v[0]])
    warm = list(np.hstack([cyclic.q, cyclic.v]))
    settings = replace(SMALL, **changes)
    return to_motion(robot, solve_step(robot, StepSpec("cyclic", 0.2, 0.2), {0.2: x0}, settings=settings, guess=warm),
                     settings)


def test_torque_rate_term_smooths_torques(robot, motions):
    """The paper's torque-rate control, as a penalty: torque jumps between knots shrink."""
    jumps = {}
    for weight in (0.0, 5e-4):
        tau = _resolved_cyclic(robot, motions, w_torque_rate=weight).tau[:-1]
        jumps[weight] = np.abs(np.diff(tau, axis=0)).max()
    assert jumps[5e-4] < 0.7 * jumps[0.0], jumps


def test_min_knee_flexion_bends_the_knees(robot, motions):
    """The small cyclic step stretches a knee to 0.10 rad; asked for a 0.3 rad bend, the
    least knee angle over its knots rises by more than 0.1 rad.  (The limit is a penalty
    barrier, which the coarse 50 ms knots and the initial state, whose knees are at 0.24
    and 0.33 rad, hold only roughly; on the 25 ms training OCPs it holds within 0.01 rad.)"""
    knees = [7 + roles["knee"] for roles in robot.leg_roles().values()]
    free = _resolved_cyclic(robot, motions).q[:, knees].min()
    bent = _resolved_cyclic(robot, motions, min_knee_flexion=0.3).q[:, knees].min()
    assert free < 0.15 and bent > free + 0.1, (free, bent)


def test_knee_bounds_bend_each_knee_the_way_its_limits_allow(robot):
    """TALOS's knees bend towards positive angles; a robot whose knees bend the other way
    gets the bound on the other side, and a bend beyond the limits is refused."""
    import copy

    from cocomopl.ocp.action_models import knee_bounds

    knees = [roles["knee"] for roles in robot.leg_roles().values()]
    lower, upper = knee_bounds(robot, 0.4)
    assert np.allclose(lower[knees], 0.4) and np.allclose(upper, robot.q_upper)
    others = np.setdiff1d(np.arange(robot.nu), knees)
    assert np.allclose(lower[others], robot.q_lower[others])
    mirrored = copy.copy(robot)
    mirrored.q_lower, mirrored.q_upper = -robot.q_upper, -robot.q_lower
    lower, upper = knee_bounds(mirrored, 0.4)
    assert np.allclose(upper[knees], -0.4) and np.allclose(lower, mirrored.q_lower)
    with pytest.raises(Error, match="knee limits"):
        knee_bounds(robot, robot.q_upper[knees].max() + 0.1)


def test_load_shares_hand_the_weight_over_linearly():
    """Between a touchdown and the next lift-off the weight moves linearly from the sole
    that lifts to the one that stays; double supports at rest are left free."""
    from cocomopl.ocp.problems import Phase, load_shares

    phases = [
        Phase("ds", 4),
        Phase("ss", 3, "left", (0.0, 0.2), (0.2, 0.2)),
        Phase("impact", swing="left", swing_to=(0.2, 0.2)),
        Phase("ds", 4),
        Phase("ss", 3, "right", (0.0, 0.0), (0.2, 0.0)),
        Phase("impact", swing="right", swing_to=(0.2, 0.0)),
        Phase("ds", 4),
    ]
    transfer = load_shares(phases, 3, from_rest=True)
    assert [s["left"] for s in transfer] == [0.0, 0.25, 0.5, 0.75]  # left just landed
    assert [s["right"] for s in transfer] == [1.0, 0.75, 0.5, 0.25]  # right lifts next
    assert load_shares(phases, 0, from_rest=True) == [None] * 4  # a start from rest
    assert load_shares(phases, 6, from_rest=True) == [None] * 4  # the final rest
    # a step that continues a walk begins where the previous step's touchdown left the weight
    assert load_shares(phases, 0, from_rest=False) == [{"right": k / 4, "left": 1 - k / 4} for k in range(4)]
    assert load_shares(phases[3:], 0, from_rest=False) == transfer


def test_load_transfer_term_hands_the_weight_over_linearly(robot, motions):
    """Without the term, rigid contacts let the optimiser share the weight in double support
    as it likes (and drop a sole's load in a jump at lift-off); with it, the soles' vertical
    forces follow the linear transfer of :func:`load_shares` far more closely."""
    from cocomopl.analysis.metrics import vertical_forces

    error = {}
    for weight in (0.0, 3e-3):
        motion = _resolved_cyclic(robot, motions, w_load_transfer=weight)
        (_, first, last) = motion.phases[0]  # the double support; the left sole lifts after it
        assert motion.phases[1][0] == "ss" and not motion.contact[last, 0]
        forces = vertical_forces(motion)[first:last]
        shares = forces[:, 0] / forces.sum(axis=1)
        ramp = 1.0 - np.arange(last - first) / (last - first)  # the left sole's share, 1 down to (almost) 0
        error[weight] = np.abs(shares - ramp).max()
    assert error[3e-3] < 0.5 * error[0.0], error


@pytest.mark.slow
def test_the_soles_gap_and_its_gradient_agree_with_the_meshes_and_finite_differences(robot):
    import crocoddyl
    import pinocchio as pin

    from cocomopl.gait import foot_separation, footstep_pose
    from cocomopl.kinematics import flat_placement, soles_distance
    from cocomopl.ocp.action_models import SoleGapResidual, soles_gap

    # side by side the rectangles' gap is the meshes'; turned, the corners come closer than
    # the meshes' rounded toes and heels do: the gap errs on the safe side
    separation, still = foot_separation(robot), flat_placement(0.0, 0.0, 0.0)
    for length, width, turn in [(0.0, 0.0, 0.0), (0.0, 0.015, 25.0), (-0.15, 0.0, 17.0), (0.15, 0.015, 25.0)]:
        landed = flat_placement(*footstep_pose(np.zeros(3), "right", (length, width, -np.radians(turn)),
                                               separation=separation))
        gap, meshes = soles_gap(robot, landed, still), soles_distance(robot, {"left": still, "right": landed})
        assert meshes - 0.005 <= gap <= meshes + 1e-4, (length, width, turn)
    assert soles_gap(robot, flat_placement(0.05, 0.1, 0.2), still) < 0  # overlapping soles have a negative gap

    state = crocoddyl.StateMultibody(robot.model)
    residual = SoleGapResidual(robot, state, "left", stance=flat_placement(0.0, -0.085, 0.3), nu=robot.model.nv - 6)
    shared = crocoddyl.DataCollectorMultibody(robot.model.createData())
    data = residual.createData(shared)
    q = robot.q_ref.copy()
    q[7:] += np.random.default_rng(0).normal(0.0, 0.1, robot.model.nq - 7)
    x = np.concatenate([q, np.zeros(robot.model.nv)])

    def gap_at(x):
        pin.forwardKinematics(robot.model, shared.pinocchio, x[: robot.model.nq])
        residual.calc(data, x)
        return float(data.r[0])

    pin.computeJointJacobians(robot.model, shared.pinocchio, x[: robot.model.nq])
    gap = gap_at(x)
    residual.calcDiff(data, x)
    gradient = np.ravel(data.Rx).copy()
    eps = 1e-7
    differences = [(gap_at(state.integrate(x, eps * np.eye(state.ndx)[i])) - gap) / eps for i in range(state.ndx)]
    np.testing.assert_allclose(gradient, differences, atol=1e-5)
    assert np.abs(gradient).max() > 0.5  # the swing leg's joints move the sole


def test_a_turning_swing_keeps_the_settings_gap_or_the_least_of_its_lift_off_and_landing(robot):
    from cocomopl.kinematics import flat_placement
    from cocomopl.ocp.problems import Phase, swing_gap
    from cocomopl.ocp.settings import OCPSettings

    settings, stance = OCPSettings(), flat_placement(0.0, 0.0, 0.0)
    ahead = Phase("ss", 4, "left", (-0.3, 0.17), (0.3, 0.17), 0.0, 0.0)
    assert swing_gap(robot, ahead, stance, settings=settings) is None  # soles facing ahead keep to their lanes
    turning = Phase("ss", 4, "left", (-0.3, 0.17), (0.3, 0.2), 0.0, np.radians(10))
    assert swing_gap(robot, turning, stance, settings=settings) == settings.sole_gap  # far apart at both ends
    close = Phase("ss", 4, "left", (-0.3, 0.17), (0.0, 0.185), 0.0, np.radians(25))  # a 25-degree gait's landing
    assert 0.0 < swing_gap(robot, close, stance, settings=settings) < settings.sole_gap
    assert swing_gap(robot, ahead, flat_placement(0.0, 0.0, 0.2), settings=settings) is not None  # a turned stance sole


def test_a_friction_ratio_on_the_cones_edge_passes_and_beyond_it_fails(robot, motions):
    """A solution on the penalised cone's edge exceeds it by the solver's resolution (1e-6 to
    1e-5 of the ratio) and passes; a sole sliding 1 % beyond it fails."""
    motion = motions["cyclic_200_R"]
    k = int(np.flatnonzero(motion.contact.all(axis=1))[0])  # in double support
    fn = float(motion.wrenches[k, 0, 2])
    for ratio, fails in ((1.0 + 1e-5, False), (1.01, True)):
        edited = copy.deepcopy(motion)
        edited.wrenches[k, 0, :3] = [ratio * SMALL.friction * fn, 0.0, fn]
        report = check_motion(robot, edited, SMALL.friction)
        assert report["friction_ratio"] == pytest.approx(ratio, rel=1e-9)
        assert ("friction_ratio" in violations(report, TOLERANCES)) is fails
