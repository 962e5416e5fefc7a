"""Start-up cost of ``femref run``: process CPU beyond the models, for two source trees, interleaved.

What it measures: for the default scene (``femref run -o X.h5``) and for its model choice
(``femref run --tolerance 0.01``), the child process's CPU (user + sys, ``resource.getrusage`` of
the child) minus the models' wall time (the sum of ``wall_time_s`` of the result file's model
groups), split into

* ``imports``: CPU inside the import system (every module loaded, at start-up or later in a function)
  outside the loop's load,
* ``loop``: CPU of :func:`femref.run.runner.load_compiled_loop` (the command's, a run's or a choice's), its imports
  (numba) included: the compiled loop's load, after its first compilation in the tree,
* ``models``: the models' wall time (as the run table's ``wall ms``),
* ``rest``: the remainder (interpreter start, validation, scene, measurement, scoring, writing, table).

Each tree runs each command once unmeasured first (numba's cache and the trees' ``__pycache__`` are
written then: the child may write bytecode even under ``PYTHONDONTWRITEBYTECODE``), then the trees
alternate, run after run; the medians of ``--repeats`` runs are printed with the ratio after/before.

Run::

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_startup.py --before /work/main --after . --repeats 5
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

#: The child: times its imports and the compiled loop's load, then runs ``femref`` with the given arguments. It imports
#: only what the command imports, when it does (``load_compiled_loop`` is wrapped as each module that holds it is
#: loaded): a module imported ahead of the command would be imported outside its start-up (collected, for one).
CHILD = r"""
import importlib._bootstrap as bootstrap, json, sys, time

spent = {"imports": 0.0, "loop": 0.0}
depth = [0]
find_and_load = bootstrap._find_and_load
loaders = []  # the compiled loop's load, as femref.run.runner defines it


def timed_load(scene):
    imported, started = spent["imports"], time.process_time()
    loaders[0](scene)
    spent["loop"] += time.process_time() - started
    spent["imports"] = imported


def patched(module):
    loader = getattr(module, "load_compiled_loop", None) if module.__name__.startswith("femref") else None
    if loader is not None and loader is not timed_load:
        loaders[:] = loaders or [loader]
        module.load_compiled_loop = timed_load
    return module


def timed_find_and_load(name, import_):
    if depth[0]:
        return patched(find_and_load(name, import_))
    depth[0] += 1
    started = time.process_time()
    try:
        return patched(find_and_load(name, import_))
    finally:
        spent["imports"] += time.process_time() - started
        depth[0] -= 1


bootstrap._find_and_load = timed_find_and_load
from femref.cli import main

try:
    main(sys.argv[2:], standalone_mode=False)
finally:
    with open(sys.argv[1], "w") as file:
        json.dump(spent, file)
"""

COMMANDS = {"default scene": [], "--tolerance 0.01": ["--tolerance", "0.01"]}


def models_wall(path: Path) -> float:
    """Σ ``wall_time_s`` of the result file's top-level groups (each model or rung run, each estimator) (s)."""
    import h5py

    with h5py.File(path, "r") as h5:
        return sum(float(h5[name].attrs["wall_time_s"]) for name in h5 if isinstance(h5[name], h5py.Group) and "wall_time_s" in h5[name].attrs)


def run_once(tree: Path, arguments: list[str], folder: Path) -> dict[str, float]:
    """One ``femref run`` of the default scene in ``tree``: CPU parts (s)."""
    output, parts = folder / "startup.h5", folder / "parts.json"
    output.unlink(missing_ok=True)
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-c", CHILD, str(parts), "run", "-o", str(output), *arguments], cwd=folder, env=env,
                          capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"femref run in {tree} exited {done.returncode}: {done.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    spent = json.loads(parts.read_text())
    models = models_wall(output)
    return {"cpu": cpu, "beyond models": cpu - models, "imports": spent["imports"], "loop": spent["loop"], "models": models,
            "rest": cpu - models - spent["imports"] - spent["loop"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True, help="source tree before (e.g. /work/main)")
    parser.add_argument("--after", type=Path, required=True, help="source tree after (e.g. .)")
    parser.add_argument("--repeats", type=int, default=5, help="runs per tree and command (medians of these)")
    args = parser.parse_args()
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    with tempfile.TemporaryDirectory() as folder:
        samples: dict[tuple[str, str], list[dict[str, float]]] = {(c, t): [] for c in COMMANDS for t in trees}
        for command, arguments in COMMANDS.items():
            for tree in trees.values():
                run_once(tree, arguments, Path(folder))  # warm-up: numba cache, bytecode
        for _ in range(args.repeats):
            for command, arguments in COMMANDS.items():
                for label, tree in trees.items():
                    samples[command, label].append(run_once(tree, arguments, Path(folder)))
    parts = ("cpu", "beyond models", "imports", "loop", "models", "rest")
    print(f"process CPU (s), medians of {args.repeats}, interleaved; before = {trees['before']}, after = {trees['after']}")
    for command in COMMANDS:
        print(f"\nfemref run, {command}")
        print(f"{'part':>14} {'before':>8} {'after':>8} {'after/before':>13}")
        for part in parts:
            before = statistics.median(s[part] for s in samples[command, "before"])
            after = statistics.median(s[part] for s in samples[command, "after"])
            print(f"{part:>14} {before:8.3f} {after:8.3f} {after / before if before else float('nan'):13.2f}")


if __name__ == "__main__":
    main()
