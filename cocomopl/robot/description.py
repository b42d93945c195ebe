"""Humanoid robot descriptions: a Pinocchio model plus what walking needs to know about it.

A description is a small JSON file (see ``talos.json`` beside this module).  It names
where the URDF comes from, the foot (sole) frames and their rectangles, joints to lock,
the reference posture and how left/right parts are named.  Everything else -- the
actuated-joint order, the limits and the left/right mirror map -- is derived from the
URDF, so any URDF humanoid works through a few lines of JSON.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from cocomopl.errors import Error

DESCRIPTIONS_DIR = Path(__file__).parent
DEFAULT_ROBOT = "talos"


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


def read_description(name_or_path: str) -> dict:
    """Read a robot description by bundled name (``talos``, in any case) or JSON path."""
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
    for key in ("name", "feet", "sole", "pelvis"):
        if key not in desc:
            raise Error(f"robot description {path} lacks the key {key!r}")
    if "urdf" in desc and not Path(desc["urdf"]).is_absolute():
        desc["urdf"] = str((path.parent / desc["urdf"]).resolve())
    return desc


def _load_full_model(desc: dict, visuals: bool = False):
    """The unreduced model and the reference posture named by the description, if any;
    with ``visuals``, also the URDF's visual geometry model."""
    visual = None
    if "example_robot_data" in desc:
        import example_robot_data

        try:
            wrapper = example_robot_data.load(desc["example_robot_data"])
        except Exception as exc:  # the loader raises bare ValueError/KeyError for unknown names
            raise Error(f"example-robot-data cannot load {desc['example_robot_data']!r}: {exc}") from None
        model, visual = wrapper.model, wrapper.visual_model
    elif "urdf" in desc:
        urdf = Path(desc["urdf"])
        if not urdf.exists():
            raise Error(f"URDF not found: {urdf}")
        try:
            model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
            if visuals:
                visual = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.VISUAL, [str(urdf.parent)])
        except (RuntimeError, ValueError) as exc:
            raise Error(f"cannot parse URDF {urdf}: {exc}") from None
        if "srdf" in desc:
            pin.loadReferenceConfigurations(model, desc["srdf"], False)
    else:
        raise Error(f"robot description {desc['name']!r} names neither 'urdf' nor 'example_robot_data'")
    posture_name = desc.get("reference_posture")
    q_ref = None
    if posture_name is not None:
        try:
            q_ref = np.array(model.referenceConfigurations[posture_name])
        except (KeyError, IndexError):
            raise Error(f"robot {desc['name']!r} has no reference posture {posture_name!r}") from None
    if visuals:
        return model, q_ref, visual
    return model, q_ref


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
    mirror_perm, mirror_sign : ndarray (nu,)
        Left/right mirror map: mirrored joint ``i`` is ``mirror_sign[i] * q[mirror_perm[i]]``.
    """

    def __init__(self, name_or_path: str = DEFAULT_ROBOT):
        desc = read_description(name_or_path)
        self.description = desc
        self._visual: pin.GeometryModel | None = None  # visual_model(), loaded on first use
        self.name: str = desc["name"]
        full, q_full_ref = _load_full_model(desc)
        if full.joints[1].shortname() != "JointModelFreeFlyer":
            raise Error(f"robot {self.name!r} has no floating base (free-flyer root joint)")
        if q_full_ref is None:
            q_full_ref = pin.neutral(full)
        locked = _locked_joint_ids(full, desc)
        self.model: pin.Model = pin.buildReducedModel(full, locked, q_full_ref) if locked else full
        self.q_ref = self._reduce_configuration(full, q_full_ref)
        self.nu = self.model.nv - 6
        for joint in self.model.joints[2:]:
            if joint.nq != 1 or joint.nv != 1:
                raise Error(f"robot {self.name!r}: only 1-DOF actuated joints are supported")
        self.joint_names: list[str] = list(self.model.names[2:])
        self.q_lower = np.array(self.model.lowerPositionLimit[7:])
        self.q_upper = np.array(self.model.upperPositionLimit[7:])
        self.v_max = np.array(self.model.velocityLimit[6:])
        self.tau_max = np.array(self.model.effortLimit[6:])
        self.mass = float(pin.computeTotalMass(self.model))
        self.foot_frames = {side: self._frame_id(desc["feet"][side]) for side in ("left", "right")}
        self.pelvis_frame = self._frame_id(desc["pelvis"])
        self.sole = Sole(**desc["sole"])
        # longest step (m) the description vouches for; beyond it the stance may still be
        # kinematically possible but walking is not (legs nearly straight)
        self.max_step_length = float(desc.get("max_step_length", np.inf))
        self.mirror_perm, self.mirror_sign = self._derive_mirror_map()
        self.inertia_asymmetry = self._symmetrize_inertias() if desc.get("symmetrize_inertias", True) else 0.0

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

    def partner_name(self, name: str) -> str:
        """The left/right counterpart of a joint or frame name (the name itself if central)."""
        sides = self.description.get("side_names", {"left": "left", "right": "right"})
        pairs = [(sides["left"], sides["right"])]
        if "left_lower" in sides:
            pairs.append((sides["left_lower"], sides["right_lower"]))
        for a, b in pairs:
            for x, y in ((a, b), (b, a)):
                if name.startswith(x) and (len(x) > 1 or name[len(x) : len(x) + 1].isupper()):
                    return y + name[len(x) :]
                token = f"_{x}_"
                if len(x) > 1 and token in name:
                    return name.replace(token, f"_{y}_", 1)
        return name

    def _derive_mirror_map(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint permutation and signs of the sagittal (y -> -y) reflection.

        A rotation about axis ``a`` by ``theta`` reflects to a rotation about ``P a`` by
        ``-theta`` (``P = diag(1, -1, 1)``), so the partner joint turns with sign
        ``-(P a) . b`` where ``b`` is the partner's axis, both taken in the world frame at
        the reference posture.
        """
        model, data = self.model, self.model.createData()
        pin.forwardKinematics(model, data, self.q_ref)
        P = np.diag([1.0, -1.0, 1.0])
        axes = {}
        for jid in range(2, model.njoints):
            motion = model.joints[jid].shortname()
            local = {"X": [1.0, 0, 0], "Y": [0, 1.0, 0], "Z": [0, 0, 1.0]}.get(motion[-1])
            if local is None:
                raise Error(f"robot {self.name!r}: joint {model.names[jid]!r} is not a revolute X/Y/Z joint")
            axes[model.names[jid]] = data.oMi[jid].rotation @ np.array(local)
        perm = np.zeros(self.nu, dtype=int)
        sign = np.zeros(self.nu)
        for i, name in enumerate(self.joint_names):
            partner = self.partner_name(name)
            if partner not in axes:
                raise Error(f"robot {self.name!r}: joint {name!r} has no mirror partner {partner!r}")
            alignment = -(P @ axes[name]) @ axes[partner]
            if abs(alignment) < 0.95:
                raise Error(
                    f"robot {self.name!r}: joints {name!r} and {partner!r} are not mirror images "
                    f"at the reference posture (axis alignment {alignment:.2f})"
                )
            perm[i] = self.joint_names.index(partner)
            sign[i] = np.sign(alignment)
        return perm, sign

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
            partner = model.getJointId(self.partner_name(model.names[jid]))
            own, other = model.inertias[jid], model.inertias[partner]
            # the partner's inertia reflected through the world and read in this link's frame
            R_o, p_o = data_m.oMi[partner].rotation, data_m.oMi[partner].translation
            R_s, p_s = data.oMi[jid].rotation, data.oMi[jid].translation
            com_w = P @ (R_o @ other.lever + p_o)
            lever = R_s.T @ (com_w - p_s)
            rot = R_s.T @ P @ R_o @ other.inertia @ R_o.T @ P @ R_s
            averaged.append(
                pin.Inertia(
                    0.5 * (own.mass + other.mass),
                    0.5 * (own.lever + lever),
                    0.5 * (own.inertia + rot),
                )
            )
        change = max(float(np.abs(a.lever - model.inertias[j].lever).max()) for j, a in enumerate(averaged, 1))
        for jid, inertia in enumerate(averaged, 1):
            model.inertias[jid] = inertia
        return change

    def visual_model(self) -> pin.GeometryModel:
        """The URDF's visual meshes, attached to the joints of the reduced model.

        Loaded on first use (reading the meshes takes about a second) and shared by later
        calls: do not modify it."""
        if self._visual is None:
            full, q_full_ref, visual = _load_full_model(self.description, visuals=True)
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
        other joints named ``arm...``) and the ``torso`` (the rest, the head among them)."""
        legs = set(self.leg_joint_indices())
        arms = [i for i, name in enumerate(self.joint_names) if i not in legs and name.startswith("arm")]
        torso = [i for i in range(self.nu) if i not in legs and i not in arms]
        return {"legs": np.array(sorted(legs), dtype=int), "torso": np.array(torso, dtype=int), "arms": np.array(arms, dtype=int)}

    def leg_roles(self) -> dict[str, dict[str, int]]:
        """Per side, the actuated-joint indices of hip roll and pitch, knee, and ankle pitch and
        roll, found by axis along the chain from the pelvis to the sole: the first X and Y
        joints are the hip's, the last Y and X the ankle's, the Y joint between them the knee."""
        out = {}
        for side in self.foot_frames:
            chain = self.leg_chain(side)
            axis = {i: self.model.joints[i + 2].shortname()[-1] for i in chain}
            xs = [i for i in chain if axis[i] == "X"]
            ys = [i for i in chain if axis[i] == "Y"]
            if len(xs) < 2 or len(ys) < 3:
                raise Error(f"robot {self.name!r}: the {side} leg has no hip-knee-ankle pitch and roll joints")
            out[side] = {"hip_roll": xs[0], "hip_pitch": ys[0], "knee": ys[1], "ankle_pitch": ys[-1], "ankle_roll": xs[-1]}
        return out

    def state_from_posture(self, q: np.ndarray) -> np.ndarray:
        """A static state ``x = (q, 0)``."""
        return np.concatenate([q, np.zeros(self.model.nv)])

    def frame_placement(self, q: np.ndarray, frame: int) -> pin.SE3:
        data = self.model.createData()
        pin.framesForwardKinematics(self.model, data, q)
        return data.oMf[frame].copy()

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, nq={self.model.nq}, nv={self.model.nv}, actuated={self.nu})"
