"""cocomopl: whole-body humanoid walking from Optimal Control, Movement Primitives and Learning."""

import os

# Eigen inside Pinocchio/Crocoddyl parallelises small matrix products with OpenMP; with
# one OCP per core that oversubscribes the CPU and runs four times slower.  Parallelism
# belongs across OCPs, so one thread per process unless the user says otherwise.  This
# must happen before those libraries load, hence here.
os.environ.setdefault("OMP_NUM_THREADS", "1")
# MuJoCo picks its OpenGL platform when it is first imported: render offscreen through EGL
# (works on CPU-only machines without a display) unless the user chose otherwise.
os.environ.setdefault("MUJOCO_GL", "egl")

from cocomopl.errors import Error

__version__ = "0.2.0"

# Public names, imported on first use: ``import cocomopl`` stays light (the CLI starts fast)
# and the fitting code's JAX is loaded only by those who fit.
_EXPORTS = {
    "BUNDLED_DATASET": "cocomopl.data",
    "BUNDLED_MODEL": "cocomopl.data",
    "BUNDLED_OMNI_MODEL": "cocomopl.data",
    "Motion": "cocomopl.motion",
    "StepSpec": "cocomopl.motion",
    "Robot": "cocomopl.robot",
    "MovementPrimitives": "cocomopl.primitives.estimator",
    "load_training_steps": "cocomopl.primitives.training",
    "load_model": "cocomopl.primitives.model_file",
    "save_model": "cocomopl.primitives.model_file",
    "read_motion": "cocomopl.motion_file",
    "read_motions": "cocomopl.motion_file",
    "write_motions": "cocomopl.motion_file",
    "generate_walk": "cocomopl.pipeline",
    "simulate_walk": "cocomopl.pipeline",
    "SimSettings": "cocomopl.pipeline",
    "WalkRequest": "cocomopl.requests",
    "StraightSteps": "cocomopl.requests",
    "Footsteps": "cocomopl.requests",
    "Goals": "cocomopl.requests",
    "Refinement": "cocomopl.requests",
    "Commands": "cocomopl.requests",
    "WalkingGenerator": "cocomopl.online",
    "VelocityCommand": "cocomopl.online",
}

__all__ = ["Error", "__version__"]
__all__ += list(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'cocomopl' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
