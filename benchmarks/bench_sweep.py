"""Sweep cost on dask.distributed: the fixed start-up and per-sample cost of a whole sweep, the speed-up of two
workers, and a long rigid sweep's rate.

    python benchmarks/bench_sweep.py [--part fit scaling rigid floor] [--repeats 5] [--json]

Every sweep is the built-in default scene with its velocity drawn uniform in 1–3.5 m/s, into a fresh file.

fit      ``femref sweep``'s cost as one call of ``run_sweep(..., workers=1)`` — its own local cluster started and
         stopped, fem + rigid — for N = 20 and N = 100 samples, ``repeats`` times, interleaved. The medians give
         ``wall = a + b·N``: ``a`` the fixed start-up, ``b`` the marginal cost of a sample. The models' time is
         what the file stores per sample, ``Σ_models wall_time_s`` (each model run's build and stepping, timed by
         the runner in the worker), its mean per sweep; the target is ``a ≤ 3 s``, ``b ≤ 1.1 ×`` it. On a machine
         whose load drifts, each call's excess over its own models' time gives the steadier ``*_excess`` figures.
scaling  the rate (samples/s) of a 200-sample fem + rigid sweep on warmed local clusters of 1 and 2 workers
         (``run_sweep(..., client=)``; cluster start-up and a 2-sample warm-up sweep apart): 2 workers ≥ 1.6× 1.
         ``busy_<n>`` = rate × models' time / n, the share of each worker's wall spent in the models: a speed-up
         short of 2× with busy ≈ 1 is the models slowed by the machine's other load, not the sweep machinery.
rigid    the whole ``run_sweep`` call of a 1000-sample rigid sweep on a warmed cluster of 2 workers (its start-up
         reported apart): ≥ 1000 samples/s. ``rigid_worker_cpu_ms``: the workers' process CPU per sample, the client's
         apart (``rigid_client_cpu_ms``), figures a machine shared with other work moves less than the rate.
floor    in this process, no Dask: the fem runs of 32 samples of the default scene (velocity drawn) stepped together
         (:func:`femref.impact.kernels.batch.solve_batch`: side by side, one copy of the cars' matrices) against the
         **batched floor**, a minimal compiled loop (:func:`batched_floor`, a measuring stick, not femref's) stepping 32
         independent copies of a banded system of the same DOFs and bandwidth with one factor, the copies innermost:
         per step three band products, one banded solve, a Newmark update. Both as ns per DOF and step
         (``fem_batch_ns``, ``floor_ns``, best of ``repeats``); the target is ``fem_batch_ns ≤ 5 × floor_ns``.
         ``fem_alone_ns``: one run alone (``solve_compiled``). ``floor_recorded_ns``: the floor's steps with the work
         femref adds that it leaves out — the dissipated energy each step and the kinetic and strain energies at
         every step, which the default scene records (:func:`recorded_floor`) — to say how much of a gap is that.
         ``*_cpu_ns``: the same from the process's CPU time (the batch's whole ``solve_batch`` call), steadier than
         wall time on a machine shared with other work.

Only public API is used (but ``floor``, which needs femref.impact.kernels.batch), so the same script times another
femref on the path (before/after comparisons: run it alternately with each on ``PYTHONPATH``; ``--json`` prints one
line of figures). Nothing here is asserted: the
tests check correctness, this measures speed.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit

from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
from femref.sweep import parse_sweep, read_sweep, run_sweep


def bench_sweep(samples: int, models: list[str], seed: int = 2024):
    """The benchmark sweep: the default scene with ``models``, one uniform parameter."""
    data = {"case": default_scene_data(), "samples": samples, "seed": seed, "models": models, "parameters": {"cars.0.velocity": {"uniform": [1.0, 3.5]}}}
    return parse_sweep(data, source=DEFAULT_SCENE_SOURCE)


def checked(summary, output: Path) -> float:
    """The mean ``Σ_models wall_time_s`` per sample of a complete sweep file."""
    if summary.failed:
        raise RuntimeError(f"{summary.failed} samples failed: {summary.failures[0][1]}")
    data = read_sweep(output)
    return float(sum(data.wall_time_s[model] for model in data.models).mean())


def fit(repeats: int, folder: Path) -> dict[str, float]:
    """``a``, ``b`` of ``wall = a + b·N`` from the medians of ``repeats`` whole calls at N = 20 and 100, the models'
    time ``m``, and the same fit of each call's excess over its own models, ``wall − N·m_call = a + (b − m)·N``,
    which a machine whose load drifts between calls moves less: ``b/m = 1 + Δexcess/(80 m)``."""
    walls: dict[int, list[float]] = {20: [], 100: []}
    excess: dict[int, list[float]] = {20: [], 100: []}
    models: list[float] = []
    for repeat in range(repeats):
        for n in walls:
            output = folder / f"fit_{n}_{repeat}.h5"
            started = time.perf_counter()
            summary = run_sweep(bench_sweep(n, ["fem", "rigid"], seed=repeat), output, workers=1)
            walls[n].append(time.perf_counter() - started)
            model = checked(summary, output)
            excess[n].append(walls[n][-1] - n * model)
            models.append(model)
    w20, w100 = statistics.median(walls[20]), statistics.median(walls[100])
    e20, e100 = statistics.median(excess[20]), statistics.median(excess[100])
    b, model = (w100 - w20) / 80.0, statistics.median(models)
    return {"wall_20_s": w20, "wall_100_s": w100, "a_s": w20 - 20.0 * b, "b_ms": 1e3 * b, "model_ms": 1e3 * model, "b_over_model": b / model,
            "excess_20_s": e20, "excess_100_s": e100, "a_excess_s": e20 - 20.0 * (e100 - e20) / 80.0, "b_over_model_excess": 1.0 + (e100 - e20) / (80.0 * model)}


def warmed_client(workers: int):
    """A local cluster of ``workers`` single-threaded processes and its client, and their start-up (s)."""
    from distributed import Client, LocalCluster

    started = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    return cluster, Client(cluster), time.perf_counter() - started


def warm_rate(client, sweep, folder: Path, name: str) -> tuple[float, float, float]:
    """(samples/s of ``sweep``'s runs, whole call s, models' ms per sample) after a 2-sample warm-up sweep on ``client``."""
    run_sweep(bench_sweep(2, sweep.spec.models, seed=99), folder / f"{name}_warm.h5", client=client)
    started = time.perf_counter()
    summary = run_sweep(sweep, folder / f"{name}.h5", client=client)
    whole = time.perf_counter() - started
    return summary.runs_per_second, whole, 1e3 * checked(summary, folder / f"{name}.h5")


def scaling(folder: Path) -> dict[str, float]:
    out = {}
    for workers in (1, 2):
        cluster, client, _ = warmed_client(workers)
        with cluster, client:
            out[f"rate_{workers}"], _, out[f"model_ms_{workers}"] = warm_rate(client, bench_sweep(200, ["fem", "rigid"]), folder, f"scaling_{workers}")
        out[f"busy_{workers}"] = out[f"rate_{workers}"] * out[f"model_ms_{workers}"] / (1e3 * workers)
    out["speed_up"] = out["rate_2"] / out["rate_1"]
    return out


def rigid(folder: Path) -> dict[str, float]:
    cluster, client, startup = warmed_client(2)
    with cluster, client:
        run_sweep(bench_sweep(2, ["rigid"], seed=99), folder / "rigid_warm.h5", client=client)
        workers, mine = sum(client.run(time.process_time).values()), time.process_time()
        rate, whole, model = warm_rate(client, bench_sweep(1000, ["rigid"]), folder, "rigid")
        workers, mine = sum(client.run(time.process_time).values()) - workers, time.process_time() - mine
    return {"cluster_start_s": startup, "rigid_whole_s": whole, "rigid_whole_rate": 1000.0 / whole, "rigid_run_rate": rate, "rigid_model_ms": model,
            "rigid_worker_cpu_ms": workers, "rigid_client_cpu_ms": mine}  # ms per sample: s per 1000 samples


@njit(cache=False)
def batched_floor(factor, history_u, history_v, history_a, u, v, a, work, steps: int, dt: float) -> None:
    """``steps`` steps of ``B`` copies (``u[:, b]``) of one banded system: ``w = H_u u + H_v v + H_a a`` (symmetric
    bands, ``H[k, j] = A[j + k, j]``), ``L Lᵀ a_new = w`` (``factor[0, j] = 1/L[j, j]``, ``factor[k, j] = L[j + k, j]``),
    ``v += dt (a + a_new)/2``, ``u += dt v``; the copies innermost."""
    n, copies = u.shape
    p = factor.shape[0] - 1
    for _ in range(steps):
        for i in range(n):
            for b in range(copies):
                work[i, b] = history_u[0, i] * u[i, b] + history_v[0, i] * v[i, b] + history_a[0, i] * a[i, b]
        for k in range(1, p + 1):
            for j in range(n - k):
                for b in range(copies):
                    work[j + k, b] += history_u[k, j] * u[j, b] + history_v[k, j] * v[j, b] + history_a[k, j] * a[j, b]
                    work[j, b] += history_u[k, j] * u[j + k, b] + history_v[k, j] * v[j + k, b] + history_a[k, j] * a[j + k, b]
        for j in range(n):
            for b in range(copies):
                work[j, b] *= factor[0, j]
            for k in range(1, min(p, n - 1 - j) + 1):
                for b in range(copies):
                    work[j + k, b] -= factor[k, j] * work[j, b]
        for j in range(n - 1, -1, -1):
            for k in range(1, min(p, n - 1 - j) + 1):
                for b in range(copies):
                    work[j, b] -= factor[k, j] * work[j + k, b]
            for b in range(copies):
                work[j, b] *= factor[0, j]
        for i in range(n):
            for b in range(copies):
                v[i, b] += 0.5 * dt * (a[i, b] + work[i, b])
                u[i, b] += dt * v[i, b]
                a[i, b] = work[i, b]


@njit(cache=False)
def _symmetric_product(bands, x, out) -> None:
    """``out = A x`` for every copy (``x[:, b]``), ``A`` of symmetric bands ``bands[k, j] = A[j + k, j]``."""
    n, copies = x.shape
    for i in range(n):
        for b in range(copies):
            out[i, b] = bands[0, i] * x[i, b]
    for k in range(1, bands.shape[0]):
        for j in range(n - k):
            for b in range(copies):
                out[j + k, b] += bands[k, j] * x[j, b]
                out[j, b] += bands[k, j] * x[j + k, b]


@njit(cache=False)
def recorded_floor(factor, history_u, history_v, history_a, u, v, a, work, steps: int, dt: float, stiffness, mass, damping,
                   v_mid, product, energy) -> None:
    """:func:`batched_floor`'s steps and what femref adds to each that the floor leaves out (not a stick, a measure of
    that work): the dissipated energy ``dt v̄ᵀ C v̄`` (v̄ the step-mean velocity: a band product and a dot) and, at every
    step (the default scene records every step), the kinetic and strain energies ``½ vᵀ M v``, ``½ uᵀ K u`` (two band
    products, two dots) — the sensors and the coupler iteration left out."""
    n, copies = u.shape
    for _ in range(steps):
        for i in range(n):
            for b in range(copies):
                v_mid[i, b] = 0.5 * v[i, b]
        batched_floor(factor, history_u, history_v, history_a, u, v, a, work, 1, dt)
        for i in range(n):
            for b in range(copies):
                v_mid[i, b] += 0.5 * v[i, b]
        _symmetric_product(damping, v_mid, product)
        for i in range(n):
            for b in range(copies):
                energy[0, b] += dt * v_mid[i, b] * product[i, b]
        _symmetric_product(stiffness, u, product)
        for b in range(copies):
            energy[1, b] = 0.0
        for i in range(n):
            for b in range(copies):
                energy[1, b] += 0.5 * u[i, b] * product[i, b]
        _symmetric_product(mass, v, product)
        for b in range(copies):
            energy[2, b] = 0.0
        for i in range(n):
            for b in range(copies):
                energy[2, b] += 0.5 * v[i, b] * product[i, b]


def floor_copies(dofs: int, band: int, copies: int):
    """The arguments of :func:`batched_floor` for ``copies`` copies of a system of ``dofs`` DOFs and half-bandwidth
    ``band`` (a diagonally dominant band: the values stay bounded), compiled once."""
    bands = np.zeros((band + 1, dofs))
    bands[0], bands[1:] = 0.5, -0.1 / band
    factor = np.zeros((band + 1, dofs))
    factor[0], factor[1:] = 0.5, -0.05 / band  # 1/L_jj and L_(j+k)j of a diagonally dominant L
    arguments = (factor, bands, bands, bands, *(np.full((dofs, copies), 1e-3) for _ in range(4)))
    batched_floor(*arguments, 2, 1e-4)
    return arguments


def floor_seconds(arguments, steps: int) -> float:
    """Wall time (s) of ``steps`` steps of :func:`batched_floor`."""
    started = time.perf_counter()
    batched_floor(*arguments, steps, 1e-4)
    if not np.all(np.isfinite(arguments[4])):
        raise RuntimeError("the floor's copies diverged")
    return time.perf_counter() - started


def recorded_copies(arguments):
    """The extra arguments of :func:`recorded_floor` beside ``arguments`` of :func:`floor_copies`, compiled once."""
    bands, u = arguments[1], arguments[4]
    extra = (bands, bands, bands, np.zeros_like(u), np.zeros_like(u), np.zeros((3, u.shape[1])))
    recorded_floor(*arguments, 2, 1e-4, *extra)
    return extra


def recorded_seconds(arguments, extra, steps: int) -> float:
    """Wall time (s) of ``steps`` steps of :func:`recorded_floor`."""
    started = time.perf_counter()
    recorded_floor(*arguments, steps, 1e-4, *extra)
    if not np.all(np.isfinite(arguments[4])):
        raise RuntimeError("the floor's copies diverged")
    return time.perf_counter() - started


def floor(repeats: int, copies: int = 32) -> dict[str, float]:
    """A batched fem sweep's stepping against :func:`batched_floor` (module docstring)."""
    from femref.fem import INTEGRATORS
    from femref.impact.kernels import pool
    from femref.impact.kernels.batch import solve_batch
    from femref.impact.kernels.loop import prepare_run
    from femref.impact.kernels.loop import solve_compiled
    from femref.models import model_form
    from femref.run import load_compiled_loop
    from femref.run.timestep import impact_time_step
    from femref.scene.build import scene_from_case

    sweep = bench_sweep(copies, ["fem"])
    scenes = [scene_from_case(sweep.sample_case(sweep.sample(i)), sweep.base_dir) for i in range(copies)]
    load_compiled_loop(scenes[0])
    integrator = INTEGRATORS[scenes[0].integrator](scenes[0].rho_inf)
    steps_of = [impact_time_step(scene, scene.runs[0])[0] for scene in scenes]
    systems = [[model_form("fem", "impact")(car, scene, dt) for car in scene.cars] for scene, dt in zip(scenes, steps_of)]
    batch, alone, bare, recorded = np.inf, np.inf, np.inf, np.inf
    batch_cpu, bare_cpu, recorded_cpu = np.inf, np.inf, np.inf
    for repeat in range(repeats):  # interleaved: a machine whose load drifts moves the three alike
        runs = [prepare_run(scene, cars, integrator, dt) for scene, cars, dt in zip(scenes, systems, steps_of)]
        if repeat == 0:
            layout, steps = runs[0].pool.layout, runs[0].steps
            dofs, band = int(np.sum(layout[:, pool.DOFS])), int(np.max(layout[:, pool.BAND]))
            arguments = floor_copies(dofs, band, copies)
            extra = recorded_copies(arguments)
        cpu = time.process_time()
        batch = min(batch, sum(response.wall_time for response in solve_batch(runs)))
        batch_cpu, cpu = min(batch_cpu, time.process_time() - cpu), time.process_time()
        alone = min(alone, solve_compiled(scenes[0], systems[0], integrator, steps_of[0]).wall_time)
        cpu = time.process_time()
        bare = min(bare, floor_seconds(arguments, steps))
        bare_cpu, cpu = min(bare_cpu, time.process_time() - cpu), time.process_time()
        recorded = min(recorded, recorded_seconds(arguments, extra, steps))
        recorded_cpu = min(recorded_cpu, time.process_time() - cpu)
    out = {"fem_dofs": dofs, "fem_band": band, "fem_steps": steps, "fem_batch_ns": 1e9 * batch / (copies * dofs * steps),
           "fem_alone_ns": 1e9 * alone / (dofs * steps), "floor_ns": 1e9 * bare / (copies * dofs * steps),
           "floor_recorded_ns": 1e9 * recorded / (copies * dofs * steps)}
    out["fem_batch_over_floor"] = out["fem_batch_ns"] / out["floor_ns"]
    per_value = 1e9 / (copies * dofs * steps)
    out.update(fem_batch_cpu_ns=per_value * batch_cpu, floor_cpu_ns=per_value * bare_cpu, floor_recorded_cpu_ns=per_value * recorded_cpu,
               fem_batch_over_floor_cpu=batch_cpu / bare_cpu)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", nargs="+", default=["fit", "scaling", "rigid", "floor"], choices=["fit", "scaling", "rigid", "floor"])
    parser.add_argument("--repeats", type=int, default=5, help="whole sweeps per N for the fit (default 5)")
    parser.add_argument("--json", action="store_true", help="print the figures as one JSON line")
    args = parser.parse_args()
    figures: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for part in args.part:
            figures.update({"fit": lambda: fit(args.repeats, Path(tmp)), "scaling": lambda: scaling(Path(tmp)), "rigid": lambda: rigid(Path(tmp)),
                            "floor": lambda: floor(args.repeats)}[part]())
    if args.json:
        print(json.dumps(figures))
        return
    for name, value in figures.items():
        print(f"{name:>18} {value:10.3f}")


if __name__ == "__main__":
    main()
