"""Solve a training set of step OCPs in parallel, resumably, and write it as one HDF5 file.

Jobs run in local processes by default, or on an existing Dask cluster.  Every finished
job is saved at once as a part file in ``<output>.parts/``; a rerun loads those and solves
only what is missing, so an interrupted run loses at most the jobs in flight.  A step that
does not converge is retried from other initial guesses and, if it still fails, reported
and left out of the training data.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import json
import math
import multiprocessing
import os
import shutil
import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from cocomopl.dataset.design import nearest_neighbour_path
from cocomopl.dataset.plan import default_transitions, successors, training_specs
from cocomopl.dataset.signals import training_signals
from cocomopl.errors import Error
from cocomopl.gait import check_footstep, gait_state_posture
from cocomopl.kinematics import check_reach
from cocomopl.motion import Motion, StepSpec, as_footstep
from cocomopl.motion_file import read_motions, writable_folder, write_motions
from cocomopl.ocp.action_models import knee_bounds
from cocomopl.ocp.settings import OCPSettings
from cocomopl.ocp.solve import length_steps, phase_durations, solve_length, solve_transition, to_motion
from cocomopl.processes import exit_with_parent
from cocomopl.provenance import versions
from cocomopl.robot import DEFAULT_ROBOT, Robot, mirror_motion

MIN_PHASE_KNOTS = 3
# --dt, s: at most the default double support over MIN_PHASE_KNOTS, so that the weight
# transfer between touchdown and lift-off has a knot between them (coarser knots also
# stretch the phases, whose knot counts are rounded up to 2); at least 5 ms, the rate of the
# seqplay export: finer knots add solve time (knots ~ 1/dt) that no exported motion carries
DT_RANGE_S = (0.005, round(OCPSettings().ds_duration / MIN_PHASE_KNOTS, 6))
# local processes per core: each OCP job runs one thread (OMP_NUM_THREADS=1, set in
# cocomopl/__init__.py), so more only time-share the cores, each with its own copy of the
# robot model and solver in memory
WORKERS_PER_CORE = 4
SCHEDULER_TIMEOUT_S = 10.0  # to reach a Dask scheduler


@dataclass
class JobResult:
    """What a job returns: converged motions by spec, and the attempts of those that failed."""

    motions: dict = field(default_factory=dict)
    failed: dict = field(default_factory=dict)
    walk: np.ndarray | None = None  # a length job's warm-up walk (states): the next length continues from it


class TimeLeft:
    """The time a dataset still needs, estimated as it is solved (for the progress bar).

    A rate of OCPs would mislead: a length's OCPs finish together after minutes (once both
    sweeps have solved it) and transitions in seconds.  So the lengths left take the pace of
    the sweeps so far; the transitions, once some are done, their own pace, and before that
    a quarter of a sweep's job each (a job is a warm-up walk and three OCPs), shared by the
    workers.  On the G1's default set that guess was 210 s for 152 s measured.
    """

    def __init__(self, *, transitions: int, workers: int | None):
        self.transitions_total = self.transitions_left = transitions
        self.workers = workers
        self.started = time.perf_counter()
        self.jobs, self.fraction, self.lengths_s = 0, 0.0, 0.0

    def lengths_done(self, jobs: int, total: int) -> None:
        """``jobs`` of the sweeps' ``total`` jobs are done (all: the lengths are finished)."""
        self.jobs, self.fraction = jobs, jobs / total if total else 1.0
        self.lengths_s = time.perf_counter() - self.started

    def transition_done(self) -> None:
        self.transitions_left = max(0, self.transitions_left - 1)

    def seconds(self) -> float | None:
        """The estimate in s, or None before anything is known to estimate from (or with an
        unknown number of workers, a Dask cluster's, while transitions are left)."""
        if self.fraction == 0.0 or (self.transitions_left and self.workers is None):
            return None
        done = self.transitions_total - self.transitions_left
        if self.fraction == 1.0 and done:
            return (time.perf_counter() - self.started - self.lengths_s) / done * self.transitions_left
        job = self.lengths_s * min(2, self.workers or 1) / self.jobs  # two sweeps side by side
        lengths = self.lengths_s * (1.0 - self.fraction) / self.fraction
        return lengths + job / 4 * math.ceil(self.transitions_left / (self.workers or 1))


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


