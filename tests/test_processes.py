"""Worker processes end with the run that started them, even a run killed outright."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

# a parent that starts one worker (as the dataset and the training start theirs), prints
# the worker's pid once it runs a long job, and waits
EXECUTOR = """
import concurrent.futures as cf, multiprocessing, os, time
from cocomopl.processes import exit_with_parent

if __name__ == "__main__":
    pool = cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=exit_with_parent, initargs=(os.getpid(),))
    print(pool.submit(os.getpid).result(), flush=True)
    pool.submit(time.sleep, 120)
    time.sleep(120)
"""

# the same with the benchmarks' pool, whose workers run an initializer of their own first
POOL = """
import os, time
from cocomopl.processes import spawn_pool

def mark(value):
    os.environ["COCOMOPL_TEST_STARTED"] = value

def marked():
    return os.environ.get("COCOMOPL_TEST_STARTED")

if __name__ == "__main__":
    pool = spawn_pool(1, mark, ("yes",))
    assert pool.apply(marked) == "yes"
    print(pool.apply(os.getpid), flush=True)
    pool.apply_async(time.sleep, (120,))
    time.sleep(120)
"""


def _running(pid: int) -> bool:
    status = Path(f"/proc/{pid}/status")
    try:
        state = next(line for line in status.read_text().splitlines() if line.startswith("State:"))
    except FileNotFoundError:
        return False
    return "Z" not in state.split()[1]  # a zombie has ended; only its parent's reaping is left


@pytest.mark.parametrize("parent_script", [EXECUTOR, POOL], ids=["executor", "pool"])
def test_a_worker_ends_when_its_parent_is_killed(tmp_path, parent_script):
    script = tmp_path / "parent.py"
    script.write_text(parent_script)
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    worker = None
    try:
        worker = int(parent.stdout.readline())
        assert _running(worker)
        parent.send_signal(signal.SIGKILL)  # no cleanup runs in the parent
        parent.wait()
        deadline = time.monotonic() + 20.0
        while _running(worker) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not _running(worker)
    finally:
        parent.kill()
        parent.wait()
        if worker is not None and _running(worker):
            os.kill(worker, signal.SIGKILL)
