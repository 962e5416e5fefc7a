"""What the first ``femref run`` after an install costs against a later one: the kernels' compile, and what it says.

    python benchmarks/bench_first_run.py [--repeats 3] [--trees /path/to/a/checkout ...]
    python benchmarks/bench_first_run.py --fresh-venv [--repeats 5] [--trees ...]

Each repeat, per tree (default: this checkout; several trees are interleaved, so a busy
machine loads them alike), runs ``femref run`` of the built-in default scene twice in fresh
processes with an empty kernel cache: the first run compiles the impact kernels (a cold cache,
as after an install) unless the install brought them compiled, the second loads them.

* default: the tree is imported from its folder (``PYTHONPATH``), ``NUMBA_CACHE_DIR`` an empty
  folder — the compile itself, as a checkout meets it;
* ``--fresh-venv``: ``python -m venv`` and ``pip install TREE`` (non-editable: a wheel built by
  the tree's own build backend; pip's cache as it is), then the venv's ``femref run`` with
  ``XDG_CACHE_HOME`` an empty folder — what a user meets after ``pip install .``. The install is
  timed too.

Printed per tree: the medians of each step's wall and CPU seconds (the child processes' user +
system time) and what the first run printed on stderr about compiling. Nothing is asserted (the
tests check the cache and the notice; this measures time).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def timed(command: list[str], env: dict[str, str], what: str) -> tuple[float, float, str]:
    """Wall and CPU seconds of ``command`` (with its children), and its stderr; exits naming ``what`` if it fails."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{what} failed ({done.returncode}): {done.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done.stderr.strip()


def checkout_runs(tree: Path, scratch: Path) -> dict[str, tuple[float, float, str]]:
    """The first and second ``femref run`` from ``tree``'s folder with an empty ``NUMBA_CACHE_DIR``."""
    cache = scratch / "cache"
    cache.mkdir()
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(tree)}
    command = [sys.executable, "-c", "from femref.cli import main; main()", "run", "-o", str(scratch / "run.h5")]
    return {name: timed(command, env, f"{tree}: femref run") for name in ("first", "second")}


def fresh_venv_runs(tree: Path, scratch: Path) -> dict[str, tuple[float, float, str]]:
    """``pip install tree`` into a new venv, then its first and second ``femref run`` with an empty cache home."""
    venv = scratch / "venv"
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    env["XDG_CACHE_HOME"] = str(scratch / "cache-home")
    steps = {"venv": timed([sys.executable, "-m", "venv", str(venv)], env, "python -m venv")}
    steps["install"] = timed([str(venv / "bin" / "pip"), "install", "-q", str(tree)], env, f"pip install {tree}")
    command = [str(venv / "bin" / "femref"), "run", "-o", str(scratch / "run.h5")]
    steps |= {name: timed(command, env, f"{tree}: femref run") for name in ("first", "second")}
    return steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--trees", type=Path, nargs="+", default=[REPO])
    parser.add_argument("--fresh-venv", action="store_true", help="pip install each tree into a new venv and run its femref")
    args = parser.parse_args()
    measure = fresh_venv_runs if args.fresh_venv else checkout_runs
    runs: dict[Path, list[dict]] = {tree: [] for tree in args.trees}
    for repeat in range(args.repeats):
        for tree in args.trees:
            scratch = Path(tempfile.mkdtemp(prefix="bench-first-run-"))
            try:
                got = measure(tree.absolute(), scratch)
            finally:
                shutil.rmtree(scratch, ignore_errors=True)
            runs[tree].append(got)
            print(f"repeat {repeat} {tree}: " + ", ".join(f"{name} {wall:.1f} s wall {cpu:.1f} s CPU" for name, (wall, cpu, _) in got.items()),
                  file=sys.stderr, flush=True)
    for tree, got in runs.items():
        print(tree)
        for name in got[0]:
            walls, cpus = zip(*((run[name][0], run[name][1]) for run in got))
            print(f"  {name:7}: wall {statistics.median(walls):6.1f} s, CPU {statistics.median(cpus):6.1f} s (median of {len(walls)})")
        said = [line for line in got[0]["first"][2].splitlines() if "compil" in line]
        print(f"  the first run said: {' / '.join(said) or '(nothing about compiling)'}")


if __name__ == "__main__":
    main()