def length_job(
    robot_name: str, settings: dict, length: float | tuple, *, kinds: list[str], cyclic: Motion | None = None,
    neighbour_walk: np.ndarray | None = None, walk_guess: np.ndarray | None = None,
    walk_controls: list[np.ndarray] | None = None,
) -> JobResult:
    """The ``kinds`` among cyclic, start and stop steps of one length or footstep (runs in a worker:
    plain data in and out).  An already solved ``cyclic`` step fixes the start state;
    ``neighbour_walk``, the warm-up walk of a neighbouring length, lends this length's its upper
    body (continuation); ``walk_guess``, the model's walk (with its torques ``walk_controls``),
    warm-starts it whole."""
    robot = Robot(robot_name)
    opts = OCPSettings.from_saved(settings)
    start_state = None
    if cyclic is not None:  # resumed: the solved cyclic step fixes S(L) and the timing
        start_state = np.concatenate([cyclic.q[0], cyclic.v[0]])
        opts = replace(opts, **phase_durations(cyclic))
    solutions, info = solve_length(robot, length, opts, kinds=tuple(kinds), cyclic_start=start_state,
                                   walk_guess=walk_guess, walk_controls=walk_controls, neighbour_walk=neighbour_walk)
    result = JobResult(walk=info.get("walk"))
    for kind, solution in solutions.items():
        spec = length_steps(length)[kind]
        if solution is None:
            result.failed[spec.name] = info["attempts"].get(kind, [])
        else:
            motion = to_motion(robot, solution, opts)
            motion.solution = replace(motion.solution, duration_search=info["duration_search"])
            result.motions[spec] = motion
    return result


def transition_job(
    robot_source: str, settings: dict, spec: StepSpec, *, cyclic_from: Motion, cyclic_to: Motion
) -> JobResult:
    """A transition step (runs in a worker: plain data in and out); see
    :func:`~cocomopl.ocp.solve.solve_transition`."""
    motion, attempts = solve_transition(Robot(robot_source), OCPSettings.from_saved(settings), spec,
                                        cyclic_from=cyclic_from, cyclic_to=cyclic_to)
    if motion is None:
        return JobResult(failed={spec.name: attempts})
    return JobResult(motions={spec: motion})


def check_dt(dt: float) -> float:
    """``dt`` (s) if within :data:`DT_RANGE_S`, the knot spacings the command line accepts
    for the default phase durations; else :class:`Error` naming the range."""
    low, high = DT_RANGE_S
    if not low <= dt <= high:
        raise Error(
            f"{dt:g} s is outside {low:g}..{high:g} s: coarser knots leave the {OCPSettings().ds_duration * 1000:g} ms "
            f"double support fewer than {MIN_PHASE_KNOTS} knots, finer ones only add solve time"
        )
    return dt


def max_workers() -> int:
    """The most local worker processes :func:`generate` starts: :data:`WORKERS_PER_CORE` per core."""
    return WORKERS_PER_CORE * (os.cpu_count() or 1)


def check_workers(workers: int) -> int:
    """``workers`` if at most :func:`max_workers`, else :class:`Error`."""
    if workers > max_workers():
        raise Error(
            f"{workers} worker processes are more than {WORKERS_PER_CORE} per core (at most {max_workers()} on "
            f"{os.cpu_count() or 1} cores): the OCPs would only share the cores"
        )
    return workers


def part_attrs(settings: OCPSettings, robot: Robot) -> dict:
    """The file attributes of a part: what a rerun compares before it reuses the part."""
    return {"content": "part", "settings": settings.as_dict(), "robot": robot.name,
            "robot_model": robot.fingerprint}


