"""Humanoid robot descriptions: a Pinocchio model plus what walking needs to know about it.

A description is a small JSON file (``docs/robots.md``; ``talos.json`` beside this module).
It names where the URDF comes from, the foot (sole) frames and their rectangles, the pelvis
frame, joints to lock and the reference posture.  Everything else -- the actuated-joint
order, the limits, the left/right mirror partners (by structure: each joint's partner is
the joint at its reflection), the joint groups (by kinematic chain) and the leg joints'
roles (by axis) -- is derived from the URDF, so any URDF humanoid works through a few lines
of JSON.
"""

from __future__ import annotations

import functools
import hashlib
import json
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from cocomopl.errors import Error
from cocomopl.robot.scale import REFERENCE_ARMATURE_KG_M2, REFERENCE_LONGEST_STEP_M, Scale

DESCRIPTIONS_DIR = Path(__file__).parent
DEFAULT_ROBOT = "talos"
MIRROR_TOLERANCE_M = 1e-3  # a joint's mirror partner is the joint this close to its reflection
MIRROR_ALIGNMENT = 0.95  # and whose axis is this aligned with its reflected axis (|cos|)
SYMMETRISED_ABOVE = 1e-9  # m and rad: a pair's placements differing by less are left as they are
SAME_CONVENTION_RAD = 1e-3  # partner frames turned further apart follow different axis conventions
CONTACT_BAND_M = 2e-3  # collision points this close above the lowest one touch the floor standing
REACH_MARGIN_M = 0.01  # the default steps' longest stands at least this far short of what the legs reach
PELVIS_DROP = 0.06  # a derived posture's pelvis, as a share of its height with straight legs (TALOS: 64 of 1083 mm)
# how far inside its limits a derived posture holds a joint off the legs: past the OCPs' own
# 0.02 rad margin, which a posture on a limit (Romeo's elbows at neutral) sets against the posture cost
POSTURE_LIMIT_MARGIN_RAD = 0.05
_P = np.diag([1.0, -1.0, 1.0])  # the sagittal reflection y -> -y
_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True)
class Sole:
    """Rectangle of a sole in its frame (x forward, y left), in metres."""

    front: float
    back: float
    half_width: float

    def corners(self) -> np.ndarray:
        """Corners (4, 2) counter-clockwise, in the sole frame."""
        f, b, w = self.front, self.back, self.half_width
        return np.array([[f, -w], [f, w], [-b, w], [-b, -w]])


def available_robots() -> list[str]:
    """Names of the robot descriptions shipped with cocomopl."""
    return sorted(p.stem for p in DESCRIPTIONS_DIR.glob("*.json"))


def read_description(name_or_path: str | dict) -> dict:
    """Read a robot description by bundled name (``talos``, in any case) or JSON path, or
    check one given as a dict (as files record it: :attr:`Robot.description`)."""
    if isinstance(name_or_path, dict):
        return _checked(dict(name_or_path), "recorded")
    path = Path(name_or_path)
    if path.suffix != ".json":
        path = DESCRIPTIONS_DIR / f"{name_or_path.lower()}.json"
        if not path.exists():
            raise Error(
                f"unknown robot {name_or_path!r}: choose one of {', '.join(available_robots())} "
                "or give a description .json file"
            )
    try:
        desc = json.loads(path.read_text())
    except FileNotFoundError:
        raise Error(f"robot description not found: {path}") from None
    except (OSError, json.JSONDecodeError) as exc:
        raise Error(f"cannot read robot description {path}: {exc}") from None
    desc = _checked(desc, str(path))
    for key in ("urdf", "srdf"):  # relative to the description's folder, not the working one
        if key in desc and not Path(desc[key]).is_absolute():
            desc[key] = str((path.parent / desc[key]).resolve())
    return desc


def _checked(desc, where: str) -> dict:
    """``desc`` if its keys hold what ``docs/robots.md`` says, else an :class:`Error` naming the key."""
    if not isinstance(desc, dict):
        raise Error(f"robot description {where} is not a JSON object")
    for key in ("name", "pelvis"):
        if key not in desc:
            raise Error(f"robot description {where} lacks the key {key!r}")
    if ("feet" in desc) != ("sole" in desc):
        raise Error(f"robot description {where}: give both 'feet' and 'sole', or neither (both are then derived)")
    if "feet" in desc and not (isinstance(desc["feet"], dict) and set(desc["feet"]) == {"left", "right"}
                               and all(isinstance(v, str) for v in desc["feet"].values())):
        raise Error(f"robot description {where}: 'feet' must name the frames of the soles, "
                    '{"left": FRAME, "right": FRAME}')
    if "sole" in desc and not (isinstance(desc["sole"], dict) and set(desc["sole"]) == {"front", "back", "half_width"}
                               and all(positive_number(v) for v in desc["sole"].values())):
        raise Error(f"robot description {where}: 'sole' must give positive 'front', 'back' and 'half_width' in m")
    for key in ("pelvis_height", "max_step_length", "foot_separation"):
        if key in desc and not positive_number(desc[key]):
            raise Error(f"robot description {where}: {key!r} must be a positive number of metres, not {desc[key]!r}")
    if "armature" in desc and not positive_number(desc["armature"]):
        raise Error(f"robot description {where}: 'armature' must be a positive number of kg m^2, not {desc['armature']!r}")
    if not isinstance(desc.get("symmetrize", True), bool):
        raise Error(f"robot description {where}: 'symmetrize' must be true or false, not {desc['symmetrize']!r}")
    if "defaults" in desc:
        _check_defaults(desc["defaults"], where)
    return desc


