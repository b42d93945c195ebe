"""A robot from its description to a walking report in one command: ``cocomopl robot bootstrap``.

The stages are the plain commands a user would run, in turn, each into the output folder:
``dataset generate`` (the robot's default straight set, :func:`~cocomopl.dataset.plan.default_lengths`)
to ``dataset.h5``, ``dataset check`` of it, ``train`` to ``model.npz``, and ``walk`` (the
robot's M_gen) to the report folder ``walk/``.  A stage whose output is already there and
made from the stage before is not run again, and the dataset's OCPs resume from its parts
(``dataset.h5.parts/``): after Ctrl-C the same command goes on where it stopped.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from cocomopl.errors import Error
from cocomopl.results import BootstrapReport, StageRecord

# cluster sizes the report projects the dataset's wall time to (docs/robots.md#bootstrap)
PROJECTED_WORKERS = (2, 4, 8, 16, 32)
STAGES = ("dataset", "check", "train", "walk")


def bootstrap_robot(
    robot: str,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    video: bool = True,
    progress: bool = False,
    command: str | None = None,
) -> BootstrapReport:
    """Solve ``robot``'s default straight dataset, check it, train a model on it and write a
    walking report of its default walk, all in ``out_dir`` (see the module's docstring).

    ``robot`` is a bundled robot's name or a description file (docs/robots.md);
    ``workers`` local processes (default: one per core) or the Dask cluster at ``scheduler``
    solve the OCPs and train.

    Raises
    ------
    Error
        On a bad robot or folder, a dataset in ``out_dir`` of another robot or other
        settings, OCPs that do not converge, or a dataset that fails its check.
    """
    import os

    from cocomopl.dataset.plan import default_lengths
    from cocomopl.jobs import check_dataset_file, generate_dataset, train_model
    from cocomopl.motion_file import writable_place
    from cocomopl.pipeline import walk_report
    from cocomopl.requests import StraightSteps, WalkRequest
    from cocomopl.robot import Robot

    started = time.perf_counter()
    description = Robot(robot)  # a bad description is refused before anything is written
    # checked, not made: the first stage that writes makes it, so a refused run leaves no empty folder
    out = writable_place(Path(out_dir), f"the output folder {out_dir}")
    dataset, model, report = out / "dataset.h5", out / "model.npz", out / "walk"
    lengths = default_lengths(description)
    finished = _finished_dataset(dataset, description, lengths)  # a file not to replace is refused before any work
    stages: list[StageRecord] = []

    def stage(name: str, output: Path, run) -> object:
        number = STAGES.index(name) + 1
        if progress:
            print(f"[{number}/{len(STAGES)}] {name}: {output}", file=sys.stderr)
        begun = time.perf_counter()
        result = run()
        stages.append(StageRecord(name, str(output), "run" if result is not None else "kept",
                                  time.perf_counter() - begun))
        return result

    def solve():
        if finished:
            return None
        summary = generate_dataset(dataset, lengths, robot=robot, workers=workers, scheduler=scheduler,
                                   command=command, progress=progress)
        if summary.failed:
            raise Error(f"{len(summary.failed)} of {summary.ocps} OCPs did not converge ({', '.join(summary.failed)}); "
                        f"{dataset} holds the others: run again to retry them")
        return summary

    stage("dataset", dataset, solve)
    check = stage("check", dataset, lambda: check_dataset_file(dataset))
    if not check.ok:
        raise Error(f"{dataset} fails its check ({', '.join(check.failures)}): see cocomopl dataset check {dataset}")
    stage("train", model, lambda: None if _trained_on(model, dataset) else train_model(
        model, dataset, workers=workers or os.cpu_count() or 1, command=command, progress=progress))
    walk = stage("walk", report, lambda: walk_report(WalkRequest(StraightSteps(), model=model), report, video=video,
                                                     progress=progress, command=command))
    return BootstrapReport(robot=description.name, folder=str(out), stages=stages, check=check.ok,
                           walk=walk, dataset_projection_s=dataset_projection(dataset),
                           wall_time_s=time.perf_counter() - started)


def _finished_dataset(path: Path, robot, lengths: tuple[float, ...]) -> bool:
    """Whether ``path`` holds this bootstrap's dataset, all converged: then it is kept.

    A file that is not a dataset of ``robot`` at its default settings and ``lengths`` is
    refused (an :class:`Error`), not replaced: it may be a user's work.  A dataset with
    OCPs left out is solved again (the parts of its run resume it).
    """
    from cocomopl.dataset.generate import settings_problem
    from cocomopl.motion_file import file_attrs, open_checked
    from cocomopl.ocp.settings import settings_for

    if not path.exists():
        return False
    with open_checked(path) as f:
        attrs = file_attrs(f)
    expected = json.loads(json.dumps(settings_for(robot).as_dict()))  # as the file holds it: lists
    if attrs.get("content") != "dataset" or attrs.get("robot") != robot.name:
        raise Error(f"{path} is not a dataset of the robot {robot.name!r}: give another folder or remove it")
    same_lengths = [round(x, 6) for x in attrs.get("lengths_m", [])] == [round(x, 6) for x in lengths]
    if not same_lengths or settings_problem(attrs.get("settings"), expected):
        raise Error(f"{path} is a dataset of other lengths or OCP settings than the robot's defaults: give another "
                    "folder or remove it")
    return bool(attrs.get("all_converged"))


def _trained_on(model: Path, dataset: Path) -> bool:
    """Whether ``model`` is a model trained on exactly ``dataset`` (by checksum): then it is kept."""
    from cocomopl.primitives.model_file import model_metadata
    from cocomopl.provenance import file_identity

    if not model.exists():
        return False
    trained = model_metadata(model).get("dataset") or {}
    return trained.get("sha256") == file_identity(dataset)["sha256"]


def dataset_projection(path: Path) -> dict[int, float] | None:
    """The dataset's wall time in s projected to clusters of :data:`PROJECTED_WORKERS` workers,
    from its run's measured times; None if the run resumed earlier parts (its times are partial).

    The lengths' work is two continuation sweeps, each a chain of jobs (a length's warm-up
    walk and OCPs wait for its neighbour's), so it takes as long on any number of workers
    from two up: its measured wall time.  The transitions are independent: their measured
    wall time on the run's workers, shared by N, but no less than the longest one's solve.
    """
    from cocomopl.motion_file import file_attrs, open_checked, read_motions

    with open_checked(path) as f:
        attrs = file_attrs(f)
    phases = attrs.get("phase_wall_time_s")
    if not phases or attrs.get("resumed_ocps", 0) or attrs.get("workers", 0) < 2:
        return None
    motions, _ = read_motions(path, dataset=True)
    longest = max((m.solution.solver["solve_time_s"] for m in motions.values() if m.steps[0].kind == "transition"),
                  default=0.0)
    work = phases["transitions"] * attrs["workers"]
    return {n: phases["lengths"] + max(work / n, longest) for n in PROJECTED_WORKERS}


__all__ = ["PROJECTED_WORKERS", "bootstrap_robot", "dataset_projection"]
