"""Checks of setting and metadata values, shared by the estimator and its model files.

Each check returns what a wrong value should have been (for a one-line message), or None
when the value is right.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Check = Callable[[object], str | None]


def whole(least: int) -> Check:
    """A whole number of at least ``least``: an integer, NumPy's too; a bool (JSON true) is no count."""

    def check(value) -> str | None:
        counts = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
        return None if counts and value >= least else f"a whole number >= {least}"

    return check


def one_of(choices: tuple[str, ...]) -> Check:
    """One of the names ``choices``."""
    return lambda value: None if isinstance(value, str) and value in choices else f"one of {', '.join(choices)}"