# What a description's "defaults" may set in place of the values scaled from TALOS's
# (docs/robots.md#overriding-the-scaled-defaults); lengths in m, angles in rad.
DEFAULTS_KEYS = ("ocp", "training_lengths", "walk", "footstep_range", "stabilizer", "simulation", "kajita")
# the fields of sim.stabilizer.StabilizerGains and pipeline.SimSettings a description sets,
# checked here so that a description is refused when it is read (tests/test_robot.py holds
# them to the settings' fields; the robot layer does not import the simulation)
STABILIZER_KEYS = ("ankle_damping", "dcm_gain", "attitude_rate_gain")
SIMULATION_KEYS = ("feedforward",)
FOOTSTEP_RANGE_KEYS = ("length", "width", "turn")


def _check_defaults(defaults, where: str) -> None:
    """An :class:`Error` naming the first entry of a description's ``defaults`` that is not
    what docs/robots.md says (the OCP and Kajita settings' names and values are checked where
    they are applied, :func:`cocomopl.ocp.settings.robot_settings` and
    :meth:`cocomopl.baselines.kajita.KajitaSettings.scaled_to`; ``robot check`` applies both)."""

    def fail(key: str, wants: str, value) -> Error:
        return Error(f"robot description {where}: defaults.{key} must be {wants}, not {value!r}")

    if not isinstance(defaults, dict):
        raise Error(f"robot description {where}: defaults must be a JSON object, not {defaults!r}")
    for key in defaults:
        if key not in DEFAULTS_KEYS:
            raise Error(f"robot description {where}: defaults has no key {key!r} (it takes {', '.join(DEFAULTS_KEYS)})")
    if not isinstance(defaults.get("ocp", {}), dict):
        raise fail("ocp", "a JSON object of OCP settings", defaults["ocp"])
    if not isinstance(defaults.get("kajita", {}), dict):
        raise fail("kajita", "a JSON object of Kajita baseline settings", defaults["kajita"])
    for key in ("training_lengths", "walk"):
        value = defaults.get(key, [0.1])
        if not (isinstance(value, list) and value and all(map(positive_number, value))):
            raise fail(key, "a list of positive step lengths in m", value)
    ranges = defaults.get("footstep_range", {})
    if not isinstance(ranges, dict) or set(ranges) - set(FOOTSTEP_RANGE_KEYS):
        raise fail("footstep_range", f"an object of {', '.join(FOOTSTEP_RANGE_KEYS)}", ranges)
    for key, value in ranges.items():
        if not (isinstance(value, list) and len(value) == 2 and all(finite_number(v) for v in value) and value[0] < value[1]):
            raise fail(f"footstep_range.{key}", "[low, high], low < high" + (" (rad)" if key == "turn" else " (m)"), value)
    gains = defaults.get("stabilizer", {})
    if not isinstance(gains, dict) or set(gains) - set(STABILIZER_KEYS) or not all(map(positive_number, gains.values())):
        raise fail("stabilizer", f"an object of positive {', '.join(STABILIZER_KEYS)}", gains)
    simulation = defaults.get("simulation", {})
    if not isinstance(simulation, dict) or set(simulation) - set(SIMULATION_KEYS) or not all(
            isinstance(v, bool) for v in simulation.values()):
        raise fail("simulation", f"an object of {', '.join(SIMULATION_KEYS)}: true or false", simulation)


def checked_overrides(given: dict, checks: dict, *, section: str, what: str) -> dict:
    """A description's ``defaults.<section>`` (``given``) checked entry by entry against
    ``checks`` (a setting's name -> (accepts, wants): a predicate on the JSON value and what to
    call a value it accepts), with JSON lists as tuples; an :class:`Error` naming the first
    entry that is not ``what`` (e.g. "an OCP setting") or not a value it takes."""
    for name, value in given.items():
        if name not in checks:
            raise Error(f"robot description: defaults.{section}.{name} is not {what}")
        accepts, wants = checks[name]
        if not accepts(value):
            raise Error(f"robot description: defaults.{section}.{name} must be {wants}, not {value!r}")
    return {name: tuple(value) if isinstance(value, list) else value for name, value in given.items()}


def finite_number(value) -> bool:
    """Whether a JSON value is a finite number (not a boolean)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and bool(np.isfinite(value))


def link_inertia(mass: float, lever: np.ndarray, rotational: np.ndarray) -> pin.Inertia:
    """A link inertia; a rotational inertia a URDF gives as zero (iCub's hips and wrists: a
    point mass) is kept zero where averaging leaves it round-off below zero, which Pinocchio refuses."""
    try:
        return pin.Inertia(mass, lever, rotational)
    except RuntimeError:
        values, vectors = np.linalg.eigh(0.5 * (rotational + rotational.T))
        return pin.Inertia(mass, lever, vectors @ np.diag(np.clip(values, 0.0, None)) @ vectors.T)


def positive_number(value) -> bool:
    """Whether a JSON value is a finite number above 0."""
    return finite_number(value) and value > 0


def load_full_model(desc: dict, geometry: pin.GeometryType | None = None):
    """The unreduced model, the reference posture named by the description (or None) and,
    if ``geometry`` is given, the URDF's visual or collision geometry model (else None)."""
    if "example_robot_data" in desc:
        wrapper = _example_robot(desc["example_robot_data"])
        model = pin.Model(wrapper.model)  # a copy: a robot adds its sole frames and evens out its inertias
        shapes = {pin.GeometryType.VISUAL: wrapper.visual_model, pin.GeometryType.COLLISION: wrapper.collision_model,
                  None: None}[geometry]
        shapes = None if shapes is None else shapes.copy()
    elif "urdf" in desc:
        urdf = Path(desc["urdf"])
        if not urdf.exists():
            raise Error(f"URDF not found: {urdf}")
        try:
            model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
            shapes = None if geometry is None else pin.buildGeomFromUrdf(model, str(urdf), geometry, [str(urdf.parent)])
        except (RuntimeError, ValueError) as exc:
            raise Error(f"cannot parse URDF {urdf}: {exc}") from None
        if "srdf" in desc:
            if not Path(desc["srdf"]).exists():
                raise Error(f"SRDF not found: {desc['srdf']}")
            try:
                pin.loadReferenceConfigurations(model, desc["srdf"], False)
            except (RuntimeError, ValueError) as exc:
                raise Error(f"cannot read SRDF {desc['srdf']}: {exc}") from None
    else:
        raise Error(f"robot description {desc['name']!r} names neither 'urdf' nor 'example_robot_data'")
    posture_name = desc.get("reference_posture")
    q_ref = None
    if posture_name is not None:
        try:
            q_ref = np.array(model.referenceConfigurations[posture_name])
        except (KeyError, IndexError):
            raise Error(f"robot {desc['name']!r} has no reference posture {posture_name!r}") from None
    return model, q_ref, shapes


