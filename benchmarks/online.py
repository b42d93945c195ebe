"""The streaming generator (``cocomopl.online``) against the whole-walk placement, side by side.

* **M_gen streamed**: the robot's bundled straight model walks M_gen through
  :class:`~cocomopl.online.WalkingGenerator` (5 ms ticks) from standing to standing again;
  the compute of every tick (median, p99, max), their sum (the streaming path's placement
  of M_gen) against :func:`~cocomopl.synthesis.world.place_steps` on the same steps (the
  whole-walk filter), and both plans judged alike: the RMS of the multibody ZMP against the
  reference on the knots (``rms_zmp_error``), ``check_motion``'s ZMP margin and torque
  ratio, the export's safety gate on every streamed 5 ms sample, and both plans played in
  MuJoCo as ``cocomopl walk`` plays a plan, with and without the stabilizer.
* **Commands**: the bundled step-space model walks a velocity-command script (forward,
  turn on the spot, sideways, backwards, stop; 3 s each); per command the compute of the
  command and of the tick after it (the replan latency) and the time until the streamed
  references first differ from those of the walk without that command.
* Peak resident memory of the process.

    python benchmarks/online.py [--robot g1] [--json]
"""

import argparse
import json
import resource
import sys
import time
import warnings

import numpy as np

from cocomopl.analysis.feasibility import check_motion
from cocomopl.data import model_path
from cocomopl.errors import Error
from cocomopl.export.safety import check_safe
from cocomopl.gait import m_gen, sequence_specs
from cocomopl.motion import Footstep
from cocomopl.online import VelocityCommand, WalkingGenerator, grid_of
from cocomopl.pipeline import SimSettings, simulate_walk
from cocomopl.primitives.model_file import load_model, model_robot
from cocomopl.requests import PLAN_DT
from cocomopl.synthesis.dynamics_filter import plan_zmp_error
from cocomopl.synthesis.step_chain import generate_steps
from cocomopl.synthesis.world import place_steps

FRICTION = 0.7
SCRIPT = ((0.0, VelocityCommand(0.2)), (3.0, VelocityCommand(yaw_rate=0.3)), (6.0, VelocityCommand(sideways=0.08)),
          (9.0, VelocityCommand(-0.1)), (12.0, VelocityCommand()))
SCRIPT_END_S = 17.0


def walk_until_standing(generator, max_s: float = 60.0) -> tuple[list, np.ndarray]:
    """Tick until the walk has stood still for a second after its last step: references and tick times (s)."""
    references, times, standing = [], [], 0
    while generator.time < max_s:
        started = time.perf_counter()
        references.append(generator.tick())
        times.append(time.perf_counter() - started)
        walked = any(r.step is not None for r in references)
        standing = standing + 1 if walked and references[-1].step is None else 0
        if standing * generator.dt >= 1.0:
            break
    return references, np.array(times)


def plan_figures(robot, motion) -> dict:
    report = check_motion(robot, motion, FRICTION)
    simulated = {}
    for stabilizer in (True, False):
        rollout, metrics = simulate_walk(robot, motion, SimSettings(stabilizer=stabilizer))
        simulated["with_stabilizer" if stabilizer else "without_stabilizer"] = {
            "fell": rollout.fell, "peak_force_over_weight": metrics.peak_force_over_weight}
    return {"zmp_error_rms_m": plan_zmp_error(robot, motion), "zmp_margin_m": report["zmp_margin"],
            "torque_ratio": report["torque_ratio"], "knots": motion.n, "simulated": simulated}


def m_gen_streamed(model, robot) -> dict:
    lengths = m_gen(robot)
    generator = WalkingGenerator(model, robot, keep_knots=True)
    generator.walk_footsteps([Footstep(length) for length in lengths[:-1]])
    references, times = walk_until_standing(generator)
    reasons, _ = check_safe(robot, grid_of(references))
    started = time.perf_counter()
    whole = place_steps(robot, generate_steps(model, sequence_specs(list(lengths))), dt=PLAN_DT)
    whole_s = time.perf_counter() - started
    return {"ticks": len(times), "walk_s": references[-1].t, "tick_median_s": float(np.median(times)),
            "tick_p99_s": float(np.percentile(times, 99)), "tick_max_s": float(times.max()),
            "placement_s": float(times.sum()), "placement_whole_walk_s": whole_s,
            "streamed": plan_figures(robot, generator.knot_motion()), "whole_walk": plan_figures(robot, whole),
            "gate_failures": reasons}


