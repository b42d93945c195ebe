"""The ``cocomopl`` command.  Thin: parse, call the API, print a table or one JSON object."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

import numpy as np

from cocomopl.dataset.plan import DEFAULT_LENGTHS_M
from cocomopl.errors import Error
from cocomopl.primitives import DEFAULT_KERNELS, DEFAULT_PRIMITIVES

BUNDLED_DATASET = Path(__file__).parent / "data" / "dataset.h5"
BUNDLED_MODEL = Path(__file__).parent / "data" / "model.npz"
M_GEN_MM = "150,150,250,350,390,350,250,150,150"  # the paper's generated sequence


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


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def _positive_float(text: str) -> float:
    value = _number(text)
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive finite number")
    return value


def _non_negative_float(text: str) -> float:
    value = _number(text)
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number, 0 or more")
    return value


def _checked(check, value: float) -> float:
    """``check(value)``, its :class:`Error` turned into argparse's one-line usage error."""
    try:
        return check(value)
    except Error as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _contact_time_constant(text: str) -> float:
    from cocomopl.sim.mujoco_model import check_contact_time_constant

    return _checked(check_contact_time_constant, _positive_float(text))


def _reference_cutoff(text: str) -> float:
    from cocomopl.sim.rollout import check_reference_cutoff

    return _checked(check_reference_cutoff, _number(text))


CUTOFF_HELP = "cut-off in Hz of the low-pass of the reference joints (default: 15; 0 plays the plan's knots interpolated linearly)"
CONTACT_HELP = "sole-floor contact softness, a time constant in s (default: 0.01, rubber soles; 0.005 is stiffer)"


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
    from cocomopl.gait import foot_separation, parse_lengths_mm, parse_transitions_mm
    from cocomopl.kinematics import double_support_posture
    from cocomopl.ocp.action_models import OCPSettings, knee_bounds
    from cocomopl.robot import Robot

    lengths = parse_lengths_mm(args.lengths_mm)
    # None: generate() takes the default extra transitions of these lengths
    extra = None if args.extra_transitions_mm is None else parse_transitions_mm(args.extra_transitions_mm, lengths)
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
    if args.load_transfer_weight is not None:
        settings = replace(settings, w_load_transfer=args.load_transfer_weight)
    if args.min_knee_flexion_rad is not None:
        settings = replace(settings, min_knee_flexion=args.min_knee_flexion_rad)
    knee_bounds(robot, settings.min_knee_flexion)  # a bend the knees cannot make is refused before solving
    out = Path(args.out)
    if out.exists() and out.is_dir():
        raise Error(f"--out {out} is a directory; give a file path such as {out / 'dataset.h5'}")
    command = "cocomopl " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    summary = generate(
        out,
        lengths,
        extra,
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


def _model_path(path: str | None) -> Path:
    if path is not None:
        return Path(path)
    if not BUNDLED_MODEL.exists():
        raise Error(f"the bundled model is missing ({BUNDLED_MODEL}); train one with 'cocomopl train'")
    return BUNDLED_MODEL


def _int_list(text: str) -> list[int]:
    try:
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of whole numbers") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must list positive whole numbers")
    return sorted(set(values))


def _kernel_list(text: str) -> list[str]:
    from cocomopl.primitives.kernels import TIME_KERNELS

    values = [x.strip() for x in text.split(",") if x.strip()]
    unknown = [x for x in values if x not in TIME_KERNELS]
    if not values or unknown:
        raise argparse.ArgumentTypeError(f"unknown kernel(s) {unknown or text!r}; choose from {','.join(TIME_KERNELS)}")
    return values


