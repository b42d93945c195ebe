"""The ``cocomopl`` command: parse the options, call one API function, print.

Every command prints a table by default and exactly one JSON object on stdout with
``--json``; progress and warnings go to stderr.  A mistake a user can make is one line
``cocomopl: error: ...`` and exit 2, without a traceback.  The work itself is in
:mod:`cocomopl.jobs` and :mod:`cocomopl.pipeline`.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from cocomopl.errors import Error
from cocomopl.ocp.settings import DEFAULT_WARM_START, WARM_STARTS
from cocomopl.provenance import command_line


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors under the one prefix."""

    def error(self, message: str):
        self.exit(2, f"cocomopl: error: {message}\n")


# ---------------------------------------------------------------------------- option types
def _number(text: str) -> float:
    try:
        if not text.isascii():  # float() reads other scripts' digits, e.g. Arabic-Indic ones
            raise ValueError
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number in ASCII digits") from None


def _positive_int(text: str) -> int:
    try:
        if not text.isascii():
            raise ValueError
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number in ASCII digits") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def _positive_float(text: str) -> float:
    value = _number(text)
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive finite number")
    return value


def _non_negative_float(text: str) -> float:
    value = _number(text)
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number, 0 or more")
    return value


def _checked(check, value):
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


def _walk_lengths_mm(text: str) -> list[float]:
    from cocomopl.gait import parse_sequence_mm

    return _checked(parse_sequence_mm, text)


def _goal(text: str) -> tuple[float, float, float]:
    from cocomopl.planning.goal import parse_goal

    return _checked(parse_goal, text)


def _footstep_file(text: str) -> list:
    from cocomopl.planning.footsteps import read_landings

    return _checked(read_landings, text)


def _push(text: str):
    from cocomopl.sim.perturbations import parse_push

    return _checked(parse_push, text)


def _existing_file(text: str) -> Path:
    if not Path(text).is_file():
        raise argparse.ArgumentTypeError(f"no file {text!r}")
    return Path(text)


def _group_values(text: str) -> dict[str, float]:
    """``X`` (every joint) or ``GROUP=X,GROUP=X`` as {group: X}."""
    out = {}
    for item in text.split(","):
        group, _, value = item.rpartition("=")
        out[group.strip() or "all"] = _number(value)
    return out


def _sim_settings(args):
    """The simulation the command line asks for (:class:`~cocomopl.pipeline.SimSettings`):
    the options of :func:`_simulation_options`, :func:`_servo_options` and ``--push`` (set by
    default where a command has no such option)."""
    from cocomopl.pipeline import SimSettings
    from cocomopl.sim.servos import ServoSettings

    servos = ServoSettings(kp_scale=args.kp_scale, kv_time_s=args.kv_time_s, latency_s=args.latency_ms / 1000,
                           encoder_noise_rad=args.encoder_noise_mrad / 1000, seed=args.noise_seed)
    return SimSettings(stabilizer=not args.no_stabilizer,
                       contact_time_constant=args.contact_time_constant_s, reference_cutoff_hz=args.reference_cutoff_hz,
                       feedforward=args.feedforward, sim_model=args.sim_model, servos=servos, pushes=tuple(args.push))


def _walk_request(args) -> dict:
    """The walk asked for: ``lengths``, or footstep ``landings``, or a ``goal``."""
    if args.footsteps is not None:
        return {"lengths": None, "landings": args.footsteps}
    if args.to is not None:
        return {"lengths": None, "goal": args.to}
    return {"lengths": args.lengths_mm}


def _gait_grid(text: str) -> tuple:
    from cocomopl.dataset.plan import parse_gait_grid

    return _checked(parse_gait_grid, text)


def _training_lengths_mm(text: str) -> tuple[float, ...]:
    from cocomopl.gait import parse_lengths_mm

    return _checked(parse_lengths_mm, text)


def _knot_spacing(text: str) -> float:
    from cocomopl.dataset.generate import check_dt

    return _checked(check_dt, _positive_float(text))


def _workers(text: str) -> int:
    from cocomopl.dataset.generate import check_workers

    return _checked(check_workers, _positive_int(text))


def _int_list(text: str) -> tuple[int, ...]:
    try:
        if not text.isascii():
            raise ValueError
        values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of whole numbers") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must list positive whole numbers")
    return tuple(sorted(set(values)))


def _kernel_list(text: str) -> tuple[str, ...]:
    from cocomopl.primitives import TIME_KERNELS

    values = [x.strip() for x in text.split(",") if x.strip()]
    unknown = [x for x in values if x not in TIME_KERNELS]
    if not values or unknown:
        raise argparse.ArgumentTypeError(f"unknown kernel(s) {unknown or text!r}; choose from {','.join(TIME_KERNELS)}")
    return tuple(values)


# ---------------------------------------------------------------------------- printing
def _emit(args, payload: dict, table: str) -> None:
    print(json.dumps(payload, default=float) if args.json else table)


def _warn(message: str) -> None:
    print(f"cocomopl: warning: {message}", file=sys.stderr)


def _note_replacing(*paths: str | Path, inputs=(), folder: bool = False, given: str | Path | None = None) -> None:
    """Say which existing outputs a command is about to replace (report folders with ``folder``).

    The command's own checks (:func:`~cocomopl.motion_file.check_output`, against its ``inputs``) run here first,
    so that a refused output is one error line, not a warning and then the error."""
    from cocomopl.motion_file import check_output

    for path in paths:
        note = check_output(path, inputs, folder=folder, given=given)
        if note:
            _warn(note)