def _part_path(parts: Path, spec: StepSpec) -> Path:
    return parts / f"{spec.name}.h5"


def write_part(parts: Path, spec: StepSpec, motion: Motion, *, attrs: dict) -> None:
    """Save the solved step ``spec`` in the folder ``parts``, with :func:`part_attrs`."""
    write_motions(_part_path(parts, spec), {spec.name: motion}, attrs)


def settings_problem(saved, current: dict) -> str | None:
    """Why the settings ``saved`` with a part are not ``current``, or None.  A weight added
    since ``saved`` was written counts with the value it had before it existed
    (:meth:`~cocomopl.ocp.settings.OCPSettings.from_saved`)."""
    if not isinstance(saved, dict):
        return "it records no OCP settings"
    with contextlib.suppress(Error, TypeError):  # an unknown key is named below, key by key
        saved = json.loads(json.dumps(OCPSettings.from_saved(saved).as_dict()))
    changed = [key for key in sorted(set(saved) | set(current)) if saved.get(key) != current.get(key)]
    if changed:
        return "it was solved with other OCP settings (" + ", ".join(
            f"{key} {saved.get(key, 'unset')}, now {current.get(key, 'unset')}" for key in changed) + ")"
    return None


def _robot_problem(attrs: dict, expected: dict, robot: Robot) -> str | None:
    """Why a part's file says it is not for ``robot`` (``expected``: :func:`part_attrs`), or None.  The motion's own
    robot name and joints are checked by the reader (:func:`~cocomopl.motion_file.read_motions`)."""
    if "robot" not in attrs or "robot_model" not in attrs:
        return "it records no robot model (an older cocomopl saved it)"
    if attrs["robot"] != robot.name:
        return f"it is for the robot {attrs['robot']!r}, not {robot.name!r}"
    if attrs["robot_model"] != expected["robot_model"]:
        return f"it was solved for another model of {robot.name} (its description, URDF or joints differ)"
    return None


def _solver_problem(motion: Motion) -> str | None:
    """Why a part lacks the solver's statistics (which the dataset's summary reports), or None."""
    solver = None if motion.solution is None else motion.solution.solver
    if not isinstance(solver, dict) or not isinstance(solver.get("solve_time_s"), (int, float)):
        return "it lacks the solver's statistics"
    return None


def _part_problem(path: Path, spec: StepSpec, expected: dict, robot: Robot) -> tuple[Motion | None, str | None]:
    """The motion of the part file ``path`` and why it is not the step ``spec`` solved as
    ``expected`` (:func:`part_attrs`) for ``robot`` (None if it is)."""
    try:
        motions, attrs = read_motions(path, robot=robot)  # kinds, shapes, NaN, indices: checked there
    except Error as exc:  # the reader's message names the file, the warning names it already
        return None, str(exc).replace(str(path), "it", 1)
    if len(motions) != 1:
        return None, f"it holds {len(motions)} motions, not one"
    motion = next(iter(motions.values()))
    if motion.steps != [spec]:
        return motion, f"it holds {motion.name}"
    current = json.loads(json.dumps(expected["settings"]))  # as read back: tuples are lists
    problem = settings_problem(attrs.get("settings"), current) or _robot_problem(attrs, expected, robot)
    return motion, problem or _solver_problem(motion)


def finished_part(path: Path, spec: StepSpec, expected: dict, robot: Robot) -> Motion | None:
    """The motion of the part ``path`` saved by an earlier run, or None.

    It is reused only if it is the step ``spec`` its name stands for, solved with the same
    settings for the same robot (``expected``: :func:`part_attrs`), complete and finite.
    Any other part is deleted with a one-line warning on stderr: its step is solved again.
    """
    if not path.exists():
        return None
    motion, problem = _part_problem(path, spec, expected, robot)
    if problem is None:
        return motion
    print(f"cocomopl: warning: not reusing {path}: {problem}", file=sys.stderr)
    with contextlib.suppress(OSError):  # a rerun must not warn about it again
        path.unlink()
    return None


