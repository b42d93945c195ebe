"""The bundled dataset and model, made by the project's own commands (README, "Bundled data").

``BUNDLED_DATASET`` holds the 32 OC training steps and their mirror images,
``BUNDLED_MODEL`` the movement primitives trained on them; ``BUNDLED_OMNI_DATASET`` and
``BUNDLED_OMNI_MODEL`` the same for the steady gaits of the default footstep grid (turning,
side and backward steps), which footstep plans and goals use.  All record in their
metadata the command, versions and date that made them.
"""

from __future__ import annotations

from pathlib import Path

from cocomopl.errors import Error

BUNDLED_DATASET = Path(__file__).parent / "dataset.h5"
BUNDLED_MODEL = Path(__file__).parent / "model.npz"
BUNDLED_OMNI_DATASET = Path(__file__).parent / "omni_dataset.h5"
BUNDLED_OMNI_MODEL = Path(__file__).parent / "omni_model.npz"


def dataset_path(path: str | Path | None = None, omni: bool = False) -> Path:
    """``path``, or the bundled (``omni``: omnidirectional) dataset when None; an
    :class:`Error` if that is missing."""
    return _given_or_bundled(path, BUNDLED_OMNI_DATASET if omni else BUNDLED_DATASET, "cocomopl dataset generate")


def model_path(path: str | Path | None = None, omni: bool = False) -> Path:
    """``path``, or the bundled (``omni``: omnidirectional) model when None; an
    :class:`Error` if that is missing."""
    return _given_or_bundled(path, BUNDLED_OMNI_MODEL if omni else BUNDLED_MODEL, "cocomopl train")


def _given_or_bundled(path: str | Path | None, bundled: Path, command: str) -> Path:
    if path is not None:
        return Path(path)
    if not bundled.exists():  # a source checkout without the data files
        raise Error(f"the bundled {bundled.stem} is missing ({bundled.name}); make one with '{command}'")
    return bundled
