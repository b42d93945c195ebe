"""What a user may tune in the step OCPs, in one plain dataclass (no solver imported)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import TYPE_CHECKING

from cocomopl.errors import Error

if TYPE_CHECKING:
    from cocomopl.robot.scale import Scale

# what refinement warm-starts each step's OCP from: the generated step, the dataset's solved
# step nearest it, or the solved steps around it interpolated (the nearest where they do not
# surround it); the commands and pipeline.refine take the interpolated ones, which need the
# fewest iterations (docs/results.md#refinement)
WARM_STARTS = ("generated", "nearest", "interpolated")
DEFAULT_WARM_START = "interpolated"


@dataclass(frozen=True)
class OCPSettings:
    """Discretisation, constraint margins and penalty weights of the step OCPs.

    Units are SI.  Weights multiply squared residuals integrated over time (s^-1).
    """

    dt: float = 0.025
    ds_duration: float = 0.15
    ss_duration: float = 0.80
    # single-support duration search per length, s (0: none).  Off by default: the cost is
    # flat within 4 % over 0.6-1.1 s, so the search picked 0.7-1.0 s irregularly across
    # lengths, and the primitives could not interpolate transitions between such gaits
    ss_search_step: float = 0.0
    ss_bounds: tuple[float, float] = (0.5, 1.2)
    start_ds_duration: float = 0.40
    rest_duration: float = 0.40
    # 300: the load transfer below makes some steps need more than 200 (stop_200: about 220)
    max_iterations: int = 300
    tolerance: float = 1e-3  # relative cost change over 25 iterations that counts as converged
    friction: float = 0.7
    zmp_margin: float = 0.02
    clearance: float = 0.05
    swing_lateral_gap: float = 0.03
    # where a sole turns, in place of the lane: the least gap (m) between the soles'
    # rectangles through a swing, or less where it lifts off or lands closer
    # (ocp.problems.swing_gap); the lane's gap, so that a swing keeps as far off either way
    sole_gap: float = 0.03
    w_torque: float = 1e-2
    w_torque_rate: float = 5e-5  # on the torque rate, (N m / s)^2 s; 0 switches it off
    w_posture: float = 1.0
    # on the joints that carry no sole (torso, arms, head), in place of w_posture: the torque
    # cost leaves them nearly free (at 1, two initial guesses of the 150 mm start step ended
    # 24 mrad RMS apart in the upper body at equal cost), and neighbouring OCPs then find them
    # on other branches.  3 is the least weight tried (1, 2, 3, 5, 10, 100) at which both
    # guesses of the 150 mm start and stop steps agree within 1 mrad; it costs 7-11 % more
    # leg torque squared there (docs/method.md#a-unique-upper-body)
    w_upper_posture: float = 3.0
    w_velocity: float = 1e-1
    # on the velocities of the joints that carry no sole, in place of w_velocity: light arms
    # left at the legs' weight swing at up to 30 rad/s in G1's step-space transitions, where
    # TALOS's stay under 4.2 (docs/experiments/g1-arm-velocities.md)
    w_upper_velocity: float = 1e-1
    w_constraint: float = 1e4
    w_limits: float = 1e5
    # on the soles' gap, m^-2: 1 mm short costs 50, about a cyclic step's whole cost (the
    # residual is in metres, where the wrench barriers' are in newtons)
    w_sole_gap: float = 1e8
    # on the landing sole's velocity at touchdown, (m/s)^2: high enough that every sole lands
    # at under 1 cm/s.  The impulse model absorbs any landing speed for free, a stiff
    # position-controlled robot does not (0.5 m/s gave 4 x the weight in MuJoCo)
    w_touchdown: float = 1e4
    w_anchor: float = 1e7
    position_limit_margin: float = 0.02  # rad
    velocity_limit_scale: float = 0.9
    w_placement: float = 1e6
    w_target: float = 1e5
    w_swing_guide: float = 1e3
    # on each sole's vertical force in double support against a linear transfer of the
    # weight from the sole that lifts next to the one that landed, N^-2 (README "Load
    # transfer"; 0 switches it off).  On straight knees it raised the generated walk's peak
    # force over 1.3 x weight; with the knees bent it makes the executed forces smoother
    w_load_transfer: float = 1e-3
    # rad: the least bend of every knee, at every knot (0: the URDF's limit and the margin
    # only).  A nearly straight knee makes a leg vertically stiff on a position-controlled
    # robot, and the double support then trades load between the soles (README "Knee
    # flexion"); the bend costs torque
    min_knee_flexion: float = 0.6

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_saved(cls, saved: dict) -> OCPSettings:
        """The settings a dataset or part file records (``as_dict`` read back), as they were
        solved with: a weight added since then takes the value it had before it existed."""
        unknown = sorted(set(saved) - {f.name for f in fields(cls)})
        if unknown:
            raise Error(f"the OCP settings name {', '.join(unknown)}, which this cocomopl does not know")
        # before w_upper_posture and w_upper_velocity, the upper body had the legs' weights
        saved = {"w_upper_posture": saved.get("w_posture", cls.w_posture),
                 "w_upper_velocity": saved.get("w_velocity", cls.w_velocity), **saved}
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in saved.items()}
        return cls(**values)


def robot_settings(scale: Scale, overrides: dict | None = None) -> OCPSettings:
    """The default settings for a robot of ``scale`` (:class:`~cocomopl.robot.scale.Scale`,
    its size relative to TALOS's, on which they were tuned; docs/robots.md):

    * the ZMP margin with the soles' half width (TALOS: 20 mm of 67 mm);
    * the swing's clearance and the gaps between the soles with the leg length;
    * the load-transfer weight (N^-2) with the inverse square of the weight, so that its cost
      is the same share of a step's;
    * the double supports' durations with the square root of the leg length (the same Froude
      number), and the single support's also with the soles' width
      (:meth:`~cocomopl.robot.scale.Scale.single_support`), each a whole number of knots.

    TALOS (a scale of 1) gets the defaults exactly.  ``overrides`` (a robot description's
    ``defaults.ocp``, :meth:`~cocomopl.robot.Robot.override`) replace any of them.
    """
    from cocomopl.robot.description import checked_overrides

    d = OCPSettings()
    durations = {key: scale.duration(getattr(d, key), d.dt) for key in ("ds_duration", "start_ds_duration", "rest_duration")}
    durations["ss_duration"] = scale.single_support(d.ss_duration, d.dt)
    scaled = replace(d, zmp_margin=d.zmp_margin * scale.width, clearance=d.clearance * scale.length,
                     swing_lateral_gap=d.swing_lateral_gap * scale.length, sole_gap=d.sole_gap * scale.length,
                     w_load_transfer=d.w_load_transfer / scale.mass**2, **durations)
    return replace(scaled, **checked_overrides(overrides or {}, _OVERRIDE_CHECKS, section="ocp",
                                               what="an OCP setting (a field of OCPSettings)"))


def settings_for(robot) -> OCPSettings:
    """The default OCP settings of ``robot`` (a :class:`~cocomopl.robot.Robot`): scaled to it
    (:func:`robot_settings`), with its description's ``defaults.ocp`` in place."""
    return robot_settings(robot.scale, robot.override("ocp"))


def _override_check(name: str, default) -> tuple:
    """What a description's ``defaults.ocp`` may give the setting ``name`` (its default
    ``default``), and how to say so (:func:`~cocomopl.robot.description.checked_overrides`)."""
    def number(value) -> bool:
        return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)

    if isinstance(default, tuple):
        return (lambda v: isinstance(v, list) and len(v) == 2 and all(isinstance(x, int | float) and x > 0 for x in v)
                and v[0] < v[1]), "two increasing positive numbers"
    if isinstance(default, int):
        return (lambda v: isinstance(v, int) and not isinstance(v, bool) and v > 0), "a positive whole number"
    if name == "dt":
        return (lambda v: number(v) and v > 0), "a positive number"
    return (lambda v: number(v) and v >= 0), "a number of at least 0"


_OVERRIDE_CHECKS = {f.name: _override_check(f.name, getattr(OCPSettings(), f.name)) for f in fields(OCPSettings)}
