"""What the first ``femref run`` after an install costs against a later one: the kernels' compile, and what it says.

    python benchmarks/bench_first_run.py [--repeats 3] [--trees /path/to/a/checkout ...]

Each repeat, per tree (default: this checkout; several trees are interleaved, so a busy
machine loads them alike), runs ``femref run`` of the built-in default scene twice in fresh
processes with ``NUMBA_CACHE_DIR`` an empty folder: the first run compiles the impact
kernels (a cold cache, as after an install), the second loads them. Printed per tree: the
medians of the first and second runs' wall and CPU seconds (the process's user + system
time) and the first run's stderr — the notice that says why it waits. Nothing is asserted
(the tests check the cache and the notice; this measures time).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def timed_run(tree: Path, cache: Path, output: Path) -> tuple[float, float, str]:
    """Wall and CPU seconds of one ``femref run`` of the default scene from ``tree`` with numba's cache in ``cache``, and its stderr."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(tree)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", "from femref.cli import main; main()", "run", "-o", str(output)],
                          env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: femref run failed ({done.returncode}): {done.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done.stderr.strip()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--trees", type=Path, nargs="+", default=[REPO])
    args = parser.parse_args()
    runs: dict[Path, dict[str, list]] = {tree: {"first": [], "second": [], "said": []} for tree in args.trees}
    with tempfile.TemporaryDirectory() as scratch:
        for repeat in range(args.repeats):
            for k, tree in enumerate(args.trees):
                cache = Path(scratch) / f"cache-{repeat}-{k}"
                cache.mkdir()
                for name in ("first", "second"):
                    wall, cpu, said = timed_run(tree, cache, Path(scratch) / f"{k}.h5")
                    runs[tree][name].append((wall, cpu))
                    if name == "first":
                        runs[tree]["said"].append(said)
    for tree, got in runs.items():
        print(tree)
        for name in ("first", "second"):
            walls, cpus = zip(*got[name])
            print(f"  {name:6} run: wall {statistics.median(walls):6.1f} s, CPU {statistics.median(cpus):6.1f} s (median of {len(walls)})")
        print(f"  the first run said: {got['said'][0] or '(nothing)'}")


if __name__ == "__main__":
    main()