@functools.cache
def _example_robot(name: str):
    """example-robot-data's robot ``name``, loaded once per process: parsing a URDF and its
    meshes takes a second or two, and commands and tests build the same robot many times."""
    import example_robot_data

    try:
        return example_robot_data.load(name)
    except Exception as exc:  # the loader raises bare ValueError/KeyError for unknown names
        raise Error(f"example-robot-data cannot load {name!r}: {exc}") from None


def _locked_joint_ids(model: pin.Model, desc: dict) -> list[int]:
    names = list(desc.get("locked_joints", []))
    pattern = desc.get("locked_joints_matching")
    if pattern:
        names += [n for n in model.names[1:] if re.search(pattern, n)]
    ids = []
    for name in names:
        if not model.existJointName(name):
            raise Error(f"robot {desc['name']!r}: no joint named {name!r} to lock")
        ids.append(model.getJointId(name))
    return ids


def _lowest_points(geometry, placement: pin.SE3) -> np.ndarray:
    """Points (k, 3) in the world that bound the bottom of one collision geometry."""
    shape = type(geometry).__name__
    if shape == "Sphere":
        return (placement.translation - [0.0, 0.0, geometry.radius])[None]
    if shape == "Box":
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * geometry.halfSide
    elif shape in ("Capsule", "Cylinder"):
        ring = np.array([[np.cos(a), np.sin(a), 0.0] for a in np.linspace(0, 2 * np.pi, 16, endpoint=False)])
        ends = np.array([[0, 0, -geometry.halfLength], [0, 0, geometry.halfLength]])
        corners = (ends[:, None] + geometry.radius * ring[None]).reshape(-1, 3)
        if shape == "Capsule":
            caps = np.array([[0.0, 0.0, -geometry.radius], [0.0, 0.0, geometry.radius]])
            corners = np.vstack([corners, ends + caps[:, None]]).reshape(-1, 3)
    elif hasattr(geometry, "vertices"):
        corners = np.asarray(geometry.vertices())
    else:
        return np.empty((0, 3))
    return corners @ placement.rotation.T + placement.translation


def derive_soles(model: pin.Model, collision: pin.GeometryModel, robot: str):
    """The sole frames and rectangle of a robot whose description names none, from the
    collision geometry of its feet standing at the neutral configuration: per side the
    placement (in its joint's frame) of a frame on the floor under the foot's joint, x
    forward and z up, and the largest rectangle (front, back, half width) about that frame
    inside the points of the foot that touch the floor."""
    data, gdata = model.createData(), collision.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    pin.updateGeometryPlacements(model, data, collision, gdata)
    points = {}
    for k, g in enumerate(collision.geometryObjects):
        p = _lowest_points(g.geometry, gdata.oMg[k])
        if len(p):
            points.setdefault(g.parentJoint, []).append(p)
    if not points:
        raise Error(f"robot {robot!r}: no collision geometry to find its soles from; name them in 'feet' and 'sole'")
    points = {j: np.vstack(p) for j, p in points.items()}
    floor = min(p[:, 2].min() for p in points.values())
    feet = [j for j, p in points.items() if p[:, 2].min() < floor + CONTACT_BAND_M]
    if len(feet) != 2:
        raise Error(f"robot {robot!r}: {len(feet)} links touch the floor at the neutral configuration "
                    f"({', '.join(model.names[j] for j in feet)}), not two feet; name the soles in 'feet' and 'sole'")
    frames, rectangles = {}, []
    for joint in sorted(feet, key=lambda j: -data.oMi[j].translation[1]):
        side = "left" if data.oMi[joint].translation[1] > 0 else "right"
        if side in frames:
            raise Error(f"robot {robot!r}: both feet on the {side} at the neutral configuration")
        touching = points[joint][points[joint][:, 2] < floor + CONTACT_BAND_M]
        origin = np.array([*data.oMi[joint].translation[:2], floor])
        frames[side] = (joint, data.oMi[joint].actInv(pin.SE3(np.eye(3), origin)))
        rectangle = _inscribed_rectangle(touching[:, :2] - origin[:2])
        if rectangle is None:
            raise Error(f"robot {robot!r}: the {side} foot's floor contacts do not surround its joint; "
                        "name the soles in 'feet' and 'sole'")
        rectangles.append(rectangle)
    front, back, half_width = np.min(rectangles, axis=0)
    return frames, (float(front), float(back), float(half_width))