WARM_START_HELP = ("what each step's OCP starts from: 'interpolated' (the dataset's solved steps around it, "
                   "interpolated; where they do not surround it, the nearest; the default), 'nearest' (the dataset's "
                   "solved step of the same kind nearest it) or 'generated' (the generated step; "
                   "docs/method.md#refinement)")
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


def _selection_table(rows: list[dict], best: tuple[str, int] | None) -> list[str]:
    lines = [f"{'kernel':9s} {'S':>3s} {'free energy':>13s} {'EV joints':>10s} {'EV zmp':>8s} {'EV pelvis':>10s} {'iter':>5s}"]
    for r in rows:
        ev = r["explained_variance"]
        mark = "  <- best" if (r["kernel"], r["n_primitives"]) == best else ""
        lines.append(
            f"{r['kernel']:9s} {r['n_primitives']:3d} {r['bound']:13.1f} {100 * ev['joints']:9.3f}% "
            f"{100 * ev['zmp']:7.3f}% {100 * ev['pelvis']:9.3f}% {r['iterations']:5d}{mark}"
        )
    return lines


# ---------------------------------------------------------------------------- commands
def cmd_dataset_generate(args) -> int:
    from cocomopl.gait import parse_transitions_mm
    from cocomopl.jobs import generate_dataset

    # None: the default extra transitions of these lengths
    extra = None if args.extra_transitions_mm is None else parse_transitions_mm(args.extra_transitions_mm, args.lengths_mm)
    lengths = args.lengths_mm
    if args.gaits is not None:
        from cocomopl.dataset.plan import gait_footsteps
        from cocomopl.robot import Robot

        if args.extra_transitions_mm is not None:
            raise Error("--extra-transitions-mm joins straight lengths; a gait grid has its own transitions")
        lengths, extra = gait_footsteps(Robot(args.robot), args.gaits)
    _note_replacing(args.out, inputs=[args.robot])
    summary = generate_dataset(
        args.out, lengths, extra, args.robot, args.dt, args.max_iterations, args.load_transfer_weight,
        args.min_knee_flexion_rad, args.workers, args.scheduler, args.command_line, progress=True,
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
    from cocomopl.data import dataset_path
    from cocomopl.dataset.info import dataset_info, format_info

    info = dataset_info(dataset_path(args.file))
    _emit(args, info, format_info(info))
    return 0


def cmd_dataset_check(args) -> int:
    from cocomopl.jobs import check_dataset_file

    report = check_dataset_file(args.file, args.verbose)
    lines = [f"{report['file']}: {report['motions']} motions, {report['junctions']} step junctions",
             f"{'check':28s} {'worst':>12s} {'tolerance':>10s}  result  where"]
    for key, value in report["worst"].items():
        ok = key not in report["failures"]
        bound = (">= " if key in ("zmp_margin", "min_normal_force") else "<= ") + f"{report['tolerances'][key]:g}"
        lines.append(f"{key:28s} {value:12.4g} {bound:>10s}  {'ok' if ok else 'FAIL':6s}  {report['worst_in'][key]}")
    lines.append("PASS" if report["ok"] else f"FAIL: {', '.join(report['failures'])}")
    _emit(args, report, "\n".join(lines))
    return 0 if report["ok"] else 1


def cmd_dataset_family(args) -> int:
    from cocomopl.jobs import check_family_file
    from cocomopl.primitives.family import GROUPS

    report = check_family_file(args.file, args.model, args.lengths_mm, args.workers, args.probes_out,
                               progress=not args.json)
    lines = [f"{report['solved']} steps solved at {', '.join(f'{x:g}' for x in report['lengths_mm'])} mm in "
             f"{report['solve_s']:.0f} s" + (f"; not converged: {', '.join(report['failed'])}" if report["failed"] else ""),
             "RMS distance of the OC steps from the model's prediction (and from the linear interpolation of the",
             "trained steps around them); joints and pelvis in mrad, ZMP in mm:",
             f"{'steps':8s}" + "".join(f"{g:>16s}" for g in GROUPS)]
    for kind in ("all", "cyclic", "start", "stop"):
        if kind in report:
            model, linear = report[kind]["model"], report[kind]["linear"]
            lines.append(f"{kind:8s}" + "".join(f"{1000 * model[g]:8.1f} ({1000 * linear[g]:5.1f})" for g in GROUPS))
    _emit(args, report, "\n".join(lines))
    return 0


def cmd_dataset_grow(args) -> int:
    from cocomopl.jobs import grow_dataset
    from cocomopl.primitives.family import GROUPS

    report = grow_dataset(args.out, args.file, args.model, args.budget, args.uniform, args.held_out, args.workers,
                          args.scheduler, args.command_line, progress=not args.json, warm_start=args.warm_start)
    picked = ", ".join(f"{x:g}" for x in report["picked_mm"])
    held_out = ", ".join(f"{x:g}" for x in report["held_out_mm"])
    lines = [(f"wrote {report['dataset']} and {report['model']}: {report['method']} growth by {picked} mm "
              f"({report['solved']} OCPs solved)" + (f"; NOT CONVERGED: {', '.join(report['failed'])}" if report["failed"] else "")),
             (f"RMS error on {report['held_out_steps']} held-out steps ({held_out} mm); "
              "joints and pelvis in mrad, ZMP in mm:"),
             f"{'model':8s}" + "".join(f"{g:>10s}" for g in GROUPS)]
    for when in ("before", "after"):
        lines.append(f"{when:8s}" + "".join(f"{1000 * report['held_out'][when]['model'][g]:10.2f}" for g in GROUPS))
    _emit(args, report, "\n".join(lines))
    return 1 if report["failed"] else 0


def cmd_train(args) -> int:
    from cocomopl.jobs import train_model

    _note_replacing(args.out, Path(args.out).with_suffix(".png"), inputs=[args.data], given=args.out)
    payload = train_model(args.out, args.data, args.primitives, args.kernels, args.max_iterations,
                          args.workers or os.cpu_count() or 1, args.command_line, progress=True)
    lines = _selection_table(payload["selection"], (payload["kernel"], payload["n_primitives"]))
    lines.append(f"wrote {payload['output']} ({payload['kernel']}, {payload['n_primitives']} primitives) and "
                 f"{payload['plot']} in {payload['wall_time_s']:.0f} s")
    _emit(args, payload, "\n".join(lines))
    return 0


def cmd_model_info(args) -> int:
    from cocomopl.jobs import model_info

    info = model_info(args.file, args.verbose)
    ev, dataset = info["explained_variance"] or {}, info["dataset"]
    checksum = f", sha256 {dataset['sha256'][:12]}" if dataset.get("sha256") else ""
    lines = [
        f"{info['file']}: {info['n_primitives']} primitives, {info['kernel']} kernel, free energy {info['bound']:.1f}",
        "explained variance: " + ", ".join(f"{g} {100 * v:.3f}%" for g, v in ev.items()),
        f"trained {info['created']} by: {info['command']}",
        f"on {dataset.get('name', '?')}{checksum} ({dataset.get('steps', '?')} steps)",
    ]
    if args.verbose and info.get("selection"):
        lines += ["model selection:", *_selection_table(info["selection"], (info["kernel"], info["n_primitives"]))]
    _emit(args, info, "\n".join(lines))
    return 0


def cmd_generate(args) -> int:
    from cocomopl.jobs import generate_walk_file

    _check_refine_options(args)
    _note_replacing(args.out, inputs=[args.model])
    request = _walk_request(args)
    payload = generate_walk_file(request.pop("lengths"), args.out, args.model, args.dt, args.first_swing, args.strict,
                                 args.command_line, args.refine, args.data, progress=not args.json,
                                 warm_start_from=args.warm_start or DEFAULT_WARM_START, **request)
    for message in payload["warnings"]:
        _warn(message)
    rows = payload["steps"]
    lines = [f"{'step':24s} {'duration':>9s} {'max joint std':>14s}  support"]
    lines += [f"{r['step']:24s} {r['duration_s']:8.3f}s {r['joint_std_max_rad']:12.4f}rad  "
              + ("ok" if r["in_support"] else f"OUTSIDE ({r['distance_mm']:.0f} mm away)") for r in rows]
    upper = payload["upper_body_limits"]
    lines.append(f"upper body (the joints that carry no sole) corrected by up to {upper['largest_change_rad']:.3f} rad: "
                 f"torque {upper['torque_ratio_before']:.2f} -> {upper['torque_ratio_after']:.2f}, velocity "
                 f"{upper['velocity_ratio_before']:.2f} -> {upper['velocity_ratio_after']:.2f} of the limits")
    if "refine" in payload:
        lines += _refine_lines(payload["refine"])
    lines.append(f"wrote {payload['output']}: {len(rows)} steps, {payload['duration_s']:.2f} s of walking; generated in "
                 f"{payload['generation_s'] * 1e6:.0f} us, placed in the world in {payload['placement_s'] * 1e3:.0f} ms")
    _emit(args, payload, "\n".join(lines))
    return 0


def _check_refine_options(args) -> None:
    """``--data`` and ``--warm-start`` say how ``--refine`` solves; alone they would be ignored."""
    for given, option in ((args.data, "--data"), (args.warm_start, "--warm-start")):
        if given and not args.refine:
            raise Error(f"{option} is used only with --refine")
    _check_warm_start(args.warm_start)


def _check_warm_start(name: str | None) -> None:
    """Refuse an unknown ``--warm-start`` before any work is done."""
    if name is not None and name not in WARM_STARTS:
        raise Error(f"--warm-start {name!r} is not one of {', '.join(WARM_STARTS)}")


def _refine_lines(summary: dict) -> list[str]:
    """The refinement's table: iterations, convergence and warm start per step, then the totals."""
    lines = [f"{'refined step':24s} {'iterations':>10s}  converged  warm start"]
    lines += [f"{step:24s} {n:10d}  {'yes' if ok else 'NO':9s}  {guess}"
              for step, n, ok, guess in zip(summary["steps"], summary["iterations"], summary["converged"], summary["guess"])]
    lines.append(f"refined in {summary['refine_s']:.1f} s (median {summary['iterations_median']:g} iterations per step); "
                 f"the generated walk's torque cost is {summary['raw_cost_ratio']:.3f} x the refined one's")
    return lines


def cmd_refine(args) -> int:
    from cocomopl.jobs import refine_walk_file

    _check_warm_start(args.warm_start)
    _note_replacing(args.out or f"{Path(args.file).stem}-refined.h5", inputs=[p for p in (args.file, args.data) if p])
    payload = refine_walk_file(args.file, args.motion, args.out, args.data, args.command_line, progress=not args.json,
                               warm_start_from=args.warm_start)
    _emit(args, payload, "\n".join([*_refine_lines(payload), f"wrote {payload['output']}"]))
    return 0 if all(payload["converged"]) else 1


def cmd_plot(args) -> int:
    from cocomopl.jobs import plot_file, plot_folder

    _note_replacing(args.out or plot_folder(args.file, args.motion), inputs=[args.file], folder=True)
    payload = plot_file(args.file, args.motion, args.out)
    _emit(args, payload, "\n".join(f"wrote {f}" for f in payload["files"]))
    return 0


def cmd_simulate(args) -> int:
    from cocomopl.jobs import simulate_file

    _note_replacing(args.out or f"{Path(args.file).stem}-sim.h5", inputs=[args.file])
    payload = simulate_file(args.file, args.motion, args.out, _sim_settings(args), args.command_line, progress=not args.json)
    _emit(args, payload, _metrics_table(payload) + f"\nwrote {payload['output']}")
    return 1 if payload["fell"] else 0


def cmd_walk(args) -> int:
    from cocomopl.pipeline import walk_label, walk_report

    _check_refine_options(args)
    out = Path(args.out)
    _note_replacing(out, inputs=[args.model], folder=True)
    request = _walk_request(args)
    label = walk_label(request.get("lengths"), request.get("goal"))
    payload = walk_report(request.pop("lengths"), out, args.model, _sim_settings(args), video=not args.no_video,
                          progress=not args.json, dt=args.dt, first_swing=args.first_swing, strict=args.strict,
                          command=args.command_line, refine_steps=args.refine, dataset=args.data, recover=args.recover,
                          reaim=args.reaim, warm_start_from=args.warm_start or DEFAULT_WARM_START,
                          **request)
    for message in payload["warnings"]:
        _warn(message)
    lines = [f"walk {label}: "
             f"{len(payload['steps'])} steps, generated in {payload['generation_s'] * 1e3:.2f} ms, "
             + ("refined by optimal control, " if args.refine else "")
             + f"simulated in MuJoCo ({'with' if payload['stabilizer'] else 'without'} stabilizer)",
             *(_refine_lines(payload["refine"]) if args.refine else []),
             _metrics_table(payload),
             *([f"ended {100 * payload['final_position_error_m']:.1f} cm and {payload['final_yaw_error_deg']:.1f} deg from the goal"]
               if "goal" in payload else []),
             *([_recovery_line(payload["recoveries"])] if args.recover else []),
             *([_reaim_line(payload["reaimed"])] if payload["reaim"] else []),
             f"report in {out}/ ({payload['wall_time_s']:.0f} s): " + ", ".join(Path(f).name for f in payload["files"])]
    _emit(args, payload, "\n".join(lines))
    return 1 if payload["fell"] else 0


def _recovery_line(changes: list[dict]) -> str:
    if not changes:
        return "recovery by stepping: no landing moved"
    moves = "; ".join(f"landing {c['landing'] + 1} moved {100 * c['shift_m'][0]:+.1f}, {100 * c['shift_m'][1]:+.1f} cm "
                      f"at {c['time_s']:.2f} s" for c in changes)
    return f"recovery by stepping: {moves}"


def _reaim_line(changes: list[dict]) -> str:
    if not changes:
        return "footstep re-aiming: no step re-aimed"
    worst = max(math.hypot(*c["stance_error_m"]) for c in changes)
    return (f"footstep re-aiming: {len(changes)} steps re-aimed, their stance soles up to {100 * worst:.1f} cm "
            "from the plan")


def cmd_reproduce(args) -> int:
    from cocomopl.pipeline import reproduce_report

    out = Path(args.out)
    _note_replacing(out, inputs=[args.model, args.data], folder=True)
    payload = reproduce_report(out, args.model, args.data, progress=not args.json, settings=_sim_settings(args),
                               command=args.command_line, kajita_variant=args.kajita)
    start, end = payload["window_s"]
    lines = [(f"every figure over the walking window {start:g} to {end:g} s; contact time constant "
              f"{1000 * payload['contact_time_constant_s']:g} ms, reference low-pass {payload['reference_cutoff_hz']:g} Hz"),
             ("Table I analogue: mean torque (N m s^-1/2), M_gen (MP), M_gen refined by optimal control (refined), "
              "M_opt (OC), Kajita on M_gen's footsteps")]
    lines += [f"  {name:36s} {value:.4f}" for name, value in payload["table1_mean_torque"].items()]
    lines.append(f"MP vs OC simulated mean torque: {100 * payload['mp_vs_oc_simulated_mean_torque_difference']:+.2f} %; "
                 f"refined vs OC: {100 * payload['refined_vs_oc']['mean_torque']['relative_difference']:+.2f} %")
    lines.append(f"{'simulated':9s} {'fell':>5s} {'peak F/W':>8s} {'var/sole':>8s} {'var sum':>8s} {'max dF/dt':>9s} "
                 f"{'knee mean':>9s} {'CoM mean':>8s} {'(range, m)':>13s} {'stabilizer D, K':>16s}")
    for name, m in payload["metrics"].items():
        gains = m["stabilizer_gains"]
        lines.append(f"{name:9s} {m['fell']!s:>5s} {m['peak_force_over_weight']:8.2f} {m['force_variation_over_weight']:8.2f} "
                     f"{m['total_force_variation_over_weight']:8.2f} {m['max_force_rate']:9.2e} "
                     f"{m['knee_angle_mean_rad']:9.2f} {m['com_height_mean_m']:8.3f} "
                     f"{m['com_height_min_m']:6.3f}-{m['com_height_max_m']:.3f} "
                     f"{gains['ankle_damping']:>10g}, {gains['dcm_gain']:g}")
    for other in ("OC", "Kajita"):
        lower = [k for k, c in payload[f"mp_vs_{other.lower()}"].items() if c["lower"] == "MP"]
        higher = [k for k, c in payload[f"mp_vs_{other.lower()}"].items() if c["lower"] != "MP"]
        lines.append(f"MP lower than {other} in: {', '.join(lower) or 'none'}; higher in: {', '.join(higher) or 'none'}")
    refined = payload["refine"]
    lines.append(f"refined M_gen: {sum(refined['converged'])} of {len(refined['converged'])} steps converged, median "
                 f"{refined['iterations_median']:g} iterations, {refined['refine_s']:.1f} s; M_gen's torque cost is "
                 f"{refined['raw_cost_ratio']:.3f} x the refined walk's")
    kajita = payload["kajita"]
    lines.append(f"Kajita ({kajita['variant']}): CoM at {kajita['com_height_m']:.3f} m (pelvis {100 * kajita['pelvis_drop']:.1f} cm "
                 f"low{', searched' if kajita['pelvis_drop_searched'] else ''}), multibody ZMP "
                 f"{100 * kajita['zmp_reference_rms_m']:.2f} cm RMS from its reference "
                 f"({100 * kajita['first_stage_zmp_reference_rms_m']:.2f} cm after preview control alone)")
    solved = payload["m_opt_solved_now"]
    lines.append(f"M_opt: {payload['m_opt_steps']} step OCPs, {payload['m_opt_steps'] - len(solved)} from the dataset and "
                 f"{len(solved)} solved now{' (' + ', '.join(solved) + ')' if solved else ''} in "
                 f"{payload['m_opt_solve_s']:.1f} s; report in {out}/ ({payload['wall_time_s']:.0f} s)")
    _emit(args, payload, "\n".join(lines))
    return 0


def cmd_export(args) -> int:
    from cocomopl.export.safety import margins_text
    from cocomopl.export.seqplay import SUFFIXES
    from cocomopl.jobs import export_file

    _note_replacing(*(f"{args.out}{suffix}" for suffix in SUFFIXES[args.format]), inputs=[args.file], given=args.out)
    payload = export_file(args.file, args.format, args.out, args.motion, args.force, args.robot)
    lines = [f"wrote {f}" for f in payload["files"]] + [f"warning (--force): {r}" for r in payload["unsafe"]]
    if not payload["unsafe"]:
        lines.append(f"safety gate passed: {margins_text(payload['gate'])}")
    _emit(args, payload, "\n".join(lines))
    return 0


def cmd_export_model(args) -> int:
    from cocomopl.export.mjcf import export_model, mesh_folder

    meshes = mesh_folder(Path(args.out))
    _note_replacing(args.out, inputs=[args.robot if args.robot.endswith(".json") else None])
    if meshes.is_dir():  # replaced as a whole by the export (the meshes of an earlier one), not a report folder
        _warn(f"replacing {meshes}")
    payload = export_model(args.robot, args.format, args.out)
    _emit(args, payload, f"wrote {payload['output']}")
    return 0


# ---------------------------------------------------------------------------- the parser
def _json_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")


def _simulation_options(parser: argparse.ArgumentParser) -> None:
    from cocomopl.sim.mujoco_model import CONTACT_TIME_CONSTANT
    from cocomopl.sim.rollout import REFERENCE_CUTOFF_HZ

    parser.add_argument("--contact-time-constant-s", type=_contact_time_constant, metavar="S",
                        help=f"sole-floor contact softness, a time constant in s (default: {CONTACT_TIME_CONSTANT:g}, "
                        "rubber soles; 0.005 is nearly rigid)")
    parser.add_argument("--reference-cutoff-hz", type=_reference_cutoff, metavar="HZ",
                        help=f"cut-off of the reference joints' low-pass, in Hz (default: {REFERENCE_CUTOFF_HZ:g}; "
                        "0 plays the plan's knots interpolated linearly)")
    parser.add_argument("--sim-model", type=_existing_file, metavar="FILE.xml",
                        help="simulate on this MuJoCo model of the robot instead of the project's own: its joints "
                        "matched by name, its servos as given (docs/cli.md#other-model-files)")
    parser.add_argument("--kp-scale", type=_group_values, default={}, metavar="[GROUP=]X,...",
                        help="multiply the servos' stiffness kp, of all joints (X) or per group legs, torso, arms "
                        "(e.g. legs=0.8,arms=1.25)")
    parser.add_argument("--kv-time-s", type=_group_values, default={}, metavar="[GROUP=]S,...",
                        help="set the servos' damping to kv = kp * S (S in seconds), of all joints or per group")
    parser.add_argument("--latency-ms", type=_non_negative_float, default=0.0, metavar="MS",
                        help="delay of every command on its way to the servos, in milliseconds (default: 0)")
    parser.add_argument("--encoder-noise-mrad", type=_non_negative_float, default=0.0, metavar="MRAD",
                        help="standard deviation of the noise on each servo's joint reading, in milliradians "
                        "(default: 0)")
    parser.add_argument("--noise-seed", type=_positive_int, default=1, metavar="N", help="seed of the encoder noise (default: 1)")


def _servo_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--no-stabilizer", action="store_true", help="joint position control only")
    parser.add_argument("--feedforward", action="store_true",
                        help="torque feedforward: offset each servo command by the plan's joint torque and velocity "
                        "over the servo's gains, so that the servos neither sag under the load nor lag")


def _synthesis_options(parser: argparse.ArgumentParser) -> None:
    from cocomopl.gait import M_GEN_MM
    from cocomopl.pipeline import PLAN_DT

    walk = parser.add_mutually_exclusive_group()
    walk.add_argument("--lengths-mm", type=_walk_lengths_mm, default=M_GEN_MM, metavar="MM,MM,...",
                      help="step lengths in millimetres, straight ahead, in order: start, ..., stop; the last two "
                      f"equal (default: the paper's M_gen, {M_GEN_MM})")
    walk.add_argument("--footsteps", type=_footstep_file, metavar="FILE.csv",
                      help="walk on the footsteps of a CSV file with columns x_m,y_m,yaw_deg,side, one landing per "
                      "row (docs/cli.md#footstep-files)")
    walk.add_argument("--to", type=_goal, action="append", metavar="X_M,Y_M,YAW_DEG",
                      help="walk to a goal pose of the feet's midpoint, metres and degrees from the start, on "
                      "footsteps planned within the model's learned range (docs/method.md#footstep-planner); "
                      "given again, walk on to the next goal after stopping at this one")
    parser.add_argument("--model", metavar="MODEL.npz", help="primitives model file (default: the bundled one)")
    parser.add_argument("--dt", type=_positive_float, metavar="S",
                        help=f"sample spacing of the generated walk, in s (default: {PLAN_DT:g})")
    parser.add_argument("--first-swing", choices=("left", "right"), default="left",
                        help="the foot that steps first (default: %(default)s)")
    parser.add_argument("--strict", action="store_true", help="refuse steps outside the training data's support")


def _dataset_and_model_options(parser: argparse.ArgumentParser) -> None:
    """A dataset and the model trained on it, both the bundled ones by default."""
    parser.add_argument("file", nargs="?", metavar="FILE.h5", help="dataset HDF5 file (default: the bundled one)")
    parser.add_argument("--model", metavar="MODEL.npz", help="model trained on it (default: the bundled one)")


def _dataset_parsers(sub) -> None:
    from cocomopl.dataset.generate import DT_RANGE_S, MIN_PHASE_KNOTS, WORKERS_PER_CORE
    from cocomopl.dataset.plan import DEFAULT_EXTRA_TRANSITIONS_M, DEFAULT_GAIT_GRID_TEXT, DEFAULT_LENGTHS_M
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.primitives.growth import WARM_STARTS
    from cocomopl.robot import DEFAULT_ROBOT

    defaults = OCPSettings()
    dataset = sub.add_parser("dataset", help="optimal-control training data").add_subparsers(
        dest="action", required=True, parser_class=_Parser)

    gen = dataset.add_parser("generate", help="solve the step OCPs and write the training dataset (HDF5)")
    lengths_mm = ",".join(f"{1000 * x:g}" for x in DEFAULT_LENGTHS_M)
    design = gen.add_mutually_exclusive_group()
    design.add_argument("--gaits", type=_gait_grid, nargs="?", const=DEFAULT_GAIT_GRID_TEXT, action="append",
                        metavar="LENGTHS_MM/WIDTHS_MM/TURNS_DEG",
                        help="an omnidirectional set: the steady gaits of a grid of footstep lengths and widths (mm) "
                        f"and turns (deg); alone, the default grid {DEFAULT_GAIT_GRID_TEXT}; given again, the gaits of "
                        "every grid; a grid that starts with a minus sign is given as --gaits=-150,... "
                        "(docs/method.md#omnidirectional-training-set)")
    design.add_argument("--lengths-mm", type=_training_lengths_mm, default=DEFAULT_LENGTHS_M, metavar="MM,MM,...",
                        help=f"training step lengths in millimetres, straight ahead (default: {lengths_mm})")
    extra = ",".join(f"{1000 * a:g}-{1000 * b:g}" for a, b in DEFAULT_EXTRA_TRANSITIONS_M)
    gen.add_argument("--extra-transitions-mm", metavar="A-B,...",
                     help="transitions between training lengths that are not neighbours, in millimetres, solved both "
                     f"ways (default: {extra}, those whose lengths are trained; '' for none)")
    gen.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME|FILE.json",
                     help="bundled robot name or robot description file (default: %(default)s)")
    gen.add_argument("--out", default="cocomopl-dataset.h5", metavar="FILE.h5", help="output HDF5 file (default: %(default)s)")
    gen.add_argument("--workers", type=_workers, metavar="N",
                     help=f"local worker processes, at most {WORKERS_PER_CORE} per core (default: one per core, at "
                     "most one per step length)")
    gen.add_argument("--scheduler", metavar="ADDRESS",
                     help="run on an existing Dask cluster, e.g. tcp://host:8786 (needs the [cluster] extra)")
    low, high = DT_RANGE_S
    gen.add_argument("--dt", type=_knot_spacing, metavar="S",
                     help=f"knot spacing in s, {low:g} to {high:g} (default: {defaults.dt:g}): coarser knots leave "
                     f"the {defaults.ds_duration * 1000:g} ms double support fewer than {MIN_PHASE_KNOTS} knots, finer "
                     "ones only add solve time")
    gen.add_argument("--max-iterations", type=_positive_int, metavar="N",
                     help=f"solver iterations per attempt, a count (default: {defaults.max_iterations})")
    gen.add_argument("--load-transfer-weight", type=_non_negative_float, metavar="W",
                     help="weight in N^-2 pulling each sole's vertical force in double support towards a linear transfer "
                     f"of the body weight (default: {defaults.w_load_transfer:g}; 0 for none; docs/method.md)")
    gen.add_argument("--min-knee-flexion-rad", type=_non_negative_float, metavar="RAD",
                     help=f"least bend of the knees at every knot, in rad (default: {defaults.min_knee_flexion:g}; "
                     "0 for only the URDF's limits; docs/method.md)")
    _json_option(gen)
    gen.set_defaults(func=cmd_dataset_generate)

    info = dataset.add_parser("info", help="summarise a dataset (default: the bundled one)")
    info.add_argument("file", nargs="?", metavar="FILE.h5", help="dataset HDF5 file (default: the bundled one)")
    _json_option(info)
    info.set_defaults(func=cmd_dataset_info)

    check = dataset.add_parser("check", help="recompute every motion with inverse dynamics and check it")
    check.add_argument("file", nargs="?", metavar="FILE.h5",
                       help="dataset or motion HDF5 file (default: the bundled dataset)")
    check.add_argument("--verbose", action="store_true", help="include every motion's values in --json")
    _json_option(check)
    check.set_defaults(func=cmd_dataset_check)

    family = dataset.add_parser("family", help="solve steps between the trained lengths and measure how far they lie "
                                "from the model's predictions and from linear interpolation, per joint group")
    _dataset_and_model_options(family)
    family.add_argument("--lengths-mm", type=_training_lengths_mm, metavar="MM,MM,...",
                        help="step lengths in millimetres to solve at, strictly between the dataset's (default: the "
                        "midpoints of its lengths)")
    family.add_argument("--workers", type=_workers, metavar="N", help="local worker processes (default: one per core)")
    family.add_argument("--probes-out", metavar="FILE.h5",
                        help="also save the solved steps there, as held-out steps for 'dataset grow --held-out'")
    _json_option(family)
    family.set_defaults(func=cmd_dataset_family)

    grow = dataset.add_parser("grow", help="add the step lengths where the model is least certain, solve them, "
                              "retrain, and measure the model on held-out steps before and after")
    _dataset_and_model_options(grow)
    grow.add_argument("--budget", type=int, required=True, metavar="N",
                      help="step lengths to add, each with its cyclic, start and stop steps and transitions to its "
                      "neighbours (7 OCPs)")
    grow.add_argument("--uniform", action="store_true",
                      help="spread the new lengths evenly instead (the baseline growth is compared with)")
    grow.add_argument("--warm-start", choices=WARM_STARTS, default="model",
                      help="start each new length's warm-up walk from the model's walk, or from the dataset's OC walk "
                      "at the nearest trained length (continuation) (default: %(default)s)")
    grow.add_argument("--held-out", metavar="PROBES.h5",
                      help="held-out steps saved by 'dataset family --probes-out' (default: solve them at the "
                      "midpoints of the dataset's lengths)")
    grow.add_argument("--out", default="cocomopl-grown.h5", metavar="FILE.h5",
                      help="grown dataset; the retrained model goes beside it as .npz (default: %(default)s)")
    grow.add_argument("--workers", type=_workers, metavar="N", help="local worker processes (default: one per core)")
    grow.add_argument("--scheduler", metavar="ADDRESS",
                      help="run on an existing Dask cluster, e.g. tcp://host:8786 (needs the [cluster] extra)")
    _json_option(grow)
    grow.set_defaults(func=cmd_dataset_grow)


