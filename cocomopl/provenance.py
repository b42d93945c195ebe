"""Provenance recorded in every file the project makes: what made it, when, and from what.

Input files are named by their file name and SHA-256, never by an absolute path: a path
says nothing on another machine, and a checksum says exactly which file it was.
"""

from __future__ import annotations

import hashlib
import shlex
import sys
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from cocomopl.errors import Error


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


def command_line(argv: list[str]) -> str:
    """The ``cocomopl`` command of arguments ``argv``, quoted as a shell would need it."""
    return "cocomopl " + " ".join(shlex.quote(a) for a in argv)


def file_identity(path: str | Path) -> dict:
    """``{"name": file name, "sha256": hex digest}`` of a file."""
    path = Path(path)
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    except FileNotFoundError:
        raise Error(f"file not found: {path}") from None
    except OSError as exc:
        raise Error(f"cannot read {path}: {exc.strerror}") from None
    return {"name": path.name, "sha256": digest.hexdigest()}


def stamp(command: str | None = None, packages: tuple[str, ...] = (), **inputs: str | Path | None) -> dict:
    """Provenance of an output: cocomopl's version (and ``packages``'), the command (or
    "Python API" when called from Python), a UTC timestamp, and each input file given by
    keyword (``model=path``) as :func:`file_identity`."""
    return {
        "command": command or "Python API",
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "versions": versions(list(packages)),
        "inputs": {key: file_identity(path) for key, path in inputs.items() if path is not None},
    }