def _inscribed_rectangle(points: np.ndarray, widths: int = 200) -> tuple[float, float, float] | None:
    """The largest rectangle ``[-back, front] x [-w, w]`` inside the convex hull of the floor
    contacts ``points`` (k, 2) about the foot's joint, as (front, back, w); None if the hull
    does not surround the joint.  The hull's chord along x shrinks towards its edges, so a
    rectangle of half-width ``w`` fits between the chords at ``y = -w`` and ``y = w``."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = points[ConvexHull(points).vertices]
    except QhullError:
        return None
    edges = np.stack([hull, np.roll(hull, -1, axis=0)], axis=1)  # (k, 2 ends, 2)

    def chord(y: float) -> tuple[float, float]:
        (x0, y0), (x1, y1) = edges[:, 0].T, edges[:, 1].T
        crosses = (np.minimum(y0, y1) <= y) & (y <= np.maximum(y0, y1)) & (y0 != y1)
        x = x0[crosses] + (y - y0[crosses]) * (x1[crosses] - x0[crosses]) / (y1[crosses] - y0[crosses])
        return (x.min(), x.max()) if len(x) else (np.inf, -np.inf)

    best, widest = None, min(hull[:, 1].max(), -hull[:, 1].min())
    corners = np.abs(hull[:, 1])  # a corner's width is often the best: try each
    for w in np.union1d(np.linspace(0.0, widest, widths + 1)[1:-1], corners[(corners > 0) & (corners <= widest)]):
        (a0, b0), (a1, b1) = chord(-w), chord(w)
        back, front = -max(a0, a1), min(b0, b1)
        if back > 0 and front > 0 and (best is None or (front + back) * w > (best[0] + best[1]) * best[2]):
            best = (float(front), float(back), float(w))
    return best


def _add_sole_frame(model: pin.Model, side: str, joint: int, placement: pin.SE3) -> str:
    """Add the derived sole frame ``{side}_sole`` on ``joint`` to ``model``; its name."""
    name = f"{side}_sole"
    if model.existFrame(name):
        raise Error(f"the model has a frame {name!r} already: name the soles in 'feet'")
    parent = model.getFrameId(model.names[joint])
    model.addFrame(pin.Frame(name, joint, parent, placement, pin.FrameType.OP_FRAME))
    return name


_BUILT: dict[str, dict] = {}  # the description of each robot built in this process, by name
_FINGERPRINTS: dict[str, set[str]] = {}  # the fingerprints of the robots built of each name


def built_description(name: str) -> dict | None:
    """The description of the robot named ``name`` last built in this process (None if none
    was): what the files written for it record, so that they are read back without it."""
    return _BUILT.get(name)


def built_fingerprint(name: str) -> str | None:
    """The :attr:`Robot.fingerprint` of the robot named ``name`` built in this process: what
    the files written for it record, to be read only with that model.  None if no robot of
    that name was built, or models of it that differ were (then a file's motions do not say
    which they were made with)."""
    built = _FINGERPRINTS.get(name, set())
    return next(iter(built)) if len(built) == 1 else None


def joint_axis(model: pin.Model, jid: int, robot: str = "") -> np.ndarray:
    """The unit axis of the revolute joint ``jid`` in its own frame.

    Raises
    ------
    Error
        If the joint is not revolute (about X, Y, Z or any unit axis).
    """
    joint = model.joints[jid]
    kind = joint.shortname()
    if kind == "JointModelRevoluteUnaligned":
        return np.array(joint.extract().axis, dtype=float)
    if kind in ("JointModelRX", "JointModelRY", "JointModelRZ"):
        return _AXES[kind[-1]].copy()
    raise Error(f"robot {robot!r}: joint {model.names[jid]!r} is not a revolute joint ({kind})")


def mirror_partners(model: pin.Model, axes: np.ndarray, robot: str) -> list[int]:
    """Each joint's mirror partner (a joint id per joint id), by structure: the joint whose origin lies
    within :data:`MIRROR_TOLERANCE_M` of the joint's reflection at the neutral configuration,
    its axis aligned with the reflected one; a joint on the sagittal plane is its own.  The
    nearest such joint is taken, so joints sharing an origin pair by axis."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    origin = np.array([data.oMi[j].translation for j in range(model.njoints)])
    world_axes = np.array([data.oMi[j].rotation @ axes[j - 2] for j in range(2, model.njoints)])
    partner = np.arange(model.njoints)
    for i in range(2, model.njoints):
        distance = np.linalg.norm(origin[2:] - _P @ origin[i], axis=1)
        aligned = np.abs(world_axes @ (_P @ world_axes[i - 2])) > MIRROR_ALIGNMENT
        candidates = np.flatnonzero(aligned & (distance < MIRROR_TOLERANCE_M))
        if len(candidates) == 0:
            nearest = int(np.argmin(distance))
            raise Error(
                f"robot {robot!r}: joint {model.names[i]!r} has no mirror image: the nearest joint to its "
                f"reflection, {model.names[nearest + 2]!r}, is {distance[nearest] * 1000:.3g} mm from it "
                f"(tolerance {MIRROR_TOLERANCE_M * 1000:g} mm)"
            )
        partner[i] = candidates[np.argmin(distance[candidates])] + 2
    return partner.tolist()


