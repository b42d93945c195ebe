"""The command line's parser, its option types and the option groups several commands share.

Each type parses one concept and leaves its rule to the one validator of the API (the
``check_*`` and ``parse_*`` functions the library calls too), turning its
:class:`~cocomopl.errors.Error` into argparse's one-line usage error.  The rules on which
walk options go together live in :mod:`cocomopl.requests`; :func:`walk_request` refuses only
the options a request has no place for where they would be ignored (``--first-swing`` without
straight steps, ``--data`` and ``--warm-start`` without ``--refine``).
"""

from __future__ import annotations

import argparse
import re
import textwrap
from pathlib import Path

from cocomopl.errors import Error

# a value that starts with a minus sign and a digit: a negative number or list, never an option
NEGATIVE_VALUE = re.compile(r"-\.?\d")


class Formatter(argparse.HelpFormatter):
    """Help wrapped at spaces only: a docs anchor or a path is never broken at its hyphens."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False, break_long_words=False)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors under the one prefix."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", Formatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        self.exit(2, f"cocomopl: error: {message}\n")


def negative_values_joined(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``argv`` with each option that takes a value joined to a following negative value
    (``--to -0.6,0.3,45`` -> ``--to=-0.6,0.3,45``), which argparse would take for an option."""
    options = {option for p in _parsers(parser) for a in p._actions if a.nargs != 0 for option in a.option_strings}
    out = []
    for token in argv:
        if out and out[-1] in options and NEGATIVE_VALUE.match(token):
            out[-1] += f"={token}"
        else:
            out.append(token)
    return out


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """``parser`` and the parsers of its commands, and of theirs."""
    nested = [command for action in parser._actions if isinstance(action, argparse._SubParsersAction)
              for command in action.choices.values()]
    return [parser, *(p for command in nested for p in _parsers(command))]


def json_options(parser: argparse.ArgumentParser) -> None:
    """``--json`` for every command of ``parser`` (those that only hold sub-commands left out)."""
    for command in _parsers(parser):
        if not any(isinstance(action, argparse._SubParsersAction) for action in command._actions):
            command.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")


def replacing(args, *paths, inputs=(), folder: bool = False, given=None) -> None:
    """Check the outputs a command is about to write against its ``inputs`` before any work
    (:func:`~cocomopl.motion_file.check_output`: a refusal is one error line); what they
    replace is noted, and said once the command has done it."""
    from cocomopl.motion_file import check_output

    args.notes += [note for path in paths if (note := check_output(path, inputs, folder=folder, given=given))]


def number(text: str) -> float:
    try:
        if not text.isascii():  # float() reads other scripts' digits, e.g. Arabic-Indic ones
            raise ValueError
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number in ASCII digits") from None


def _whole_number(text: str, least: int) -> int:
    try:
        if not text.isascii():
            raise ValueError
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number in ASCII digits") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least {least}")
    return value


def positive_int(text: str) -> int:
    return _whole_number(text, 1)


def non_negative_int(text: str) -> int:
    return _whole_number(text, 0)


def positive_float(text: str) -> float:
    value = number(text)
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive finite number")
    return value


def non_negative_float(text: str) -> float:
    value = number(text)
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number, 0 or more")
    return value


def _checked(check, value):
    """``check(value)``, its :class:`Error` turned into argparse's one-line usage error."""
    try:
        return check(value)
    except Error as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def contact_time_constant(text: str) -> float:
    from cocomopl.sim.mujoco_model import check_contact_time_constant

    return _checked(check_contact_time_constant, positive_float(text))


def reference_cutoff(text: str) -> float:
    from cocomopl.sim.rollout import check_reference_cutoff

    return _checked(check_reference_cutoff, number(text))


def walk_lengths_mm(text: str) -> list[float]:
    from cocomopl.gait import parse_sequence_mm

    return _checked(parse_sequence_mm, text)


def goal(text: str) -> tuple[float, float, float]:
    from cocomopl.planning.goal import parse_goal

    return _checked(parse_goal, text)


