"""Shared fixtures: the robot and one small dataset, solved once per test session.

The OCPs here are deliberately coarse (50 ms knots, short phases): the tests check
properties -- dynamics, mirroring, continuity, limits -- not the quality of the gait.  They
leave out the default knee bend and load transfer, which the coarse knots hold only roughly;
each has its own test on the small cyclic step.
"""

from pathlib import Path

import pytest

from cocomopl.ocp.action_models import OCPSettings
from cocomopl.robot import Robot

SMALL = OCPSettings(
    dt=0.05, ds_duration=0.1, ss_duration=0.6, ss_search_step=0.0, start_ds_duration=0.3, rest_duration=0.2,
    max_iterations=150, w_load_transfer=0.0, min_knee_flexion=0.0,
)
SMALL_LENGTH = 0.2


@pytest.fixture(scope="session")
def robot() -> Robot:
    return Robot("talos")


@pytest.fixture(scope="session")
def small_dataset(tmp_path_factory) -> Path:
    from cocomopl.dataset.generate import generate

    out = tmp_path_factory.mktemp("dataset") / "small.h5"
    summary = generate(out, (SMALL_LENGTH,), settings=SMALL, workers=2, command="pytest", progress=False)
    assert summary["failed"] == [], summary
    return out