# ---------------------------------------------------------------------------- primitives
def cmd_train(args) -> int:
    import os
    import time

    from cocomopl.analysis.plots import plot_model_selection
    from cocomopl.motion_file import writable_folder
    from cocomopl.primitives.model_file import save_model
    from cocomopl.primitives.selection import select_model
    from cocomopl.primitives.training import load_training_steps
    from cocomopl.provenance import versions

    out = Path(args.out)
    if out.is_dir():
        raise Error(f"--out {out} is a directory; give a file path such as {out / 'model.npz'}")
    writable_folder(out.parent, f"the folder of --out {out}")
    data = _dataset_path(args.data)
    steps = load_training_steps(data)
    started = time.perf_counter()
    best, rows = select_model(
        steps,
        n_primitives=args.primitives,
        kernels=args.kernels,
        max_iterations=args.max_iterations,
        workers=args.workers or os.cpu_count() or 1,
        progress=True,
    )
    wall = time.perf_counter() - started
    metadata = {
        "command": "cocomopl " + " ".join(shlex.quote(a) for a in sys.argv[1:]),
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "versions": versions(["numpy", "scipy", "jax", "jaxlib", "pin", "crocoddyl"]),
        "robot": steps.source["robot"] or "talos",
        "dataset": {**steps.source, "path": str(data), "steps": len(steps)},
        "selection": rows,
        "training_wall_time_s": wall,
    }
    save_model(out, best, metadata)
    plot = plot_model_selection(rows, out.with_suffix(".png"))
    lines = [f"{'kernel':9s} {'S':>3s} {'free energy':>13s} {'EV joints':>10s} {'EV zmp':>8s} {'EV pelvis':>10s} {'iter':>5s}"]
    for r in rows:
        ev = r["explained_variance"]
        mark = "  <- best" if (r["kernel"], r["n_primitives"]) == (best.kernel, best.n_primitives) else ""
        lines.append(
            f"{r['kernel']:9s} {r['n_primitives']:3d} {r['bound']:13.1f} {100 * ev['joints']:9.3f}% "
            f"{100 * ev['zmp']:7.3f}% {100 * ev['pelvis']:9.3f}% {r['iterations']:5d}{mark}"
        )
    lines.append(f"wrote {out} ({best.kernel}, {best.n_primitives} primitives) and {plot} in {wall:.0f} s")
    payload = {"output": str(out), "plot": str(plot), "kernel": best.kernel, "n_primitives": best.n_primitives,
               "bound": best.bound_, "explained_variance": best.explained_variance_, "selection": rows,
               "wall_time_s": wall}
    _emit(args, payload, "\n".join(lines))
    return 0


def cmd_model_info(args) -> int:
    from cocomopl.primitives.model_file import model_metadata

    path = _model_path(args.file)
    meta = model_metadata(path)
    info = {"file": str(path), **{k: meta.get(k) for k in (
        "n_primitives", "kernel", "bound", "explained_variance", "n_grid", "created", "command", "versions",
        "dataset", "training_wall_time_s", "checksum", "format_version")}}
    if args.verbose:
        info["selection"] = meta.get("selection")
    ev = info["explained_variance"] or {}
    table = "\n".join([
        f"{path}: {info['n_primitives']} primitives, {info['kernel']} kernel, free energy {info['bound']:.1f}",
        "explained variance: " + ", ".join(f"{g} {100 * v:.3f}%" for g, v in ev.items()),
        f"trained {info['created']} by: {info['command']}",
        f"from {info['dataset']}",
    ])
    _emit(args, info, table)
    return 0