def reusable_steps(path: str | Path, settings: OCPSettings, robot: Robot) -> dict[StepSpec, Motion]:
    """The solved steps (left swing; the right ones are their mirror images) of the dataset
    ``path``, for a run that solves with ``settings`` for ``robot`` to take instead of solving
    them again.

    Raises
    ------
    Error
        If ``path`` is not a dataset of ``robot`` solved with the same OCP settings.
    """
    motions, attrs = read_motions(path, dataset=True, robot=robot)
    if attrs.get("robot") not in (None, robot.name):
        raise Error(f"cannot reuse {path}: it is for the robot {attrs['robot']!r}, not {robot.name!r}")
    problem = settings_problem(attrs.get("settings"), json.loads(json.dumps(settings.as_dict())))
    if problem:
        raise Error(f"cannot reuse {path}: {problem}")
    return {m.steps[0]: m for m in motions.values() if m.steps[0].swing_side == "left"}


@contextlib.contextmanager
def _working_folder(parts: Path, output: Path):
    """Yield ``parts``, the working folder of ``output``, created if needed.

    If the block fails or is interrupted, the parts of the OCPs finished stay for a rerun
    to resume from, but the folder goes if it holds none: there is nothing to resume.
    """
    writable_folder(parts, f"the working folder {parts} of {output}")
    try:
        yield parts
    except BaseException:
        with contextlib.suppress(OSError):  # rmdir removes only an empty folder
            parts.rmdir()
        raise


def _dask_client(scheduler: str):
    """A Dask client of the cluster at ``scheduler``; :class:`Error` in one line if the
    [cluster] extra is missing or the scheduler does not answer within :data:`SCHEDULER_TIMEOUT_S`."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise Error(
            "--scheduler needs the [cluster] extra: pip install 'cocomopl[cluster]' "
            "(or pip install -e '.[cluster]')"
        ) from None
    _refused_at_once(scheduler)
    try:
        return Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        raise Error(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None


def _refused_at_once(scheduler: str) -> None:
    """An :class:`Error` at once if nothing listens at a ``tcp://HOST:PORT`` scheduler address
    (the client would retry for :data:`SCHEDULER_TIMEOUT_S`); other addresses are left to it."""
    import socket
    from urllib.parse import urlsplit

    address = urlsplit(scheduler)
    try:
        host, port = address.hostname, address.port
    except ValueError:  # a port that is not a number: the client says so
        return
    if address.scheme != "tcp" or host is None or port is None:
        return
    try:
        socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT_S).close()
    except ConnectionRefusedError:
        raise Error(f"cannot reach the Dask scheduler at {scheduler}: nothing listens on port {port}") from None
    except OSError:  # unreachable or slow: the client's own timeout and message
        return


@contextlib.contextmanager
def job_executor(workers: int, scheduler: str | None) -> Iterator[cf.Executor]:
    """Yield the :class:`concurrent.futures.Executor` the OCP jobs run on: ``workers`` local
    processes, or the Dask cluster at ``scheduler`` (its client's executor,
    ``Client.get_executor``).  The jobs still waiting when the block ends are cancelled.

    Raises
    ------
    Error
        If ``scheduler`` is given and cannot be used (see :func:`_dask_client`).
    """
    if scheduler:
        client = _dask_client(scheduler)
        try:
            yield client.get_executor(pure=False)  # not pure: a job run twice is solved twice
        finally:
            client.close()
        return
    # spawned, not forked: a fork of a process that runs JAX or Dask threads can deadlock
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=exit_with_parent, initargs=(os.getpid(),))
    try:
        yield pool
    finally:
        pool.shutdown(cancel_futures=True)


def _worker_deaths() -> tuple[type[BaseException], ...]:
    """What a job's future raises when its worker process died: the local pool's exception,
    and Dask's if Dask is in use (it is imported only for ``--scheduler``)."""
    distributed = sys.modules.get("distributed")
    return (BrokenProcessPool,) if distributed is None else (BrokenProcessPool, distributed.KilledWorker)


