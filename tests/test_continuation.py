"""Dataset generation's bookkeeping.  Continuation: each length's walk warm-starts the next in its sweep,
and each length keeps the better of the two sweeps.  The solver is replaced by a stand-in
that records what it was given, so the bookkeeping is checked without solving.  Saved OCP
settings: read as they were solved."""

import concurrent.futures as cf
import json

import numpy as np
import pytest

from cocomopl.dataset import generate as module
from cocomopl.dataset.generate import JobResult, settings_problem, solve_by_continuation
from cocomopl.errors import Error
from cocomopl.motion import SolutionRecord, StepSpec
from cocomopl.ocp.settings import OCPSettings


class InlineExecutor(cf.Executor):
    """Runs each job at once, in this process."""

    def submit(self, fn, /, *args, **kwargs):
        future = cf.Future()
        future.set_result(fn(*args, **kwargs))
        return future


class FakeMotion:
    def __init__(self, cost, q):
        self.solution = SolutionRecord(solver={"cost": cost})
        self.q = q


def test_each_sweep_continues_from_its_last_walk_and_each_length_keeps_the_cheaper_sweep(monkeypatch):
    calls = []

    def fake_length_job(robot_name, settings, length, kinds, cyclic=None, neighbour_walk=None):
        calls.append((length, None if neighbour_walk is None else float(neighbour_walk[0])))
        seen = sum(1 for L, _ in calls if length == L)  # 1 in the first sweep to reach it, 2 in the other
        cost = {0.15: (1.0, 2.0), 0.2: (3.0, 1.0), 0.25: (5.0, 5.5)}[length][seen - 1]
        q = np.full((4, 10), cost)
        return JobResult(motions={StepSpec("cyclic", length, length): FakeMotion(cost, q)}, walk=np.array([length]))

    monkeypatch.setattr(module, "length_job", fake_length_job)
    kept = []
    todo = {L: ["cyclic"] for L in (0.15, 0.2, 0.25)}
    record = solve_by_continuation(InlineExecutor(), "talos", OCPSettings(), todo=todo, done={}, collect=kept.append)

    # every length after a sweep's first is warm-started from the length solved before it in that sweep
    assert (0.15, None) in calls and (0.25, None) in calls
    assert (0.2, 0.15) in calls and (0.25, 0.2) in calls  # up
    assert (0.2, 0.25) in calls and (0.15, 0.2) in calls  # down
    assert len(calls) == 6
    # each length keeps its cheaper sweep and records both
    costs = {L: next(iter(r.motions.values())).solution.solver["cost"] for r in kept
             for L in [next(iter(r.motions)).start_length]}
    assert costs == {0.15: 1.0, 0.2: 1.0, 0.25: 5.0}
    assert set(record) == {"150", "200", "250"}
    assert record["200"]["ascending_cost"] != record["200"]["descending_cost"]
    assert record["150"]["cyclic_joint_difference_rad"] == 1.0


def test_a_single_length_is_solved_once(monkeypatch):
    calls = []

    def fake_length_job(robot_name, settings, length, kinds, cyclic=None, neighbour_walk=None):
        calls.append(length)
        return JobResult(motions={StepSpec("cyclic", length, length): FakeMotion(1.0, np.zeros((2, 8)))})

    monkeypatch.setattr(module, "length_job", fake_length_job)
    record = solve_by_continuation(InlineExecutor(), "talos", OCPSettings(), todo={0.2: ["cyclic"]}, done={},
                                   collect=lambda result: None)
    assert calls == [0.2]
    assert record["200"]["chosen"] == "ascending"


def test_settings_saved_before_the_upper_body_weights_read_as_they_were_solved():
    saved = OCPSettings(w_posture=2.0, w_velocity=0.4).as_dict()
    del saved["w_upper_posture"], saved["w_upper_velocity"]
    read = OCPSettings.from_saved(saved)
    assert (read.w_upper_posture, read.w_upper_velocity) == (2.0, 0.4)  # then the legs' weights held for every joint
    assert OCPSettings.from_saved(OCPSettings().as_dict()) == OCPSettings()


def test_a_part_saved_before_a_weight_existed_has_the_settings_it_was_solved_with():
    """A dataset or part written before the upper body's velocity weight existed is reusable
    under the defaults (the weight then was the legs'), and not under other values."""
    current = json.loads(json.dumps(OCPSettings().as_dict()))
    saved = {k: v for k, v in current.items() if k != "w_upper_velocity"}
    assert settings_problem(saved, current) is None
    changed = json.loads(json.dumps(OCPSettings(w_upper_velocity=1.0).as_dict()))
    assert "w_upper_velocity 0.1, now 1.0" in settings_problem(saved, changed)


def test_settings_of_an_unknown_kind_are_refused():
    with pytest.raises(Error, match="w_new"):
        OCPSettings.from_saved({**OCPSettings().as_dict(), "w_new": 1.0})
