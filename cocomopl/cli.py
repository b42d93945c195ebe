"""The ``cocomopl`` command.  Thin: parse, call the API, print a table or one JSON object."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from cocomopl.errors import Error

BUNDLED_DATASET = Path(__file__).parent / "data" / "dataset.h5"


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive finite number")
    return value


def _emit(args, payload: dict, table: str) -> None:
    if args.json:
        print(json.dumps(payload, default=float))
    else:
        print(table)


def _dataset_path(path: str | None) -> Path:
    if path is not None:
        return Path(path)
    if not BUNDLED_DATASET.exists():
        raise Error(f"the bundled dataset is missing ({BUNDLED_DATASET}); generate one with 'cocomopl dataset generate'")
    return BUNDLED_DATASET


# ---------------------------------------------------------------------------- dataset
def cmd_dataset_generate(args) -> int:
    from dataclasses import replace

    from cocomopl.dataset.generate import generate
    from cocomopl.dataset.plan import parse_lengths_mm
    from cocomopl.ocp.models import OCPSettings
    from cocomopl.robot import Robot
    from cocomopl.ocp.posture import double_support_posture
    from cocomopl.ocp.problems import foot_separation

    lengths = parse_lengths_mm(args.lengths_mm)
    robot = Robot(args.robot)
    for L in lengths:  # a stance the robot cannot take is rejected before any solving
        if L > robot.max_step_length:
            raise Error(
                f"step length {L * 1000:g} mm is beyond {robot.name}'s reach "
                f"(at most {robot.max_step_length * 1000:g} mm, from its description)"
            )
        double_support_posture(robot, (-L, foot_separation(robot)), (0.0, 0.0))
    settings = OCPSettings()
    if args.dt is not None:
        settings = replace(settings, dt=args.dt)
    if args.max_iterations is not None:
        settings = replace(settings, max_iterations=args.max_iterations)
    out = Path(args.out)
    if out.exists() and out.is_dir():
        raise Error(f"--out {out} is a directory; give a file path such as {out / 'dataset.h5'}")
    command = "cocomopl " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    summary = generate(
        out,
        lengths,
        robot_name=args.robot,
        settings=settings,
        workers=args.workers,
        scheduler=args.scheduler,
        command=command,
        progress=True,  # on stderr, so --json output stays one object on stdout
    )
    table = (
        f"wrote {summary['output']}: {summary['motions']} motions from {summary['ocps']} OCPs "
        f"({summary['solved']} solved, {summary['reused']} reused) in {summary['wall_time_s']:.1f} s"
    )
    if summary["failed"]:
        table += f"\nNOT CONVERGED (left out): {', '.join(summary['failed'])}"
    _emit(args, summary, table)
    return 1 if summary["failed"] else 0


def cmd_dataset_info(args) -> int:
    from cocomopl.dataset.info import dataset_info, format_info

    info = dataset_info(_dataset_path(args.file))
    _emit(args, info, format_info(info))
    return 0


def cmd_dataset_check(args) -> int:
    from cocomopl.dataset.check import check_dataset
    from cocomopl.motion_file import read_motions
    from cocomopl.robot import Robot

    path = _dataset_path(args.file)
    motions, attrs = read_motions(path)
    robot = Robot(attrs.get("robot", "talos"))
    settings = attrs.get("settings", {})
    report = check_dataset(robot, motions, float(settings.get("friction", 0.7)), float(settings.get("dt", 0.025)))
    if not args.verbose:
        report.pop("per_motion")
    lines = [f"{path}: {report['motions']} motions, {report['junctions']} step junctions"]
    lines.append(f"{'check':28s} {'worst':>12s} {'tolerance':>10s}  result  where")
    for key, value in report["worst"].items():
        ok = key not in report["failures"]
        bound = (">= " if key in ("zmp_margin", "min_normal_force") else "<= ") + f"{report['tolerances'][key]:g}"
        lines.append(f"{key:28s} {value:12.4g} {bound:>10s}  {'ok' if ok else 'FAIL':6s}  {report['worst_in'][key]}")
    lines.append("PASS" if report["ok"] else f"FAIL: {', '.join(report['failures'])}")
    _emit(args, report, "\n".join(lines))
    return 0 if report["ok"] else 1


# ---------------------------------------------------------------------------- plot
def cmd_plot(args) -> int:
    from cocomopl.analysis.plots import plot_motion
    from cocomopl.motion_file import read_motion
    from cocomopl.robot import Robot

    motion = read_motion(args.file, args.motion)
    robot = Robot(motion.robot)
    out = Path(args.out) if args.out else Path(f"{motion.name}-plots")
    files = plot_motion(robot, motion, out)
    _emit(args, {"files": [str(f) for f in files]}, "\n".join(f"wrote {f}" for f in files))
    return 0


def build_parser() -> argparse.ArgumentParser:
    from cocomopl import __version__

    parser = _Parser(prog="cocomopl", description=__doc__)
    parser.add_argument("--version", action="version", version=f"cocomopl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    dataset = sub.add_parser("dataset", help="optimal-control training data").add_subparsers(
        dest="action", required=True, parser_class=_Parser
    )
    gen = dataset.add_parser("generate", help="solve the step OCPs and write the training dataset (HDF5)")
    gen.add_argument(
        "--lengths-mm",
        default="150,250,300,350,400",
        help="training step lengths in millimetres, comma-separated (default: the paper's 150,250,300,350,400)",
    )
    gen.add_argument("--robot", default="talos", help="bundled robot name or description .json (default: talos)")
    gen.add_argument("--out", default="cocomopl-dataset.h5", help="output HDF5 file (default: %(default)s)")
    gen.add_argument("--workers", type=_positive_int, help="local worker processes (default: one per core)")
    gen.add_argument("--scheduler", metavar="ADDRESS", help="run on an existing Dask cluster, e.g. tcp://host:8786")
    gen.add_argument("--dt", type=_positive_float, help="knot spacing in seconds (default: 0.025)")
    gen.add_argument("--max-iterations", type=_positive_int, help="solver iterations per attempt (default: 200)")
    gen.add_argument("--json", action="store_true", help="print one JSON object")
    gen.set_defaults(func=cmd_dataset_generate)

    info = dataset.add_parser("info", help="summarise a dataset (default: the bundled one)")
    info.add_argument("file", nargs="?")
    info.add_argument("--json", action="store_true", help="print one JSON object")
    info.set_defaults(func=cmd_dataset_info)

    check = dataset.add_parser("check", help="recompute every motion with inverse dynamics and check it")
    check.add_argument("file", nargs="?")
    check.add_argument("--verbose", action="store_true", help="include every motion's values in --json")
    check.add_argument("--json", action="store_true", help="print one JSON object")
    check.set_defaults(func=cmd_dataset_check)

    plot = sub.add_parser("plot", help="PNG plots of one motion: joints, ZMP, contact forces, torques")
    plot.add_argument("file")
    plot.add_argument("--motion", help="motion name (needed when the file holds several)")
    plot.add_argument("--out", help="output folder (default: <motion>-plots)")
    plot.add_argument("--json", action="store_true", help="print one JSON object")
    plot.set_defaults(func=cmd_plot)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except Error as exc:
        print(f"cocomopl: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("cocomopl: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
