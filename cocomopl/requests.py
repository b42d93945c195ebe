"""What a walk is asked for, as values that cannot be built wrong.

A walk follows one :data:`WalkPath`: straight step lengths (:class:`StraightSteps`), the world
landings of a footstep plan (:class:`Footsteps`) or goal poses reached in turn (:class:`Goals`).
A :class:`WalkRequest` adds the model, the sample spacing, strictness, an optional
:class:`Refinement` by optimal control and the replanner of the simulated walk; the options
that exclude each other are refused when it is built, in one line naming them.
:func:`cocomopl.pipeline.generate_walk` and :func:`cocomopl.pipeline.walk_report` take it, as
the simulation takes :class:`~cocomopl.pipeline.SimSettings`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

from cocomopl.data import dataset_path, model_path
from cocomopl.errors import Error
from cocomopl.ocp.settings import DEFAULT_WARM_START, WARM_STARTS
from cocomopl.planning.footsteps import Landing

Goal = tuple[float, float, float]  # x, y (m), yaw (rad) of the feet's midpoint, world frame
# s: sample spacing of generated walks, the OC training data's knot spacing
PLAN_DT = 0.025
PLAN_DT_RANGE = (0.01, 0.05)  # s: see check_plan_dt; at 0.01 M_gen takes 76 s on 2 cores, at 0.005 500 s
FIRST_SWINGS = ("left", "right")
# how a simulated walk is planned again while it runs (docs/method.md#footstep-re-aiming,
# docs/method.md#recovery-by-stepping); both replan with the primitives, so neither goes
# with a walk refined by optimal control
REPLANNERS = ("none", "reaim", "recover")
REPLANNER_NAMES = {"reaim": "footstep re-aiming", "recover": "recovery by stepping"}


def check_plan_dt(dt: float) -> float:
    """``dt`` (s) if it is a sample spacing for a generated walk within ``PLAN_DT_RANGE``, else :class:`Error`."""
    low, high = PLAN_DT_RANGE
    if not low <= dt <= high:
        raise Error(f"--dt {dt:g} s is outside {low:g} to {high:g} s (the dynamics filter's QP grows with the "
                    "number of samples; beyond the upper end the touchdowns are not resolved)")
    return dt


def check_warm_start(name: str) -> str:
    """``name`` if refinement can warm-start from it (:data:`~cocomopl.ocp.settings.WARM_STARTS`), else :class:`Error`."""
    if name not in WARM_STARTS:
        raise Error(f"the warm start {name!r} is not one of {', '.join(WARM_STARTS)}")
    return name


@dataclass(frozen=True)
class StraightSteps:
    """Step ``lengths`` (m) straight ahead, in order: start, ..., stop; ``first_swing`` steps
    first.  No lengths: the paper's M_gen scaled to the model's robot (:func:`~cocomopl.gait.m_gen`)."""

    lengths: tuple[float, ...] = ()
    first_swing: str = "left"

    def __post_init__(self):
        object.__setattr__(self, "lengths", tuple(float(x) for x in self.lengths))
        if self.first_swing not in FIRST_SWINGS:
            raise Error(f"the first swing foot is one of {', '.join(FIRST_SWINGS)}, not {self.first_swing!r}")

    def label(self) -> str:
        return ",".join(f"{1000 * x:g}" for x in self.lengths) + " mm" if self.lengths else "M_gen"


@dataclass(frozen=True)
class Footsteps:
    """The world ``landings`` of a footstep plan (:mod:`cocomopl.planning.footsteps`)."""

    landings: tuple[Landing, ...]

    def __post_init__(self):
        object.__setattr__(self, "landings", tuple(self.landings))
        if not self.landings:
            raise Error("a footstep plan needs at least one landing")

    def label(self) -> str:
        return "on footsteps"


@dataclass(frozen=True)
class Goals:
    """Goal ``poses`` (x, y in m, yaw in rad) of the feet's midpoint, reached in turn,
    stopping at each (:func:`~cocomopl.planning.goal.plan_through`)."""

    poses: tuple[Goal, ...]

    def __post_init__(self):
        poses = tuple(tuple(float(v) for v in pose) for pose in self.poses)
        if not poses or any(len(pose) != 3 or not all(map(math.isfinite, pose)) for pose in poses):
            raise Error(f"goals are one or more poses of three finite numbers (x m, y m, yaw rad), not {self.poses!r}")
        object.__setattr__(self, "poses", poses)

    def label(self) -> str:
        return "to " + " then ".join(f"{g[0]:g} m, {g[1]:g} m, {math.degrees(g[2]):g} deg" for g in self.poses)


@dataclass(frozen=True)
class Commands:
    """Timed velocity commands ``(t s, forward m/s, sideways m/s, yaw rate rad/s)``, in order,
    the last a stop, walked by the streaming generator (:mod:`cocomopl.online`)."""

    commands: tuple[tuple[float, float, float, float], ...]

    def __post_init__(self):
        commands = tuple(tuple(float(v) for v in c) for c in self.commands)
        if not commands or any(len(c) != 4 or not all(map(math.isfinite, c)) for c in commands):
            raise Error(f"commands are one or more rows of four finite numbers (t s, forward m/s, sideways m/s, "
                        f"yaw rate rad/s), not {self.commands!r}")
        if any(b[0] <= a[0] for a, b in pairwise(commands)) or commands[0][0] < 0:
            raise Error("the commands' times must increase from 0")
        if any(commands[-1][1:]):
            raise Error("the last command must be a stop (0, 0, 0): a walk ends standing")
        object.__setattr__(self, "commands", commands)

    def label(self) -> str:
        return f"{len(self.commands)} velocity commands"


WalkPath = StraightSteps | Footsteps | Goals | Commands


@dataclass(frozen=True)
class Refinement:
    """Refinement of the generated walk by the OCPs of ``dataset`` (default: the bundled one
    the model belongs with), each warm-started as ``warm_start`` says
    (:func:`cocomopl.pipeline.refine`)."""

    dataset: str | Path | None = None
    warm_start: str = DEFAULT_WARM_START

    def __post_init__(self):
        check_warm_start(self.warm_start)


@dataclass(frozen=True)
class WalkRequest:
    """A walk to generate (and to simulate, by :func:`cocomopl.pipeline.walk_report`).

    Attributes
    ----------
    path : the walk's :data:`WalkPath`
    model : primitives model file; None: the bundled one of ``robot`` (for footsteps and
        goals, the bundled omnidirectional one)
    robot : a bundled robot's name; None: the model's (TALOS for the bundled model).  A
        model for another robot is refused
    dt : s, the generated walk's sample spacing; None: ``PLAN_DT``
    strict : refuse steps outside the training support instead of warning about them
    refinement : refine the generated walk by optimal control; None: no refinement
    replanner : one of :data:`REPLANNERS`; None: "reaim" for goals without refinement (a
        robot that walks to a goal aims its steps from where it stands), else "none"
    """

    path: WalkPath
    model: str | Path | None = None
    dt: float | None = None
    strict: bool = False
    refinement: Refinement | None = None
    replanner: str | None = None
    robot: str | None = None

    def __post_init__(self):
        if not isinstance(self.path, StraightSteps | Footsteps | Goals | Commands):
            raise Error(f"a walk's path is StraightSteps, Footsteps, Goals or Commands, not {type(self.path).__name__}")
        if self.dt is not None:
            check_plan_dt(self.dt)
        if isinstance(self.path, Commands) and self.refinement is not None:
            raise Error("a walk of velocity commands is streamed step by step: it cannot be refined (--refine)")
        replanner = self.replanner
        if replanner is None:
            replanner = "reaim" if isinstance(self.path, Goals) and self.refinement is None else "none"
        if replanner not in REPLANNERS:
            raise Error(f"the replanner is one of {', '.join(REPLANNERS)}, not {replanner!r}")
        if replanner != "none" and self.refinement is not None:
            raise Error(f"{REPLANNER_NAMES[replanner]} replans with the primitives: it cannot be combined with "
                        "refinement (--refine)")
        object.__setattr__(self, "replanner", replanner)

    @property
    def omni(self) -> bool:
        """Whether the walk may turn or side-step: its model and dataset default to the omnidirectional ones."""
        return not isinstance(self.path, StraightSteps)

    def model_file(self) -> Path:
        """The model file: the one given, or the bundled one for this walk."""
        return model_path(self.model, omni=self.omni, robot=self.robot)

    def dataset_file(self) -> Path | None:
        """The refinement's dataset file (the one given, or the bundled one for this walk); None without refinement."""
        return None if self.refinement is None else dataset_path(self.refinement.dataset, omni=self.omni,
                                                                 robot=self.robot)

    def inputs(self) -> list[Path]:
        """The files the walk is made from: the model and the refinement's dataset."""
        return [self.model_file()] + ([self.dataset_file()] if self.refinement else [])

