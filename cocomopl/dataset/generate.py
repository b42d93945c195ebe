"""Solve a training set of step OCPs in parallel, resumably, and write it as one HDF5 file.

Jobs run in local processes by default, or on an existing Dask cluster.  Every finished
job is saved at once as a part file in ``<output>.parts/``; a rerun loads those and solves
only what is missing, so an interrupted run loses at most the jobs in flight.  A step that
does not converge is retried from other initial guesses and, if it still fails, reported
and left out of the training data.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import multiprocessing
import os
import shutil
import sys
import time
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from cocomopl.dataset.plan import default_transitions, successors, training_specs
from cocomopl.dataset.signals import training_signals
from cocomopl.errors import Error
from cocomopl.gait import foot_separation
from cocomopl.kinematics import double_support_posture
from cocomopl.motion import Motion, StepSpec
from cocomopl.motion_file import read_motions, writable_folder, write_motions
from cocomopl.ocp.action_models import knee_bounds
from cocomopl.ocp.settings import OCPSettings
from cocomopl.ocp.solve import length_steps, phase_durations, solve_length, solve_transition, to_motion
from cocomopl.provenance import versions
from cocomopl.robot import DEFAULT_ROBOT, Robot, mirror_motion


@dataclass
class JobResult:
    """What a job returns: converged motions by spec, and the attempts of those that failed."""

    motions: dict = field(default_factory=dict)
    failed: dict = field(default_factory=dict)


def length_job(
    robot_name: str, settings: dict, length: float, kinds: list[str], cyclic: Motion | None = None
) -> JobResult:
    """The ``kinds`` among cyclic, start and stop steps of one length (runs in a worker:
    plain data in and out).  An already solved ``cyclic`` step fixes the start state."""
    robot = Robot(robot_name)
    opts = OCPSettings(**settings)
    start_state = None
    if cyclic is not None:  # resumed: the solved cyclic step fixes S(L) and the timing
        start_state = np.concatenate([cyclic.q[0], cyclic.v[0]])
        opts = replace(opts, **phase_durations(cyclic))
    solutions, info = solve_length(robot, length, opts, tuple(kinds), start_state)
    result = JobResult()
    for kind, solution in solutions.items():
        spec = length_steps(length)[kind]
        if solution is None:
            result.failed[spec.name] = info["attempts"].get(kind, [])
        else:
            motion = to_motion(robot, solution, opts)
            motion.meta["duration_search"] = info["duration_search"]
            result.motions[spec] = motion
    return result


def transition_job(robot_source: str, settings: dict, spec: StepSpec, cyclic_from: Motion, cyclic_to: Motion) -> JobResult:
    """A transition step (runs in a worker: plain data in and out); see
    :func:`~cocomopl.ocp.solve.solve_transition`."""
    motion, attempts = solve_transition(Robot(robot_source), OCPSettings(**settings), spec, cyclic_from, cyclic_to)
    if motion is None:
        return JobResult(failed={spec.name: attempts})
    return JobResult(motions={spec: motion})


def _part_path(parts: Path, spec: StepSpec) -> Path:
    return parts / f"{spec.name}.h5"


def _finished_part(path: Path, settings: OCPSettings) -> Motion | None:
    """The motion of a part file saved by an earlier run with the same OCP settings, or
    None.  A damaged part, or one solved with other settings (a rerun with another
    option), is deleted: its step is solved again."""
    if not path.exists():
        return None
    try:
        motions, attrs = read_motions(path)
    except Error:
        motions, attrs = {}, {}
    if attrs.get("settings") != json.loads(json.dumps(settings.as_dict())) or len(motions) != 1:
        path.unlink()
        return None
    return next(iter(motions.values()))


class _Executor:
    """Local process pool or Dask client behind one submit/as_completed interface."""

    def __init__(self, workers: int, scheduler: str | None):
        self.scheduler = scheduler
        if scheduler:
            try:
                from dask.distributed import Client
            except ImportError:
                raise Error("--scheduler needs the [cluster] extra: pip install 'cocomopl[cluster]' (or pip install -e '.[cluster]')") from None
            try:
                self.client = Client(scheduler, timeout=10)
            except (OSError, TimeoutError, ValueError) as exc:
                raise Error(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        else:
            # spawned, not forked: a fork of a process that runs JAX or Dask threads can deadlock
            self.pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))

    def submit(self, fn, *args):
        if self.scheduler:
            return self.client.submit(fn, *args, pure=False)
        return self.pool.submit(fn, *args)

    def as_completed(self, futures):
        if self.scheduler:
            from dask.distributed import as_completed

            return as_completed(futures)
        return cf.as_completed(futures)

    @staticmethod
    def result(future):
        return future.result()

    def close(self):
        if self.scheduler:
            self.client.close()
        else:
            self.pool.shutdown(cancel_futures=True)


def check_stances(robot: Robot, lengths: tuple[float, ...], settings: OCPSettings) -> None:
    """Refuse before any solving, with an :class:`Error`, a step length beyond the robot's
    reach or a knee bend its knees cannot make."""
    for length in lengths:
        if length > robot.max_step_length:
            raise Error(
                f"step length {length * 1000:g} mm is beyond {robot.name}'s reach "
                f"(at most {robot.max_step_length * 1000:g} mm, from its description)"
            )
        double_support_posture(robot, (-length, foot_separation(robot)), (0.0, 0.0))
    knee_bounds(robot, settings.min_knee_flexion)


def generate(
    output: str | Path,
    lengths: tuple[float, ...],
    extra_transitions: tuple[tuple[float, float], ...] | None = None,
    robot_name: str = DEFAULT_ROBOT,
    settings: OCPSettings | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    command: str = "Python API",
    progress: bool = True,
) -> dict:
    """Solve the training set for ``lengths`` (m) and ``extra_transitions`` (pairs of them;
    None: :func:`~cocomopl.dataset.plan.default_transitions`) and write the dataset to ``output``.

    Returns a summary: solved, reused, failed steps and timings.
    """
    from tqdm import tqdm

    settings = settings or OCPSettings()
    if extra_transitions is None:
        extra_transitions = default_transitions(lengths)
    robot = Robot(robot_name)  # fail fast on a bad robot before any process starts
    check_stances(robot, lengths, settings)
    output = Path(output)
    parts = output.with_name(output.name + ".parts")
    workers = workers or max(1, min(len(lengths), os.cpu_count() or 1))
    executor = _Executor(workers, scheduler)  # an unreachable cluster is refused before anything is written
    try:
        writable_folder(parts, f"the working folder {parts} of {output}")
    except Error:
        executor.close()
        raise
    specs = training_specs(lengths, extra_transitions)
    done: dict[StepSpec, Motion] = {}
    for spec in specs:
        motion = _finished_part(_part_path(parts, spec), settings)
        if motion is not None:
            done[spec] = motion
    reused = len(done)
    failed: dict[str, list] = {}
    start = time.perf_counter()
    # no ETA: a length's three OCPs finish together after minutes, transitions in seconds
    bar = tqdm(total=len(specs), initial=reused, desc="OCPs solved", disable=not progress, file=sys.stderr,
               bar_format="{desc}: {n_fmt}/{total_fmt} |{bar}| {elapsed} elapsed{postfix}")
    bar.set_postfix_str(f"on {workers} local processes" if not scheduler else "on the Dask cluster", refresh=False)

    def note(line: str) -> None:
        if progress:
            bar.write(line, file=sys.stderr)

    def collect(futures) -> None:
        for future in executor.as_completed(list(futures)):
            result: JobResult = executor.result(future)
            for spec, motion in result.motions.items():
                write_motions(_part_path(parts, spec), {spec.name: motion}, {"content": "part", "settings": settings.as_dict()})
                done[spec] = motion
                solver = motion.meta["solver"]
                note(f"solved {spec.name} in {solver['solve_time_s']:.1f} s ({solver['iterations']} iterations)")
                bar.update(1)
            for name, attempts in result.failed.items():
                failed[name] = attempts
                note(f"did not converge: {name} after {len(attempts)} attempts")
                bar.update(1)

    try:
        # lengths first: every transition starts and ends in a cyclic step's start state
        per_length = {L: [s for s in specs if s.kind != "transition" and L in (s.start_length, s.end_length)] for L in lengths}
        futures = {}
        for L, group in per_length.items():
            missing = [s.kind for s in group if s not in done]
            if missing:
                cyclic = done.get(StepSpec("cyclic", L, L))
                futures[executor.submit(length_job, robot_name, settings.as_dict(), L, missing, cyclic)] = L
        collect(futures)
        cyclic = {s.start_length: m for s, m in done.items() if s.kind == "cyclic"}
        futures = {}
        for spec in specs:
            if spec.kind != "transition" or spec in done:
                continue
            if spec.start_length in cyclic and spec.end_length in cyclic:
                futures[executor.submit(
                    transition_job, robot_name, settings.as_dict(), spec, cyclic[spec.start_length], cyclic[spec.end_length]
                )] = spec
            else:
                failed[spec.name] = [{"error": "a cyclic step it joins did not converge"}]
                bar.update(1)
        collect(futures)
    finally:
        bar.close()
        executor.close()
    wall = time.perf_counter() - start
    motions: dict[str, Motion] = {}
    for spec in specs:
        if spec in done:
            motions[spec.name] = done[spec]
            mirrored = mirror_motion(robot, done[spec])
            motions[mirrored.name] = mirrored
    signals = {name: training_signals(robot, m) for name, m in motions.items()}
    solve_times = [m.meta["solver"]["solve_time_s"] for m in done.values()]
    attrs = {
        "content": "dataset",
        "robot": robot.name,
        "robot_inertia_symmetrisation_m": robot.inertia_asymmetry,
        "lengths_m": list(lengths),
        "extra_transitions_m": [list(pair) for pair in extra_transitions],
        "ocps": [s.name for s in specs],
        "failed": failed,
        "all_converged": not failed,
        "settings": settings.as_dict(),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "command": command,
        "versions": versions(["pin", "crocoddyl", "example-robot-data", "numpy", "h5py", "dask"]),
        "wall_time_s": wall,
        "workers": 0 if scheduler else workers,
        "scheduler": scheduler or "local processes",
        "signal_names": signals[next(iter(signals))]["names"] if signals else [],
        "continuity": continuity_report(robot, done),
        "mean_solve_time_s": float(np.mean(solve_times)) if solve_times else None,
    }
    write_motions(output, motions, attrs, signals)
    if not failed:
        shutil.rmtree(parts, ignore_errors=True)
    return {
        "output": str(output),
        "ocps": len(specs),
        "solved": len(done) - reused,
        "reused": reused,
        "failed": sorted(failed),
        "motions": len(motions),
        "wall_time_s": wall,
    }


def continuity_report(robot: Robot, done: dict[StepSpec, Motion]) -> dict:
    """End-to-start mismatch of every ordered pair of solved steps that may follow each other."""
    from cocomopl.dataset.continuity import step_mismatch

    report = {}
    specs = list(done)
    mirrored = {s.mirrored(): mirror_motion(robot, m) for s, m in done.items()}
    for spec in specs:
        for nxt in successors(spec, list(mirrored)):
            report[f"{spec.name}->{nxt.name}"] = step_mismatch(robot, done[spec], mirrored[nxt])
    return report


__all__ = ["JobResult", "generate", "length_job", "transition_job"]