def job_result(future: cf.Future) -> JobResult:
    """The result of a job submitted to a :func:`job_executor`; a worker that died is an
    :class:`Error`, not a traceback."""
    try:
        return future.result()
    except _worker_deaths():
        raise Error("a solver process died (a crash in compiled code, or out of memory); the OCPs solved "
                    "so far are kept: run the same command again to resume") from None


def check_stances(robot: Robot, lengths: tuple, settings: OCPSettings) -> None:
    """Refuse before any solving, with an :class:`Error`, a step length (or footstep) beyond
    the robot's reach, a footstep out of range or with colliding feet, or a knee bend its
    knees cannot make."""
    footsteps = [as_footstep(f) for f in lengths]
    check_reach(robot, [abs(f.length) for f in footsteps])
    for footstep in footsteps:
        if not footstep.straight:
            check_footstep(robot, "left", footstep)
        gait_state_posture(robot, footstep)
    knee_bounds(robot, settings.min_knee_flexion)


def generate(
    output: str | Path,
    lengths: tuple,
    extra_transitions: tuple | None = None,
    *,
    robot_name: str = DEFAULT_ROBOT,
    settings: OCPSettings | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    command: str = "Python API",
    progress: bool = True,
    known: dict[StepSpec, Motion] | None = None,
    walk_guesses: dict[float, tuple] | None = None,
    record: dict | None = None,
    continuation: bool = True,
) -> dict:
    """Solve the training set for ``lengths`` (m; or footsteps, :class:`~cocomopl.motion.Footstep`)
    and ``extra_transitions`` (pairs of them; None: :func:`~cocomopl.dataset.plan.default_transitions`)
    and write the dataset to ``output``.

    Parts of an earlier run in ``<output>.parts/`` are reused if they pass
    :func:`finished_part`, and so are the steps ``known`` (those of a dataset being grown).
    ``walk_guesses``: per length (or footstep), the warm-up walk's initial states and torques (a grown
    length's, from the model); those lengths are solved each from its own guess, not by
    continuation.  ``continuation=False`` solves every length from its own kinematic
    guess, all at once: for footsteps spread far apart (a step-space design), where a
    neighbour's walk is no guide (docs/method.md#omnidirectional-training-set).  ``record`` is added to the dataset's attributes.  ``workers`` local processes (at most :func:`max_workers`), or
    the Dask cluster at ``scheduler``, solve the rest.  The command line also bounds
    ``settings.dt`` to :data:`DT_RANGE_S`; this function takes any.

    Returns a summary: solved, reused, failed steps and timings.

    Raises
    ------
    Error
        On bad input, an unreachable scheduler, or if no OCP converged: then no dataset is
        written (a file already at ``output`` stays as it was).
    """
    settings = settings or OCPSettings()
    robot = Robot(robot_name)  # fail fast on a bad robot before any process starts
    if extra_transitions is None:
        extra_transitions = default_transitions(lengths, robot)
    check_stances(robot, lengths, settings)
    output = Path(output)
    parts = output.with_name(output.name + ".parts")
    workers = check_workers(workers or max(1, min(len(lengths), os.cpu_count() or 1)))
    specs = training_specs(lengths, extra_transitions)
    # an unreachable cluster is refused before anything is written
    with job_executor(workers, scheduler) as executor, _working_folder(parts, output):
        attrs = part_attrs(settings, robot)
        done = {spec: motion for spec, motion in (known or {}).items() if spec in specs}
        done.update({spec: motion for spec in specs if spec not in done
                     and (motion := finished_part(_part_path(parts, spec), spec, attrs, robot)) is not None})
        reused = len(done)
        start = time.perf_counter()
        where = f"on {workers} local processes" if not scheduler else "on the Dask cluster"
        failed, swept, phases = _solve_missing(executor, robot_name, settings, specs, done, parts, attrs, where,
                                       progress, walk_guesses, continuation=continuation,
                                       workers=None if scheduler else workers)
        wall = time.perf_counter() - start
        if not done:  # a dataset of no motion is of no use, and would pass `dataset check`
            raise Error(
                f"no OCP converged with these settings (dt {settings.dt:g} s, at most {settings.max_iterations} "
                f"iterations per attempt; {len(specs)} OCPs); nothing written"
            )
        footsteps = [as_footstep(f) for f in lengths]
        omni = {"footsteps_m_rad": [list(f) for f in footsteps]} if not all(f.straight for f in footsteps) else {}
        run = {"lengths_m": [f.length for f in footsteps if f.straight], **omni,
               "extra_transitions_m": [[as_footstep(a).length, as_footstep(b).length] if omni == {} else
                                       [list(as_footstep(a)), list(as_footstep(b))] for a, b in extra_transitions],
               "ocps": [s.name for s in specs], "failed": failed, "all_converged": not failed,
               "settings": settings.as_dict(), "command": command, "wall_time_s": wall,
               "continuation": swept, "phase_wall_time_s": phases, "resumed_ocps": reused,
               "workers": 0 if scheduler else workers, "scheduler": scheduler or "local processes", **(record or {})}
        motions = _write_dataset(output, robot, specs, done, run)
    if not failed:
        shutil.rmtree(parts, ignore_errors=True)
    return {
        "output": str(output),
        "ocps": len(specs),
        "solved": len(done) - reused,
        "reused": reused,
        "failed": sorted(failed),
        "motions": motions,
        "wall_time_s": wall,
    }