def footstep_file(text: str) -> list:
    from cocomopl.planning.footsteps import read_landings

    return _checked(read_landings, text)


def command_file(text: str) -> list:
    from cocomopl.online.commands import read_commands

    return _checked(read_commands, text)


def push(text: str):
    from cocomopl.sim.perturbations import parse_push

    return _checked(parse_push, text)


def existing_file(text: str) -> Path:
    if not Path(text).is_file():
        raise argparse.ArgumentTypeError(f"no file {text!r}")
    return Path(text)


def group_values(text: str) -> dict[str, float]:
    """``X`` (every joint) or ``GROUP=X,GROUP=X`` as {group: X}."""
    out = {}
    for item in text.split(","):
        group, _, value = item.rpartition("=")
        out[group.strip() or "all"] = number(value)
    return out


def gait_grid(text: str) -> tuple:
    from cocomopl.dataset.plan import parse_gait_grid

    return _checked(parse_gait_grid, text)


def step_space(text: str) -> tuple[int, int]:
    from cocomopl.dataset.design import parse_step_space

    return _checked(parse_step_space, text)


def training_lengths_mm(text: str) -> tuple[float, ...]:
    from cocomopl.gait import parse_lengths_mm

    return _checked(parse_lengths_mm, text)


def knot_spacing(text: str) -> float:
    from cocomopl.dataset.generate import check_dt

    return _checked(check_dt, positive_float(text))


def workers(text: str) -> int:
    from cocomopl.dataset.generate import check_workers

    return _checked(check_workers, positive_int(text))


def int_list(text: str) -> tuple[int, ...]:
    try:
        if not text.isascii():
            raise ValueError
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of whole numbers") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must list positive whole numbers")
    return tuple(sorted(set(values)))


def kernel_list(text: str) -> tuple[str, ...]:
    from cocomopl.primitives import TIME_KERNELS

    values = [x.strip() for x in text.split(",") if x.strip()]
    unknown = [x for x in values if x not in TIME_KERNELS]
    if not values or unknown:
        raise argparse.ArgumentTypeError(f"unknown kernel(s) {unknown or text!r}; choose from {','.join(TIME_KERNELS)}")
    return tuple(values)


class Replanner(argparse.Action):
    """``--reaim``, ``--no-reaim`` and ``--recover``: the one replanner of a walk
    (:data:`~cocomopl.requests.REPLANNERS`), refused in one line when given twice differently."""

    def __call__(self, parser, namespace, values, option_string=None):
        chosen = {"--reaim": "reaim", "--no-reaim": "none", "--recover": "recover"}[option_string]
        earlier = getattr(namespace, self.dest)
        if earlier not in (None, chosen):
            parser.error("footstep re-aiming (--reaim), recovery by stepping (--recover) and --no-reaim exclude each "
                         "other: give one")
        setattr(namespace, self.dest, chosen)


# ---------------------------------------------------------------------------- shared option groups
def scheduler_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on an existing Dask cluster, e.g. tcp://host:8786 (needs the [cluster] extra)")


WARM_START_HELP = ("what each step's OCP starts from: 'interpolated' (the dataset's solved steps around it, "
                   "interpolated; where they do not surround it, the nearest; the default), 'nearest' (the dataset's "
                   "solved step of the same kind nearest it) or 'generated' (the generated step; "
                   "docs/method.md#refinement)")


