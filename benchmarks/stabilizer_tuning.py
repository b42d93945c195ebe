"""The stabilizer's two main gains, tuned per walk generator, and how much the figures move with them.

For each generator (MP: the primitives; OC: chained step OCPs; Kajita: two-stage preview
control on the MP walk's footsteps and timing), every setting of a grid of ankle damping D
and DCM gain K is simulated on three tuning sequences that no reported figure uses, and
measured by the comparison protocol of ``cocomopl reproduce`` (``analysis/comparison.py``:
the same walking window for all).  The objective is the mean peak force over weight among
the settings under which none of a generator's tuning walks falls: the stabilizer's job is
to keep the robot up and land it gently (the project's goal: peaks at most 1.3 x weight);
the other measures are reported, not optimised.  A setting replaces the standing one
(``StabilizerGains()``, D = 3000 N m s/rad and K = 2) only if it lowers that mean by more
than ``SIGNIFICANT`` x weight: the three sequences rank settings within it differently.  With ``--reported``
the same grid also runs on the reported walks (M_gen, M_opt and their Kajita walk), to show
how sensitive the figures of ``cocomopl reproduce`` are to the gains; nothing is tuned on them.

``--robot`` tunes for another bundled robot on its own models and dataset: the sequences'
lengths are TALOS's scaled to the robot (``Scale.length_m``, which gives its dataset's lengths),
the grid's ankle damping D is TALOS's scaled by the robot's torque ratio as the stabilizer
scales it (``sim.stabilizer.robot_gains``; the tables keep TALOS's values), and every walk runs
with the robot's other defaults (G1's torque feedforward).

    python benchmarks/stabilizer_tuning.py [--robot g1] [--reported] [--workers 2] [--json]
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from dataclasses import replace

import numpy as np
from tqdm import tqdm

from cocomopl.processes import spawn_pool

# Tuning sequences (mm): transitions of 50 mm, all in the bundled dataset, so M_opt-style OC
# walks need no new OCP; none is M_gen or M_opt.
TUNING = {
    "short": (150, 150, 200, 250, 250, 200, 150, 150),
    "middle": (200, 200, 250, 300, 300, 250, 200, 200),
    "long": (300, 300, 350, 400, 400, 350, 300, 300),
}
ANKLE_DAMPING = (300.0, 1000.0, 3000.0, 10000.0)  # N m s/rad
DCM_GAIN = (1.0, 2.0, 3.0)
SIGNIFICANT = 0.01  # x weight: a smaller gain in the mean peak is not a reason to change the gains
FIGURES = ("fell", "peak_force_over_weight", "force_variation_over_weight", "total_force_variation_over_weight",
           "max_force_rate", "mean_torque")


def scaled_mm(robot, lengths_mm: tuple) -> tuple[int, ...]:
    """TALOS's step lengths ``lengths_mm`` (mm) scaled to ``robot`` (mm)."""
    return tuple(round(1000 * robot.scale.length_m(x / 1000)) for x in lengths_mm)


def plans(robot: str, lengths_mm: tuple, opt_lengths_mm: tuple | None = None) -> dict:
    """The MP, OC and Kajita plans of one sequence of the bundled ``robot``."""
    from cocomopl.data import dataset_path
    from cocomopl.gait import sequence_specs
    from cocomopl.motion_file import read_motions
    from cocomopl.ocp.chained_steps import solve_sequence
    from cocomopl.pipeline import generate_walk, kajita_for
    from cocomopl.requests import StraightSteps, WalkRequest

    dataset, attrs = read_motions(dataset_path(robot=robot), dataset=True)
    walk = generate_walk(WalkRequest(StraightSteps([x / 1000 for x in lengths_mm]), robot=robot))
    specs = sequence_specs([x / 1000 for x in (opt_lengths_mm or lengths_mm)])
    oc = solve_sequence(walk.robot, specs, dataset, settings=attrs["settings"])
    return {"MP": walk.motion, "OC": oc, "Kajita": kajita_for(walk)}


def run_one(job: tuple) -> dict:
    """Figures of one generator's walk of one sequence under one setting, over the window
    common to the sequence's three walks."""
    from cocomopl.analysis.comparison import common_window
    from cocomopl.pipeline import simulate_compared
    from cocomopl.robot import Robot
    from cocomopl.sim.stabilizer import robot_gains

    sequence, generator, walks, damping, gain = job
    robot = Robot(walks[generator].robot)
    gains = replace(robot_gains(robot, walks[generator].producer), ankle_damping=damping * robot.scale.torque,
                    dcm_gain=gain)
    _, figures, _ = simulate_compared(robot, {generator: walks[generator]}, gains={generator: gains},
                                      window=common_window(walks))
    return {"sequence": sequence, "generator": generator, "ankle_damping": damping, "dcm_gain": gain,
            **{k: figures[generator][k] for k in FIGURES}}


def grid_table(rows: list[dict]) -> list[dict]:
    """Per generator and setting, the figures averaged over the sequences (falls counted)."""
    out = []
    for (generator, damping, gain), group in itertools.groupby(
        sorted(rows, key=lambda r: (r["generator"], r["ankle_damping"], r["dcm_gain"])),
        key=lambda r: (r["generator"], r["ankle_damping"], r["dcm_gain"]),
    ):
        group = list(group)
        out.append({"generator": generator, "ankle_damping": damping, "dcm_gain": gain, "walks": len(group),
                    "falls": sum(r["fell"] for r in group),
                    **{k: float(np.mean([r[k] for r in group])) for k in FIGURES if k != "fell"}})
    return out


