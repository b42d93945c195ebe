"""One function per ``cocomopl`` command: files in, files and a typed result out.

The command line only parses its options, calls one of these and prints the result
(:mod:`cocomopl.results`: ``to_json()`` and ``to_table()``), so a script gets exactly what
the command gives.  Each function checks what a user can get
wrong before it writes anything, and raises :class:`~cocomopl.errors.Error` with one line
naming the problem.  ``command`` is recorded in the files' provenance (None: "Python API").
``cocomopl walk`` and ``cocomopl reproduce`` are :func:`cocomopl.pipeline.walk_report` and
:func:`cocomopl.pipeline.reproduce_report`; ``cocomopl dataset generate`` is
:func:`generate_dataset`.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from cocomopl.data import dataset_path, model_path
from cocomopl.errors import Error, require_extra
from cocomopl.motion_file import (
    atomic_path,
    check_output,
    is_dataset,
    load_robot,
    output_file,
    read_motion,
    read_motions,
    report_folder,
    write_motions,
)
from cocomopl.provenance import file_identity, stamp
from cocomopl.requests import Refinement, WalkRequest
from cocomopl.results import (
    CheckReport,
    DatasetInfo,
    DatasetSummary,
    ExportReport,
    FamilyReport,
    GenerateReport,
    GrowReport,
    ModelExport,
    ModelInfo,
    PlotReport,
    RefineReport,
    RobotCheck,
    SimulateReport,
    StepRow,
    TrainReport,
)
from cocomopl.robot import DEFAULT_ROBOT


# ---------------------------------------------------------------------------- stage 1
def generate_dataset(
    out: str | Path,
    lengths: tuple[float, ...],
    extra_transitions: tuple[tuple[float, float], ...] | None = None,
    *,
    robot: str = DEFAULT_ROBOT,
    dt: float | None = None,
    max_iterations: int | None = None,
    load_transfer_weight: float | None = None,
    min_knee_flexion: float | None = None,
    upper_velocity_weight: float | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    command: str | None = None,
    progress: bool = False,
    record: dict | None = None,
    continuation: bool = True,
    reuse: Sequence[str | Path] = (),
) -> DatasetSummary:
    """Solve the training OCPs for step ``lengths`` (m; or footsteps) and write the dataset to ``out``.

    The OCP settings are :class:`~cocomopl.ocp.settings.OCPSettings`'s defaults scaled to the
    robot (:func:`~cocomopl.ocp.settings.settings_for`; TALOS's are the defaults), with
    each of ``dt`` (s), ``max_iterations``, ``load_transfer_weight`` (N^-2),
    ``min_knee_flexion`` (rad) and ``upper_velocity_weight`` that is not None instead; ``record`` (how the set was
    designed) is added to the dataset's attributes; ``continuation=False`` solves each
    footstep from its own guess (a step-space design).  The steps already solved in the
    datasets ``reuse`` (same robot, same OCP settings: :func:`~cocomopl.dataset.generate.reusable_steps`)
    are taken from them, and the files are recorded (``reused_from``).  See
    :func:`cocomopl.dataset.generate.generate` for the summary returned.
    """
    from cocomopl.dataset.generate import generate, reusable_steps
    from cocomopl.ocp.settings import settings_for
    from cocomopl.robot import Robot

    description = Robot(robot)
    overrides = {"dt": dt, "max_iterations": max_iterations, "w_load_transfer": load_transfer_weight,
                 "min_knee_flexion": min_knee_flexion, "w_upper_velocity": upper_velocity_weight}
    defaults = settings_for(description)
    settings = replace(defaults, **{k: v for k, v in overrides.items() if v is not None})
    out = output_file(out, "dataset.h5", inputs=[robot, *reuse])  # a robot description file is an input
    known = {}
    if reuse:
        for path in reuse:
            known |= reusable_steps(path, settings, description)
        record = {**(record or {}), "reused_from": [file_identity(path) for path in reuse]}
    return DatasetSummary(**generate(out, lengths, extra_transitions, robot_name=robot, settings=settings,
                                     workers=workers, scheduler=scheduler, command=command or "Python API",
                                     progress=progress, record=record, continuation=continuation, known=known))


def dataset_summary(path: str | Path | None = None) -> DatasetInfo:
    """Counts, convergence, timings and provenance of a dataset (default: the bundled one;
    :func:`cocomopl.dataset.info.dataset_info`)."""
    from cocomopl.dataset.info import dataset_info

    return DatasetInfo(dataset_info(dataset_path(path)))


def _saved_setting(path: Path, settings: dict, key: str, default: float) -> float:
    """The OCP setting ``key`` a file was made with, as a number (``default`` if it names none);
    an :class:`Error` naming the file and the setting if it holds something else (a null, a word)."""
    value = settings.get(key, default)
    try:
        if isinstance(value, bool):
            raise TypeError
        return float(value)
    except (TypeError, ValueError):
        raise Error(f"{path}: its OCP setting {key!r} is {value!r}, not a number") from None


def check_dataset_file(path: str | Path | None = None, verbose: bool = False) -> CheckReport:
    """The independent check of a dataset or motion file (default: the bundled dataset);
    see :func:`cocomopl.dataset.check.check_dataset`.  NaN and Inf are read, and fail the
    check, rather than refused on reading.  Without ``verbose`` the per-motion values are
    left out."""
    from cocomopl.dataset.check import check_dataset
    from cocomopl.ocp.settings import OCPSettings

    path = dataset_path(path)
    motions, attrs = read_motions(path, finite=False, signals=is_dataset(path))
    defaults = OCPSettings()
    settings = attrs.get("settings") if isinstance(attrs.get("settings"), dict) else {}
    friction = _saved_setting(path, settings, "friction", defaults.friction)
    dt = _saved_setting(path, settings, "dt", defaults.dt)
    robot = load_robot(next(iter(motions.values())).robot)
    signals = {name: s["values"] for name, s in attrs.get("signals", {}).items()}
    report = check_dataset(robot, motions, friction, dt=dt, signals=signals)
    if not verbose:
        report.pop("per_motion")
    return CheckReport(file=str(path), **report)


def _trained_model(path: Path, model: Path):
    """The training steps of the dataset ``path``, its motions by name and attributes, the model
    ``model`` trained on its robot's signals, the robot and its trained lengths (m); an
    :class:`Error` if the model is another robot's."""
    from cocomopl.primitives.model_file import load_model
    from cocomopl.primitives.training import load_training_steps

    training = load_training_steps(path)
    dataset, attrs = read_motions(path, dataset=True)
    primitives = load_model(model).prepare()
    robot = load_robot(training.source["robot"])
    if list(primitives.signal_names) != list(training.signal_names) or primitives.metadata_.get("robot", robot.name) != robot.name:
        raise Error(f"{model} was not trained on {robot.name}'s signals, those of {path}")
    trained = sorted({s.start_length for s in training.specs if s.kind == "cyclic"})
    return training, dataset, attrs, primitives, robot, trained


def _check_probe_lengths(lengths: list[float], trained: list[float]) -> list[float]:
    """``lengths`` (m), sorted, if all lie strictly between the ``trained`` ones; else :class:`Error`."""
    lengths = sorted(set(lengths))
    outside = [x for x in lengths if not trained[0] < x < trained[-1] or x in trained]
    if outside:
        raise Error(f"probe lengths must lie strictly between the dataset's lengths "
                    f"({1000 * trained[0]:g} to {1000 * trained[-1]:g} mm, none of them): {', '.join(f'{1000 * x:g}' for x in outside)} mm")
    return lengths


def _solve_probes(robot_name: str, settings: dict, lengths: list[float], workers: int, progress: bool) -> tuple[dict, list]:
    """The cyclic, start and stop steps of each length (m), solved as the dataset's are, in ``workers``
    local processes: the motions by spec and the names of the steps that did not converge."""
    from concurrent.futures import as_completed

    from tqdm import tqdm

    from cocomopl.dataset.generate import job_executor, job_result, length_job

    solved, failed = {}, []
    with job_executor(workers, None) as executor:
        futures = [executor.submit(length_job, robot_name, settings, L, kinds=["cyclic", "start", "stop"])
                   for L in lengths]
        for future in tqdm(as_completed(futures), total=len(futures), desc="probe lengths solved",
                           disable=not progress):
            result = job_result(future)
            solved.update(result.motions)
            failed += list(result.failed)
    if not solved:
        raise Error(f"no probe step converged ({', '.join(failed)})")
    return solved, failed


def check_family_file(
    path: str | Path | None = None,
    model: str | Path | None = None,
    lengths: list[float] | None = None,
    *,
    workers: int | None = None,
    probes_out: str | Path | None = None,
    progress: bool = False,
) -> FamilyReport:
    """The family check of a dataset (default: the bundled one) against a model trained on it
    (default: the bundled one): its cyclic, start and stop steps solved at ``lengths`` (m;
    default: the midpoints of the dataset's lengths) and compared with the model's predictions
    and with the linear interpolation of the dataset's steps (:mod:`cocomopl.primitives.family`).
    ``probes_out``: also save the solved steps there, for ``dataset grow --held-out``.
    """
    from cocomopl.dataset.generate import check_workers
    from cocomopl.primitives.family import family_errors, probe_lengths, probe_steps, signal_group_indices

    path, model = dataset_path(path), model_path(model)
    training, _, attrs, primitives, robot, trained = _trained_model(path, model)
    lengths = _check_probe_lengths(probe_lengths(trained) if lengths is None else lengths, trained)
    if probes_out is not None:
        probes_out = output_file(probes_out, "probes.h5", inputs=[path, model], option="--probes-out")
    workers = min(check_workers(workers) if workers else (os.cpu_count() or 1), len(lengths))
    started = time.perf_counter()
    solved, failed = _solve_probes(robot.name, attrs["settings"], lengths, workers, progress)
    if probes_out is not None:
        write_motions(probes_out, {s.name: m for s, m in solved.items()},
                      {"content": "probes", "robot": robot.name, "settings": attrs["settings"]})
    probes = probe_steps(robot, solved, training.source)
    errors = family_errors(primitives, probes, training, groups=signal_group_indices(robot, training.signal_names))
    return FamilyReport(dataset=str(path), model=str(model), lengths_mm=[1000 * x for x in lengths], solved=len(solved),
                        failed=sorted(failed), solve_s=time.perf_counter() - started, errors=errors)


def grow_dataset(
    out: str | Path,
    data: str | Path | None = None,
    model: str | Path | None = None,
    *,
    budget: int = 2,
    uniform: bool = False,
    held_out: str | Path | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    command: str | None = None,
    progress: bool = False,
    warm_start: str = "model",
) -> GrowReport:
    """Grow the dataset ``data`` (default: the bundled one) by ``budget`` step lengths where the
    model ``model`` trained on it (default: the bundled one) is least certain
    (:mod:`cocomopl.primitives.growth`; ``uniform``: spread evenly instead, the baseline), write
    it to ``out``, retrain the model beside it (``out`` with ``.npz``) and measure both models
    on held-out steps.

    Each new length's cyclic, start and stop steps and its transitions to its neighbours are
    solved as ``dataset generate`` solves them (resumably, locally or on Dask at
    ``scheduler``), the warm-up walk warm-started from the model's walk at that length
    (``warm_start`` "model", :func:`model_walk`) or from the dataset's OC walk at the nearest
    trained length ("neighbour", continuation, :func:`neighbour_walk`).  The held-out steps are
    those of ``held_out`` (saved by ``dataset family --probes-out``), or, by default, solved at
    the midpoints of the dataset's lengths; no length is picked among them.
    """
    from cocomopl.dataset.generate import check_workers, generate
    from cocomopl.ocp.settings import OCPSettings
    from cocomopl.primitives.family import family_errors, probe_lengths, probe_steps, signal_group_indices
    from cocomopl.primitives.growth import GROWTH_WARM_STARTS, check_budget, pick_uncertain, pick_uniform, variance_left
    from cocomopl.primitives.model_file import load_model
    from cocomopl.primitives.training import load_training_steps

    if warm_start not in GROWTH_WARM_STARTS:
        raise Error(f"the warm start must be one of {', '.join(GROWTH_WARM_STARTS)}, not {warm_start!r}")
    require_extra("jax", "train", "cocomopl dataset grow")
    data, model = dataset_path(data), model_path(model)
    training, dataset, attrs, primitives, robot, trained = _trained_model(data, model)
    probes, held_lengths = (None, probe_lengths(trained)) if held_out is None else _read_probes(held_out, robot, attrs,
                                                                                                trained)
    check_budget(budget, trained, held_lengths)
    out = output_file(out, "grown.h5", inputs=[data, model, held_out], beside=(".npz", ".png"))
    workers = check_workers(workers) if workers else (os.cpu_count() or 1)
    started = time.perf_counter()
    if probes is None:
        probes, _ = _solve_probes(robot.name, attrs["settings"], held_lengths, workers, progress)
    if uniform:
        picked = pick_uniform(trained, budget, held_lengths)
    else:
        picked = [L for L, _ in pick_uncertain(primitives, trained, budget, exclude=held_lengths)]
    settings = OCPSettings.from_saved(attrs["settings"])
    if warm_start == "model":
        guesses = {L: model_walk(robot, model, L, settings=settings) for L in picked}
    else:
        guesses = {L: neighbour_walk(robot, dataset, attrs["settings"], neighbour=min(trained, key=lambda x: abs(x - L)),
                                     length=L, settings=settings)
                   for L in picked}
    known = {m.steps[0]: m for m in dataset.values() if m.steps[0].swing_side == "left"}
    pairs = {(s.start_length, s.end_length) for s in known if s.kind == "transition" and s.start_length < s.end_length}
    record = {"grown": {"from_dataset": file_identity(data), "from_model": file_identity(model),
                        "method": "uniform" if uniform else "uncertainty",
                        "warm_start": warm_start,
                        "picked_mm": [1000 * L for L in picked],
                        "variance_left": [variance_left(primitives, L, []) for L in picked],
                        "held_out_mm": [1000 * L for L in held_lengths]}}
    solved = generate(out, tuple(sorted(trained + picked)), extra_transitions=tuple(sorted(pairs)), robot_name=robot.name,
                      settings=settings, workers=workers, scheduler=scheduler, command=command or "Python API",
                      progress=progress, known=known, walk_guesses=guesses, record=record)
    retrained = train_model(out.with_suffix(".npz"), out, workers=workers if not scheduler else os.cpu_count() or 1,
                            command=command, progress=progress)
    groups = signal_group_indices(robot, training.signal_names)
    held = probe_steps(robot, probes, training.source)
    grown = load_training_steps(out)
    errors = {"before": family_errors(primitives, held, training, groups=groups)["all"],
              "after": family_errors(load_model(out.with_suffix(".npz")).prepare(), held, grown, groups=groups)["all"]}
    return GrowReport(grown=record["grown"], dataset=str(out), model=retrained.output, source=str(data),
                      solved=solved["solved"], failed=solved["failed"], held_out_steps=len(probes),
                      kernel=retrained.kernel, n_primitives=retrained.n_primitives, held_out=errors,
                      wall_time_s=time.perf_counter() - started)


def model_walk(robot, model: Path, length: float, *, settings) -> tuple[np.ndarray, list[np.ndarray]]:
    """The model's walk at ``length`` (m) on the knots of the warm-up walk of that length, as
    ``settings`` (:class:`~cocomopl.ocp.settings.OCPSettings`) place them: states and torques
    (``dataset grow --warm-start model``)."""
    from cocomopl.pipeline import generate_walk
    from cocomopl.requests import StraightSteps, WalkRequest

    walk = generate_walk(WalkRequest(StraightSteps((length,) * 4), model=model))
    return _on_warm_up_knots(robot, walk.motion, length, settings)


def neighbour_walk(robot, dataset: dict, saved_settings: dict, *, neighbour: float, length: float,
                   settings) -> tuple[np.ndarray, list[np.ndarray]]:
    """The dataset's OC walk at the trained length ``neighbour`` (its start, cyclic and stop steps
    chained, as ``saved_settings`` say) on the knots of the warm-up walk of ``length``, as
    ``settings`` place them: continuation from the neighbour (``dataset grow --warm-start neighbour``)."""
    from cocomopl.gait import sequence_specs
    from cocomopl.ocp.chained_steps import solve_sequence

    walk = solve_sequence(robot, sequence_specs([neighbour] * 4), dict(dataset), settings=saved_settings)
    return _on_warm_up_knots(robot, walk, length, settings)


def _on_warm_up_knots(robot, walk, length: float, settings) -> tuple[np.ndarray, list[np.ndarray]]:
    """A walk of four steps (start, two cyclic, stop) on the knots of the warm-up walk of
    ``length`` (m): its states and torques, each impact-free segment mapped in time."""
    from cocomopl.ocp.refine import walk_guess, warm_start
    from cocomopl.ocp.solve import warm_up_plan

    plan = warm_up_plan(robot, length, settings)
    xs, us = warm_start(robot, walk_guess(robot, walk), plan.phases, x0=plan.x0, dt=settings.dt)
    return np.array(xs), us


def _read_probes(path: str | Path, robot, attrs: dict, trained: list[float]) -> tuple[dict, list[float]]:
    """The held-out steps of a ``dataset family --probes-out`` file, by spec, and their lengths (m);
    an :class:`Error` unless they were solved for ``robot`` with the dataset's settings
    (``attrs``) between its lengths."""
    motions, probe_attrs = read_motions(path, robot=robot)
    if probe_attrs.get("content") != "probes":
        raise Error(f"{path}: it is not a file of held-out steps (from 'cocomopl dataset family --probes-out')")
    if probe_attrs.get("settings") != attrs["settings"]:
        raise Error(f"{path}: its steps were solved with other OCP settings than the dataset's")
    probes = {m.steps[0]: m for m in motions.values()}
    return probes, _check_probe_lengths([s.start_length or s.end_length for s in probes], trained)


# ---------------------------------------------------------------------------- stage 2
def train_model(
    out: str | Path,
    data: str | Path | None = None,
    *,
    n_primitives: tuple[int, ...] | None = None,
    kernels: tuple[str, ...] | None = None,
    max_iterations: int | None = None,
    n_widths: int | None = None,
    workers: int = 1,
    command: str | None = None,
    progress: bool = False,
) -> TrainReport:
    """Select a model among the candidate numbers of primitives and time kernels on the dataset
    ``data`` (default: the bundled one; :func:`~cocomopl.primitives.selection.select_model`),
    write it to ``out`` and the comparison plot beside it (``out`` with ``.png``).

    Returns the chosen model's summary and the selection table (``selection``).
    """
    from cocomopl import primitives
    from cocomopl.analysis.plots import plot_model_selection
    from cocomopl.primitives.model_file import save_model
    from cocomopl.primitives.selection import select_model
    from cocomopl.primitives.training import load_training_steps

    require_extra("jax", "train", "cocomopl train")
    data = dataset_path(data)
    out = output_file(out, "model.npz", inputs=[data], beside=(".png",))  # minutes of training need a place to go
    steps = load_training_steps(data)
    started = time.perf_counter()
    best, rows = select_model(
        steps,
        n_primitives=n_primitives or primitives.DEFAULT_PRIMITIVES,
        kernels=kernels or primitives.DEFAULT_KERNELS,
        max_iterations=max_iterations or primitives.DEFAULT_MAX_ITERATIONS,
        n_widths=n_widths or primitives.DEFAULT_WIDTHS,
        workers=workers,
        progress=progress,
    )
    wall = time.perf_counter() - started
    provenance = stamp(command, ("numpy", "scipy", "jax", "jaxlib", "pin", "crocoddyl"), dataset=data)
    metadata = {
        "command": provenance["command"],
        "created": provenance["created"],
        "versions": provenance["versions"],
        "robot": steps.source["robot"],
        **({"robot_description": steps.source["robot_description"]} if steps.source["robot_description"] else {}),
        **({"robot_model": steps.source["robot_model"]} if steps.source["robot_model"] else {}),
        # the dataset by name and checksum: its path would name a folder of this machine
        "dataset": {"created": steps.source["created"], **provenance["inputs"]["dataset"], "steps": len(steps)},
        "selection": rows,
        "training_wall_time_s": wall,
    }
    save_model(out, best, metadata)
    plot = plot_model_selection(rows, out.with_suffix(".png"))
    return TrainReport(output=str(out), plot=str(plot), kernel=best.kernel, n_primitives=best.n_primitives,
                       bound=best.bound_, explained_variance=best.explained_variance_, selection=rows, wall_time_s=wall)


def model_info(path: str | Path | None = None, verbose: bool = False, *,
               coverage_samples: int | None = None) -> ModelInfo:
    """Summary of a model file (default: the bundled one); ``verbose`` adds the
    model-selection table.  The training dataset is named by file name and checksum.

    ``coverage`` measures how far allowed steps lie from the training steps
    (:func:`cocomopl.primitives.coverage.coverage`, its default seed), over
    ``coverage_samples`` transitions (default: ``DEFAULT_SAMPLES``).
    """
    from cocomopl.primitives.coverage import DEFAULT_SAMPLES, coverage
    from cocomopl.primitives.model_file import load_model

    path = model_path(path)
    model = load_model(path)
    meta = model.metadata_
    keys = ("n_primitives", "kernel", "max_iterations", "bound", "explained_variance", "n_grid", "created", "command",
            "versions", "training_wall_time_s", "checksum", "format_version")
    return ModelInfo(file=path.name, **{k: meta.get(k) for k in keys}, n_widths=model.n_widths,
                     dataset=_dataset_identity(meta.get("dataset") or {}),
                     coverage=coverage(model, samples=DEFAULT_SAMPLES if coverage_samples is None else coverage_samples),
                     selection=meta.get("selection") if verbose else None)


def _dataset_identity(dataset: dict) -> dict:
    """A model's training dataset without the machine's path (models made before the
    checksum was recorded keep only the path, of which the name is kept)."""
    out = {k: v for k, v in dataset.items() if k != "path"}
    if "name" not in out and "path" in dataset:
        out["name"] = Path(dataset["path"]).name
    return out


def generate_walk_file(request: WalkRequest, out: str | Path, *, command: str | None = None,
                       progress: bool = False) -> GenerateReport:
    """Generate the walk of ``request`` with the primitives (refined by optimal control if it
    asks so; :func:`cocomopl.pipeline.generate_walk`) and write it as one motion to ``out`` (HDF5).

    Returns per step its duration, uncertainty and training support, the timings, the
    dynamics filter's error left, the upper-body correction, ``warnings``, and with a
    refinement its summary as ``refine``.
    """
    from cocomopl.pipeline import generate_walk, robot_provenance, walk_provenance
    from cocomopl.requests import StraightSteps
    from cocomopl.synthesis.step_chain import joint_std_max

    out = output_file(out, "motion.h5", inputs=request.inputs())
    walk = generate_walk(request, progress=progress)
    motion = walk.planned
    provenance = walk_provenance(command, request.model_file(), dataset=request.dataset_file()) | robot_provenance(walk.robot)
    write_motions(out, {motion.name: motion}, {"producer": motion.producer, **provenance})
    rows = [StepRow(step=s.spec.name, duration_s=s.duration, duration_std_s=float(np.linalg.norm(s.duration_std)),
                    joint_std_max_rad=joint_std_max(walk.model, s), in_support=bool(s.in_support),
                    distance_mm=1000 * s.distance) for s in walk.steps]
    return GenerateReport(
        output=str(out), steps=rows, n_steps=len(rows), duration_s=motion.duration, generation_s=walk.generation_s,
        placement_s=walk.placement_s, dynamics_filter_zmp_error_m=walk.motion.plan.plan_zmp_error_m,
        upper_body_limits=walk.motion.plan.upper_body_limits,
        out_of_support=[r.step for r in rows if not r.in_support], warnings=walk.warnings,
        footsteps=None if isinstance(request.path, StraightSteps) else walk.motion.plan.footsteps,
        refine=walk.refinement)


def refine_walk_file(
    path: str | Path,
    motion_name: str | None = None,
    out: str | Path | None = None,
    *,
    refinement: Refinement | None = None,
    command: str | None = None,
    progress: bool = False,
) -> RefineReport:
    """Refine a generated walk of a file as ``refinement`` says (default: by the OCPs of the
    bundled dataset, the omnidirectional one for a walk that turns or side-steps, warm-started
    from the solved steps around each; :func:`cocomopl.pipeline.refine`), and write the
    refined walk to ``out`` (default: ``<file>-refined.h5``).
    """
    from cocomopl.pipeline import refine

    refinement = refinement or Refinement()
    walk = read_motion(path, motion_name)
    dataset = dataset_path(refinement.dataset, omni=not all(spec.straight for spec in walk.steps), robot=walk.robot)
    out = output_file(out or f"{Path(path).stem}-refined.h5", "motion.h5", inputs=[path, dataset])
    refined, summary = refine(walk, replace(refinement, dataset=dataset), progress=progress)
    write_motions(out, {refined.motion.name: refined.motion},
                  {"robot": walk.robot, "producer": "ocp", **stamp(command, ("crocoddyl", "pin"), walk=path, dataset=dataset)})
    return RefineReport(output=str(out), summary=summary)


# ---------------------------------------------------------------------------- stage 3 and tools
def simulate_file(
    path: str | Path,
    motion_name: str | None = None,
    out: str | Path | None = None,
    *,
    settings=None,
    command: str | None = None,
    progress: bool = False,
) -> SimulateReport:
    """Run a motion of a file in MuJoCo as a position-controlled robot, as ``settings`` say
    (:class:`~cocomopl.pipeline.SimSettings`; default: its defaults), and write the measured
    motion to ``out`` (default: ``<file>-sim.h5`` in the working folder).

    Returns the metrics against the reference (``fell`` among them) and the settings used.
    """
    from cocomopl.pipeline import SimSettings, simulate_walk, simulation_record

    settings = settings or SimSettings()
    reference = read_motion(path, motion_name)
    out = output_file(out or f"{Path(path).stem}-sim.h5", "motion.h5", inputs=[path])
    robot = load_robot(reference.robot)
    rollout, metrics = simulate_walk(robot, reference, settings, progress=progress)
    write_motions(out, {"measured": rollout.measured},
                  {"robot": robot.name, "producer": "mujoco", **stamp(command, ("mujoco",), reference=path)})
    return SimulateReport(output=str(out), simulation=simulation_record(rollout.measured), metrics=metrics)


def plot_folder(path: str | Path, motion_name: str | None = None) -> Path:
    """The default folder of :func:`plot_file` for a motion of a file."""
    return _plots_of(path, read_motion(path, motion_name))


def _plots_of(path: str | Path, motion) -> Path:
    """``<step>-plots`` for a one-step motion, else ``<file>-plots`` (a walk's name joins all its steps)."""
    return Path(f"{motion.name if len(motion.steps) == 1 else Path(path).stem}-plots")


def plot_file(path: str | Path, motion_name: str | None = None, out: str | Path | None = None) -> PlotReport:
    """PNGs of one motion of a file (joints, ZMP, contact forces, torques) in the report
    folder ``out`` (default: :func:`plot_folder`), written as a unit by
    :func:`~cocomopl.motion_file.report_folder`."""
    from cocomopl.analysis.plots import plot_motion

    motion = read_motion(path, motion_name)
    folder = Path(out) if out else _plots_of(path, motion)
    with report_folder(folder, inputs=[path]) as work:
        files = plot_motion(load_robot(motion.robot), motion, work)
    return PlotReport(files=[str(folder / f.name) for f in files])


def export_file(path: str | Path, fmt: str, prefix: str | Path, *, motion_name: str | None = None,
                force: bool = False, robot: str = DEFAULT_ROBOT) -> ExportReport:
    """Write a motion for a robot (``fmt`` "seqplay" or "csv", files ``prefix.*``) behind
    the safety gate, with the limits of ``robot`` (a bundled name or a description file,
    never the file's own word): an unsafe motion is refused with its first reason unless
    ``force``; one holding NaN or Inf is always refused."""
    from cocomopl.export.seqplay import SUFFIXES, export_motion

    motion = read_motion(path, motion_name)
    prefix = Path(prefix)
    if prefix.is_dir():
        raise Error(f"--out {prefix} is a directory; give a file prefix such as {prefix / 'walk'}")
    for suffix in SUFFIXES.get(fmt, ()):  # an unknown format is export_motion's to refuse
        check_output(f"{prefix}{suffix}", [path], given=prefix)
    files, report = export_motion(load_robot(robot), motion, fmt, prefix=prefix, force=force)
    unsafe = report.pop("unsafe")
    return ExportReport(files=[str(f) for f in files], format=fmt, unsafe=unsafe, forced=bool(unsafe), gate=report)


def init_robot(source: str, out: str | Path) -> RobotCheck:
    """Write a starting description of the robot ``source`` (an ``example-robot-data`` name or
    a URDF path) to ``out``: its name, where its model comes from and its pelvis (the body
    of its floating base), the rest derived (``docs/robots.md``), after checking that it loads;
    what is derived, as :func:`check_robot` gives it."""
    import json

    import pinocchio as pin

    from cocomopl.robot import Robot
    from cocomopl.robot.description import load_full_model

    out = output_file(out, "robot.json", inputs=[source])
    if source.endswith(".urdf"):
        description = {"name": Path(source).stem, "urdf": str(Path(source).resolve())}
    else:
        description = {"name": source, "example_robot_data": source}
    model = load_full_model(description)[0]
    bodies = [f.name for f in model.frames if f.parentJoint == 1 and f.type == pin.FrameType.BODY]
    if model.joints[1].shortname() != "JointModelFreeFlyer" or not bodies:
        raise Error(f"{source} has no floating base with a body on it: not a legged humanoid cocomopl can walk")
    description["pelvis"] = bodies[0]
    Robot(description)  # refused here, before anything is written, if it does not load
    with atomic_path(out, suffix=".json") as tmp:
        tmp.write_text(json.dumps(description, indent=2) + "\n")
    return check_robot(str(out))


def check_robot(robot: str, png: str | Path | None = None) -> RobotCheck:
    """What cocomopl derives from the description of ``robot`` (a bundled name or a
    description file): joint groups, mirror pairs, soles, posture and the symmetrisation;
    with ``png``, a picture of the posture and its soles."""

    from cocomopl.baselines.kajita import KajitaSettings
    from cocomopl.dataset.plan import default_lengths
    from cocomopl.gait import footstep_range, m_gen
    from cocomopl.ocp.settings import settings_for
    from cocomopl.pipeline import SimSettings, servo_feedforward
    from cocomopl.robot import Robot
    from cocomopl.sim.mujoco_model import servo_stiffness
    from cocomopl.sim.stabilizer import robot_gains

    if png is not None:
        check_output(png)
    r = Robot(robot)
    names = r.joint_names
    kp = servo_stiffness(r)
    straight = r.leg_length
    height = r.q_ref[2] - r.frame_placement(r.q_ref, r.foot_frames["left"]).translation[2]
    result = RobotCheck(
        robot=r.name,
        mass_kg=r.mass,
        actuated_joints=r.nu,
        groups={group: [names[i] for i in idx] for group, idx in r.joint_groups().items()},
        mirror_pairs=[[names[i], names[j]] for i, j in enumerate(r.mirror_perm) if i < j],
        soles={"source": "given" if "feet" in r.description else "derived",
               **{side: r.model.frames[frame].name for side, frame in r.foot_frames.items()},
               "front_m": r.sole.front, "back_m": r.sole.back, "half_width_m": r.sole.half_width},
        posture={"source": r.description.get("reference_posture", "derived"), "pelvis_height_m": float(height),
                 "straight_pelvis_height_m": float(straight),
                 "knees_rad": [float(r.q_ref[7 + roles["knee"]]) for roles in r.leg_roles().values()]},
        placement_symmetrised_m=r.placement_asymmetry,
        inertia_symmetrised_m=r.inertia_asymmetry,
        armature={"source": r.armature_source, "min_kg_m2": float(r.model.armature[6:].min()),
                  "max_kg_m2": float(r.model.armature[6:].max())},
        scale={**asdict(r.scale), "time": r.scale.time},
        defaults={"given": sorted(r.description.get("defaults", {})), "walk_m": list(m_gen(r)),
                  "training_lengths_m": list(default_lengths(r)),
                  "footstep_range": {key: list(v) for key, v in footstep_range(r).items()},
                  "ocp": settings_for(r).as_dict(), "feedforward": servo_feedforward(SimSettings(), r),
                  "stabilizer": robot_gains(r).as_dict(), "kajita": asdict(KajitaSettings().scaled_to(r)),
                  "leg_servo_kp": {names[j]: float(kp[j]) for j in sorted(r.leg_joint_roles())}},
    )
    if png is not None:
        from cocomopl.analysis.plots import plot_robot_posture

        result.png = str(plot_robot_posture(r, Path(png)))
    return result


def export_model_file(robot: str, fmt: str, out: str | Path) -> ModelExport:
    """Write the model of ``robot`` (a bundled name or a description file) that cocomopl
    simulates, in ``fmt`` (:func:`cocomopl.export.mjcf.export_model`)."""
    from cocomopl.export.mjcf import export_model

    return ModelExport(export_model(robot, fmt, out))


