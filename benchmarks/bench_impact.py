"""Cost of the default impact scene per fidelity, as ratios measured in one run.

    python benchmarks/bench_impact.py [--quick]
    python benchmarks/bench_impact.py --cold 5 [--json PATH] [--before CHECKOUT]

Reports, for the built-in default scene (two covered hoppers, draft gear, 0.5 s):
* each fidelity's wall time (median of repeats) for the whole run, steps per second,
  and the fem cost as a multiple of modal, quasi-rigid and rigid cost in the same run;
* how the fem run grows with elements per car (1e1 … 1e4, P2), at the scene's step.

``--cold N`` measures what ``femref run`` of the default scene meets instead: N fresh processes, each loading the
compiled loop and then running the scene's model runs once in their order (each model's wall time,
``ModelResult.wall_time_s``, including building its cars the first time in the process, as the run table's
speed-up column does), and prints each model's median and the median of the per-process fem / model ratios.
With ``--before CHECKOUT`` (another checkout of femref, e.g. the commit before a change) the processes alternate
between that checkout (first on the path, its own copy of this script) and this one, and both columns are printed.
Nothing here is asserted: the test suite checks correctness, this script measures speed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

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


def cold_once(checkout: Path) -> dict[str, float]:
    """:func:`cold_walls` in a fresh process of the femref checked out at ``checkout`` (first on the path)."""
    environment = {**os.environ, "PYTHONPATH": str(checkout)}
    done = subprocess.run([sys.executable, str(checkout / "benchmarks" / "bench_impact.py"), "--cold-once"], cwd=checkout,
                          env=environment, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.splitlines()[-1])


def cold(processes: int, json_path: str | None, before: Path | None = None) -> None:
    """``processes`` fresh processes of :func:`cold_walls` (alternating with ``before``'s): medians and fem / model ratios."""
    here = Path(__file__).resolve().parents[1]
    trees = {"": here} if before is None else {"before ": before.resolve(), "after ": here}
    runs: dict[str, list[dict[str, float]]] = {label: [] for label in trees}
    for _ in range(processes):
        for label, checkout in trees.items():
            runs[label].append(cold_once(checkout))
    print(f"default scene, cold ({processes} processes each): median wall per model and of fem / model in each process")
    print(f"{'model':<14}" + "".join(f" {label + 'wall ms':>16} {label + 'fem / this':>18}" for label in trees))
    summary: dict[str, dict] = {}
    for name in runs[next(iter(trees))][0]:
        row = f"{name:<14}"
        for label, done in runs.items():
            wall = statistics.median(r[name] for r in done)
            ratio = statistics.median(r["fem"] / r[name] for r in done)
            summary.setdefault(label.strip() or "this", {})[name] = {"wall_s": wall, "fem_over_this": ratio, "runs_s": [r[name] for r in done]}
            row += f" {wall * 1e3:16.3f} {ratio:18.2f}"
        print(row)
    if json_path:
        with open(json_path, "w", encoding="utf-8") as out:
            json.dump(summary, out, indent=2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats and element counts")
    parser.add_argument("--cold", type=int, metavar="N", help="N fresh processes of the default scene's run (cold)")
    parser.add_argument("--cold-once", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--json", metavar="PATH", help="with --cold: also write the numbers as JSON")
    parser.add_argument("--before", type=Path, metavar="CHECKOUT", help="with --cold: alternate with this checkout's processes")
    args = parser.parse_args()
    if args.cold_once:
        print(json.dumps(cold_walls()))
        return
    if args.cold:
        cold(args.cold, args.json, args.before)
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
