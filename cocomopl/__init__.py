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

from cocomopl.errors import Error  # noqa: E402

__version__ = "0.1.0"

__all__ = ["Error", "__version__"]
