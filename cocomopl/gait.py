"""The walking vocabulary every stage shares: sides, footsteps, phase plans, step sequences.

A walk is a list of step lengths (m): the first is the start step's, the last the stop's.
From it follow the :class:`~cocomopl.motion.StepSpec` of each step, where each sole stands
before and after it, and which foot is in the air in each of its phases.  Users give step
lengths in millimetres, as the paper does; they are parsed here into metres.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from cocomopl.errors import Error
from cocomopl.kinematics import double_support_posture
from cocomopl.motion import StepSpec
from cocomopl.robot import Robot

OTHER_SIDE = {"left": "right", "right": "left"}

# The paper's test walk M_gen (sec. V) and its OC counterpart M_opt, with 400 for 390 mm
M_GEN = (0.15, 0.15, 0.25, 0.35, 0.39, 0.35, 0.25, 0.15, 0.15)
M_OPT = (0.15, 0.15, 0.25, 0.35, 0.40, 0.35, 0.25, 0.15, 0.15)
M_GEN_MM = ",".join(f"{1000 * x:g}" for x in M_GEN)


def m_gen(robot: Robot) -> tuple[float, ...]:
    """M_gen for ``robot``: its description's ``defaults.walk``, else TALOS's lengths scaled by
    its leg length, to 10 mm (TALOS: ``M_GEN``)."""
    return _default_walk(robot, M_GEN)


def m_opt(robot: Robot) -> tuple[float, ...]:
    """M_opt for ``robot``: its description's ``defaults.walk``, else scaled as :func:`m_gen`
    (TALOS: ``M_OPT``)."""
    return _default_walk(robot, M_OPT)


def _default_walk(robot: Robot, talos: tuple[float, ...]) -> tuple[float, ...]:
    given = robot.override("walk")
    return tuple(map(float, given)) if given is not None else tuple(robot.scale.length_m(x) for x in talos)


def foot_separation(robot: Robot) -> float:
    """Lateral distance between the soles in the reference posture (m)."""
    left = robot.frame_placement(robot.q_ref, robot.foot_frames["left"]).translation
    right = robot.frame_placement(robot.q_ref, robot.foot_frames["right"]).translation
    return round(float(left[1] - right[1]), 4)


def footstep_pose(other: np.ndarray, side: str, footstep: Sequence[float], *, separation: float) -> np.ndarray:
    """Where sole ``side`` lands, (x, y, yaw), taking the ``footstep`` (length, width, turn) from
    the other sole at pose ``other`` (:class:`~cocomopl.motion.StepSpec` says how a footstep
    is measured); ``separation``: the soles' nominal lateral distance (m)."""
    length, width, turn = footstep
    sign = 1.0 if side == "left" else -1.0
    dx, dy = length, sign * (separation + width)
    c, s = math.cos(other[2]), math.sin(other[2])
    return np.array([other[0] + c * dx - s * dy, other[1] + s * dx + c * dy, other[2] + sign * turn])


def footstep_origin(landed: np.ndarray, side: str, footstep: Sequence[float], *, separation: float) -> np.ndarray:
    """The pose of the sole that sole ``side`` took the ``footstep`` (length, width, turn) from,
    given where it ``landed``: the inverse of :func:`footstep_pose`."""
    length, width, turn = footstep
    sign = 1.0 if side == "left" else -1.0
    yaw = landed[2] - sign * turn
    dx, dy = length, sign * (separation + width)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([landed[0] - (c * dx - s * dy), landed[1] - (s * dx + c * dy), yaw])


def gait_state_posture(robot: Robot, footstep: Sequence[float]) -> np.ndarray:
    """The posture of the gait state S of ``footstep`` (length, width, turn): the right sole
    at the origin, the left where the footstep leaves from, the CoM between them.

    Raises
    ------
    Error
        If the legs cannot stand so (:func:`~cocomopl.kinematics.double_support_posture`).
    """
    left = footstep_origin(np.zeros(3), "right", footstep, separation=foot_separation(robot))
    return double_support_posture(robot, (left[0], left[1]), (0.0, 0.0), yaws=(left[2], 0.0))


