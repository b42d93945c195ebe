"""The online generator driving the simulated robot live, tick by tick, steered by a callback.

Each 5 ms control tick a callback (here a script in time: forward, on the spot, sideways,
stop) may give a new velocity command; the generator (``cocomopl.online.WalkingGenerator``)
returns that tick's references, whose joint angles go straight to the simulated robot's
position servos (offset by the tick's feed-forward torques where the robot's servos take
them by default, as G1's: ``(tau + kv qdot) / kp``), and MuJoCo runs to the next tick.  No
stabilizer: the plain loop a robot's controller would run.  Prints whether the robot stood, where it ended, and
the generator's compute per tick against the 5 ms it has.

    python scripts/online_loop.py [--robot g1] [--seconds 16] [--json]
"""

import argparse
import json
import sys
import time
import warnings

import mujoco
import numpy as np

from cocomopl.data import model_path
from cocomopl.errors import Error
from cocomopl.online import VelocityCommand, WalkingGenerator
from cocomopl.pipeline import SimSettings, servo_feedforward
from cocomopl.primitives.model_file import load_model, model_robot
from cocomopl.sim.mujoco_model import build_sim_model
from cocomopl.sim.rollout import placed_on_floor

FELL_HEIGHT = 0.5  # of the pelvis's standing height: below it, the robot has fallen


def steer(t: float) -> VelocityCommand | None:
    """The callback: a new command at time ``t`` (s), or None to keep the last one."""
    script = {0.0: VelocityCommand(0.15), 3.0: VelocityCommand(yaw_rate=0.25), 6.0: VelocityCommand(sideways=0.05),
              9.0: VelocityCommand()}
    return next((command for at, command in script.items() if abs(t - at) < 1e-9), None)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="talos", help="a bundled robot, talos or g1 (default: talos)")
    parser.add_argument("--seconds", type=float, default=16.0, help="seconds to run (default: 16)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    if not 0.1 <= args.seconds <= 600:
        parser.exit(2, f"online_loop.py: error: --seconds {args.seconds:g} is outside 0.1..600\n")
    try:
        model = load_model(model_path(omni=True, robot=args.robot)).prepare()
    except Error as exc:
        parser.exit(2, f"online_loop.py: error: {exc}\n")
    robot = model_robot(model)
    generator = WalkingGenerator(model, robot)
    sim = build_sim_model(robot, visuals=False)
    data = mujoco.MjData(sim.mj)
    feedforward = servo_feedforward(SimSettings(), robot)
    kp, kv = sim.servo_gains()
    substeps = round(generator.dt / sim.mj.opt.timestep)
    compute, fell_at, standing_height = [], None, None
    while generator.time < args.seconds:
        started = time.perf_counter()
        command = steer(round(generator.time, 6))
        if command is not None:
            generator.command(command)
        reference = generator.tick()
        compute.append(time.perf_counter() - started)
        if standing_height is None:  # the robot starts at rest on the floor in the first tick's posture
            placed_on_floor(sim, data, reference.q)
            standing_height = data.qpos[2]
        offset = (reference.tau + kv * reference.v[6:]) / kp if feedforward else 0.0
        sim.command(data, reference.q[7:] + offset)
        for _ in range(substeps):
            mujoco.mj_step(sim.mj, data)
        if data.qpos[2] < FELL_HEIGHT * standing_height:
            fell_at = generator.time
            break
    compute = np.array(compute)
    report = {"robot": robot.name, "feedforward": feedforward, "seconds": generator.time, "fell": fell_at is not None, "fall_time_s": fell_at,
              "end_position_m": [float(x) for x in data.qpos[:2]],
              "planned_end_position_m": [float(x) for x in reference.q[:2]], "tick_median_s": float(np.median(compute)),
              "tick_p99_s": float(np.percentile(compute, 99)), "tick_max_s": float(compute.max()),
              "control_period_s": generator.dt}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{robot.name}: {'fell at ' + format(fell_at, '.2f') + ' s' if fell_at else 'stood'} over "
              f"{report['seconds']:.2f} s, ending at x = {report['end_position_m'][0]:.2f} m, "
              f"y = {report['end_position_m'][1]:.2f} m (planned {report['planned_end_position_m'][0]:.2f}, "
              f"{report['planned_end_position_m'][1]:.2f} m)")
        print(f"generator per {1e3 * generator.dt:.0f} ms tick: median {1e3 * report['tick_median_s']:.2f} ms, "
              f"p99 {1e3 * report['tick_p99_s']:.2f} ms, max {1e3 * report['tick_max_s']:.2f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