def _solve_missing(
    executor: cf.Executor,
    robot_name: str,
    settings: OCPSettings,
    specs: list[StepSpec],
    done: dict[StepSpec, Motion],
    parts: Path,
    attrs: dict,
    where: str,
    progress: bool,
    walk_guesses: dict[float, tuple] | None = None,
    *,
    continuation: bool = True,
    workers: int | None = None,
) -> tuple[dict[str, list], dict, dict[str, float]]:
    """Solve the ``specs`` not in ``done``, adding each converged one to ``done`` and saving
    it at once in ``parts`` (with ``attrs``): the lengths' steps by continuation
    (:func:`solve_by_continuation`, or each from its own guess), then the transitions.  Returns the attempts of those
    that failed, the continuation's record, and the wall time in s of the lengths' work and of
    the transitions'."""
    from tqdm import tqdm

    failed: dict[str, list] = {}
    bar = tqdm(total=len(specs), initial=len(done), desc="OCPs solved", disable=not progress, file=sys.stderr,
               bar_format="{desc}: {n_fmt}/{total_fmt} |{bar}| {elapsed} elapsed{postfix}")
    transitions = [s for s in specs if s.kind == "transition" and s not in done]
    left = TimeLeft(transitions=len(transitions), workers=workers)

    def show() -> None:
        eta = left.seconds()
        bar.set_postfix_str(where + ("" if eta is None else f", about {_minutes(eta)} left"))

    show()

    def note(line: str) -> None:
        if progress:
            bar.write(line, file=sys.stderr)

    def advanced(jobs: int, total: int) -> None:
        left.lengths_done(jobs, total)
        show()

    def collect_one(result: JobResult) -> None:
        for spec, motion in result.motions.items():
            write_part(parts, spec, motion, attrs=attrs)
            done[spec] = motion
            solver = motion.solution.solver
            if spec.kind == "transition":
                left.transition_done()
            note(f"solved {spec.name} in {solver['solve_time_s']:.1f} s ({solver['iterations']} iterations)")
            bar.update(1)
        for name, attempts in result.failed.items():
            failed[name] = attempts
            if name.startswith("transition"):
                left.transition_done()
            note(f"did not converge: {name} after {len(attempts)} attempts")
            bar.update(1)
        show()

    def collect(futures) -> None:
        for future in cf.as_completed(list(futures)):
            collect_one(job_result(future))

    try:
        # lengths first: every transition starts and ends in a cyclic step's start state
        todo = {}
        for f in [s.start_footstep for s in specs if s.kind == "cyclic"]:  # one per footstep
            missing = [s.kind for s in specs if s.kind != "transition" and f in (s.start_footstep, s.end_footstep)
                       and s not in done]
            if missing:
                todo[f.gait_key] = missing
        if walk_guesses or not continuation:
            record = _solve_from_guesses(executor, robot_name, settings, todo, done, collect, walk_guesses or {})
        else:
            record = solve_by_continuation(executor, robot_name, settings, todo=todo, done=done, collect=collect_one,
                                           note=note, advanced=advanced)
        advanced(1, 1)
        cyclic = {s.start_footstep: m for s, m in done.items() if s.kind == "cyclic"}
        futures = {}
        for spec in specs:
            if spec.kind != "transition" or spec in done:
                continue
            if spec.start_footstep in cyclic and spec.end_footstep in cyclic:
                future = executor.submit(transition_job, robot_name, settings.as_dict(), spec,
                                         cyclic_from=cyclic[spec.start_footstep], cyclic_to=cyclic[spec.end_footstep])
                futures[future] = spec
            else:
                failed[spec.name] = [{"error": "a cyclic step it joins did not converge"}]
                bar.update(1)
        collect(futures)
    finally:
        bar.close()
    phases = {"lengths": left.lengths_s, "transitions": time.perf_counter() - left.started - left.lengths_s}
    return failed, record, phases


