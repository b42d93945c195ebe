"""A whole walk from optimal control: one OCP per step, chained (the paper's M_opt).

Every step of length L begins in the gait state S(L) (the start of the cyclic step of
that length) and its OCP pins its end to the next step's start state, as in the training
data; so consecutive steps join.  The S(L) of each length and every step already solved
come from a dataset (by default the bundled one); the steps it lacks (for M_opt the
transitions 250 -> 350 and 350 -> 250 mm) are solved here.  Steps are solved with the
right foot in support and mirrored when the other foot supports, then placed on their
footsteps in one world-frame :class:`Motion`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from tqdm import tqdm

from cocomopl.errors import Error
from cocomopl.gait import OTHER_SIDE, footsteps
from cocomopl.motion import SAMPLED, Motion, SolutionRecord, StepSpec
from cocomopl.ocp.problems import translate_state, turn_state
from cocomopl.ocp.settings import OCPSettings
from cocomopl.ocp.solve import solve_transition
from cocomopl.robot import Robot, mirror_motion


def _right_support(spec: StepSpec) -> StepSpec:
    return spec if spec.swing_side == "left" else spec.mirrored()


def solve_step_motion(robot: Robot, spec: StepSpec, motions: dict[str, Motion], *, settings: dict) -> Motion:
    """The motion of one step in its own frame (stance sole at the origin): from ``motions``
    if solved there; a missing transition is solved between the gait states of its lengths,
    with the timing of the gait it leaves, exactly as the dataset's transitions are."""
    right = _right_support(spec)
    if right.name not in motions:
        cyclic = {L: StepSpec("cyclic", L, L).name for L in (right.start_length, right.end_length)}
        missing = [name for name in cyclic.values() if name not in motions]
        if right.kind != "transition" or missing:
            raise Error(f"cannot solve {spec.name}: the dataset has no {', '.join(missing) or right.name}")
        solved, attempts = solve_transition(
            robot, OCPSettings.from_saved(settings), right, cyclic_from=motions[cyclic[right.start_length]],
            cyclic_to=motions[cyclic[right.end_length]]
        )
        if solved is None:
            raise Error(f"the OCP of {right.name} did not converge: {attempts}")
        motions[right.name] = solved
    motion = motions[right.name]
    return motion if spec.swing_side == "left" else mirror_motion(robot, motion)


def place(robot: Robot, motion: Motion, stance_xy: np.ndarray, *, stance_yaw: float = 0.0) -> Motion:
    """A step motion moved from its own frame onto the world pose of its stance sole: turned
    by ``stance_yaw`` (rad) about the vertical, then moved to ``stance_xy``.  Velocities are
    in the base frame (unchanged); the ZMP and the wrenches' world-aligned axes turn."""
    q = translate_state(robot, turn_state(robot, motion.q, stance_yaw), stance_xy[:2])
    c, s = np.cos(stance_yaw), np.sin(stance_yaw)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    zmp = motion.zmp @ rotation.T
    zmp[:, :2] += stance_xy[:2]
    wrenches = np.concatenate([motion.wrenches[..., :3] @ rotation.T, motion.wrenches[..., 3:] @ rotation.T], axis=-1)
    return dataclasses.replace(motion, q=q, zmp=zmp, wrenches=wrenches)


def concatenate(steps: list[Motion]) -> Motion:
    """One motion of consecutive steps.  A step ends in the state the next one starts in;
    that sample is kept once, as the next step's first (whose torques and wrenches hold
    over the interval after it)."""
    parts, offset, count = [], 0.0, 0
    phases, impacts, starts = [], [], []
    for k, m in enumerate(steps):
        n = m.n if k == len(steps) - 1 else m.n - 1
        parts.append((m, n, m.t[:n] - m.t[0] + offset))
        starts.append(count)
        phases += [(kind, first + count, last + count) for kind, first, last in m.phases]
        impacts += [int(i) + count for i in m.impacts]
        offset += m.t[-1] - m.t[0]
        count += n

    first = steps[0]
    return Motion(
        t=np.concatenate([t for _, _, t in parts]),
        **{field: np.concatenate([getattr(m, field)[:n] for m, n, _ in parts]) for field in SAMPLED},
        phases=phases,
        impacts=np.array(impacts, dtype=int),
        steps=[s for m in steps for s in m.steps],
        step_starts=np.array(starts, dtype=int),
        joint_names=list(first.joint_names),
        robot=first.robot,
        producer="ocp",
        solution=SolutionRecord(solver=[None if m.solution is None else m.solution.solver for m in steps]),
    )


def solve_sequence(
    robot: Robot,
    specs: list[StepSpec],
    motions: dict[str, Motion],
    *,
    settings: dict,
    progress: bool = False,
) -> Motion:
    """The walk ``specs`` from chained step OCPs, as one world-frame :class:`Motion`.

    ``motions`` is a dataset's motions by name and ``settings`` its OCP settings: its cyclic
    steps give the gait states, and its solved steps are reused (steps solved here are added
    to it; their names are in ``solution.solved_now``).  The footsteps are those of
    :func:`cocomopl.gait.footsteps`, the same as a generated walk's.
    """
    known = set(motions)
    placed = []
    for spec, feet in tqdm(list(zip(specs, footsteps(robot, specs))), desc="M_opt steps", disable=not progress, leave=False):
        stance = OTHER_SIDE[spec.swing_side]
        motion = solve_step_motion(robot, spec, motions, settings=settings)
        # a step's frame: the stance sole at the origin, facing +x
        placed.append(place(robot, motion, feet["start"][stance][:2], stance_yaw=feet["yaw"]["start"][stance]))
    walk = concatenate(placed)
    walk.solution = dataclasses.replace(walk.solution, solved_now=sorted(set(motions) - known))  # the rest came from ``motions``
    return walk
