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
    if path is not None:
        return Path(path)
    if not BUNDLED_DATASET.exists():
        raise Error(f"the bundled dataset is missing ({BUNDLED_DATASET.name}); generate one with 'cocomopl dataset generate'")
    return BUNDLED_DATASET


def model_path(path: str | Path | None = None) -> Path:
    """``path``, or the bundled model when None; an :class:`Error` if that is missing."""
    if path is not None:
        return Path(path)
    if not BUNDLED_MODEL.exists():
        raise Error(f"the bundled model is missing ({BUNDLED_MODEL.name}); train one with 'cocomopl train'")
    return BUNDLED_MODEL