def symmetrize_placements(model: pin.Model, partner: list[int]) -> float:
    """Move each pair of mirror partners halfway to each other's reflection (at the neutral
    configuration), so that a mirrored motion moves the same bodies the same way.

    URDFs of nominally symmetric robots differ left to right by CAD round-off (the Unitree
    G1's shoulders by 10 um): the inverse dynamics of a mirrored motion then misses by more
    than a solver's tolerance.  Pairs closer than :data:`SYMMETRISED_ABOVE` are left as they
    are, and so are pairs whose frames follow different axis conventions (turned apart by more
    than :data:`SAME_CONVENTION_RAD`: their axes are checked by the mirror map instead).
    Returns the largest move of a joint's origin (m), as a record of the change.
    """
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    world = [data.oMi[j].copy() for j in range(model.njoints)]
    moved = np.zeros(model.njoints, dtype=bool)
    largest = 0.0
    for i in range(1, model.njoints):
        j = partner[i]
        if j < i:
            continue
        reflected = pin.SE3(_P @ world[j].rotation @ _P, _P @ world[j].translation)
        error = pin.log6(world[i].actInv(reflected))
        if np.linalg.norm(error.angular) > SAME_CONVENTION_RAD or max(
                np.linalg.norm(error.linear), np.linalg.norm(error.angular)) <= SYMMETRISED_ABOVE:
            continue
        world[i] = world[i] * pin.exp6(0.5 * error)
        world[j] = pin.SE3(_P @ world[i].rotation @ _P, _P @ world[i].translation)
        moved[[i, j]] = True
        largest = max(largest, 0.5 * float(np.linalg.norm(reflected.translation - data.oMi[i].translation)))
    for k in range(1, model.njoints):
        parent = model.parents[k]
        if moved[k] or moved[parent]:
            model.jointPlacements[k] = world[parent].actInv(world[k])
    return largest