def _primitives_parsers(sub) -> None:
    from cocomopl.primitives import DEFAULT_KERNELS, DEFAULT_MAX_ITERATIONS, DEFAULT_PRIMITIVES

    train = sub.add_parser("train", help="learn movement primitives from a dataset, choosing S and the kernel "
                           "(needs the [train] extra)")
    train.add_argument("data", nargs="?", metavar="DATASET.h5", help="dataset HDF5 file (default: the bundled one)")
    train.add_argument("--out", default="cocomopl-model.npz", metavar="MODEL.npz",
                       help="output model file; the comparison plot goes beside it as .png (default: %(default)s)")
    train.add_argument("--primitives", type=_int_list, default=DEFAULT_PRIMITIVES, metavar="S,S,...",
                       help="candidate numbers of primitives (default: %s)" % ",".join(map(str, DEFAULT_PRIMITIVES)))
    train.add_argument("--kernels", type=_kernel_list, default=DEFAULT_KERNELS, metavar="K,K,...",
                       help="candidate time kernels (default: %s)" % ",".join(DEFAULT_KERNELS))
    train.add_argument("--max-iterations", type=_positive_int, default=DEFAULT_MAX_ITERATIONS, metavar="N",
                       help="the most EM rounds per candidate, a count (default: %(default)s)")
    train.add_argument("--workers", type=_workers, metavar="N",
                       help="local worker processes, at most 4 per core (default: one per core)")
    _json_option(train)
    train.set_defaults(func=cmd_train)

    model = sub.add_parser("model", help="inspect a primitives model").add_subparsers(
        dest="action", required=True, parser_class=_Parser)
    info = model.add_parser("info", help="summarise a model (default: the bundled one)")
    info.add_argument("file", nargs="?", metavar="MODEL.npz", help="model file (default: the bundled one)")
    info.add_argument("--verbose", action="store_true", help="add the model-selection table")
    _json_option(info)
    info.set_defaults(func=cmd_model_info)

    generate = sub.add_parser("generate", help="synthesise a walk from step lengths with the primitives")
    _synthesis_options(generate)
    generate.add_argument("--out", default="cocomopl-walk.h5", metavar="FILE.h5", help="output motion HDF5 (default: %(default)s)")
    _refine_options(generate)
    _json_option(generate)
    generate.set_defaults(func=cmd_generate)

    refine = sub.add_parser("refine", help="make a generated walk optimal: each step warm-starts the OCP it was "
                            "learned from")
    refine.add_argument("file", metavar="MOTION.h5", help="a walk from 'cocomopl generate'")
    refine.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    refine.add_argument("--data", metavar="DATASET.h5",
                        help="OC dataset whose OCP settings the steps are solved with (default: the bundled one)")
    refine.add_argument("--out", metavar="FILE.h5", help="refined motion HDF5 (default: <file>-refined.h5)")
    refine.add_argument("--warm-start", default=DEFAULT_WARM_START, metavar="FROM", help=WARM_START_HELP)
    _json_option(refine)
    refine.set_defaults(func=cmd_refine)


