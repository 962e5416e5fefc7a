"""What a fem impact step costs against its bare arithmetic, at 64 and 1e4 elements per car.

    python benchmarks/bench_step.py [--elements 64 10000] [--steps 1500]

The run is the built-in default scene (two hoppers, draft gear) with every car fem at the
given mesh, cut to ``--steps`` steps at the fem's own step, stepped by the compiled loop
(:func:`femref.impact.kernels.loop.solve_compiled`) with every step recorded. Its
``wall_time / steps`` is the step.

The **bare arithmetic** is the operator products and banded solves a step cannot do
without, called back to back in one compiled loop on the same packed cars, with nothing
else (no coupler iteration, no bookkeeping, no branches between them):

* every step, per car: the three history products (−K u, −(C + (1−αf) dt K) v,
  −(αm M + …) a), one banded solve with the step matrix S, the response ``Z L`` and the
  dissipation product ``C v̄``;
* every recorded step, per car: ``K u`` and ``M v`` (energies), ``C v`` and a solve with M
  (the equilibrium acceleration), the sensor products.

The ratio step / bare arithmetic is the loop's overhead factor (the target is at most 3).
Both are measured in the same run, best of ``--repeats``; nothing is asserted (the tests
check correctness, this measures speed).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
from numba import njit

from femref.case import parse_case
from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
from femref.fem import INTEGRATORS
from femref.impact.kernels import pool as K
from femref.impact.kernels.loop import coupler_maps, solve_compiled
from femref.impact.kernels.packing import pack_cars, prepared_car
from femref.models import model_form
from femref.run import load_compiled_loop
from femref.run.timestep import impact_time_step
from femref.scene import ModelRun
from femref.scene.build import scene_from_case


@njit(cache=True)
def bare_step(layout, w, repeats: int) -> None:
    """The per-step products and solves of every car, ``repeats`` times (module docstring)."""
    for _ in range(repeats):
        for c in range(layout.shape[0]):
            n, p, J = layout[c, K.DOFS], layout[c, K.BAND], layout[c, K.LOAD_COUNT]
            K.band_product(w, layout[c, K.HISTORY_U], p, n, layout[c, K.U], layout[c, K.WORK1])
            K.band_product(w, layout[c, K.HISTORY_V], p, n, layout[c, K.V], layout[c, K.WORK2])
            K.band_product(w, layout[c, K.HISTORY_A], p, n, layout[c, K.A], layout[c, K.WORK3])
            K.band_solve(w, layout[c, K.EFFECTIVE_FACTOR], p, n, layout[c, K.WORK1])
            K.matvec(w, layout[c, K.RESPONSE], n, J, layout[c, K.LOADS], layout[c, K.WORK2])
            K.band_product(w, layout[c, K.DAMPING], p, n, layout[c, K.V], layout[c, K.WORK3])


@njit(cache=True)
def bare_record(layout, w, repeats: int) -> None:
    """The products and solves of one recorded step of every car, ``repeats`` times."""
    for _ in range(repeats):
        for c in range(layout.shape[0]):
            n, p, S = layout[c, K.DOFS], layout[c, K.BAND], layout[c, K.SENSOR_COUNT]
            K.band_product(w, layout[c, K.STIFFNESS], p, n, layout[c, K.U], layout[c, K.WORK1])
            K.band_product(w, layout[c, K.MASS], p, n, layout[c, K.V], layout[c, K.WORK2])
            K.band_product(w, layout[c, K.DAMPING], p, n, layout[c, K.V], layout[c, K.WORK3])
            K.band_solve(w, layout[c, K.MASS_FACTOR], p, n, layout[c, K.WORK3])
            K.matvec(w, layout[c, K.SENSOR_OUTPUTS], S, n, layout[c, K.U], layout[c, K.WORK1])
            K.matvec(w, layout[c, K.SENSOR_OUTPUTS], S, n, layout[c, K.WORK3], layout[c, K.WORK2])


def best_time(function, *args, repeats: int) -> float:
    """Best wall time (s) of ``function(*args)`` over ``repeats`` calls (after one warm-up)."""
    function(*args)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function(*args)
        times.append(time.perf_counter() - started)
    return min(times)


def measure(elements: int, steps: int, repeats: int) -> dict[str, float]:
    """Step and bare-arithmetic costs (s per step) of the default scene with fem cars of ``elements``."""
    data = default_scene_data()
    data["fem"]["elements"] = elements
    scene = scene_from_case(parse_case(data, source=DEFAULT_SCENE_SOURCE))
    run = ModelRun("fem", ("fem",) * len(scene.cars))
    dt, _ = impact_time_step(scene, run)
    scene = dataclasses.replace(scene, end=steps * dt, output_stride=1)
    integrator = INTEGRATORS[scene.integrator](scene.rho_inf)
    systems = [model_form("fem", "impact")(car, scene, dt) for car in scene.cars]
    load_compiled_loop(scene)
    step = best_time(lambda: solve_compiled(scene, systems, integrator, dt), repeats=repeats)
    response = solve_compiled(scene, systems, integrator, dt)
    prepared = [prepared_car(system, integrator, dt, *maps) for system, maps in zip(systems, coupler_maps(scene))]
    pool = pack_cars(systems, prepared, [car.velocity for car in scene.cars], [np.zeros(2) for _ in scene.cars],
                       [0] * len(scene.cars))
    inner = max(1, 200_000 // (elements + 1))
    bare = best_time(bare_step, pool.layout, pool.values, inner, repeats=repeats) / inner
    record = best_time(bare_record, pool.layout, pool.values, inner, repeats=repeats) / inner
    whole = step / response.steps
    return {"dofs": int(pool.layout[0, K.DOFS]), "steps": response.steps, "step": whole, "bare": bare, "record": record}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs="+", default=[64, 10_000], help="elements per car (default 64 10000)")
    parser.add_argument("--steps", type=int, default=1500, help="steps per run (default 1500)")
    parser.add_argument("--repeats", type=int, default=5, help="repeats, best taken (default 5)")
    args = parser.parse_args()
    print("default scene, fem cars (P2), every step recorded; µs per step, best of repeats")
    print(f"{'elements':>9} {'DOFs/car':>9} {'step':>9} {'bare step':>10} {'bare record':>12} {'bare total':>11} {'step / bare':>12}")
    for elements in args.elements:
        m = measure(elements, args.steps, args.repeats)
        total = m["bare"] + m["record"]
        print(f"{elements:9d} {m['dofs']:9d} {1e6 * m['step']:9.2f} {1e6 * m['bare']:10.2f} {1e6 * m['record']:12.2f} "
              f"{1e6 * total:11.2f} {m['step'] / total:11.2f}×")


if __name__ == "__main__":
    main()
