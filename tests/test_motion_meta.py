"""A motion's typed metadata (producer, plan, solution, simulation records) and its JSON attribute ``meta``."""

import dataclasses
import json

import h5py

from cocomopl.data import BUNDLED_DATASET
from cocomopl.motion import Motion, PlanRecord, RolloutRecord, SolutionRecord
from cocomopl.motion_file import read_motion, read_motions, write_motions

from conftest import synthetic

PLAN = PlanRecord(dynamics_filter_zmp_error_m=[0.02, 0.004], dynamics_filter_kept_error_m=0.004,
                  upper_body_limits={"corrected": False}, plan_zmp_error_m=0.005, model="model.npz",
                  footsteps=[{"x_m": 0.25, "y_m": 0.1, "yaw_deg": 0.0, "side": "left"}])
SIMULATION = RolloutRecord(reference_producer="primitives", stabilizer=True, stabilizer_gains={"d": 3000.0},
                           reference_cutoff_hz=0.0, feedforward=False, fell=False, fall_time_s=None, timestep_s=0.001,
                           sim_model=None, contact_time_constant_s=0.005, servos={"latency_s": 0.0}, pushes=[],
                           recoveries=[])


def _meta_attribute(path, name):
    with h5py.File(path) as f:
        return f["motions"][name].attrs["meta"]


def _typed(motion):
    return motion.producer, motion.plan, motion.solution, motion.simulation, motion.meta


def test_the_bundled_datasets_meta_reads_as_typed_fields_and_writes_back_the_same_attribute(tmp_path):
    motions, _ = read_motions(BUNDLED_DATASET)
    out = tmp_path / "again.h5"
    write_motions(out, motions, {"robot": "talos"})
    again, _ = read_motions(out)
    for name, motion in motions.items():
        assert motion.producer == "ocp" and isinstance(motion.solution, SolutionRecord) and motion.meta == {}
        assert motion.plan is None and motion.simulation is None
        assert motion.solution.mirrored is (True if name.endswith("_R") else None)
        assert _typed(again[name]) == _typed(motion)
        assert _meta_attribute(out, name) == _meta_attribute(BUNDLED_DATASET, name)


def test_typed_fields_and_free_form_meta_round_trip_in_one_json_object(robot, tmp_path):
    planned = dataclasses.replace(synthetic(robot, [0.0, 0.1]), producer="primitives", plan=PLAN, meta={"note": "x"})
    measured = dataclasses.replace(synthetic(robot, [0.0, 0.1]), producer="mujoco", simulation=SIMULATION)
    for motion in (planned, measured):
        out = tmp_path / f"{motion.producer}.h5"
        write_motions(out, {"walk": motion}, {"robot": robot.name})
        read = read_motion(out)
        assert _typed(read) == _typed(motion)
        stored = json.loads(_meta_attribute(out, "walk"))
        assert next(iter(stored)) == "producer" and stored == motion.meta_json()
    # fields left unset are not written; the free-form keys come after the typed ones
    assert list(planned.meta_json()) == ["producer", "dynamics_filter_zmp_error_m", "dynamics_filter_kept_error_m",
                                         "upper_body_limits", "plan_zmp_error_m", "model", "footsteps", "note"]
    assert "reaimed" not in measured.meta_json() and measured.meta_json()["fall_time_s"] is None


def test_keys_of_an_incomplete_record_stay_free_form():
    split = Motion.split_meta({"producer": "kajita", "plan_zmp_error_m": 0.01, "walking_span_s": [0.0, 1.0]})
    assert split == {"producer": "kajita", "plan": None, "solution": None, "simulation": None,
                     "meta": {"plan_zmp_error_m": 0.01, "walking_span_s": [0.0, 1.0]}}