def _refine_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--refine", action="store_true",
                        help="refine every generated step by the OCP it was learned from (docs/method.md#refinement)")
    parser.add_argument("--data", metavar="DATASET.h5",
                        help="with --refine: the OC dataset whose OCP settings are used (default: the bundled one)")
    parser.add_argument("--warm-start", metavar="FROM", help="with --refine: " + WARM_START_HELP)


def _simulation_parsers(sub) -> None:
    walk = sub.add_parser("walk", help="the main job: generate a walk with the primitives, simulate it, write a report")
    _synthesis_options(walk)
    walk.add_argument("--out", default="cocomopl-walk", metavar="DIR", help="report folder (default: %(default)s)")
    _servo_options(walk)
    walk.add_argument("--no-video", action="store_true", help="skip the MP4 (saves about 15 s)")
    walk.add_argument("--push", type=_push, action="append", default=[], metavar="AT_S,FX_N,FY_N",
                      help="push the pelvis for 0.1 s, AT_S seconds after the walk starts, with FX_N, FY_N newtons "
                      "(world axes: x forward, y left); may be given again")
    walk.add_argument("--recover", action="store_true",
                      help="recovery by stepping: a push the stabilizer cannot absorb moves the swing foot's landing, "
                      "and the walk is generated again from there (docs/method.md#recovery-by-stepping)")
    walk.add_argument("--reaim", action=argparse.BooleanOptionalAction,
                      help="footstep re-aiming: each step is aimed from where the stance sole was measured at the "
                      "plan's landing, and the walk is generated again from there (default: on for --to walks "
                      "without --refine or --recover; docs/method.md#footstep-re-aiming)")
    _refine_options(walk)
    _simulation_options(walk)
    _json_option(walk)
    walk.set_defaults(func=cmd_walk)

    reproduce = sub.add_parser("reproduce", help="the paper's experiment: M_gen vs M_opt vs Kajita, simulated; "
                               "Table I, Figs. 6, 8, 9")
    reproduce.add_argument("--out", default="cocomopl-reproduce", metavar="DIR", help="report folder (default: %(default)s)")
    reproduce.add_argument("--model", metavar="MODEL.npz", help="primitives model file (default: the bundled one)")
    reproduce.add_argument("--data", metavar="DATASET.h5",
                           help="OC dataset for M_opt's steps and gait states (default: the bundled one)")
    reproduce.add_argument("--kajita", choices=("two-stage", "legacy"), default="two-stage",
                           help="the Kajita baseline: as jrl-walkgen runs it (two-stage, default) or the earlier "
                                "single-stage one with a fixed 4 cm crouch (legacy)")
    _simulation_options(reproduce)
    _json_option(reproduce)
    # the paper's comparison: every walk with the stabilizer, without feedforward or pushes
    reproduce.set_defaults(func=cmd_reproduce, no_stabilizer=False, feedforward=False, push=[])

    simulate = sub.add_parser("simulate", help="run a motion in MuJoCo with joint position control and measure it")
    simulate.add_argument("file", metavar="MOTION.h5", help="motion HDF5 file (e.g. from 'cocomopl generate')")
    simulate.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    simulate.add_argument("--out", metavar="FILE.h5", help="measured motion HDF5 (default: <file>-sim.h5)")
    _servo_options(simulate)
    _simulation_options(simulate)
    _json_option(simulate)
    simulate.set_defaults(func=cmd_simulate, push=[])


