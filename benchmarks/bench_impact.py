"""Cost of the default impact scene per fidelity, as ratios measured in one run.

    python benchmarks/bench_impact.py [--quick]
    python benchmarks/bench_impact.py --cold 5 [--json PATH]

Reports, for the built-in default scene (two covered hoppers, draft gear, 0.5 s):
* each fidelity's wall time (median of repeats) for the whole run, steps per second,
  and the fem cost as a multiple of modal, quasi-rigid and rigid cost in the same run;
* how the fem run grows with elements per car (1e1 … 1e4, P2), at the scene's step.

``--cold N`` measures what ``femref run`` of the default scene meets instead: N fresh processes, each loading the
compiled loop and then running the scene's model runs once in their order (each model's wall time,
``ModelResult.wall_time_s``, including building its cars the first time in the process, as the run table's
speed-up column does), and prints each model's median and the median of the per-process fem / model ratios.
Nothing here is asserted: the test suite checks correctness, this script measures speed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import subprocess
import sys
import time

from femref.case import parse_case
from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
from femref.run.runner import step_cars
from femref.run.timestep import impact_time_step
from femref.scene import ModelRun
from femref.scene.build import scene_from_case


def default_scene():
    return scene_from_case(parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE))


def timed(scene, fidelity: str, repeats: int, dt: float | None = None) -> tuple[float, int]:
    """Median wall time of a uniform run (its automatic step unless ``dt``) and its step count."""
    run = ModelRun(fidelity, (fidelity,) * len(scene.cars))
    dt = dt or impact_time_step(scene, run)[0]
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        response = step_cars(scene, run, dt)
        times.append(time.perf_counter() - started)
    return statistics.median(times), response.steps


def cold_walls() -> dict[str, float]:
    """One process's cold run of the default scene: each model run's wall time (s), in the scene's order."""
    from femref.run.runner import load_compiled_loop, run_model

    scene = default_scene()
    load_compiled_loop(scene)
    return {run.name: run_model(scene, run).wall_time_s for run in scene.runs}


def cold(processes: int, json_path: str | None) -> None:
    """``processes`` fresh processes of :func:`cold_walls`: medians and fem / model ratios."""
    runs = []
    for _ in range(processes):
        done = subprocess.run([sys.executable, __file__, "--cold-once"], check=True, capture_output=True, text=True)
        runs.append(json.loads(done.stdout.splitlines()[-1]))
    print(f"default scene, cold ({processes} processes): median wall per model and of fem / model in each process")
    print(f"{'model':<14} {'wall ms':>9} {'fem / this':>11}")
    summary = {}
    for name in runs[0]:
        wall = statistics.median(r[name] for r in runs)
        ratio = statistics.median(r["fem"] / r[name] for r in runs)
        summary[name] = {"wall_s": wall, "fem_over_this": ratio, "runs_s": [r[name] for r in runs]}
        print(f"{name:<14} {wall * 1e3:9.3f} {ratio:11.2f}")
    if json_path:
        with open(json_path, "w", encoding="utf-8") as out:
            json.dump(summary, out, indent=2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats and element counts")
    parser.add_argument("--cold", type=int, metavar="N", help="N fresh processes of the default scene's run (cold)")
    parser.add_argument("--cold-once", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--json", metavar="PATH", help="with --cold: also write the numbers as JSON")
    args = parser.parse_args()
    if args.cold_once:
        print(json.dumps(cold_walls()))
        return
    if args.cold:
        cold(args.cold, args.json)
        return
    repeats = 3 if args.quick else 5
    scene = default_scene()
    print(f"default scene: end = {scene.end} s, fem {scene.fem.elements} P{scene.fem.order} elements per car")
    costs, steps = {}, {}
    fem_dt = impact_time_step(scene, ModelRun("fem", ("fem",) * len(scene.cars)))[0]
    for fidelity in ("fem", "modal", "quasi_rigid", "rigid"):
        costs[fidelity], steps[fidelity] = timed(scene, fidelity, repeats)
        costs[f"{fidelity} @fem dt"], steps[f"{fidelity} @fem dt"] = timed(scene, fidelity, repeats, fem_dt)
    print("each fidelity at its own automatic step, and at the fem step:")
    print(f"{'fidelity':<20} {'steps':>6} {'wall s':>9} {'steps/s':>10} {'fem / this':>11}")
    for fidelity, cost in costs.items():
        print(f"{fidelity:<20} {steps[fidelity]:6d} {cost:9.4f} {steps[fidelity] / cost:10.0f} {costs['fem'] / cost:11.2f}")
    print("\nfem cost against elements per car (P2, the 64-element step):")
    print(f"{'elements':>9} {'wall s':>9} {'µs/step':>9} {'× 64 el.':>9}")
    counts = (10, 100, 1000) if args.quick else (10, 64, 100, 1000, 10000)
    base = costs["fem"]
    for n in counts:
        meshed = dataclasses.replace(scene, fem=dataclasses.replace(scene.fem, elements=n))
        cost, count = timed(meshed, "fem", 1 if n >= 1000 else repeats, fem_dt)
        print(f"{n:9d} {cost:9.4f} {cost / count * 1e6:9.1f} {cost / base:9.2f}")


if __name__ == "__main__":
    main()
