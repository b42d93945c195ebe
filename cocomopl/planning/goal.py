"""A footstep planner to a goal pose: the fewest steps of one steady gait that end there.

The gait repeats one pair of footsteps: the leading foot (the first to swing) steps
``(length, max(lateral, 0) + d, turn)``, the trailing foot ``(length, max(-lateral, 0) + d,
-turn)``, where ``d`` (:func:`turn_step_out`) widens the stance at large turns.
So every step advances by ``length`` and turns the walk by ``turn`` (toes out on the leading
foot, in on the trailing one), and every pair moves it ``lateral`` sideways, always by the
foot on that side stepping outward: stepping inward is limited by the feet colliding.  The
walk is an arc of constant curvature, straight or sideways as special cases; a stop repeats
the last footstep before the feet close up, which the planner accounts for.

For n = 2, 3, ... landings and both leading feet, the three gait parameters are solved by
least squares (SciPy) so the walk's end pose (the feet's midpoint and heading, after the stop)
is the goal; the first n whose solution reaches it within the footstep ``limits``, with every
footstep clear of collision, is the plan.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from cocomopl.errors import Error, parse_finite
from cocomopl.gait import OTHER_SIDE, check_footstep, footstep_range, wrap_angle
from cocomopl.motion import Footstep, StepSpec
from cocomopl.planning.footsteps import footstep_specs, midpoint, soles_after
from cocomopl.robot import Robot

MAX_LANDINGS = 40
POSITION_TOLERANCE_M = 1e-3  # of the planned end pose; the planner is exact, the walk is not
YAW_TOLERANCE_RAD = math.radians(0.1)
YAW_WEIGHT_M = 0.3  # m per rad in the least squares: a sole's length


# How far both feet step out at a 25-degree turn.  Toeing in (the trailing foot) or out (the
# leading one) beyond 16 degrees brings the soles within FEET_GAP of each other at some length
# from -150 to 400 mm unless the foot lands further out (``check_footstep``, 0.25 mm steps):
# 0.75 mm at 17 degrees, 5 at 20, 11.5 at 25.  The step-out covers that at every degree.
TURN_STEP_OUT_M = 0.015
TURN_STEP_OUT_FROM = math.radians(12)
TURN_STEP_OUT_AT = math.radians(25)


def turn_step_out(turn: float) -> float:
    """How far (m) both feet of a gait that turns ``turn`` rad a step land beyond their
    sideways step: none up to 12 degrees (so the gaits of the 12-degree sets stay as they
    were), then quadratic up to 15 mm at 25, so that the planner's least squares stays smooth.
    Both feet step out, so a pair still moves ``lateral`` sideways."""
    excess = max(abs(turn) - TURN_STEP_OUT_FROM, 0.0) / (TURN_STEP_OUT_AT - TURN_STEP_OUT_FROM)
    return TURN_STEP_OUT_M * excess**2


def steady_gait(length: float, lateral: float, turn: float) -> tuple[Footstep, Footstep]:
    """The leading and the trailing foot's footsteps of the steady gait that advances
    ``length`` m and turns ``turn`` rad a step and moves ``lateral`` m sideways a pair."""
    out = turn_step_out(turn)
    return Footstep(length, max(lateral, 0.0) + out, turn), Footstep(length, max(-lateral, 0.0) + out, -turn + 0.0)


def gait_specs(n: int, lead: str, gait: Sequence[float]) -> list[StepSpec]:
    """The steps of ``n`` landings of the ``gait`` (length m, lateral m per pair, turn rad per
    step), ``lead`` foot first."""
    length, lateral, turn = gait
    leading, trailing = steady_gait(length, lateral, turn)
    return footstep_specs([leading if k % 2 == 0 else trailing for k in range(n - 1)], lead)


def _end_error(robot: Robot, goal: np.ndarray, specs: list[StepSpec]) -> np.ndarray:
    end = midpoint(soles_after(robot, specs))
    return np.array([end[0] - goal[0], end[1] - goal[1], YAW_WEIGHT_M * wrap_angle(end[2] - goal[2])])


def _solve(robot: Robot, goal: np.ndarray, n: int, lead: str, limits: dict) -> tuple[float, float, float] | None:
    """The gait whose ``n`` landings from ``lead`` end at ``goal``, or None."""
    from scipy.optimize import least_squares  # 0.4 s to load: only walks to goals pay it

    (l0, l1), (_, w1), (t0, t1) = limits["length"], limits["width"], limits["turn"]
    turn = min(t1, -t0)  # both feet take it, one toes out and the other toes in
    lateral = w1 - turn_step_out(turn)  # the widest side step that still has room to turn
    if turn < 0 or lateral < 0 or l0 > l1:
        return None
    low, high = np.array([l0, -lateral, -turn]), np.array([l1, lateral, turn])
    guess = np.clip([goal[0] / n, 2 * goal[1] / n, goal[2] / n], low, high)
    fit = least_squares(lambda p: _end_error(robot, goal, gait_specs(n, lead, p)), guess,
                        bounds=(low - 1e-12, high + 1e-12), xtol=1e-10, ftol=1e-12)
    error = _end_error(robot, goal, gait_specs(n, lead, fit.x))
    if np.hypot(error[0], error[1]) > POSITION_TOLERANCE_M or abs(error[2]) / YAW_WEIGHT_M > YAW_TOLERANCE_RAD:
        return None
    return tuple(float(v) for v in np.clip(fit.x, low, high))


def plan_to_goal(robot: Robot, goal: tuple[float, float, float], *, limits: dict | None = None,
                 accept: Callable[[list[StepSpec]], bool] | None = None) -> list[StepSpec]:
    """The steps of the fewest-landing steady gait whose feet end at ``goal``.

    Parameters
    ----------
    goal : (x, y, yaw) of the feet's midpoint and heading at the end, world frame (m, rad),
        from the feet side by side at the origin facing +x
    limits : (low, high) per footstep ``"length"``, ``"width"``, ``"turn"`` the plan must
        keep within (default: the robot's, :func:`~cocomopl.gait.footstep_range`); a model's learned range
    accept : a further test a plan must pass, e.g. that every step lies within a model's
        training support (:func:`cocomopl.pipeline.plan_in_support`); a plan it refuses gives
        way to the next

    Raises
    ------
    Error
        If no gait of up to ``MAX_LANDINGS`` landings reaches the goal within the limits (and
        passes ``accept``).
    """
    limits = footstep_range(robot) if limits is None else limits
    goal = np.array([float(v) for v in goal])
    if not np.all(np.isfinite(goal)):
        raise Error(f"goal {tuple(goal)} is not finite")
    goal[2] = wrap_angle(goal[2])
    # lead with the foot on the side the walk goes: it steps outward first
    leads = ("left", "right") if goal[2] > 0 or (goal[2] == 0 and goal[1] >= 0) else ("right", "left")
    refused = False  # by accept: the range alone would have had a plan
    for n in range(2, MAX_LANDINGS + 1):
        for lead in leads:
            gait = _solve(robot, goal, n, lead, limits)
            if gait is None:
                continue
            specs = gait_specs(n, lead, gait)
            if _clear(robot, specs):
                if accept is None or accept(specs):
                    return specs
                refused = True
    raise Error(
        f"no steady walk of up to {MAX_LANDINGS} steps reaches ({goal[0]:g} m, {goal[1]:g} m, "
        f"{math.degrees(goal[2]):g} deg) within the footstep range "
        + ("and the model's support " if refused else "")
        + ", ".join(f"{k} {_shown(k, lo)}..{_shown(k, hi)}" for k, (lo, hi) in limits.items())
        + (" (a model of straight steps: it reaches goals straight ahead only)"
           if limits["width"] == (0.0, 0.0) and limits["turn"] == (0.0, 0.0) else "")
    )


def plan_through(robot: Robot, goals: Sequence[tuple[float, float, float]], *, limits: dict | None = None,
                 accept: Callable[[list[StepSpec]], bool] | None = None) -> list[StepSpec]:
    """The walks of :func:`plan_to_goal` to each of ``goals`` in turn: the robot stops at
    every goal, feet side by side, and walks on from there to the next.

    ``goals`` are world poses (x, y, yaw) of the feet's midpoint and heading (m, rad); each
    walk is planned from where the planned walk before it ends (within
    ``POSITION_TOLERANCE_M`` and ``YAW_TOLERANCE_RAD`` of its goal), so the plan's error does
    not add up over the goals.  ``accept`` as :func:`plan_to_goal`'s.
    """
    if not goals:
        raise Error("a walk through goals needs at least one goal")
    specs: list[StepSpec] = []
    for goal in goals:
        here = midpoint(soles_after(robot, specs)) if specs else np.zeros(3)
        c, s = math.cos(here[2]), math.sin(here[2])
        dx, dy = goal[0] - here[0], goal[1] - here[1]
        specs += plan_to_goal(robot, (c * dx + s * dy, -s * dx + c * dy, wrap_angle(goal[2] - here[2])), limits=limits,
                              accept=accept)
    return specs


def _shown(key: str, value: float) -> str:
    return f"{math.degrees(value):.0f} deg" if key == "turn" else f"{value * 1000:.0f} mm"


def _clear(robot: Robot, specs: list[StepSpec]) -> bool:
    """Whether every footstep of ``specs`` is in range and clear of the other foot."""
    for spec in specs:
        footstep = spec.start_footstep if spec.kind == "stop" else spec.end_footstep
        side = spec.swing_side
        try:
            check_footstep(robot, side, footstep)
            if spec.kind == "stop":
                check_footstep(robot, OTHER_SIDE[side], (0.0, 0.0, 0.0))
        except Error:
            return False
    return True


MAX_GOAL_M = 10.0  # farther than MAX_LANDINGS steps can go


def parse_goal(text: str) -> tuple[float, float, float]:
    """A goal pose from ``"X_M,Y_M,YAW_DEG"`` (metres and degrees) to (x, y, yaw) in m and rad."""
    items = [s.strip() for s in str(text).split(",")]
    if len(items) != 3:
        raise Error(f"goal {text!r} must be three numbers X_M,Y_M,YAW_DEG (metres, metres, degrees), e.g. 1.0,0.5,90")
    x, y, yaw = (parse_finite(item, f"goal {name}") for item, name in zip(items, ("x", "y", "yaw")))
    if math.hypot(x, y) > MAX_GOAL_M:
        raise Error(f"goal ({x:g}, {y:g}) m is more than {MAX_GOAL_M:g} m away: plan a long walk as several")
    return x, y, math.radians(yaw)