def simulation_options(parser: argparse.ArgumentParser) -> None:
    from cocomopl.sim.mujoco_model import CONTACT_TIME_CONSTANT
    from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ

    parser.add_argument("--contact-time-constant-s", type=contact_time_constant, metavar="S",
                        help=f"sole-floor contact softness, a time constant in s (default: {CONTACT_TIME_CONSTANT:g}, "
                        "rubber soles; 0.005 is nearly rigid)")
    parser.add_argument("--reference-cutoff-hz", type=reference_cutoff, metavar="HZ",
                        help=f"cut-off of the reference joints' low-pass, in Hz (default: {REFERENCE_CUTOFF_HZ:g}; "
                        "0 plays the plan's knots interpolated linearly)")
    parser.add_argument("--sim-model", type=existing_file, metavar="FILE.xml",
                        help="simulate on this MuJoCo model of the robot instead of the project's own: its joints "
                        "matched by name, its servos as given (docs/cli.md#other-model-files)")
    parser.add_argument("--kp-scale", type=group_values, default={}, metavar="[GROUP=]X,...",
                        help="multiply the servos' stiffness kp, of all joints (X) or per group legs, torso, arms "
                        "(e.g. legs=0.8,arms=1.25)")
    parser.add_argument("--kv-time-s", type=group_values, default={}, metavar="[GROUP=]S,...",
                        help="set the servos' damping to kv = kp * S (S in seconds), of all joints or per group")
    parser.add_argument("--latency-ms", type=non_negative_float, default=0.0, metavar="MS",
                        help="delay of every command on its way to the servos, in milliseconds (default: 0)")
    parser.add_argument("--encoder-noise-mrad", type=non_negative_float, default=0.0, metavar="MRAD",
                        help="standard deviation of the noise on each servo's joint reading, in milliradians "
                        "(default: 0)")
    parser.add_argument("--noise-seed", type=positive_int, default=1, metavar="N", help="seed of the encoder noise (default: 1)")


def servo_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--no-stabilizer", action="store_true", help="joint position control only")
    feedforward = parser.add_mutually_exclusive_group()
    feedforward.add_argument("--feedforward", action="store_true", default=None,
                             help="torque feedforward: offset each servo command by the plan's joint torque and "
                             "velocity over the servo's gains, so that the servos neither sag under the load nor lag "
                             "(default: the robot's, on for G1, off for TALOS)")
    feedforward.add_argument("--no-feedforward", action="store_false", dest="feedforward",
                             help="no torque feedforward, whatever the robot's default")


def synthesis_options(parser: argparse.ArgumentParser) -> None:
    from cocomopl.gait import M_GEN_MM
    from cocomopl.ocp.settings import WARM_STARTS
    from cocomopl.requests import FIRST_SWINGS, PLAN_DT

    walk = parser.add_mutually_exclusive_group()
    walk.add_argument("--lengths-mm", type=walk_lengths_mm, default=(), metavar="MM,MM,...",
                      help="step lengths in millimetres, straight ahead, in order: start, ..., stop; the last two "
                      f"equal (default: the paper's M_gen, {M_GEN_MM} for TALOS, scaled to the model's robot by its "
                      "leg length: docs/robots.md)")
    walk.add_argument("--footsteps", type=footstep_file, metavar="FILE.csv",
                      help="walk on the footsteps of a CSV file with columns x_m,y_m,yaw_deg,side, one landing per "
                      "row (docs/cli.md#footstep-files)")
    walk.add_argument("--to", type=goal, action="append", metavar="X_M,Y_M,YAW_DEG",
                      help="walk to a goal pose of the feet's midpoint, metres and degrees from the start, on "
                      "footsteps planned within the model's learned range and training support (docs/method.md#footstep-planner); "
                      "given again, walk on to the next goal after stopping at this one")
    walk.add_argument("--commands", type=command_file, metavar="FILE.csv",
                      help="walk a script of timed velocity commands, streamed step by step by the online generator: "
                      "a CSV file with columns t_s,forward_m_s,sideways_m_s,yaw_rate_deg_s, the last row a stop "
                      "(docs/cli.md#command-files)")
    parser.add_argument("--model", metavar="MODEL.npz", help="primitives model file (default: the robot's bundled one)")
    bundled_robot_option(parser)
    parser.add_argument("--dt", type=positive_float, metavar="S",
                        help=f"sample spacing of the generated walk, in s (default: {PLAN_DT:g})")
    parser.add_argument("--first-swing", choices=FIRST_SWINGS,
                        help=f"with --lengths-mm: the foot that steps first (default: {FIRST_SWINGS[0]})")
    parser.add_argument("--strict", action="store_true", help="refuse a walk with a step outside the model's training support "
                        "(otherwise one warning per such step)")
    parser.add_argument("--refine", action="store_true",
                        help="refine every generated step by the OCP it was learned from (docs/method.md#refinement)")
    parser.add_argument("--data", metavar="DATASET.h5",
                        help="with --refine: the OC dataset whose OCP settings are used (default: the bundled one)")
    parser.add_argument("--warm-start", choices=WARM_STARTS, metavar="FROM", help="with --refine: " + WARM_START_HELP)


