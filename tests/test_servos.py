"""The servo model: per-group gains, control latency and encoder noise."""

import numpy as np
import pytest

from cocomopl.data import BUNDLED_DATASET
from cocomopl.errors import Error
from cocomopl.motion_file import read_motion
from cocomopl.sim.mujoco_model import build_sim_model
from cocomopl.sim.rollout import simulate
from cocomopl.sim.servos import CommandChannel, ServoSettings, with_gains


@pytest.fixture(scope="module")
def sim(robot):
    return build_sim_model(robot, visuals=False)


def test_gains_are_set_per_group_on_a_copy(robot, sim):
    settings = ServoSettings(kp_scale={"all": 0.5, "legs": 2.0}, kv_time_s={"arms": 0.01})
    other = with_gains(sim, settings)
    kp, kv = other.servo_gains()
    kp0, kv0 = sim.servo_gains()
    groups = robot.joint_groups()
    assert np.allclose(kp[groups["legs"]], 2.0 * kp0[groups["legs"]])
    assert np.allclose(kp[groups["torso"]], 0.5 * kp0[groups["torso"]])
    assert np.allclose(kv[groups["arms"]], 0.01 * kp[groups["arms"]])
    assert np.allclose(kv[groups["legs"]], kv0[groups["legs"]])  # kv not named: the model's own
    assert np.allclose(sim.servo_gains(), [kp0, kv0]) and other.mj is not sim.mj  # the model given is untouched
    assert set(np.concatenate(list(groups.values()))) == set(range(robot.nu))


def test_commands_reach_the_servos_after_the_latency_with_the_encoder_noise():
    channel = CommandChannel(ServoSettings(latency_s=0.003), timestep=0.001, n=2)
    received = [channel.received(np.full(2, float(k)))[0] for k in range(6)]
    assert received == [0.0, 0.0, 0.0, 0.0, 1.0, 2.0]  # 3 control steps late, the first command held before
    noisy = CommandChannel(ServoSettings(encoder_noise_rad=0.002, seed=4), timestep=0.001, n=30)
    offsets = np.array([noisy.received(np.zeros(30)) for _ in range(200)])
    assert np.std(offsets) == pytest.approx(0.002, rel=0.05) and abs(offsets.mean()) < 2e-4


@pytest.mark.slow
def test_an_oc_step_walks_with_5_ms_latency_and_encoder_noise(robot, sim):
    reference = read_motion(BUNDLED_DATASET, "start_250_L")
    servos = ServoSettings(latency_s=0.005, encoder_noise_rad=0.001, seed=1)
    rollout = simulate(sim, reference, stabilizer=True, servos=servos)
    assert not rollout.fell
    assert rollout.measured.simulation.servos["latency_s"] == 0.005


@pytest.mark.parametrize("settings, message", [
    ({"kp_scale": {"knees": 1.0}}, "servo group 'knees' is not one of"),
    ({"kp_scale": {"legs": 0.0}}, "kp scale 0.0 of the legs"),
    ({"kv_time_s": {"all": float("nan")}}, "kv time constant nan"),
    ({"latency_s": 0.5}, "latency 0.5 s is outside"),
    ({"encoder_noise_rad": -1.0}, "encoder noise -1.0 rad"),
])
def test_bad_servo_settings_are_refused_in_one_line(settings, message):
    with pytest.raises(Error, match=message) as raised:
        ServoSettings(**settings)
    assert "\n" not in str(raised.value)