SWEEPS = ("ascending", "descending")


def solve_by_continuation(executor: cf.Executor, robot_name: str, settings: OCPSettings, *, todo: dict,
                          done: dict[StepSpec, Motion], collect: Callable[[JobResult], None],
                          note: Callable[[str], None] = lambda line: None,
                          advanced: Callable[[int, int], None] = lambda jobs, total: None) -> dict:
    """Solve the missing ``todo[L]`` kinds of each length (or footstep, by its
    :attr:`~cocomopl.motion.Footstep.gait_key`) by continuation, and pass each length's chosen
    result to ``collect``.

    Two sweeps run side by side, one up the lengths and one down, each length's warm-up walk
    (whose second cyclic step gives ``S(L)`` and whose steps warm-start the length's OCPs)
    takes its upper body from the walk of the length solved before it in the same sweep
    (:func:`~cocomopl.ocp.solve.continued_guess`), so that neighbours stay on one solution branch.  Where the sweeps disagree, the length takes the
    sweep whose OCPs converged more often, then the lower summed cost.  Lengths are swept
    in increasing order, footsteps along a nearest-neighbour path
    (:func:`~cocomopl.dataset.design.nearest_neighbour_path`).  Returns, per length (mm; a footstep's
    :attr:`~cocomopl.motion.Footstep.label`), each sweep's summed cost and the RMS difference (rad) of their cyclic steps' joints,
    and the sweep chosen.  ``note`` gets a line as each sweep finishes a length: a length's
    OCPs are only collected once both sweeps have solved it, halfway through.  ``advanced``
    gets the number of the sweeps' jobs done and their total, after each length of each sweep.
    """
    keys = {as_footstep(key): key for key in todo}
    order = [keys[f] for f in nearest_neighbour_path(keys)]
    if not order:
        return {}
    chains = {sweep: order if sweep == "ascending" else order[::-1] for sweep in SWEEPS[: 1 if len(order) < 2 else 2]}
    results: dict[float | tuple, dict[str, JobResult]] = {L: {} for L in order}
    pending = {}

    def submit(sweep: str, i: int, walk: np.ndarray | None) -> None:
        L = chains[sweep][i]
        f = as_footstep(L)
        cyclic = done.get(StepSpec.between("cyclic", f, f))
        future = executor.submit(length_job, robot_name, settings.as_dict(), L, kinds=todo[L], cyclic=cyclic,
                                 neighbour_walk=walk)
        pending[future] = (sweep, i)

    for sweep in chains:
        submit(sweep, 0, None)
    record, swept = {}, 0
    while pending:
        future = next(cf.as_completed(pending))
        sweep, i = pending.pop(future)
        L = chains[sweep][i]
        results[L][sweep] = job_result(future)
        swept += 1
        note(f"{sweep} sweep: {as_footstep(L).label} solved ({i + 1} of {len(order)})")
        advanced(swept, len(order) * len(chains))
        if i + 1 < len(order):
            submit(sweep, i + 1, results[L][sweep].walk)
        if len(results[L]) == len(chains):
            chosen, record[as_footstep(L).label] = _choose_branch(results[L])
            collect(results[L][chosen])
    return record


