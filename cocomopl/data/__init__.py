"""The bundled datasets and models, made by the project's own commands (README, "Bundled data").

``BUNDLED_DATASET`` holds TALOS's 32 OC training steps and their mirror images,
``BUNDLED_MODEL`` the movement primitives trained on them; ``BUNDLED_OMNI_DATASET`` and
``BUNDLED_OMNI_MODEL`` the same over the step space (turning, side and backward steps),
which footstep plans and goals use.  Another bundled robot's files carry its name in front
(``g1_dataset.h5``, ``g1_model.npz``, ``g1_omni_dataset.h5``, ``g1_omni_model.npz``).  All record in their metadata the command, versions
and date that made them.
"""

from __future__ import annotations

from pathlib import Path

from cocomopl.errors import Error

BUNDLED_DATASET = Path(__file__).parent / "dataset.h5"
BUNDLED_MODEL = Path(__file__).parent / "model.npz"
BUNDLED_OMNI_DATASET = Path(__file__).parent / "omni_dataset.h5"
BUNDLED_OMNI_MODEL = Path(__file__).parent / "omni_model.npz"


def dataset_path(path: str | Path | None = None, omni: bool = False, robot: str | None = None) -> Path:
    """``path``, or ``robot``'s bundled (``omni``: omnidirectional) dataset when None (None:
    TALOS's); an :class:`Error` if that is missing."""
    return _given_or_bundled(path, _bundled(BUNDLED_OMNI_DATASET if omni else BUNDLED_DATASET, robot),
                             "cocomopl dataset generate")


def model_path(path: str | Path | None = None, omni: bool = False, robot: str | None = None) -> Path:
    """``path``, or ``robot``'s bundled (``omni``: omnidirectional) model when None (None:
    TALOS's); an :class:`Error` if that is missing."""
    return _given_or_bundled(path, _bundled(BUNDLED_OMNI_MODEL if omni else BUNDLED_MODEL, robot), "cocomopl train")


def _bundled(talos: Path, robot: str | None) -> Path:
    return talos if robot in (None, "talos") else talos.with_name(f"{robot}_{talos.name}")


def _given_or_bundled(path: str | Path | None, bundled: Path, command: str) -> Path:
    if path is not None:
        return Path(path)
    if not bundled.exists():  # a source checkout without the data files, or a robot without them
        raise Error(f"there is no bundled {bundled.stem.replace('_', ' ')} ({bundled.name}); make one with '{command}'")
    return bundled
