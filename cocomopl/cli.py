"""The ``cocomopl`` command: parse the options, call one API function, print its result.

Every command prints a table by default and exactly one JSON object on stdout with ``--json``
(:mod:`cocomopl.results`); progress and warnings go to stderr.  A mistake a user can make is one
line ``cocomopl: error: ...`` and exit 2, without a traceback.  The work is in :mod:`cocomopl.jobs`
and :mod:`cocomopl.pipeline`, the option types in :mod:`cocomopl.options`.  Nothing heavy is
imported at the top: Ctrl-C even while the libraries load ends in ``cocomopl: interrupted``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cocomopl.errors import Error
from cocomopl.options import Parser, json_options, negative_values_joined, replacing, sim_settings, walk_request


# ---------------------------------------------------------------------------- commands
def cmd_dataset_generate(args):
    from cocomopl.jobs import generate_dataset

    lengths, extra, record = args.lengths_mm, None, None  # None: the default extra transitions of these lengths
    if lengths is None and args.step_space is None and args.gaits is None:
        from cocomopl.dataset.plan import default_lengths
        from cocomopl.robot import Robot

        lengths = default_lengths(Robot(args.robot))
    if args.step_space is not None:
        from cocomopl.dataset.design import step_space_design
        from cocomopl.robot import Robot

        if args.extra_transitions_mm is not None:
            raise Error("--extra-transitions-mm joins straight lengths; a step-space design has its own transitions")
        footsteps, pairs = args.step_space
        design = step_space_design(Robot(args.robot), footsteps=footsteps, pairs=pairs, sampling=args.sampling,
                                   seed=args.design_seed)
        lengths, extra, record = design.footsteps, design.pairs, design.record
    elif args.gaits is not None:
        from cocomopl.dataset.plan import gait_footsteps
        from cocomopl.robot import Robot

        if args.extra_transitions_mm is not None:
            raise Error("--extra-transitions-mm joins straight lengths; a gait grid has its own transitions")
        lengths, extra = gait_footsteps(Robot(args.robot), args.gaits)
    elif args.extra_transitions_mm is not None:
        from cocomopl.gait import parse_transitions_mm

        extra = parse_transitions_mm(args.extra_transitions_mm, lengths)
    replacing(args, args.out, inputs=[args.robot, *args.reuse])
    return generate_dataset(args.out, lengths, extra, robot=args.robot, dt=args.dt, max_iterations=args.max_iterations,
                            load_transfer_weight=args.load_transfer_weight, min_knee_flexion=args.min_knee_flexion_rad,
                            upper_velocity_weight=args.upper_velocity_weight, workers=args.workers,
                            scheduler=args.scheduler, command=args.command_line, progress=True,
                            record=record, continuation=record is None, reuse=args.reuse)


def cmd_dataset_info(args):
    from cocomopl.jobs import dataset_summary

    return dataset_summary(args.file)


def cmd_dataset_check(args):
    from cocomopl.jobs import check_dataset_file

    return check_dataset_file(args.file, args.verbose)


def cmd_dataset_family(args):
    from cocomopl.jobs import check_family_file

    return check_family_file(args.file, args.model, args.lengths_mm, workers=args.workers, probes_out=args.probes_out,
                             progress=not args.json)


def cmd_dataset_grow(args):
    from cocomopl.jobs import grow_dataset

    return grow_dataset(args.out, args.file, args.model, budget=args.budget, uniform=args.uniform, held_out=args.held_out,
                        workers=args.workers, scheduler=args.scheduler, command=args.command_line,
                        progress=not args.json, warm_start=args.warm_start)


def cmd_train(args):
    import os

    from cocomopl.jobs import train_model

    replacing(args, args.out, Path(args.out).with_suffix(".png"), inputs=[args.data], given=args.out)
    return train_model(args.out, args.data, n_primitives=args.primitives, kernels=args.kernels,
                       max_iterations=args.max_iterations, n_widths=args.widths,
                       workers=args.workers or os.cpu_count() or 1, command=args.command_line, progress=True)


def cmd_model_info(args):
    from cocomopl.jobs import model_info

    return model_info(args.file, args.verbose, coverage_samples=args.coverage_samples)


def cmd_generate(args):
    from cocomopl.jobs import generate_walk_file

    request = walk_request(args)
    replacing(args, args.out, inputs=[args.model])
    return generate_walk_file(request, args.out, command=args.command_line, progress=not args.json)


def cmd_refine(args):
    from cocomopl.jobs import refine_walk_file
    from cocomopl.requests import Refinement

    refinement = Refinement(args.data, args.warm_start)
    replacing(args, args.out or f"{Path(args.file).stem}-refined.h5", inputs=[p for p in (args.file, args.data) if p])
    return refine_walk_file(args.file, args.motion, args.out, refinement=refinement, command=args.command_line,
                            progress=not args.json)


def cmd_plot(args):
    from cocomopl.jobs import plot_file, plot_folder

    replacing(args, args.out or plot_folder(args.file, args.motion), inputs=[args.file], folder=True)
    return plot_file(args.file, args.motion, args.out)


def cmd_simulate(args):
    from cocomopl.jobs import simulate_file

    replacing(args, args.out or f"{Path(args.file).stem}-sim.h5", inputs=[args.file])
    return simulate_file(args.file, args.motion, args.out, settings=sim_settings(args), command=args.command_line,
                         progress=not args.json)


def cmd_walk(args):
    from cocomopl.pipeline import walk_report

    request = walk_request(args)
    replacing(args, args.out, inputs=[args.model], folder=True)
    return walk_report(request, args.out, settings=sim_settings(args), video=not args.no_video, progress=not args.json,
                       command=args.command_line)


def cmd_reproduce(args):
    from cocomopl.pipeline import reproduce_report

    replacing(args, args.out, inputs=[args.model, args.data], folder=True)
    return reproduce_report(args.out, args.model, args.data, progress=not args.json, settings=sim_settings(args),
                            command=args.command_line, kajita_variant=args.kajita, robot=args.robot)


def cmd_export(args):
    from cocomopl.export.seqplay import SUFFIXES
    from cocomopl.jobs import export_file

    replacing(args, *(f"{args.out}{suffix}" for suffix in SUFFIXES[args.format]), inputs=[args.file], given=args.out)
    return export_file(args.file, args.format, args.out, motion_name=args.motion, force=args.force, robot=args.robot)


def cmd_robot_init(args):
    from cocomopl.jobs import init_robot

    replacing(args, args.out, inputs=[args.source])
    return init_robot(args.source, args.out)


def cmd_robot_check(args):
    from cocomopl.jobs import check_robot

    if args.png is not None:
        replacing(args, args.png, inputs=[args.robot if args.robot.endswith(".json") else None])
    return check_robot(args.robot, args.png)


def cmd_robot_bootstrap(args):
    from cocomopl.bootstrap import bootstrap_robot

    return bootstrap_robot(args.robot, args.out, workers=args.workers, scheduler=args.scheduler,
                           video=not args.no_video, progress=True, command=args.command_line)


def cmd_export_model(args):
    from cocomopl.export.mjcf import mesh_folder
    from cocomopl.jobs import export_model_file

    replacing(args, args.out, inputs=[args.robot if args.robot.endswith(".json") else None])
    meshes = mesh_folder(Path(args.out))
    if meshes.is_dir():  # replaced as a whole by the export (the meshes of an earlier one), not a report folder
        args.notes.append(f"replacing {meshes}")
    return export_model_file(args.robot, args.format, args.out)


# ---------------------------------------------------------------------------- the parser
def _dataset_parsers(sub) -> None:
    from cocomopl import options as o
    from cocomopl.dataset.design import DEFAULT_STEP_SPACE, DEFAULT_STEP_SPACE_TEXT, SAMPLINGS
    from cocomopl.dataset.generate import DT_RANGE_S, MIN_PHASE_KNOTS, WORKERS_PER_CORE
    from cocomopl.dataset.plan import DEFAULT_EXTRA_TRANSITIONS_M, DEFAULT_GAIT_GRID_TEXT, DEFAULT_LENGTHS_M
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.primitives.growth import GROWTH_WARM_STARTS
    from cocomopl.robot import DEFAULT_ROBOT

    defaults = OCPSettings()
    dataset = sub.add_parser("dataset", help="optimal-control training data").add_subparsers(
        dest="action", required=True, parser_class=Parser)

    gen = dataset.add_parser("generate", help="solve the step OCPs and write the training dataset (HDF5)")
    lengths_mm = ",".join(f"{1000 * x:g}" for x in DEFAULT_LENGTHS_M)
    design = gen.add_mutually_exclusive_group()
    design.add_argument("--gaits", type=o.gait_grid, nargs="?", const=DEFAULT_GAIT_GRID_TEXT, action="append",
                        metavar="LENGTHS_MM/WIDTHS_MM/TURNS_DEG",
                        help="an omnidirectional set: the steady gaits of a grid of footstep lengths and widths (mm) "
                        f"and turns (deg); alone, the default grid {DEFAULT_GAIT_GRID_TEXT}; given again, the gaits of "
                        "every grid (docs/method.md#omnidirectional-training-set)")
    design.add_argument("--step-space", type=o.step_space, nargs="?", const=DEFAULT_STEP_SPACE,
                        metavar="FOOTSTEPS/PAIRS",
                        help="an omnidirectional set over the whole step space: FOOTSTEPS footsteps spread over the "
                        "footstep range, each a start, cyclic and stop step, and transitions joining neighbours and "
                        f"PAIRS more pairs, both ways (default: {DEFAULT_STEP_SPACE_TEXT}; "
                        "docs/method.md#omnidirectional-training-set)")
    design.add_argument("--lengths-mm", type=o.training_lengths_mm, metavar="MM,MM,...",
                        help=f"training step lengths in millimetres, straight ahead (default: {lengths_mm} for TALOS, "
                        "scaled by the robot's leg length to 10 mm: docs/robots.md)")
    extra = ",".join(f"{1000 * a:g}-{1000 * b:g}" for a, b in DEFAULT_EXTRA_TRANSITIONS_M)
    gen.add_argument("--extra-transitions-mm", metavar="A-B,...",
                     help="transitions between training lengths that are not neighbours, in millimetres, solved both "
                     f"ways (default: {extra} for TALOS, scaled as the lengths, those whose lengths are trained; "
                     "'' for none)")
    gen.add_argument("--sampling", choices=SAMPLINGS, default="maximin",
                     help="how --step-space spreads its footsteps and pairs: maximin fills the range greedily, random "
                     "draws them uniformly, as for a held-out set (default: %(default)s)")
    gen.add_argument("--design-seed", type=o.non_negative_int, default=0, metavar="N",
                     help="seed of the --step-space design (default: %(default)s)")
    gen.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME|FILE.json",
                     help="bundled robot name or robot description file (default: %(default)s)")
    gen.add_argument("--out", default="cocomopl-dataset.h5", metavar="FILE.h5", help="output HDF5 file (default: %(default)s)")
    gen.add_argument("--reuse", action="append", default=[], metavar="FILE.h5",
                     help="take the steps this set needs that a dataset of the same robot and OCP settings already "
                     "holds (a smaller --step-space design, say) instead of solving them again; given again, from "
                     "several")
    gen.add_argument("--workers", type=o.workers, metavar="N", help=f"local worker processes, at most {WORKERS_PER_CORE} "
                     "per core (default: one per core, at most one per step length)")
    o.scheduler_option(gen)
    low, high = DT_RANGE_S
    gen.add_argument("--dt", type=o.knot_spacing, metavar="S",
                     help=f"knot spacing in s, {low:g} to {high:g} (default: {defaults.dt:g}): coarser knots leave "
                     f"the {defaults.ds_duration * 1000:g} ms double support fewer than {MIN_PHASE_KNOTS} knots, finer "
                     "ones only add solve time")
    gen.add_argument("--max-iterations", type=o.positive_int, metavar="N",
                     help=f"solver iterations per attempt, a count (default: {defaults.max_iterations})")
    gen.add_argument("--load-transfer-weight", type=o.non_negative_float, metavar="W",
                     help="weight in N^-2 pulling each sole's vertical force in double support towards a linear transfer "
                     f"of the body weight (default: {defaults.w_load_transfer:g}; 0 for none; docs/method.md)")
    gen.add_argument("--min-knee-flexion-rad", type=o.non_negative_float, metavar="RAD",
                     help=f"least bend of the knees at every knot, in rad (default: {defaults.min_knee_flexion:g}; "
                     "0 for only the URDF's limits; docs/method.md)")
    gen.add_argument("--upper-velocity-weight", type=o.non_negative_float, metavar="W",
                     help="weight of the upper body's joint velocities (rad/s) in the posture cost (default: the "
                     "robot's, which is the legs' weight unless its description sets it; docs/method.md)")
    gen.set_defaults(func=cmd_dataset_generate)

    info = dataset.add_parser("info", help="summarise a dataset (default: the bundled one)")
    info.add_argument("file", nargs="?", metavar="FILE.h5", help="dataset HDF5 file (default: the bundled one)")
    info.set_defaults(func=cmd_dataset_info)

    check = dataset.add_parser("check", help="recompute every motion with inverse dynamics and check it")
    check.add_argument("file", nargs="?", metavar="FILE.h5", help="dataset or motion HDF5 file (default: the bundled dataset)")
    check.add_argument("--verbose", action="store_true", help="include every motion's values in --json")
    check.set_defaults(func=cmd_dataset_check)

    family = dataset.add_parser("family", help="solve steps between the trained lengths and measure how far they lie "
                                "from the model's predictions and from linear interpolation, per joint group")
    o.dataset_and_model_options(family)
    family.add_argument("--lengths-mm", type=o.training_lengths_mm, metavar="MM,MM,...", help="step lengths in "
                        "millimetres to solve at, strictly between the dataset's (default: the midpoints of its lengths)")
    family.add_argument("--workers", type=o.workers, metavar="N", help="local worker processes (default: one per core)")
    family.add_argument("--probes-out", metavar="FILE.h5",
                        help="also save the solved steps there, as held-out steps for 'dataset grow --held-out'")
    family.set_defaults(func=cmd_dataset_family)

    grow = dataset.add_parser("grow", help="add the step lengths where the model is least certain, solve them, "
                              "retrain, and measure the model on held-out steps before and after")
    o.dataset_and_model_options(grow)
    grow.add_argument("--budget", type=int, required=True, metavar="N", help="step lengths to add, each with its "
                      "cyclic, start and stop steps and transitions to its neighbours (7 OCPs)")
    grow.add_argument("--uniform", action="store_true",
                      help="spread the new lengths evenly instead (the baseline growth is compared with)")
    grow.add_argument("--warm-start", choices=GROWTH_WARM_STARTS, default="model",
                      help="start each new length's warm-up walk from the model's walk, or from the dataset's OC walk "
                      "at the nearest trained length (continuation) (default: %(default)s)")
    grow.add_argument("--held-out", metavar="PROBES.h5", help="held-out steps saved by 'dataset family --probes-out' "
                      "(default: solve them at the midpoints of the dataset's lengths)")
    grow.add_argument("--out", default="cocomopl-grown.h5", metavar="FILE.h5",
                      help="grown dataset; the retrained model goes beside it as .npz (default: %(default)s)")
    grow.add_argument("--workers", type=o.workers, metavar="N", help="local worker processes (default: one per core)")
    o.scheduler_option(grow)
    grow.set_defaults(func=cmd_dataset_grow)


def _primitives_parsers(sub) -> None:
    from cocomopl import options as o
    from cocomopl.ocp.settings import DEFAULT_WARM_START, WARM_STARTS
    from cocomopl.primitives import DEFAULT_KERNELS, DEFAULT_MAX_ITERATIONS, DEFAULT_PRIMITIVES, DEFAULT_WIDTHS

    train = sub.add_parser("train", help="learn movement primitives from a dataset, choosing S and the kernel "
                           "(needs the [train] extra)")
    train.add_argument("data", nargs="?", metavar="DATASET.h5", help="dataset HDF5 file (default: the bundled one)")
    train.add_argument("--out", default="cocomopl-model.npz", metavar="MODEL.npz",
                       help="output model file; the comparison plot goes beside it as .png (default: %(default)s)")
    train.add_argument("--primitives", type=o.int_list, default=DEFAULT_PRIMITIVES, metavar="S,S,...",
                       help=f"candidate numbers of primitives (default: {','.join(map(str, DEFAULT_PRIMITIVES))})")
    train.add_argument("--kernels", type=o.kernel_list, default=DEFAULT_KERNELS, metavar="K,K,...",
                       help=f"candidate time kernels (default: {','.join(DEFAULT_KERNELS)})")
    train.add_argument("--max-iterations", type=o.positive_int, default=DEFAULT_MAX_ITERATIONS, metavar="N",
                       help="the most EM rounds per candidate, a count (default: %(default)s)")
    train.add_argument("--widths", type=o.positive_int, default=DEFAULT_WIDTHS, metavar="N",
                       help="candidate widths of the weight kernels, log-spaced from 7 mm to 0.7 m; fewer make "
                            "generation faster (default: %(default)s)")
    train.add_argument("--workers", type=o.workers, metavar="N",
                       help="local worker processes, at most 4 per core (default: one per core)")
    train.set_defaults(func=cmd_train)

    model = sub.add_parser("model", help="inspect a primitives model").add_subparsers(
        dest="action", required=True, parser_class=Parser)
    info = model.add_parser("info", help="summarise a model (default: the bundled one)")
    info.add_argument("file", nargs="?", metavar="MODEL.npz", help="model file (default: the bundled one)")
    info.add_argument("--verbose", action="store_true", help="add the model-selection table")
    info.add_argument("--coverage-samples", type=o.positive_int, metavar="N",
                      help="allowed transitions drawn to measure the coverage, a count (default: 4000)")
    info.set_defaults(func=cmd_model_info)

    generate = sub.add_parser("generate", help="synthesise a walk from step lengths with the primitives")
    o.synthesis_options(generate)
    generate.add_argument("--out", default="cocomopl-walk.h5", metavar="FILE.h5", help="output motion HDF5 (default: %(default)s)")
    generate.set_defaults(func=cmd_generate)

    refine = sub.add_parser("refine", help="make a generated walk optimal: each step warm-starts the OCP it was "
                            "learned from")
    refine.add_argument("file", metavar="MOTION.h5", help="a walk from 'cocomopl generate'")
    refine.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    refine.add_argument("--data", metavar="DATASET.h5",
                        help="OC dataset whose OCP settings the steps are solved with (default: the bundled one)")
    refine.add_argument("--out", metavar="FILE.h5", help="refined motion HDF5 (default: <file>-refined.h5)")
    refine.add_argument("--warm-start", choices=WARM_STARTS, default=DEFAULT_WARM_START, metavar="FROM",
                        help=o.WARM_START_HELP)
    refine.set_defaults(func=cmd_refine)


def _simulation_parsers(sub) -> None:
    from cocomopl import options as o

    walk = sub.add_parser("walk", help="the main job: generate a walk with the primitives, simulate it, write a report")
    o.synthesis_options(walk)
    walk.add_argument("--out", default="cocomopl-walk", metavar="DIR", help="report folder (default: %(default)s)")
    o.servo_options(walk)
    walk.add_argument("--no-video", action="store_true", help="skip the MP4 (saves about 15 s)")
    walk.add_argument("--push", type=o.push, action="append", default=[], metavar="AT_S,FX_N,FY_N",
                      help="push the pelvis for 0.1 s, AT_S seconds after the walk starts, with FX_N, FY_N newtons "
                      "(world axes: x forward, y left); may be given again")
    walk.add_argument("--recover", action=o.Replanner, nargs=0, dest="replanner",
                      help="recovery by stepping: a push the stabilizer cannot absorb moves the swing foot's landing, "
                      "and the walk is generated again from there (docs/method.md#recovery-by-stepping)")
    walk.add_argument("--reaim", "--no-reaim", action=o.Replanner, nargs=0, dest="replanner",
                      help="footstep re-aiming: each step is aimed from where the stance sole was measured at the "
                      "plan's landing, and the walk is generated again from there (default: on for --to walks "
                      "without --refine or --recover; docs/method.md#footstep-re-aiming)")
    o.simulation_options(walk)
    walk.set_defaults(func=cmd_walk)

    reproduce = sub.add_parser("reproduce", help="the paper's experiment: M_gen vs M_opt vs Kajita, simulated; "
                               "Table I, Figs. 6, 8, 9")
    reproduce.add_argument("--out", default="cocomopl-reproduce", metavar="DIR", help="report folder (default: %(default)s)")
    reproduce.add_argument("--model", metavar="MODEL.npz", help="primitives model file (default: the robot's bundled one)")
    o.bundled_robot_option(reproduce)
    reproduce.add_argument("--data", metavar="DATASET.h5",
                           help="OC dataset for M_opt's steps and gait states (default: the bundled one)")
    reproduce.add_argument("--kajita", choices=("two-stage", "legacy"), default="two-stage",
                           help="the Kajita baseline: as jrl-walkgen runs it (two-stage, default) or the earlier "
                                "single-stage one with a fixed 4 cm crouch (legacy)")
    o.simulation_options(reproduce)
    # the paper's comparison: every walk with the stabilizer, without feedforward or pushes
    reproduce.set_defaults(func=cmd_reproduce, no_stabilizer=False, feedforward=False, push=[])

    simulate = sub.add_parser("simulate", help="run a motion in MuJoCo with joint position control and measure it")
    simulate.add_argument("file", metavar="MOTION.h5", help="motion HDF5 file (e.g. from 'cocomopl generate')")
    simulate.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    simulate.add_argument("--out", metavar="FILE.h5", help="measured motion HDF5 (default: <file>-sim.h5)")
    o.servo_options(simulate)
    o.simulation_options(simulate)
    simulate.set_defaults(func=cmd_simulate, push=[])


def _tool_parsers(sub) -> None:
    from cocomopl import options as o
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
    export.set_defaults(func=cmd_export)

    export_model = sub.add_parser("export-model", help="write the robot model cocomopl simulates (MuJoCo MJCF)")
    export_model.add_argument("--format", choices=MODEL_FORMATS, default=MODEL_FORMATS[0], help="(default: %(default)s)")
    export_model.add_argument("--out", required=True, metavar="FILE", help="output file, e.g. talos.xml")
    export_model.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME|FILE.json",
                              help="bundled robot name or robot description file (default: %(default)s)")
    export_model.set_defaults(func=cmd_export_model)

    robot = sub.add_parser("robot", help="robot descriptions (docs/robots.md)").add_subparsers(
        dest="action", required=True, parser_class=Parser)
    init = robot.add_parser("init", help="write a starting description of a robot from example-robot-data or a URDF")
    init.add_argument("source", metavar="NAME|FILE.urdf", help="an example-robot-data robot name or a URDF file")
    init.add_argument("--out", required=True, metavar="FILE.json", help="the description to write")
    init.set_defaults(func=cmd_robot_init)
    check = robot.add_parser("check", help="print what is derived from a robot's description: joint groups, mirror "
                                           "pairs, soles, posture, symmetrisation")
    check.add_argument("robot", metavar="NAME|FILE.json", help="bundled robot name or robot description file")
    check.add_argument("--png", metavar="FILE.png", help="also draw the posture and its soles")
    check.set_defaults(func=cmd_robot_check)
    bootstrap = robot.add_parser("bootstrap", help="from a robot's description to a walking report: solve its default "
                                 "dataset, check it, train, walk; resumable (docs/robots.md#bootstrap)")
    bootstrap.add_argument("robot", metavar="NAME|FILE.json", help="bundled robot name or robot description file")
    bootstrap.add_argument("--out", required=True, metavar="DIR",
                           help="the folder of dataset.h5, model.npz and the walk report walk/; run again to resume")
    bootstrap.add_argument("--workers", type=o.workers, metavar="N",
                           help="local worker processes (default: one per core)")
    o.scheduler_option(bootstrap)
    bootstrap.add_argument("--no-video", action="store_true", help="skip the walk's MP4 (saves about 15 s)")
    bootstrap.set_defaults(func=cmd_robot_bootstrap)

    plot = sub.add_parser("plot", help="PNG plots of one motion: joints, ZMP, contact forces, torques")
    plot.add_argument("file", metavar="MOTION.h5", help="motion or dataset HDF5 file")
    plot.add_argument("--motion", metavar="NAME", help="motion name (needed when the file holds several)")
    plot.add_argument("--out", metavar="DIR", help="output folder (default: <step>-plots for one step, else <file>-plots)")
    plot.set_defaults(func=cmd_plot)


def build_parser() -> argparse.ArgumentParser:
    from cocomopl import __version__

    parser = Parser(prog="cocomopl", description="Whole-body humanoid walking from optimal control, movement primitives and learning.")
    parser.add_argument("--version", action="version", version=f"cocomopl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for add in (_dataset_parsers, _primitives_parsers, _simulation_parsers, _tool_parsers):
        add(sub)
    json_options(parser)  # every command prints one JSON object with --json
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:  # the imports too: Ctrl-C while the libraries load is an interruption like any other
        import json

        from cocomopl.provenance import command_line

        parser = build_parser()
        args = parser.parse_args(negative_values_joined(parser, argv))
        args.command_line, args.notes = command_line(argv), []  # the command line goes into the provenance
        result = args.func(args)
        for message in [*getattr(result, "warnings", ()), *args.notes]:
            print(f"cocomopl: warning: {message}", file=sys.stderr)
        print(json.dumps(result.to_json(), default=float) if args.json else result.to_table())
        return result.exit_code
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

