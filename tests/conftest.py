"""Shared fixtures and helpers: the robot, one small dataset solved once per test session,
the command line (through its entry point, or in a process of its own), and a hand-made motion.

The OCPs here are deliberately coarse (50 ms knots, short phases): the tests check
properties -- dynamics, mirroring, continuity, limits -- not the quality of the gait.  They
leave out the default knee bend and load transfer, which the coarse knots hold only roughly;
each has its own test on the small cyclic step.
"""

import contextlib
import fcntl
import io
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cocomopl.motion import Footstep, Motion, StepSpec
from cocomopl.ocp.settings import OCPSettings
from cocomopl.robot import Robot

SMALL = OCPSettings(
    dt=0.05, ds_duration=0.1, ss_duration=0.6, ss_search_step=0.0, start_ds_duration=0.3, rest_duration=0.2,
    max_iterations=150, w_load_transfer=0.0, min_knee_flexion=0.0,
)
SMALL_LENGTH = 0.2


@pytest.fixture(scope="session")
def robot() -> Robot:
    return Robot("talos")


# the fixtures that solve a dataset for the whole run (40-90 s), by name: every test that
# needs one, directly or through another fixture, is marked slow and so left out of the fast loop
SHARED_DATASETS: set[str] = set()


def shared_dataset(fixture):
    """A session fixture that solves a dataset for the whole run (:data:`SHARED_DATASETS`)."""
    SHARED_DATASETS.add(fixture.__name__)
    return pytest.fixture(scope="session")(fixture)


@pytest.hookimpl(tryfirst=True)  # before ``-m`` deselects by mark
def pytest_collection_modifyitems(items):
    for item in items:
        if SHARED_DATASETS & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)


@shared_dataset
def small_dataset(tmp_path_factory) -> Path:
    """The OCPs of one length on coarse knots, solved once for all test processes."""
    return _shared_dataset(tmp_path_factory, "small-dataset", (SMALL_LENGTH,))


# each sole lands toeing out by 15 degrees from the other
TURNED = Footstep(SMALL_LENGTH, 0.0, math.radians(15))


@shared_dataset
def turning_dataset(tmp_path_factory) -> Path:
    """The cyclic, start and stop OCPs of the footstep :data:`TURNED`, on coarse knots,
    solved once for all test processes (a steady turn's two footsteps and the transitions
    between them took 113 s on 2 cores, one footstep 48 s on one)."""
    return _shared_dataset(tmp_path_factory, "turning-dataset", (TURNED,))


def _shared_dataset(tmp_path_factory, name: str, lengths: tuple) -> Path:
    """A dataset solved once for all test processes: the first xdist worker to get here
    solves it while the others wait on the lock."""
    from cocomopl.dataset.generate import generate

    base = tmp_path_factory.getbasetemp()
    shared = base.parent if "PYTEST_XDIST_WORKER" in os.environ else base  # this run's, common to its workers
    out = shared / f"{name}.h5"
    with open(shared / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not out.exists():
            summary = generate(out, lengths, settings=SMALL, workers=2, command="pytest", progress=False)
            assert summary["failed"] == [], summary
    return out


def run_cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """``cocomopl ARGS`` through the command's entry point, :func:`cocomopl.cli.main`, in this
    process (as click's ``CliRunner`` does): its exit code and what it printed on stdout and
    stderr.  A new interpreter would add a second or two of imports to every call and test
    nothing more; :func:`run_cli_process` runs one where the process itself is tested
    (signals, the environment), and tests/test_readme.py runs the README's lines so."""
    from cocomopl.cli import main

    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr), contextlib.chdir(cwd or os.getcwd()):
        try:
            code = main(list(args))
        except SystemExit as exc:  # argparse's usage errors and --help
            code = exc.code if isinstance(exc.code, int) else int(exc.code is not None)
    return subprocess.CompletedProcess(["cocomopl", *args], code, stdout.getvalue(), stderr.getvalue())


def run_cli_process(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """``cocomopl ARGS`` in a new process, as a user runs it."""
    return subprocess.run([sys.executable, "-m", "cocomopl", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=300)


def assert_one_line_error(result: subprocess.CompletedProcess, *words: str) -> None:
    """The command failed with one line on stderr, no traceback, naming every one of ``words``."""
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    for word in words:
        assert word in lines[0], lines[0]


def synthetic(robot, t, q=None, tau=None, fz=None, zmp=None, impacts=()) -> Motion:
    """A motion on the time grid ``t``; unspecified parts: standing still in the reference
    posture, zero torques, no force, ZMP at the origin."""
    n = len(t)
    wrenches = np.zeros((n, 2, 6))
    if fz is not None:
        wrenches[:, :, 2] = fz
    return Motion(
        t=np.asarray(t, dtype=float),
        q=np.tile(robot.q_ref, (n, 1)) if q is None else q,
        v=np.zeros((n, robot.model.nv)),
        tau=np.zeros((n, robot.nu)) if tau is None else tau,
        wrenches=wrenches,
        contact=wrenches[:, :, 2] > 0,
        zmp=np.zeros((n, 3)) if zmp is None else zmp,
        phases=[("ds", 0, n - 1)],
        impacts=np.array(impacts, dtype=int),
        steps=[StepSpec("cyclic", 0.2, 0.2)],
        step_starts=np.array([0]),
        joint_names=list(robot.joint_names),
        robot=robot.name,
    )


@pytest.fixture(scope="session")
def standing(robot):
    """``standing(seconds)``: a motion standing still for ``seconds`` on both soles, side by
    side at the robot's foot separation."""
    from cocomopl.gait import foot_separation
    from cocomopl.kinematics import double_support_posture

    y = foot_separation(robot)
    q = double_support_posture(robot, (0.0, y / 2), (0.0, -y / 2))

    def motion(seconds: float) -> Motion:
        n = 2
        return Motion(
            t=np.array([0.0, seconds]), q=np.stack([q] * n), v=np.zeros((n, robot.model.nv)),
            tau=np.zeros((n, robot.nu)), wrenches=np.zeros((n, 2, 6)), contact=np.ones((n, 2), bool),
            zmp=np.zeros((n, 3)), phases=[("ds", 0, 1)], impacts=np.zeros(0, int), steps=[],
            step_starts=np.zeros(0, int), joint_names=list(robot.joint_names), robot=robot.name,
            producer="test",
        )

    return motion
