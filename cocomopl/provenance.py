"""Provenance recorded in every file the project makes: which package versions made it."""

from __future__ import annotations

import sys
from importlib.metadata import PackageNotFoundError, version


def versions(packages: list[str]) -> dict:
    """cocomopl's and Python's version and those of ``packages`` (None when not installed)."""
    import cocomopl

    out = {"cocomopl": cocomopl.__version__, "python": sys.version.split()[0]}
    for name in packages:
        try:
            out[name] = version(name)
        except PackageNotFoundError:  # a missing optional package is recorded as such
            out[name] = None
    return out
