"""Sweep throughput on dask.distributed: samples of the default scene per second, 1 and 2 local workers.

    python benchmarks/bench_sweep.py [--samples 16] [--workers 1 2] [--models fem]

The same sweep (the built-in default scene with the given models, fem only by default,
the hammer's speed drawn uniform in 1–3.5 m/s) runs into a fresh sweep file on a local cluster of each size. Workers are
warmed up first (imports, one small run each), so the rate is the steady one a long
sweep sees; the cluster start-up is reported apart. The speed-up is the rate ratio
against one worker, measured in the same run; with one worker per core the target is
≥ 1.6× on 2 cores.

For reference the same samples also run without Dask: ``run_sample`` in a pool of as many
single-threaded processes (``concurrent.futures``). Its speed-up is what the machine
gives to this work; the Dask rate divided by it is the cost of the sweep machinery
(scheduling, shipping records back, the client's HDF5 writes). Nothing here is asserted:
the tests check correctness, this measures speed.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
from femref.sweep import parse_sweep, run_sweep
from femref.sweep.worker import run_sample


def bench_sweep(samples: int, models: list[str]):
    """The benchmark sweep: the default scene with ``models``, one uniform parameter."""
    data = {"case": default_scene_data(), "samples": samples, "seed": 2024, "models": models, "parameters": {"cars.0.velocity": {"uniform": [1.0, 3.5]}}}
    return parse_sweep(data, source=DEFAULT_SCENE_SOURCE)


def warm_up(client, sweep) -> None:
    """Import femref and run one sample on every worker, so timings exclude first-call costs."""
    case = sweep.sample(0).case_data
    client.run(run_sample, case, str(sweep.base_dir), 20, 20)


def timed_sweep(sweep, workers: int, folder: Path) -> tuple[float, float, float]:
    """(samples/s, sweep wall s, cluster start-up s) on a fresh local cluster of ``workers`` processes."""
    from distributed import Client, LocalCluster

    started = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        warm_up(client, sweep)
        startup = time.perf_counter() - started
        summary = run_sweep(sweep, folder / f"bench_{workers}.h5", client=client)
    if summary.failed:
        raise RuntimeError(f"{summary.failed} samples failed: {summary.failures[0][1]}")
    return summary.runs_per_second, summary.wall_time_s, startup


def _run_one(args: tuple) -> str:
    return run_sample(*args)["error"]


def pool_rate(sweep, processes: int) -> float:
    """samples/s of the sweep's samples in a pool of single-threaded processes, without Dask (warmed up)."""
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # as Dask's nannies set them
        os.environ[name] = "1"
    tasks = [(sweep.sample(i).case_data, str(sweep.base_dir), 200, 200) for i in range(sweep.size)]
    with ProcessPoolExecutor(processes, mp_context=get_context("spawn")) as pool:
        list(pool.map(_run_one, tasks[:processes]))  # warm up: imports and one run per process (roughly)
        started = time.perf_counter()
        list(pool.map(_run_one, tasks))
        return len(tasks) / (time.perf_counter() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=16, help="samples per sweep (default 16)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="local cluster sizes (default 1 2)")
    parser.add_argument("--models", nargs="+", default=["fem"], help="models of each sample (default fem)")
    args = parser.parse_args()
    sweep = bench_sweep(args.samples, args.models)
    run_sample(sweep.sample(0).case_data, str(sweep.base_dir), 200, 200)  # warm this process for the serial rate
    started = time.perf_counter()
    for i in range(min(4, sweep.size)):
        run_sample(sweep.sample(i).case_data, str(sweep.base_dir), 200, 200)
    serial = min(4, sweep.size) / (time.perf_counter() - started)
    print(f"default scene, models {' '.join(args.models)} ({sweep.base_case.fem.elements} P{sweep.base_case.fem.order} "
          f"elements per fem car), {sweep.size} samples per sweep")
    print(f"in-process serial run_sample: {serial:.2f} samples/s")
    header = f"{'workers':>7} {'samples/s':>9} {'sweep s':>8} {'start-up s':>10} {'speed-up':>9} {'no-Dask pool samples/s':>23} {'pool speed-up':>14} {'Dask / pool':>12}"
    print(header)
    rates, pools = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in args.workers:
            rate, wall, startup = timed_sweep(sweep, workers, Path(tmp))
            pools[workers] = pool_rate(sweep, workers)
            rates[workers] = rate
            first = min(args.workers)
            print(
                f"{workers:7d} {rate:9.2f} {wall:8.2f} {startup:10.2f} {rate / rates[first]:8.2f}× "
                f"{pools[workers]:23.2f} {pools[workers] / pools[first]:13.2f}× {rate / pools[workers]:12.2f}"
            )


if __name__ == "__main__":
    main()