def bundled_robot_option(parser: argparse.ArgumentParser) -> None:
    """``--robot``: whose bundled model and dataset are the defaults."""
    parser.add_argument("--robot", metavar="NAME",
                        help="a bundled robot whose model and dataset are the defaults, talos or g1 (default: the "
                        "model's robot; talos for the bundled model); a model or dataset of another robot is refused")


def dataset_and_model_options(parser: argparse.ArgumentParser) -> None:
    """A dataset and the model trained on it, both the bundled ones by default."""
    parser.add_argument("file", nargs="?", metavar="FILE.h5", help="dataset HDF5 file (default: the bundled one)")
    parser.add_argument("--model", metavar="MODEL.npz", help="model trained on it (default: the bundled one)")


def walk_request(args):
    """The :class:`~cocomopl.requests.WalkRequest` of the options of :func:`synthesis_options`
    (and ``walk``'s replanner); ``--data`` and ``--warm-start`` say how ``--refine`` solves
    and ``--first-swing`` how straight steps start: without those, they are refused, as they
    would be ignored."""
    from cocomopl.ocp.settings import DEFAULT_WARM_START
    from cocomopl.requests import FIRST_SWINGS, Commands, Footsteps, Goals, Refinement, StraightSteps, WalkRequest

    straight = args.footsteps is None and args.to is None and args.commands is None
    for given, option, used, needed in ((args.data, "--data", args.refine, "--refine"),
                                        (args.warm_start, "--warm-start", args.refine, "--refine"),
                                        (args.first_swing, "--first-swing", straight, "--lengths-mm")):
        if given and not used:
            raise Error(f"{option} is used only with {needed}")
    if args.commands is not None:
        path = Commands(tuple((t, c.forward, c.sideways, c.yaw_rate) for t, c in args.commands))
    elif args.footsteps is not None:
        path = Footsteps(args.footsteps)
    elif args.to is not None:
        path = Goals(args.to)
    else:
        path = StraightSteps(args.lengths_mm, args.first_swing or FIRST_SWINGS[0])
    refinement = Refinement(args.data, args.warm_start or DEFAULT_WARM_START) if args.refine else None
    return WalkRequest(path, model=args.model, dt=args.dt, strict=args.strict, refinement=refinement,
                       replanner=getattr(args, "replanner", None), robot=args.robot)


def sim_settings(args):
    """The simulation the command line asks for (:class:`~cocomopl.pipeline.SimSettings`):
    the options of :func:`simulation_options`, :func:`servo_options` and ``--push`` (set by
    default where a command has no such option)."""
    from cocomopl.pipeline import SimSettings
    from cocomopl.sim.servos import ServoSettings

    servos = ServoSettings(kp_scale=args.kp_scale, kv_time_s=args.kv_time_s, latency_s=args.latency_ms / 1000,
                           encoder_noise_rad=args.encoder_noise_mrad / 1000, seed=args.noise_seed)
    return SimSettings(stabilizer=not args.no_stabilizer,
                       contact_time_constant=args.contact_time_constant_s, reference_cutoff_hz=args.reference_cutoff_hz,
                       feedforward=args.feedforward, sim_model=args.sim_model, servos=servos, pushes=tuple(args.push))
