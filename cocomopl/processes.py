"""Worker processes that end with the run that started them.

A run stopped by Ctrl-C stops its workers too (the terminal signals the whole process group),
but a run killed outright (``kill``, a batch system's time limit, an out-of-memory kill) runs
no cleanup: its workers would go on solving or fitting for minutes with no one to take
their results.  :func:`exit_with_parent`, a pool's initializer, ends each worker within a
second of its parent.
"""

from __future__ import annotations

import os
import threading
import time

POLL_S = 1.0  # how often a worker looks for its parent


def exit_with_parent(parent: int) -> None:
    """Start a daemon thread that ends this process once its parent, the process ``parent``
    (its ``os.getpid()``, passed as the pool's ``initargs``), is gone."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(POLL_S)
        os._exit(1)  # no cleanup: the results it would hand on have no taker

    threading.Thread(target=watch, name="parent watch", daemon=True).start()


__all__ = ["POLL_S", "exit_with_parent"]