# What a footstep may ask of the robot (length, width in m; turn in rad).  Backward steps
# are shorter than forward ones: the swing leg passes behind the hip, where the knee cannot
# help.  Outward, 150 mm of side step beyond the nominal separation, and the 15 mm more a
# 25-degree turn steps out (``planning.goal.turn_step_out``), keep the stance hip's abduction
# within its limits.  Inward steps and turns are bounded by the feet themselves:
# ``check_footstep`` refuses a footstep whose soles come closer than ``FEET_GAP``.
# These are TALOS's; another robot's are scaled by its size (``footstep_range``).
FOOTSTEP_RANGE = {"length": (-0.15, 0.40), "width": (-0.05, 0.165), "turn": (-math.radians(25), math.radians(25))}
FEET_GAP = 0.01  # m between the feet's meshes, both flat on the ground
# How far past a bound of FOOTSTEP_RANGE a footstep still counts as on it: a footstep file's
# landings are world poses in rounded numbers, and a footstep at a bound read back from them
# lands up to a few micrometres (at 0.1 deg of yaw, a third of a millimetre) on either side.
RANGE_ROUNDING = {"length": 5e-4, "width": 5e-4, "turn": math.radians(0.05)}

# Weights of a footstep's width (m/m) and turn (m/rad) in the metric the weight GPs and the
# training design measure footsteps in, metres of step length: each maps its range
# (FOOTSTEP_RANGE: 200 mm without the 15 mm turns add, 50 degrees) onto the lengths' 550 mm,
# so that one kernel width spans the three alike.
WIDTH_SCALE = 2.75
TURN_SCALE = 0.63
FOOTSTEP_METRIC = np.array([1.0, WIDTH_SCALE, TURN_SCALE])  # (length, width, turn) -> metres


def footstep_range(robot: Robot) -> dict[str, tuple[float, float]]:
    """What a footstep may ask of ``robot``: (low, high) per ``"length"``, ``"width"`` (m) and
    ``"turn"`` (rad).

    ``FOOTSTEP_RANGE``'s lengths and widths scaled as the robot's step lengths
    (:meth:`~cocomopl.robot.scale.Scale.length_m`: the leg length, or the stride the legs
    stand across), to 10 and 5 mm; its turns as they are, since a hip's yaw range does not
    grow with the leg.  TALOS's: ``FOOTSTEP_RANGE`` itself.  The description's
    ``defaults.footstep_range`` replaces any of the three.
    """
    scale = robot.scale
    length = tuple(scale.length_m(x) for x in FOOTSTEP_RANGE["length"])
    width = tuple(scale.length_m(x, resolution=0.005) for x in FOOTSTEP_RANGE["width"])
    given = {key: (float(low), float(high)) for key, (low, high) in (robot.override("footstep_range") or {}).items()}
    return {"length": length, "width": width, "turn": FOOTSTEP_RANGE["turn"]} | given


def within_range(key: str, value: float, limits: dict[str, tuple[float, float]] = FOOTSTEP_RANGE) -> bool:
    """Whether a footstep's ``key`` ("length", "width" or "turn") is within ``limits``
    (by default ``FOOTSTEP_RANGE``), give or take ``RANGE_ROUNDING``."""
    low, high = limits[key]
    return low - RANGE_ROUNDING[key] <= value <= high + RANGE_ROUNDING[key]


def check_footstep(robot: Robot, side: str, footstep: Sequence[float]) -> None:
    """An :class:`Error` unless sole ``side`` may land at the ``footstep`` (length, width, turn)
    from the other: within :func:`footstep_range` (give or take ``RANGE_ROUNDING``) and with
    the feet's meshes ``FEET_GAP`` apart."""
    from cocomopl.kinematics import flat_placement, soles_distance

    length, width, turn = footstep
    asked = {"length": length, "width": width, "turn": turn}
    limits = footstep_range(robot)
    for key, value in asked.items():
        if not (isinstance(value, (int, float)) and math.isfinite(value) and within_range(key, value, limits)):
            low, high = limits[key]
            unit, scale = ("deg", math.degrees(1)) if key == "turn" else ("mm", 1000)
            raise Error(f"footstep {key} {value * scale:g} {unit} is outside {low * scale:g}..{high * scale:g} {unit}")
    landed = footstep_pose(np.zeros(3), side, footstep, separation=foot_separation(robot))
    other = OTHER_SIDE[side]
    gap = soles_distance(robot, {other: flat_placement(0.0, 0.0, 0.0), side: flat_placement(*landed)})
    if gap < FEET_GAP:
        raise Error(
            f"footstep ({length * 1000:g} mm, width {width * 1000:g} mm, turn {math.degrees(turn):g} deg) puts the "
            f"{side} foot {max(gap, 0.0) * 1000:.0f} mm from the {other} one (at least {FEET_GAP * 1000:g} mm)"
        )


