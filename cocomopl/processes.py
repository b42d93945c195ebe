"""Worker processes that end with the run that started them.

A run stopped by Ctrl-C stops its workers too (the terminal signals the whole process group),
but a run killed outright (``kill``, a batch system's time limit, an out-of-memory kill) runs
no cleanup: its workers would go on solving or fitting for minutes with no one to take
their results.  :func:`exit_with_parent`, a pool's initializer, ends each worker within a
second of its parent.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.pool
import os
import threading
import time
from collections.abc import Callable

POLL_S = 1.0  # how often a worker looks for its parent


def exit_with_parent(parent: int) -> None:
    """Start a daemon thread that ends this process once its parent, the process ``parent``
    (its ``os.getpid()``, passed as the pool's ``initargs``), is gone."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(POLL_S)
        os._exit(1)  # no cleanup: the results it would hand on have no taker

    threading.Thread(target=watch, name="parent watch", daemon=True).start()


def spawn_pool(processes: int, initializer: Callable | None = None, initargs: tuple = ()) -> multiprocessing.pool.Pool:
    """A pool of ``processes`` spawned workers (not forked: a fork of a process that runs
    threads can deadlock) that end with this process (:func:`exit_with_parent`), each
    running ``initializer(*initargs)`` first if given."""
    return multiprocessing.get_context("spawn").Pool(processes, initializer=_start_worker,
                                                     initargs=(os.getpid(), initializer, initargs))


def _start_worker(parent: int, initializer: Callable | None, initargs: tuple) -> None:
    exit_with_parent(parent)
    if initializer is not None:
        initializer(*initargs)


__all__ = ["POLL_S", "exit_with_parent", "spawn_pool"]