def _tool_parsers(sub) -> None:
    from cocomopl.export.mjcf import MODEL_FORMATS
    from cocomopl.export.seqplay import FORMATS
    from cocomopl.robot import DEFAULT_ROBOT

    export = sub.add_parser("export", help="write a motion for a robot (OpenHRP seqplay or CSV), behind a safety gate")
    export.add_argument("file", metavar="MOTION.h5", help="motion HDF5 file")
    export.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    export.add_argument("--format", choices=FORMATS, required=True,
                        help="seqplay: .pos .zmp .hip .waist at 5 ms; csv: one table with units in the column names")
    export.add_argument("--out", required=True, metavar="PREFIX", help="output file prefix, e.g. out/walk -> out/walk.pos ...")
    export.add_argument("--force", action="store_true",
                        help="export even if the safety gate refuses the motion (never NaN or infinite values)")
    export.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME|FILE.json",
                        help="the robot whose limits the gate checks: bundled name or description file; the motion must "
                        "be for it (default: %(default)s)")
    _json_option(export)
    export.set_defaults(func=cmd_export)

    export_model = sub.add_parser("export-model", help="write the robot model cocomopl simulates (MuJoCo MJCF)")
    export_model.add_argument("--format", choices=MODEL_FORMATS, default=MODEL_FORMATS[0], help="(default: %(default)s)")
    export_model.add_argument("--out", required=True, metavar="FILE", help="output file, e.g. talos.xml")
    export_model.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME|FILE.json",
                              help="bundled robot name or robot description file (default: %(default)s)")
    _json_option(export_model)
    export_model.set_defaults(func=cmd_export_model)

    plot = sub.add_parser("plot", help="PNG plots of one motion: joints, ZMP, contact forces, torques")
    plot.add_argument("file", metavar="MOTION.h5", help="motion or dataset HDF5 file")
    plot.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    plot.add_argument("--out", metavar="DIR", help="output folder (default: <step>-plots for one step, else <file>-plots)")
    _json_option(plot)
    plot.set_defaults(func=cmd_plot)


def build_parser() -> argparse.ArgumentParser:
    from cocomopl import __version__

    parser = _Parser(prog="cocomopl", description="Whole-body humanoid walking from optimal control, movement primitives and learning.")
    parser.add_argument("--version", action="version", version=f"cocomopl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _dataset_parsers(sub)
    _primitives_parsers(sub)
    _simulation_parsers(sub)
    _tool_parsers(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser()
    args = parser.parse_args(argv)
    args.command_line = command_line(argv)  # recorded in the provenance of what it writes
    try:
        return args.func(args)
    except Error as exc:
        print(f"cocomopl: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # the system refused: a full disk, a read-only place, a name too long, ...
        from cocomopl.motion_file import os_error_message

        print(f"cocomopl: error: {os_error_message(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("cocomopl: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