def initial_soles(robot: Robot) -> dict[str, np.ndarray]:
    """The soles' poses (x, y, yaw) before a walk: side by side at the origin, facing +x."""
    half = foot_separation(robot) / 2
    return {"left": np.array([0.0, half, 0.0]), "right": np.array([0.0, -half, 0.0])}


def wrap_angle(angle: float) -> float:
    """``angle`` (rad) in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def mean_yaw(left: float, right: float) -> float:
    """The heading (rad) halfway between two soles' yaws, the short way round."""
    return right + 0.5 * wrap_angle(left - right)


def footsteps(robot: Robot, specs: list[StepSpec], soles: dict[str, np.ndarray] | None = None) -> list[dict]:
    """Where each sole stands at each step's start and end, world frame (x forward, z up):
    ``"start"`` and ``"end"`` positions (3,) by side, and under ``"yaw"`` the soles' yaws
    (rad) at the ``"start"`` and ``"end"``.  The walk starts from the sole poses (x, y, yaw)
    ``soles`` by side, by default side by side, facing +x, the right one at y = -separation/2."""
    separation = foot_separation(robot)
    poses = {side: np.array(pose, dtype=float) for side, pose in (soles or initial_soles(robot)).items()}
    out = []
    for spec in specs:
        start = {k: v.copy() for k, v in poses.items()}
        stance, swing = OTHER_SIDE[spec.swing_side], spec.swing_side
        footstep = spec.start_footstep if spec.kind == "stop" else spec.end_footstep
        poses[swing] = footstep_pose(poses[stance], swing, footstep, separation=separation)
        if spec.kind == "stop":  # the stance foot closes up beside it
            poses[stance] = footstep_pose(poses[swing], stance, (0.0, 0.0, 0.0), separation=separation)
        out.append({
            "start": {side: np.array([p[0], p[1], 0.0]) for side, p in start.items()},
            "end": {side: np.array([p[0], p[1], 0.0]) for side, p in poses.items()},
            "yaw": {"start": {side: float(p[2]) for side, p in start.items()},
                    "end": {side: float(p[2]) for side, p in poses.items()}},
        })
    return out


def sole_poses(robot: Robot, specs: list[StepSpec]) -> list[dict[str, np.ndarray]]:
    """Per step of ``specs``, the soles' world poses (x, y, yaw) at its start, by side
    (:func:`footsteps`)."""
    return [{side: np.array([*feet["start"][side][:2], feet["yaw"]["start"][side]]) for side in OTHER_SIDE}
            for feet in footsteps(robot, specs)]


def phase_plan(spec: StepSpec) -> list[tuple[str, str | None]]:
    """(phase kind, foot in the air or None) per phase of a step."""
    swing, stance = spec.swing_side, OTHER_SIDE[spec.swing_side]
    plan = [("ds", None), ("ss", swing)]
    if spec.kind == "stop":
        plan += [("ds", None), ("ss", stance), ("ds", None)]
    return plan


def ground_position(feet: dict, plan: list, side: str, *, phase: int) -> np.ndarray:
    """Where a sole stands in a phase: its start position until it has swung, then its end."""
    return feet[_when(plan, side, phase)][side]


def ground_yaw(feet: dict, plan: list, side: str, *, phase: int) -> float:
    """The yaw (rad) of a sole in a phase, as :func:`ground_position` places it."""
    return feet["yaw"][_when(plan, side, phase)][side]


def _when(plan: list, side: str, phase: int) -> str:
    """``"end"`` once sole ``side`` has swung by ``phase`` of the step's ``plan``, else ``"start"``."""
    return "end" if any(air == side for _, air in plan[:phase]) else "start"