class Robot:
    """A floating-base humanoid for walking.

    Attributes
    ----------
    model : pinocchio.Model
        The reduced model (locked joints removed); ``nq = 7 + nu``, ``nv = 6 + nu``.
    joint_names : list of str
        Actuated joints, in the order of ``q[7:]``, ``v[6:]`` and every torque vector.
    q_lower, q_upper, v_max, tau_max : ndarray (nu,)
        Joint position, velocity and torque limits from the URDF (rad, rad/s, N m).
    foot_frames : dict
        ``{"left": frame id, "right": frame id}`` of the sole frames.
    sole : Sole
        The sole rectangle, the same for both feet (mirrored).
    q_ref : ndarray (nq,)
        Reference standing posture.
    joint_axes : ndarray (nu, 3)
        Each actuated joint's unit axis in its own frame.
    joint_partner : list of int
        Each joint's mirror partner (a model joint id per model joint id, found by structure).
    mirror_perm, mirror_sign : ndarray (nu,)
        Left/right mirror map: mirrored joint ``i`` is ``mirror_sign[i] * q[mirror_perm[i]]``.
    armature_source : str
        Where the joints' armature (reflected rotor inertia, ``model.armature``) comes from:
        ``given`` by the description, ``the model's`` rotor parameters, or ``derived``
        (TALOS's scaled to the robot's mass and leg length squared).
    placement_asymmetry, inertia_asymmetry : float
        The largest move of a joint's origin and of a link's centre of mass made to render
        the model exactly symmetric, m (0 when the description turns ``symmetrize`` off).
    """

    def __init__(self, name_or_path: str | dict = DEFAULT_ROBOT):
        desc = read_description(name_or_path)
        self.description = desc
        _BUILT[desc["name"]] = desc
        self._visual: pin.GeometryModel | None = None  # visual_model(), loaded on first use
        self.name: str = desc["name"]
        derive_feet = "feet" not in desc  # and so "sole" is not either (_checked)
        full, q_full_ref, collision = load_full_model(desc, pin.GeometryType.COLLISION if derive_feet else None)
        if full.joints[1].shortname() != "JointModelFreeFlyer":
            raise Error(f"robot {self.name!r} has no floating base (free-flyer root joint)")
        feet, sole = desc.get("feet"), desc.get("sole")
        if derive_feet:
            if len(collision.geometryObjects) == 0:  # a URDF without collision geometry: its meshes
                collision = load_full_model(desc, pin.GeometryType.VISUAL)[2]
            frames, derived = derive_soles(full, collision, self.name)
            feet = {side: _add_sole_frame(full, side, *frames[side]) for side in frames}
            sole = dict(zip(("front", "back", "half_width"), derived))
        named_posture = q_full_ref is not None
        if q_full_ref is None:
            q_full_ref = pin.neutral(full)
        locked = _locked_joint_ids(full, desc)
        self.model: pin.Model = pin.buildReducedModel(full, locked, q_full_ref) if locked else full
        self.q_ref = self._reduce_configuration(full, q_full_ref)
        self.nu = self.model.nv - 6
        for jid in range(2, self.model.njoints):
            joint = self.model.joints[jid]
            if joint.nq != 1 or joint.nv != 1:
                raise Error(f"robot {self.name!r}: joint {self.model.names[jid]!r} is not a 1-DOF joint "
                            f"({joint.shortname()}); only 1-DOF actuated joints are supported")
        self.joint_names: list[str] = list(self.model.names[2:])
        self.joint_axes = np.array([joint_axis(self.model, jid, self.name) for jid in range(2, self.model.njoints)])
        symmetrize = bool(desc.get("symmetrize", True))
        self.joint_partner = mirror_partners(self.model, self.joint_axes, self.name)
        self.placement_asymmetry = symmetrize_placements(self.model, self.joint_partner) if symmetrize else 0.0
        self.q_lower = np.array(self.model.lowerPositionLimit[7:])
        self.q_upper = np.array(self.model.upperPositionLimit[7:])
        self.v_max = np.array(self.model.velocityLimit[6:])
        self.tau_max = np.array(self.model.effortLimit[6:])
        self.mass = float(pin.computeTotalMass(self.model))
        self.foot_frames = {side: self._frame_id(feet[side]) for side in ("left", "right")}
        self.pelvis_frame = self._frame_id(desc["pelvis"])
        self.sole = Sole(**sole)
        # longest step (m) the description vouches for; beyond it the stance may still be
        # kinematically possible but walking is not (legs nearly straight)
        self.max_step_length = float(desc.get("max_step_length", np.inf))
        self.mirror_perm, self.mirror_sign = self._derive_mirror_map()
        self._check_facing()
        if not named_posture:
            self.q_ref = self._bent_knee_posture(desc.get("pelvis_height"), desc.get("foot_separation"))
        self.inertia_asymmetry = self._symmetrize_inertias() if symmetrize else 0.0
        self.armature_source = self._set_armature(desc.get("armature"))
        _FINGERPRINTS.setdefault(self.name, set()).add(self.fingerprint)

    # ------------------------------------------------------------------ set-up helpers
    def _frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            raise Error(f"robot {self.name!r} has no frame named {name!r}")
        return self.model.getFrameId(name)

    def _reduce_configuration(self, full: pin.Model, q_full: np.ndarray) -> np.ndarray:
        q = pin.neutral(self.model)
        q[:7] = q_full[:7]
        for jid in range(2, self.model.njoints):
            name = self.model.names[jid]
            q[self.model.idx_qs[jid]] = q_full[full.idx_qs[full.getJointId(name)]]
        return q

    def override(self, key: str):
        """What the description's ``defaults`` set for ``key`` (one of :data:`DEFAULTS_KEYS`) in
        place of the value scaled from TALOS's, or None (docs/robots.md)."""
        return self.description.get("defaults", {}).get(key)

    def _set_armature(self, given: float | None) -> str:
        """Give every actuated joint the description's ``armature`` (kg m^2), or, where the model
        has no rotor inertia at all, TALOS's scaled to the robot; say which."""
        v = slice(6, None)
        if given is not None:
            self.model.armature[v] = given
            return "given"
        if np.any(self.model.armature[v]):
            return "the model's"
        # a servo's rotor, reflected through its gear, stiffens the light links' dynamics
        # against the servo's gains: without it, G1's stance foot chatters on the floor
        self.model.armature[v] = REFERENCE_ARMATURE_KG_M2 * self.scale.mass * self.scale.length**2
        return "derived"

    @functools.cached_property
    def fingerprint(self) -> str:
        """A digest of the model as built: its description (without the paths of its files,
        which change when a checkout moves) and the numbers of its reduced model (joint names,
        limits, posture, inertias, placements, frames), so that an edited description or URDF
        under the same robot name tells apart.  Every file made for the robot records it."""
        description = {key: value for key, value in self.description.items() if key not in ("urdf", "srdf")}
        digest = hashlib.sha256(json.dumps(description, sort_keys=True).encode())
        digest.update(json.dumps(list(self.model.names)).encode())
        numbers = [self.q_ref, self.q_lower, self.q_upper, self.v_max, self.tau_max]
        numbers += [np.r_[body.mass, body.lever, body.inertia.ravel()] for body in self.model.inertias]
        numbers += [placement.homogeneous for placement in self.model.jointPlacements]
        numbers += [frame.placement.homogeneous for frame in self.model.frames]
        for values in numbers:  # rounded: a digest of the values, not of their last bits
            digest.update(np.round(np.asarray(values, dtype=float), 9).tobytes())
        return digest.hexdigest()[:16]

    @functools.cached_property
    def scale(self) -> Scale:
        """The robot's size relative to TALOS's, by which size-dependent defaults scale.

        Step lengths scale with the leg length, unless the legs cannot stand, with
        :data:`REACH_MARGIN_M` to spare, across TALOS's longest step so scaled (Romeo's ankles
        leave it 140 mm from its derived posture): then with the longest step, to 10 mm, they can.
        """
        scale = Scale.of(self.mass, self.leg_length, self.sole.half_width)
        longest = scale.length_m(REFERENCE_LONGEST_STEP_M)
        if self.stands_across(longest + REACH_MARGIN_M):
            return scale
        reach = next((x for x in np.arange(longest - 0.01, 0.0, -0.01).round(2)
                      if self.stands_across(x + REACH_MARGIN_M)), None)
        if reach is None:
            raise Error(f"robot {self.name!r} cannot stand with its feet apart by any step from its posture: "
                        "give a reference_posture or another pelvis_height")
        return replace(scale, stride=float(reach) / REFERENCE_LONGEST_STEP_M)

    def stands_across(self, length: float) -> bool:
        """Whether the legs stand in the gait state of a straight step of ``length`` (m): the
        feet that far apart, the CoM between them (inverse kinematics within the joint limits)."""
        from cocomopl.gait import gait_state_posture

        try:
            gait_state_posture(self, (length, 0.0, 0.0))
        except Error:
            return False
        return True

    @functools.cached_property
    def leg_length(self) -> float:
        """The pelvis height above the soles with straight legs (the neutral configuration), m."""
        neutral = pin.neutral(self.model)
        soles = [self.frame_placement(neutral, frame).translation[2] for frame in self.foot_frames.values()]
        return float(neutral[2] - np.mean(soles))

    def _bent_knee_posture(self, pelvis_height: float | None, separation: float | None = None) -> np.ndarray:
        """A standing posture for a robot whose description names none: the soles flat on the
        floor where they are at the neutral configuration (``separation`` m apart sideways
        if given), the pelvis ``pelvis_height`` (m) above
        them -- by default :data:`PELVIS_DROP` lower than with straight legs -- and the legs
        bent to reach (:func:`~cocomopl.kinematics.place_legs`)."""
        from cocomopl.kinematics import IK_REACHED, leg_joints, place_legs

        q = pin.neutral(self.model)
        soles = {side: self.frame_placement(q, frame) for side, frame in self.foot_frames.items()}
        floor = np.mean([sole.translation[2] for sole in soles.values()])
        straight = self.leg_length
        height = straight * (1.0 - PELVIS_DROP) if pelvis_height is None else float(pelvis_height)
        if not 0.0 < height <= straight:
            raise Error(f"robot {self.name!r}: pelvis_height {height:g} m is not within (0, {straight:.3f}] m, "
                        "the pelvis height with straight legs")
        targets = {side: pin.SE3(sole.rotation, sole.translation - [0.0, 0.0, floor]) for side, sole in soles.items()}
        if separation is not None:
            for target in targets.values():
                target.translation[1] = np.sign(target.translation[1]) * float(separation) / 2
        q[2] = height
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, q)
        for roles in self.leg_roles().values():  # bent a little first: straight legs are singular
            pitch = np.array([roles["hip_pitch"], roles["knee"], roles["ankle_pitch"]])
            # knee forward for a joint turning about +y (TALOS, the G1), so the other way about -y
            sign = np.sign([(data.oMi[int(i) + 2].rotation @ self.joint_axes[i])[1] for i in pitch])
            q[7 + pitch] = sign * [-0.2, 0.4, -0.2]
        q = place_legs(self, q, targets, legs=leg_joints(self), height_weight=1e3)
        upper = 7 + self.upper_body_joint_indices()
        low, high = self.q_lower[upper - 7], self.q_upper[upper - 7]
        margin = np.minimum(POSTURE_LIMIT_MARGIN_RAD, (high - low) / 2)
        q[upper] = np.clip(q[upper], low + margin, high - margin)
        error = max(np.linalg.norm(pin.log6(targets[side].actInv(self.frame_placement(q, frame))).vector)
                    for side, frame in self.foot_frames.items())
        if error > IK_REACHED:
            raise Error(f"robot {self.name!r}: the legs cannot stand with the pelvis {height:.3f} m above the soles "
                        f"(sole error {error * 1000:.1f} mm); give a reference_posture or another pelvis_height")
        return q

    def _check_facing(self) -> None:
        """An :class:`Error` unless the robot faces +x in its base frame, as every walk assumes.

        A knee flexes towards the longer side of its range; flexed, it swings the sole
        back, under a robot that faces +x.  A robot whose knees all swing their soles forwards
        faces -x (iCub's base frame).
        """
        q = pin.neutral(self.model)
        forwards = []
        for side, roles in self.leg_roles().items():
            knee = roles["knee"]
            flexion = 1.0 if abs(self.q_upper[knee]) >= abs(self.q_lower[knee]) else -1.0
            bent = q.copy()
            bent[7 + knee] = float(np.clip(0.3 * flexion, self.q_lower[knee], self.q_upper[knee]))
            frame = self.foot_frames[side]
            swing = self.frame_placement(bent, frame).translation[0] - self.frame_placement(q, frame).translation[0]
            if swing > 0:
                forwards.append(self.joint_names[knee])
        if len(forwards) == len(self.foot_frames):
            raise Error(f"robot {self.name!r} faces -x in its base frame (its knees {' and '.join(forwards)} "
                        "flex the soles forwards); cocomopl walks robots that face +x")

    def _derive_mirror_map(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint permutation and signs of the sagittal (y -> -y) reflection.

        A rotation about axis ``a`` by ``theta`` reflects to a rotation about ``P a`` by
        ``-theta`` (``P = diag(1, -1, 1)``), so the partner joint turns with sign
        ``-(P a) . b`` where ``b`` is the partner's axis, both taken in the world frame at
        the neutral configuration (the structure's: a reference posture need not be symmetric).
        """
        model, data = self.model, self.model.createData()
        pin.forwardKinematics(model, data, pin.neutral(model))
        axes = np.array([data.oMi[jid].rotation @ self.joint_axes[jid - 2] for jid in range(2, model.njoints)])
        perm = np.array(self.joint_partner[2:]) - 2
        alignment = -np.einsum("ij,ij->i", axes @ _P, axes[perm])
        for i in np.flatnonzero(np.abs(alignment) < MIRROR_ALIGNMENT):
            raise Error(
                f"robot {self.name!r}: joints {self.joint_names[i]!r} and {self.joint_names[perm[i]]!r} are not "
                f"mirror images (axis alignment {alignment[i]:.2f})"
            )
        return perm, np.sign(alignment)

    def _symmetrize_inertias(self) -> float:
        """Replace each link's inertia by the mean of itself and its mirrored partner.

        URDFs of nominally symmetric robots differ left to right by CAD noise (TALOS: the
        whole-body CoM of a mirrored posture moves by about 2 mm).  Averaging makes the
        model exactly symmetric, so that a mirrored optimal motion is an exact solution
        of the same dynamics, as the paper assumes.  Returns the largest change of a
        link's CoM lever (m), as a record of how asymmetric the URDF was.
        """
        from cocomopl.robot.mirror import mirror_configuration

        model = self.model
        P = np.diag([1.0, -1.0, 1.0])
        data, data_m = model.createData(), model.createData()
        pin.forwardKinematics(model, data, self.q_ref)
        pin.forwardKinematics(model, data_m, mirror_configuration(self, self.q_ref))
        averaged = []
        for jid in range(1, model.njoints):
            partner = self.joint_partner[jid]
            own, other = model.inertias[jid], model.inertias[partner]
            # the partner's inertia reflected through the world and read in this link's frame
            R_o, p_o = data_m.oMi[partner].rotation, data_m.oMi[partner].translation
            R_s, p_s = data.oMi[jid].rotation, data.oMi[jid].translation
            com_w = P @ (R_o @ other.lever + p_o)
            lever = R_s.T @ (com_w - p_s)
            rot = R_s.T @ P @ R_o @ other.inertia @ R_o.T @ P @ R_s
            averaged.append(link_inertia(0.5 * (own.mass + other.mass), 0.5 * (own.lever + lever), 0.5 * (own.inertia + rot)))
        change = max(float(np.abs(a.lever - model.inertias[j].lever).max()) for j, a in enumerate(averaged, 1))
        for jid, inertia in enumerate(averaged, 1):
            model.inertias[jid] = inertia
        return change

    def visual_model(self) -> pin.GeometryModel:
        """The URDF's visual meshes, attached to the joints of the reduced model.

        Loaded on first use (reading the meshes takes about a second, once per process) and
        shared by later calls: do not modify it."""
        if self._visual is None:
            full, q_full_ref, visual = load_full_model(self.description, pin.GeometryType.VISUAL)
            if q_full_ref is None:
                q_full_ref = pin.neutral(full)
            locked = _locked_joint_ids(full, self.description)
            self._visual = pin.buildReducedModel(full, visual, locked, q_full_ref)[1] if locked else visual
        return self._visual

    # ------------------------------------------------------------------ conveniences
    def leg_chain(self, side: str) -> list[int]:
        """Actuated-joint indices from the pelvis down to the ``side`` sole, in order."""
        return [j - 2 for j in self.model.supports[self.model.frames[self.foot_frames[side]].parentJoint] if j >= 2]

    def leg_joint_indices(self) -> list[int]:
        """Actuated-joint indices of the chains from the pelvis to the soles."""
        return sorted(set(self.leg_chain("left")) | set(self.leg_chain("right")))

    def upper_body_joint_indices(self) -> np.ndarray:
        """Actuated-joint indices of the joints that carry no sole (on TALOS the torso, the arms
        and the head)."""
        return np.setdiff1d(np.arange(self.nu), self.leg_joint_indices())

    def joint_groups(self) -> dict[str, np.ndarray]:
        """Actuated-joint indices of the ``legs`` (the chains to the soles), the ``arms`` (the
        other joints off the sagittal plane: each has a mirror partner other than itself) and
        the ``torso`` (the joints on the plane, the head's among them)."""
        legs = set(self.leg_joint_indices())
        arms = [i for i in range(self.nu) if i not in legs and self.mirror_perm[i] != i]
        torso = [i for i in range(self.nu) if i not in legs and i not in arms]
        return {"legs": np.array(sorted(legs), dtype=int), "torso": np.array(torso, dtype=int), "arms": np.array(arms, dtype=int)}

    @functools.cached_property
    def upper_body_inertia(self) -> np.ndarray:
        """The roll and pitch moments of inertia (2,), kg m², of everything the legs carry (the
        pelvis, torso, arms and head) about the midpoint of the hips, in the posture: what the
        hip joints turn when the soles stand on the ground."""
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, self.q_ref)
        hips = {self.leg_chain(side)[0] + 2 for side in self.foot_frames}  # joint ids: the universe and the free flyer first
        legs = {j for j in range(1, self.model.njoints) if hips & set(self.model.supports[j])}
        upper = pin.Inertia.Zero()
        for j in set(range(1, self.model.njoints)) - legs:
            upper += data.oMi[j].act(self.model.inertias[j])
        about = np.mean([data.oMi[j].translation for j in hips], axis=0)
        upper = pin.SE3(np.eye(3), about).actInv(upper)
        return np.array([upper.matrix()[3, 3], upper.matrix()[4, 4]])

    def leg_roles(self) -> dict[str, dict[str, int]]:
        """Per side, the actuated-joint indices of hip roll and pitch, knee, and ankle pitch and
        roll, found by axis along the chain from the pelvis to the sole: the first X (roll)
        and Y (pitch) joints are the hip's, the last Y and X the ankle's, the Y joint between
        them the knee (:meth:`axis_names`)."""
        out = {}
        names = self.axis_names()
        for side in self.foot_frames:
            chain = self.leg_chain(side)
            axis = {i: names[i] for i in chain}
            xs = [i for i in chain if axis[i] == "X"]
            ys = [i for i in chain if axis[i] == "Y"]
            if len(xs) < 2 or len(ys) < 3:
                raise Error(f"robot {self.name!r}: the {side} leg has no hip-knee-ankle pitch and roll joints")
            out[side] = {"hip_roll": xs[0], "hip_pitch": ys[0], "knee": ys[1], "ankle_pitch": ys[-1], "ankle_roll": xs[-1]}
        return out

    def leg_joint_roles(self) -> dict[int, str]:
        """Actuated-joint index -> role of each leg joint :meth:`leg_roles` names, and
        ``hip_yaw`` for a Z joint above the knee."""
        out = {}
        names = self.axis_names()
        for side, roles in self.leg_roles().items():
            out.update({joint: role for role, joint in roles.items()})
            chain = self.leg_chain(side)
            out.update({j: "hip_yaw" for j in chain[:chain.index(roles["knee"])] if names[j] == "Z"})
        return out

    def axis_names(self) -> list[str]:
        """Per actuated joint, ``"X"``, ``"Y"`` or ``"Z"``: the pelvis axis its own axis is
        nearest to at the neutral configuration (roll, pitch or yaw)."""
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, pin.neutral(self.model))
        pelvis = data.oMi[1].rotation
        return ["XYZ"[int(np.argmax(np.abs(pelvis.T @ data.oMi[jid].rotation @ self.joint_axes[jid - 2])))]
                for jid in range(2, self.model.njoints)]

    def state_from_posture(self, q: np.ndarray) -> np.ndarray:
        """A static state ``x = (q, 0)``."""
        return np.concatenate([q, np.zeros(self.model.nv)])

    def frame_placement(self, q: np.ndarray, frame: int) -> pin.SE3:
        """The placement of ``frame`` at the configuration ``q``."""
        pin.forwardKinematics(self.model, self._placement_data, q)
        return pin.updateFramePlacement(self.model, self._placement_data, frame).copy()

    @functools.cached_property
    def _placement_data(self) -> pin.Data:
        """The data :meth:`frame_placement` works in: creating one costs it ten times its
        kinematics, and it is called per sample."""
        return self.model.createData()

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, nq={self.model.nq}, nv={self.model.nv}, actuated={self.nu})"
