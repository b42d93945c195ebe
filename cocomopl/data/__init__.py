"""The bundled dataset and model, made by the project's own commands (README, "Bundled data").

``BUNDLED_DATASET`` holds the 32 OC training steps and their mirror images,
``BUNDLED_MODEL`` the movement primitives trained on them; both record in their metadata
the command, versions and date that made them.
"""

from __future__ import annotations

from pathlib import Path

from cocomopl.errors import Error

BUNDLED_DATASET = Path(__file__).parent / "dataset.h5"
BUNDLED_MODEL = Path(__file__).parent / "model.npz"


def dataset_path(path: str | Path | None = None) -> Path:
    """``path``, or the bundled dataset when None; an :class:`Error` if that is missing."""
    return _given_or_bundled(path, BUNDLED_DATASET, "cocomopl dataset generate")


def model_path(path: str | Path | None = None) -> Path:
    """``path``, or the bundled model when None; an :class:`Error` if that is missing."""
    return _given_or_bundled(path, BUNDLED_MODEL, "cocomopl train")


def _given_or_bundled(path: str | Path | None, bundled: Path, command: str) -> Path:
    if path is not None:
        return Path(path)
    if not bundled.exists():  # a source checkout without the data files
        raise Error(f"the bundled {bundled.stem} is missing ({bundled.name}); make one with '{command}'")
    return bundled
