"""Set-up of the quasi-rigid car of the default impact scene, part by part, cold and warm.

    python benchmarks/bench_setup_quasi_rigid.py [--processes N] [--against DIR]

Each of N fresh processes (default 5) first runs the scene's fem and modal models (as ``femref run`` does before
quasi_rigid), then the quasi_rigid run cold, in its parts: building the first car (the once-per-process tables
included: the Gauss rule and its antiderivatives), the second, packing and factorising (``setup_time``), stepping
(``wall_time``), the result; then the first car again part by part after ``forget_built`` (warm): the body's
quadrature (:class:`BodyQuadrature`), the rod with its creep correction, the stepper's coefficients at the ends and
sensors, the step matrices, the coefficients at the nodes (the energy forms), the whole car
(:func:`femref.models.quasi_rigid.quasi_rigid_car`). ``--against DIR`` alternates each process with one that imports
femref and reduced from DIR first (another checkout: before and after in one run, interleaved). Prints medians over
the processes (µs), with ``--against`` after / before, and the median of fem / quasi_rigid per process, of wall times
and of the thread's CPU times (on a busy machine the CPU ratio is the steadier: a wall time counts the time the
process waited for a core).
Nothing here is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def parts() -> dict[str, float]:
    """One process: the quasi_rigid run's parts, cold, and the first car's parts, warm (s)."""
    from femref.case import parse_case
    from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
    from femref.core.threads import one_blas_thread
    from femref.impact import solve_impact
    from femref.models import model_form
    from femref.models.base import forget_built
    from femref.models.quasi_rigid import quasi_rigid_car
    from femref.run.runner import load_compiled_loop, model_result, run_model
    from femref.run.timestep import impact_time_step
    from femref.scene.build import scene_from_case
    from reduced.quasi_rigid import QuasiRigidRod, QuasiRigidStepper
    from reduced.quasi_rigid.profiles import BodyQuadrature

    scene = scene_from_case(parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE))
    load_compiled_loop(scene)
    runs = {run.name: run for run in scene.runs}
    cpu = time.thread_time()
    fem = run_model(scene, runs["fem"]).wall_time_s
    fem_cpu = time.thread_time() - cpu
    run_model(scene, runs["modal"])
    car, run = scene.cars[0], runs["quasi_rigid"]
    body = car.body
    cpu = time.thread_time()
    with one_blas_thread():
        started = time.perf_counter()
        dt, rule = impact_time_step(scene, run)
        first = time.perf_counter()
        systems = [model_form(run.fidelity[0], "impact")(scene.cars[0], scene, dt)]
        second = time.perf_counter()
        systems += [model_form(f, "impact")(c, scene, dt) for c, f in zip(scene.cars[1:], run.fidelity[1:])]
        built = time.perf_counter()
        response = solve_impact(scene, systems, dt)
        stepped = time.perf_counter()
    model_result(scene, run, response, dt, rule)
    done = time.perf_counter()
    run_cpu = time.thread_time() - cpu
    out = {"run: time step": first - started, "run: build the first car (cold)": second - first, "run: build the other car": built - second,
           "run: pack and factorise": response.setup_time, "run: step": response.wall_time, "run: result": done - stepped,
           "run: quasi_rigid total": done - started, "run: fem wall": fem, "run: quasi_rigid CPU": run_cpu, "run: fem CPU": fem_cpu}
    forget_built()
    with one_blas_thread():
        for _ in range(2):  # the second pass is reported: every part warm
            started = time.perf_counter()
            BodyQuadrature(body.half_length, body.mass_per_length, body.stiffness, body.viscosity, body.jumps)
            out["warm: quadrature"] = time.perf_counter() - started
            started = time.perf_counter()
            rod = QuasiRigidRod(body.half_length, body.mass_per_length, body.stiffness, body.viscosity, jumps=body.jumps)
            out["warm: rod (quadrature + correction)"] = time.perf_counter() - started
            started = time.perf_counter()
            stepper = QuasiRigidStepper(rod, car.sensor_x, initial_shape="undeformed")
            out["warm: stepper (coefficients at ends, sensors)"] = time.perf_counter() - started
            started = time.perf_counter()
            stepper.transition(dt)
            out["warm: step matrices"] = time.perf_counter() - started
            started = time.perf_counter()
            rod.correction.node_coefficients()
            out["warm: coefficients at the nodes"] = time.perf_counter() - started
            forget_built()
            started = time.perf_counter()
            quasi_rigid_car(car, dt)
            out["warm: whole car"] = time.perf_counter() - started
    return out


def fresh(directory: Path) -> dict[str, float]:
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join([str(directory), os.environ.get("PYTHONPATH", "")]),
                       OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    done = subprocess.run([sys.executable, __file__, "--once"], check=True, capture_output=True, text=True, env=environment)
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=5, metavar="N", help="fresh processes (medians over them)")
    parser.add_argument("--against", metavar="DIR", help="another checkout, its processes interleaved with this one's")
    parser.add_argument("--once", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.once:
        print(json.dumps(parts()))
        return
    trees = {"this": HERE} | ({"before": Path(args.against).resolve()} if args.against else {})
    samples: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
    for _ in range(args.processes):
        for name, directory in trees.items():
            samples[name].append(fresh(directory))
    print(f"quasi-rigid car of the default scene, {args.processes} fresh processes each: medians, µs (busy machine)")
    header = f"{'part':<48} {'this':>9}" + (f" {'before':>9} {'this/before':>12}" if args.against else "")
    print(header)
    for key in samples["this"][0]:
        this = statistics.median(s[key] for s in samples["this"]) * 1e6
        line = f"{key:<48} {this:9.0f}"
        if args.against:
            before = statistics.median(s[key] for s in samples["before"]) * 1e6
            line += f" {before:9.0f} {this / before:12.2f}"
        print(line)
    for name in trees:
        ratio = statistics.median(s["run: fem wall"] / s["run: quasi_rigid total"] for s in samples[name])
        cpu = statistics.median(s["run: fem CPU"] / s["run: quasi_rigid CPU"] for s in samples[name])
        print(f"fem / quasi_rigid ({name}): {ratio:.1f} wall, {cpu:.1f} thread CPU")


if __name__ == "__main__":
    main()
