"""The robot as a MuJoCo MJCF file: the model ``simulate``, ``walk`` and ``reproduce`` build.

The XML is the text :func:`cocomopl.sim.mujoco_model.mjcf` gives the simulator, written as
is (MuJoCo's own writer, ``MjSpec.to_xml``, rounds limits and inertias to 6 digits), with two
additions for a model used on its own: the base stands on the floor as loaded, and the
keyframe ``home`` is the reference posture standing on the floor, its servo commands holding it.
The URDF's STL meshes are copied beside it into ``<name>-meshes/`` (about 5 MB for TALOS)
and referenced by relative path, so the XML and its folder load anywhere, even without
example-robot-data installed, and can be moved together.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import mujoco

from cocomopl.errors import Error
from cocomopl.motion_file import atomic_path, check_output, remove_stale_temps, temp_name, writable_folder
from cocomopl.robot import Robot
from cocomopl.sim.mujoco_model import CONTACT_TIME_CONSTANT, check_contact_time_constant, mesh_files, mjcf

MODEL_FORMATS = ("mjcf",)


def mesh_folder(path: Path) -> Path:
    """The folder the meshes of the MJCF file ``path`` are copied to: ``talos.xml`` -> ``talos-meshes``."""
    return path.with_name(f"{path.stem}-meshes")


@contextmanager
def _atomic_folder(folder: Path) -> Iterator[Path]:
    """Yield a temporary folder beside ``folder`` that replaces it only if the block succeeds.

    Temporary names are the file layer's (:func:`~cocomopl.motion_file.temp_name`, with the
    writer's pid), so what a killed export leaves is removed by the next run into that place."""
    remove_stale_temps(folder.parent)
    tmp = temp_name(folder)
    tmp.mkdir()  # not mkdtemp: its 0700 would make the meshes unreadable to others
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if folder.exists():  # a folder cannot be renamed over a non-empty one: move the old one aside
        old = temp_name(folder)
        os.replace(folder, old)
        os.replace(tmp, folder)
        shutil.rmtree(old)
    else:
        os.replace(tmp, folder)


def export_mjcf(robot: Robot, path: str | Path, contact_time_constant: float | None = None) -> Path:
    """Write the robot's MuJoCo model to ``path``, its meshes to :func:`mesh_folder`.

    Parameters
    ----------
    robot : the robot, as the OCPs and the simulator use it
    path : the XML file; its folder is created if missing
    contact_time_constant : sole-floor contact softness, s (``None``: the simulator's default)

    Returns
    -------
    Path
        ``path``.  The mesh folder is replaced first and the XML appears last; on a failure
        nothing new is left behind and a previous export stays as it was.

    Raises
    ------
    Error
        if ``path`` is a directory, the mesh folder's name is taken by a file, the folder
        cannot be written, or the time constant is unusable.
    """
    path = Path(path)
    if path.is_dir():
        raise Error(f"{path} is a directory; give an XML file name such as {path / f'{robot.name}.xml'}")
    meshes = mesh_folder(path)
    if meshes.exists() and not meshes.is_dir():
        raise Error(f"cannot write the meshes to {meshes}: a file is in the way")
    if contact_time_constant is None:
        contact_time_constant = CONTACT_TIME_CONSTANT
    check_contact_time_constant(contact_time_constant)
    writable_folder(path.parent, f"the folder of {path}")
    text = mjcf(robot, contact_time_constant=contact_time_constant, mesh_folder=meshes.name, home=True)
    with ExitStack() as stack:  # exits in reverse: the meshes are in place before the XML
        xml = stack.enter_context(atomic_path(path))
        copies = stack.enter_context(_atomic_folder(meshes))
        for relative, source in mesh_files(robot.visual_model()).items():
            (copies / relative).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, copies / relative)
        xml.write_text(text)
    return path


def export_model(robot_source: str, fmt: str, out: str | Path, *, contact_time_constant: float | None = None) -> dict:
    """Write a robot model file and summarise it from the file as written.

    Parameters
    ----------
    robot_source : a bundled robot name (``"talos"``) or a robot description ``.json``
    fmt : one of ``MODEL_FORMATS``
    out : the output file
    contact_time_constant : sole-floor contact softness, s (``None``: the simulator's default)

    Returns
    -------
    dict
        JSON-able: ``output`` (the XML), ``format``, ``robot``, ``meshes`` (folder), ``mesh_files``,
        ``nq``, ``nv``, ``nu``, ``joints`` (hinges), ``mass_kg``, ``contact_time_constant_s``.

    Raises
    ------
    Error
        for an unknown format or robot, or an unwritable ``out`` (see :func:`export_mjcf`).
    """
    if fmt not in MODEL_FORMATS:
        raise Error(f"unknown model format {fmt!r}: choose one of {', '.join(MODEL_FORMATS)}")
    description = robot_source if str(robot_source).endswith(".json") else None
    check_output(out, [description])  # the description file is an input
    robot = Robot(robot_source)
    path = export_mjcf(robot, out, contact_time_constant)
    model = mujoco.MjModel.from_xml_path(str(path))
    meshes = mesh_folder(path)
    return {
        "output": str(path),
        "format": fmt,
        "robot": robot.name,
        "meshes": str(meshes),
        "mesh_files": sum(1 for f in meshes.rglob("*") if f.is_file()),
        "nq": int(model.nq),
        "nv": int(model.nv),
        "nu": int(model.nu),
        "joints": int(model.njnt - 1),  # all but the free joint
        "mass_kg": float(model.body_mass.sum()),
        "contact_time_constant_s": float(model.geom_solref[model.geom("floor").id, 0]),
    }