def commands_walked(model, robot) -> dict:
    """The command script, and per command the replan latency and when the references change."""
    def run(script):
        generator = WalkingGenerator(model, robot)
        references, latencies, pending = [], [], list(script)
        while generator.time < SCRIPT_END_S:
            if pending and generator.time >= pending[0][0] - 1e-9:
                started = time.perf_counter()
                generator.command(pending.pop(0)[1])
                references.append(generator.tick())
                latencies.append(time.perf_counter() - started)
            else:
                references.append(generator.tick())
        return references, latencies

    references, latencies = run(SCRIPT)
    changes = []
    for k in range(1, len(SCRIPT)):
        before, _ = run(SCRIPT[:k])
        at = next(i for i, r in enumerate(references) if r.t >= SCRIPT[k][0] - 1e-9)
        differ = next((i for i in range(at, len(before)) if np.abs(before[i].q - references[i].q).max() > 1e-9), None)
        changes.append(None if differ is None else references[differ].t - SCRIPT[k][0])
    return {"commands": len(SCRIPT), "replan_latency_s": latencies, "reference_change_after_s": changes,
            "end_pose": [float(v) for v in references[-1].q[:3]]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", metavar="NAME", default="talos", help="a bundled robot, talos or g1 (default: talos)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    try:
        straight = load_model(model_path(robot=args.robot)).prepare()
        omni = load_model(model_path(omni=True, robot=args.robot)).prepare()
    except Error as exc:
        parser.exit(2, f"online.py: error: {exc}\n")
    robot = model_robot(straight)
    mgen = m_gen_streamed(straight, robot)
    commands = commands_walked(omni, robot)
    report = {
        "robot": robot.name,
        "tick_median_s": mgen["tick_median_s"], "tick_p99_s": mgen["tick_p99_s"], "tick_max_s": mgen["tick_max_s"],
        "replan_latency_s": max(commands["replan_latency_s"][1:]),  # the first command starts the pipeline's walk
        "m_gen_placement_s": mgen["placement_s"], "m_gen_placement_whole_walk_s": mgen["placement_whole_walk_s"],
        "m_gen": mgen, "commands": commands,
        "peak_memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    if args.json:
        print(json.dumps(report))
        return 0
    s, w = mgen["streamed"], mgen["whole_walk"]
    print(f"{robot.name}: M_gen streamed, {mgen['ticks']} ticks of 5 ms ({mgen['walk_s']:.2f} s of walk)")
    print(f"  tick compute: median {1e3 * mgen['tick_median_s']:.3f} ms, p99 {1e3 * mgen['tick_p99_s']:.3f} ms, "
          f"max {1e3 * mgen['tick_max_s']:.2f} ms")
    print(f"  placement: streamed {mgen['placement_s']:.2f} s (all ticks), whole walk {mgen['placement_whole_walk_s']:.2f} s")
    print(f"  ZMP error RMS: streamed {1e3 * s['zmp_error_rms_m']:.1f} mm, whole walk {1e3 * w['zmp_error_rms_m']:.1f} mm; "
          f"ZMP margin {1e3 * s['zmp_margin_m']:.0f} / {1e3 * w['zmp_margin_m']:.0f} mm; "
          f"torque ratio {s['torque_ratio']:.2f} / {w['torque_ratio']:.2f}")
    for key, label in (("with_stabilizer", "with"), ("without_stabilizer", "without")):
        a, b = s["simulated"][key], w["simulated"][key]
        print(f"  MuJoCo {label} the stabilizer: streamed {'falls' if a['fell'] else 'stands'}, peak "
              f"{a['peak_force_over_weight']:.2f} x weight; whole walk {'falls' if b['fell'] else 'stands'}, "
              f"peak {b['peak_force_over_weight']:.2f}")
    print(f"  export gate on every streamed sample: {'passes' if not mgen['gate_failures'] else '; '.join(mgen['gate_failures'])}")
    print(f"commands: replan latency {', '.join(f'{1e3 * x:.2f}' for x in commands['replan_latency_s'])} ms; "
          f"references change {', '.join('-' if x is None else f'{x:.2f}' for x in commands['reference_change_after_s'])} s "
          "after each command")
    print(f"peak memory {report['peak_memory_mb']:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