def _solve_from_guesses(executor: cf.Executor, robot_name: str, settings: OCPSettings, todo: dict,
                        done: dict[StepSpec, Motion], collect, guesses: dict) -> dict:
    """Solve the missing ``todo[L]`` kinds of each length (or footstep's gait key) at once, each
    one's warm-up walk from its own guess ``guesses[L]`` (states, torques; kinematic where there is none)."""
    futures = []
    for L, kinds in todo.items():
        walk_guess, walk_controls = guesses.get(L, (None, None))
        futures.append(executor.submit(length_job, robot_name, settings.as_dict(), L, kinds=kinds,
                                       cyclic=done.get(StepSpec.between("cyclic", as_footstep(L), as_footstep(L))),
                                       walk_guess=walk_guess, walk_controls=walk_controls))
    collect(futures)
    return {as_footstep(L).label: {"chosen": "model" if L in guesses else "kinematic"} for L in todo}


def _choose_branch(by_sweep: dict[str, JobResult]) -> tuple[str, dict]:
    """The sweep whose result a length keeps (see :func:`solve_by_continuation`) and the record."""
    def cost(result: JobResult) -> float:
        return sum(m.solution.solver["cost"] for m in result.motions.values())

    chosen = min(by_sweep, key=lambda sweep: (-len(by_sweep[sweep].motions), cost(by_sweep[sweep])))
    record = {"chosen": chosen, **{f"{sweep}_cost": cost(result) for sweep, result in by_sweep.items()}}
    cyclic = [next((m for s, m in r.motions.items() if s.kind == "cyclic"), None) for r in by_sweep.values()]
    if len(cyclic) == 2 and None not in cyclic:
        record["cyclic_joint_difference_rad"] = float(np.sqrt(((cyclic[0].q[:, 7:] - cyclic[1].q[:, 7:]) ** 2).mean()))
    return chosen, record


def _write_dataset(output: Path, robot: Robot, specs: list[StepSpec], done: dict[StepSpec, Motion], run: dict) -> int:
    """Write the solved steps ``done`` and their mirror images, with their training signals
    and ``run``'s attributes, to ``output``.  Returns the number of motions written."""
    motions: dict[str, Motion] = {}
    for spec in specs:
        if spec in done:
            motions[spec.name] = done[spec]
            mirrored = mirror_motion(robot, done[spec])
            motions[mirrored.name] = mirrored
    signals = {name: training_signals(robot, m) for name, m in motions.items()}
    solve_times = [m.solution.solver["solve_time_s"] for m in done.values()]
    attrs = {
        "content": "dataset",
        "robot": robot.name,
        "robot_inertia_symmetrisation_m": robot.inertia_asymmetry,
        **run,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "versions": versions(["pin", "crocoddyl", "example-robot-data", "numpy", "h5py", "dask"]),
        "signal_names": signals[next(iter(signals))]["names"],
        "continuity": continuity_report(robot, done),
        "mean_solve_time_s": float(np.mean(solve_times)),
    }
    write_motions(output, motions, attrs, signals=signals)
    return len(motions)


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


__all__ = ["JobResult", "generate", "job_executor", "job_result", "length_job", "reusable_steps", "solve_by_continuation",
           "transition_job"]
