"""Guards against the pin/crocoddyl ABI mismatch.

pin 4.1.0 with crocoddyl 3.2.1 segfaults or raises MemoryError inside contact models.  The
contact-dynamics exercise runs in a child process, so a segfault fails this test instead
of killing the whole test session.
"""

import subprocess
import sys
from importlib.metadata import version

import pytest

CONTACT_EXERCISE = r"""
import numpy as np, crocoddyl, pinocchio as pin
from cocomopl.robot import Robot
robot = Robot("talos")
state = crocoddyl.StateMultibody(robot.model)
actuation = crocoddyl.ActuationModelFloatingBase(state)
contacts = crocoddyl.ContactModelMultiple(state, actuation.nu)
for side in ("left", "right"):
    contacts.addContact(side, crocoddyl.ContactModel6D(state, robot.foot_frames[side], pin.SE3.Identity(),
                        pin.LOCAL_WORLD_ALIGNED, actuation.nu, np.array([0.0, 30.0])))
costs = crocoddyl.CostModelSum(state, actuation.nu)
model = crocoddyl.IntegratedActionModelEuler(
    crocoddyl.DifferentialActionModelContactFwdDynamics(state, actuation, contacts, costs), 0.01)
data = model.createData()
x = np.concatenate([robot.q_ref, np.zeros(robot.model.nv)])
for _ in range(50):
    model.calc(data, x, np.zeros(actuation.nu))
    model.calcDiff(data, x, np.zeros(actuation.nu))
assert np.all(np.isfinite(data.Fx)) and np.all(np.isfinite(data.xnext))
print("ok")
"""


def test_pinned_versions_are_installed():
    assert version("pin") == "4.0.0"
    assert version("crocoddyl") == "3.2.1"


@pytest.mark.slow
def test_contact_dynamics_run_without_crashing():
    result = subprocess.run([sys.executable, "-c", CONTACT_EXERCISE], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, f"exit {result.returncode}: {result.stderr[-2000:]}"
    assert result.stdout.strip() == "ok"