def tuned(table: list[dict]) -> dict:
    """Per generator, the best setting (lowest mean peak force, no fall) and the tuned one:
    the standing setting unless the best beats it by more than ``SIGNIFICANT``."""
    from cocomopl.sim.stabilizer import StabilizerGains

    standing = StabilizerGains()
    standing_gains = {"ankle_damping": standing.ankle_damping, "dcm_gain": standing.dcm_gain}
    out = {}
    for generator in sorted({r["generator"] for r in table}):
        upright = [r for r in table if r["generator"] == generator and r["falls"] == 0]
        if not upright:
            continue
        best = min(upright, key=lambda r: r["peak_force_over_weight"])
        current = [r for r in upright if {k: r[k] for k in standing_gains} == standing_gains]
        keep = current and current[0]["peak_force_over_weight"] <= best["peak_force_over_weight"] + SIGNIFICANT
        chosen = current[0] if keep else best
        out[generator] = {k: chosen[k] for k in standing_gains} | {
            "best": {k: best[k] for k in standing_gains}, "best_peak": best["peak_force_over_weight"],
            "tuned_peak": chosen["peak_force_over_weight"]}
    return out


def print_table(title: str, table: list[dict], chosen: dict) -> None:
    print(title)
    print(f"{'walk':7s} {'D':>6s} {'K':>4s} {'falls':>5s} {'peak F/W':>8s} {'var/sole':>8s} {'var sum':>8s} "
          f"{'max dF/dt':>9s} {'mean torque':>11s}")
    for r in table:
        choice = chosen.get(r["generator"], {})
        setting = (r["ankle_damping"], r["dcm_gain"])
        mark = " <- tuned" if setting == (choice.get("ankle_damping"), choice.get("dcm_gain")) else (
            " <- lowest peak" if setting == tuple(choice.get("best", {}).values()) else "")
        print(f"{r['generator']:7s} {r['ankle_damping']:6g} {r['dcm_gain']:4g} {r['falls']:>3d}/{r['walks']} "
              f"{r['peak_force_over_weight']:8.3f} {r['force_variation_over_weight']:8.2f} "
              f"{r['total_force_variation_over_weight']:8.2f} {r['max_force_rate']:9.2e} {r['mean_torque']:11.4f}{mark}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="talos", metavar="NAME",
                        help="a bundled robot, talos or g1, tuned on its own models and dataset (default: %(default)s)")
    parser.add_argument("--reported", action="store_true", help="also run the grid on M_gen, M_opt and their Kajita walk")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.workers < 1:
        parser.error(f"--workers {args.workers} must be at least 1")
    from cocomopl.data import dataset_path, model_path
    from cocomopl.errors import Error
    from cocomopl.gait import m_gen, m_opt
    from cocomopl.robot import Robot

    try:
        robot = Robot(args.robot)
        dataset_path(robot=args.robot)  # the robot's bundled dataset and model, or a one-line error
        model_path(robot=args.robot)
    except Error as exc:
        parser.exit(2, f"stabilizer_tuning.py: error: {exc}\n")
    started = time.perf_counter()
    lengths = {name: scaled_mm(robot, mm) for name, mm in TUNING.items()}
    sequences = {name: plans(args.robot, mm) for name, mm in tqdm(lengths.items(), desc="plans", file=sys.stderr)}
    if args.reported:
        sequences["reported"] = plans(args.robot, tuple(1000 * x for x in m_gen(robot)),
                                      tuple(1000 * x for x in m_opt(robot)))
    jobs = [(name, generator, walks, damping, gain) for name, walks in sequences.items() for generator in walks
            for damping, gain in itertools.product(ANKLE_DAMPING, DCM_GAIN)]
    with spawn_pool(args.workers) as pool:
        rows = list(tqdm(pool.imap_unordered(run_one, jobs), total=len(jobs), desc="simulations", file=sys.stderr))
    tuning = grid_table([r for r in rows if r["sequence"] != "reported"])
    chosen = tuned(tuning)
    summary = {"robot": args.robot, "tuning_sequences_mm": lengths, "ankle_damping_scale": robot.scale.torque,
               "significant_peak_change": SIGNIFICANT,
               "objective": "no fall, then the lowest mean peak force over weight",
               "tuned": chosen, "tuning": tuning,
               "reported": grid_table([r for r in rows if r["sequence"] == "reported"]),
               "runs": rows, "wall_time_s": time.perf_counter() - started}
    if args.json:
        print(json.dumps(summary))
    else:
        sequences_text = ", ".join(f"{name} {min(mm)}-{max(mm)} mm" for name, mm in lengths.items())
        print_table(f"{args.robot}, tuning sequences (means over {sequences_text}; D is TALOS's, times "
                    f"{robot.scale.torque:g} on the robot):", tuning, chosen)
        if args.reported:
            print_table("reported walks (M_gen, M_opt and their Kajita walk), sensitivity only:", summary["reported"], chosen)
        for generator, c in chosen.items():
            print(f"{generator}: tuned D = {c['ankle_damping']:g}, K = {c['dcm_gain']:g} (mean peak {c['tuned_peak']:.3f}; "
                  f"lowest {c['best_peak']:.3f} at D = {c['best']['ankle_damping']:g}, K = {c['best']['dcm_gain']:g})")
        print(f"{summary['wall_time_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