def cmd_generate(args) -> int:
    from cocomopl.gait import parse_sequence_mm
    from cocomopl.motion_file import writable_folder, write_motions
    from cocomopl.pipeline import generate_walk

    lengths = parse_sequence_mm(args.lengths_mm)
    out = Path(args.out)
    if out.is_dir():
        raise Error(f"--out {out} is a directory; give a file path such as {out / 'motion.h5'}")
    writable_folder(out.parent, f"the folder of --out {out}")
    walk = generate_walk(lengths, _model_path(args.model), args.dt, args.first_swing, args.strict)
    for message in walk.warnings:
        print(f"cocomopl: warning: {message}", file=sys.stderr)
    motion, steps, generation_s, placement_s = walk.motion, walk.steps, walk.generation_s, walk.placement_s
    write_motions(out, {motion.name: motion}, {"robot": walk.robot.name, "producer": "primitives"})
    rows = [{
        "step": s.spec.name, "duration_s": s.duration, "duration_std_s": float(np.linalg.norm(s.duration_std)),
        "joint_std_max_rad": float(s.std[:, :30].max()), "in_support": bool(s.in_support),
        "distance_mm": 1000 * s.distance} for s in steps]
    payload = {"output": str(out), "steps": rows, "n_steps": len(steps), "duration_s": motion.duration,
               "generation_s": generation_s, "placement_s": placement_s,
               "dynamics_filter_zmp_error_m": motion.meta["plan_zmp_error_m"],
               "upper_body_limits": motion.meta["upper_body_limits"],
               "out_of_support": [r["step"] for r in rows if not r["in_support"]]}
    lines = [f"{'step':24s} {'duration':>9s} {'max joint std':>14s}  support"]
    lines += [f"{r['step']:24s} {r['duration_s']:8.3f}s {r['joint_std_max_rad']:12.4f}rad  "
              + ("ok" if r["in_support"] else f"OUTSIDE ({r['distance_mm']:.0f} mm away)") for r in rows]
    upper = motion.meta["upper_body_limits"]
    lines.append(f"upper body (the joints that carry no sole) corrected by up to {upper['largest_change_rad']:.3f} rad: torque "
                 f"{upper['torque_ratio_before']:.2f} -> {upper['torque_ratio_after']:.2f}, velocity "
                 f"{upper['velocity_ratio_before']:.2f} -> {upper['velocity_ratio_after']:.2f} of the limits")
    lines.append(f"wrote {out}: {len(steps)} steps, {motion.duration:.2f} s of walking; generated in "
                 f"{generation_s * 1e6:.0f} us, placed in the world in {placement_s * 1e3:.0f} ms")
    _emit(args, payload, "\n".join(lines))
    return 0


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


# ---------------------------------------------------------------------------- simulation
METRIC_ROWS = (
    ("fell", "fell", "{}"),
    ("peak_force_over_weight", "peak vertical force / weight", "{:.2f}"),
    ("max_force_rate", "max vertical force rate, 20 ms (N/s)", "{:.0f}"),
    ("mean_torque", "mean torque (Table I, N m s^-1/2)", "{:.4f}"),
    ("rms_torque", "RMS joint torque (N m)", "{:.2f}"),
    ("zmp_rms_error", "ZMP RMS error vs reference (m)", "{:.4f}"),
    ("tracking_rms_rad", "joint tracking RMS (rad)", "{:.4f}"),
    ("touchdown_delay_median_s", "median touchdown delay (s)", "{:+.3f}"),
    ("foot_slip_m", "foot slip (m)", "{:.4f}"),
    ("duration_s", "duration (s)", "{:.2f}"),
)


def _metrics_table(metrics: dict) -> str:
    return "\n".join(
        f"{label:38s} {'-' if metrics.get(key) is None else fmt.format(metrics[key])}" for key, label, fmt in METRIC_ROWS
    )


def _output_file(path: str, default: Path) -> Path:
    out = Path(path) if path else default
    if out.is_dir():
        raise Error(f"--out {out} is a directory; give a file path such as {out / 'motion.h5'}")
    from cocomopl.motion_file import writable_folder

    writable_folder(out.parent, f"the folder of --out {out}")
    return out


def cmd_simulate(args) -> int:
    from cocomopl.motion_file import read_motion, write_motions
    from cocomopl.pipeline import simulate_walk
    from cocomopl.robot import Robot

    reference = read_motion(args.file, args.motion)
    out = _output_file(args.out, Path(f"{Path(args.file).stem}-sim.h5"))
    robot = Robot(reference.robot)
    rollout, metrics = simulate_walk(robot, reference, stabilizer=not args.no_stabilizer, progress=not args.json,
                                     contact_time_constant=args.contact_time_constant_s,
                                     reference_cutoff_hz=args.reference_cutoff_hz)
    write_motions(out, {"measured": rollout.measured}, {"robot": robot.name, "producer": "mujoco"})
    payload = {"output": str(out), "stabilizer": not args.no_stabilizer,
               "contact_time_constant_s": rollout.measured.meta["contact_time_constant_s"],
               "reference_cutoff_hz": rollout.measured.meta["reference_cutoff_hz"], **metrics}
    _emit(args, payload, _metrics_table(metrics) + f"\nwrote {out}")
    return 1 if rollout.fell else 0