def sequence_specs(lengths: Sequence[float], first_swing: str = "left") -> list[StepSpec]:
    """Step specs for step lengths (m): a start, then cyclic or transition steps, then a stop.

    The first length is the start step's, the last the stop's; in between, a step whose
    length equals the previous one is cyclic, otherwise a transition.  Feet alternate.  A
    stop starts in the gait of its own length, so the last two lengths must be equal (the
    paper's M_gen ends ...,150,150).
    """
    lengths = [float(x) for x in lengths]
    if len(lengths) < 2:
        raise Error(f"a walk needs at least two steps (a start and a stop), got {len(lengths)}")
    for x in lengths:
        if not math.isfinite(x) or x <= 0:
            raise Error(f"step length {x * 1000:g} mm must be a positive finite number")
    if lengths[-1] != lengths[-2]:
        # a stop step of length L starts in the gait of length L (the paper's S(L))
        a, b = (f"{1000 * x:g}" for x in lengths[-2:])
        raise Error(
            f"the stop step ({b} mm) must repeat the length before it ({a} mm): a stop starts where the "
            f"previous step ended; end the list with ...,{b},{b} or ...,{a},{a}"
        )
    specs = [StepSpec("start", 0.0, lengths[0], first_swing)]
    for previous, length in itertools.pairwise(lengths[:-1]):
        kind = "cyclic" if length == previous else "transition"
        specs.append(StepSpec(kind, previous, length, OTHER_SIDE[specs[-1].swing_side]))
    specs.append(StepSpec("stop", lengths[-1], 0.0, OTHER_SIDE[specs[-1].swing_side]))
    return specs


def parse_sequence_mm(text: str) -> list[float]:
    """Step lengths of a walk from ``"150,150,250,...,150"`` (millimetres) to metres, in order."""
    items = [s.strip() for s in str(text).split(",")]
    if not any(items):
        raise Error("no step lengths given: expected e.g. --lengths-mm 150,150,250,150")
    out = [length_mm_to_m(item) for item in items]
    if len(out) < 2:
        raise Error(f"a walk needs at least two steps (a start and a stop), got {len(out)}")
    return out


MAX_LENGTH_M = 0.80  # beyond any human-sized humanoid's stride; the IK rejects earlier
# Shorter steps than this are not walking but shuffling, and no training set has them; it
# also catches lengths typed in metres where millimetres are asked for (0.15 for 150).
MIN_LENGTH_M = 0.05


def length_mm_to_m(item: str) -> float:
    """One step length given in millimetres, in metres; an :class:`Error` unless a number of millimetres within ``MIN_LENGTH_M``..``MAX_LENGTH_M``."""
    try:
        if not str(item).isascii():  # float() reads other scripts' digits, e.g. Arabic-Indic ones
            raise ValueError
        value = float(item)
    except ValueError:
        raise Error(f"step length {item!r} is not a number in ASCII digits (millimetres expected)") from None
    if not math.isfinite(value) or value <= 0:
        raise Error(f"step length {item!r} mm must be a positive finite number")
    if value / 1000 < MIN_LENGTH_M:
        raise Error(
            f"step length {value:g} mm is below the shortest step of {MIN_LENGTH_M * 1000:g} mm: step lengths are "
            f"in millimetres ({value:g} m would be {value * 1000:g} mm)"
        )
    if value / 1000 > MAX_LENGTH_M:
        raise Error(f"step length {value:g} mm is beyond reach (at most {MAX_LENGTH_M * 1000:g} mm)")
    return round(value / 1000, 6)


def parse_lengths_mm(text: str) -> tuple[float, ...]:
    """Parse a comma-separated list of step lengths in millimetres into metres.

    Raises
    ------
    Error
        On anything but a list of distinct positive numbers.
    """
    items = [s.strip() for s in str(text).split(",") if s.strip()]
    if not items:
        raise Error("no step lengths given: expected e.g. --lengths-mm 150,250,300")
    lengths = [length_mm_to_m(item) for item in items]
    if len(set(lengths)) != len(lengths):
        raise Error("step lengths must be distinct")
    return tuple(sorted(lengths))


def parse_transitions_mm(text: str, lengths: tuple[float, ...]) -> tuple[tuple[float, float], ...]:
    """Parse extra transitions such as ``150-250,250-350`` (mm) into pairs of lengths (m).

    Raises
    ------
    Error
        Unless every pair joins two different lengths of ``lengths``.
    """
    pairs = []
    for item in (s.strip() for s in str(text).split(",") if s.strip()):
        ends = item.split("-")
        if len(ends) != 2:
            raise Error(f"transition {item!r} is not two lengths in millimetres joined by '-', e.g. 150-250")
        try:
            a, b = (length_mm_to_m(end) for end in ends)
        except Error as exc:
            raise Error(f"transition {item!r}: {exc}") from None
        for end in (a, b):
            if end not in lengths:
                raise Error(f"transition {item!r}: {end * 1000:g} mm is not one of the training lengths")
        if a == b:
            raise Error(f"transition {item!r} joins a length to itself (that is a cyclic step)")
        pairs.append((min(a, b), max(a, b)))
    return tuple(sorted(set(pairs)))