def cmd_walk(args) -> int:
    from cocomopl.gait import parse_sequence_mm
    from cocomopl.pipeline import walk_report

    lengths = parse_sequence_mm(args.lengths_mm)
    payload = walk_report(lengths, Path(args.out), _model_path(args.model), stabilizer=not args.no_stabilizer,
                          video=not args.no_video, progress=not args.json,
                          contact_time_constant=args.contact_time_constant_s,
                          reference_cutoff_hz=args.reference_cutoff_hz)
    for message in payload["warnings"]:
        print(f"cocomopl: warning: {message}", file=sys.stderr)
    lines = [f"walk {args.lengths_mm} mm: {len(payload['steps'])} steps, generated in "
             f"{payload['generation_s'] * 1e3:.2f} ms, simulated in MuJoCo "
             f"({'with' if payload['stabilizer'] else 'without'} stabilizer)", _metrics_table(payload),
             f"report in {args.out}/ ({payload['wall_time_s']:.0f} s): " + ", ".join(Path(f).name for f in payload["files"])]
    _emit(args, payload, "\n".join(lines))
    return 1 if payload["fell"] else 0


def cmd_reproduce(args) -> int:
    from cocomopl.pipeline import reproduce_report

    payload = reproduce_report(Path(args.out), _model_path(args.model), _dataset_path(args.data), progress=not args.json,
                               contact_time_constant=args.contact_time_constant_s,
                               reference_cutoff_hz=args.reference_cutoff_hz)
    lines = ["Table I analogue: mean torque (N m s^-1/2), M_gen (MP), M_opt (OC), Kajita on M_gen's footsteps"]
    lines += [f"  {name:36s} {value:.4f}" for name, value in payload["table1_mean_torque"].items()]
    lines.append(f"MP vs OC simulated mean torque: {100 * payload['mp_vs_oc_simulated_mean_torque_difference']:+.1f} %")
    lines.append(f"{'simulated':12s} {'fell':>5s} {'peak F/W':>9s} {'force variation/W':>18s} {'(planned)':>10s} "
                 f"{'ZMP RMS (m)':>12s} {'touchdown delay (s)':>20s}")
    for name, m in payload["metrics"].items():
        zmp = "-" if m["zmp_rms_error"] is None else f"{m['zmp_rms_error']:.4f}"
        delay = "-" if m["touchdown_delay_median_s"] is None else f"{m['touchdown_delay_median_s']:+.3f}"
        lines.append(f"{name:12s} {m['fell']!s:>5s} {m['peak_force_over_weight']:9.2f} "
                     f"{m['force_variation_over_weight']:18.1f} {payload['planned_force_variation_over_weight'][name]:10.1f} "
                     f"{zmp:>12s} {delay:>20s}")
    lines.append(f"MP contact forces smoother than Kajita's: {payload['mp_smoother_than_kajita']}")
    lines.append(f"M_opt solved in {payload['m_opt_solve_s']:.0f} s; report in {args.out}/ ({payload['wall_time_s']:.0f} s)")
    _emit(args, payload, "\n".join(lines))
    return 0


def cmd_export(args) -> int:
    from cocomopl.export.safety import check_safe
    from cocomopl.export.seqplay import export_motion
    from cocomopl.motion_file import read_motion, writable_folder
    from cocomopl.robot import Robot

    motion = read_motion(args.file, args.motion)
    prefix = Path(args.out)
    if prefix.is_dir():
        raise Error(f"--out {prefix} is a directory; give a file prefix such as {prefix / 'walk'}")
    robot = Robot(motion.robot)
    reasons = check_safe(robot, motion)
    if reasons and not args.force:
        more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
        raise Error(f"refused, unsafe for a robot: {reasons[0]}{more}; --force exports anyway")
    writable_folder(prefix.parent, f"the folder of --out {prefix}")
    files = export_motion(robot, motion, args.format, prefix)
    payload = {"files": [str(f) for f in files], "format": args.format, "unsafe": reasons, "forced": bool(reasons)}
    lines = [f"wrote {f}" for f in files] + [f"warning (--force): {r}" for r in reasons]
    _emit(args, payload, "\n".join(lines))
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
        default=",".join(f"{1000 * x:g}" for x in DEFAULT_LENGTHS_M),
        help="training step lengths in millimetres, comma-separated (default: the paper's 150,250,300,350,400 "
        "and 200: %(default)s)",
    )
    gen.add_argument(
        "--extra-transitions-mm",
        metavar="A-B,...",
        help="extra transitions between training lengths that are not neighbours, in millimetres, both ways "
        "(default: 150-250,250-350, those of them whose lengths are trained; '' for none)",
    )
    gen.add_argument("--robot", default="talos", help="bundled robot name or description .json (default: talos)")
    gen.add_argument("--out", default="cocomopl-dataset.h5", help="output HDF5 file (default: %(default)s)")
    gen.add_argument("--workers", type=_positive_int, help="local worker processes (default: one per core)")
    gen.add_argument("--scheduler", metavar="ADDRESS", help="run on an existing Dask cluster, e.g. tcp://host:8786")
    gen.add_argument("--dt", type=_positive_float, help="knot spacing in seconds (default: 0.025)")
    gen.add_argument("--max-iterations", type=_positive_int, help="solver iterations per attempt (default: 300)")
    gen.add_argument(
        "--load-transfer-weight",
        type=_non_negative_float,
        metavar="W",
        help="weight (N^-2) pulling each sole's vertical force in double support towards a linear transfer of the "
        "body weight between touchdown and lift-off (default: 0.001; 0 for none; README 'Load transfer')",
    )
    gen.add_argument(
        "--min-knee-flexion-rad",
        type=_non_negative_float,
        metavar="RAD",
        help="least bend of the knees, in radians, at every knot (default: 0.6; 0 for only the URDF's limits; "
        "README 'Knee flexion')",
    )
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

    train = sub.add_parser("train", help="learn movement primitives from a dataset, choosing S and the kernel")
    train.add_argument("data", nargs="?", help="dataset HDF5 (default: the bundled one)")
    train.add_argument("--out", default="cocomopl-model.npz", help="output model file (default: %(default)s)")
    train.add_argument("--primitives", type=_int_list, default=list(DEFAULT_PRIMITIVES),
                       help="candidate numbers of primitives S (default: %s)" % ",".join(map(str, DEFAULT_PRIMITIVES)))
    train.add_argument("--kernels", type=_kernel_list, default=list(DEFAULT_KERNELS),
                       help="candidate time kernels (default: %s)" % ",".join(DEFAULT_KERNELS))
    train.add_argument("--max-iterations", type=_positive_int, default=150, help="L-BFGS-B iterations (default: 150)")
    train.add_argument("--workers", type=_positive_int, help="local worker processes (default: one per core)")
    train.add_argument("--json", action="store_true", help="print one JSON object")
    train.set_defaults(func=cmd_train)

    model = sub.add_parser("model", help="inspect a primitives model").add_subparsers(
        dest="action", required=True, parser_class=_Parser
    )
    minfo = model.add_parser("info", help="summarise a model (default: the bundled one)")
    minfo.add_argument("file", nargs="?")
    minfo.add_argument("--verbose", action="store_true", help="include the model-selection table")
    minfo.add_argument("--json", action="store_true", help="print one JSON object")
    minfo.set_defaults(func=cmd_model_info)

    gen_walk = sub.add_parser("generate", help="synthesise a walk from step lengths with the primitives")
    gen_walk.add_argument("--lengths-mm", default=M_GEN_MM,
                          help="step lengths in millimetres, in order: start, ..., stop (default: the paper's M_gen "
                          f"{M_GEN_MM})")
    gen_walk.add_argument("--model", help="model file (default: the bundled one)")
    gen_walk.add_argument("--out", default="cocomopl-walk.h5", help="output motion HDF5 (default: %(default)s)")
    gen_walk.add_argument("--dt", type=_positive_float, default=0.025, help="sample spacing in s (default: 0.025)")
    gen_walk.add_argument("--first-swing", choices=("left", "right"), default="left", help="foot that steps first")
    gen_walk.add_argument("--strict", action="store_true", help="refuse steps outside the training support")
    gen_walk.add_argument("--json", action="store_true", help="print one JSON object")
    gen_walk.set_defaults(func=cmd_generate)

    walk = sub.add_parser("walk", help="the main job: generate a walk with the primitives, simulate it, write a report")
    walk.add_argument("--lengths-mm", default=M_GEN_MM,
                      help=f"step lengths in millimetres, start to stop (default: the paper's M_gen {M_GEN_MM})")
    walk.add_argument("--out", default="cocomopl-walk", help="report folder (default: %(default)s)")
    walk.add_argument("--model", help="model file (default: the bundled one)")
    walk.add_argument("--no-stabilizer", action="store_true", help="joint position control only")
    walk.add_argument("--no-video", action="store_true", help="skip the MP4 (saves about 15 s)")
    walk.add_argument("--contact-time-constant-s", type=_contact_time_constant, help=CONTACT_HELP)
    walk.add_argument("--reference-cutoff-hz", type=_reference_cutoff, help=CUTOFF_HELP)
    walk.add_argument("--json", action="store_true", help="print one JSON object")
    walk.set_defaults(func=cmd_walk)

    reproduce = sub.add_parser("reproduce", help="the paper's experiment: M_gen vs M_opt vs Kajita, simulated; Table I, Figs. 6, 8, 9")
    reproduce.add_argument("--out", default="cocomopl-reproduce", help="report folder (default: %(default)s)")
    reproduce.add_argument("--model", help="model file (default: the bundled one)")
    reproduce.add_argument("--data", help="OC dataset for M_opt's steps and gait states (default: the bundled one)")
    reproduce.add_argument("--contact-time-constant-s", type=_contact_time_constant, help=CONTACT_HELP)
    reproduce.add_argument("--reference-cutoff-hz", type=_reference_cutoff, help=CUTOFF_HELP)
    reproduce.add_argument("--json", action="store_true", help="print one JSON object")
    reproduce.set_defaults(func=cmd_reproduce)

    simulate = sub.add_parser("simulate", help="run a motion in MuJoCo with joint position control and measure it")
    simulate.add_argument("file", help="motion HDF5 (e.g. from 'cocomopl generate')")
    simulate.add_argument("--motion", help="motion name (needed when the file holds several)")
    simulate.add_argument("--out", help="measured motion HDF5 (default: <file>-sim.h5)")
    simulate.add_argument("--no-stabilizer", action="store_true", help="joint position control only")
    simulate.add_argument("--contact-time-constant-s", type=_contact_time_constant, help=CONTACT_HELP)
    simulate.add_argument("--reference-cutoff-hz", type=_reference_cutoff, help=CUTOFF_HELP)
    simulate.add_argument("--json", action="store_true", help="print one JSON object")
    simulate.set_defaults(func=cmd_simulate)

    export = sub.add_parser("export", help="write a motion for a robot (OpenHRP seqplay or CSV), behind a safety gate")
    export.add_argument("file", help="motion HDF5")
    export.add_argument("--motion", help="motion name (needed when the file holds several)")
    export.add_argument("--format", choices=("seqplay", "csv"), required=True, help="seqplay: .pos .zmp .hip .waist at 5 ms")
    export.add_argument("--out", required=True, help="output file prefix, e.g. out/walk -> out/walk.pos ...")
    export.add_argument("--force", action="store_true", help="export even if the safety gate refuses the motion")
    export.add_argument("--json", action="store_true", help="print one JSON object")
    export.set_defaults(func=cmd_export)

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
