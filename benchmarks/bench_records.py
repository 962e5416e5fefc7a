"""The CSV record reader's rate (MB/s, samples/s) per dialect, and two femref trees compared interleaved.

    python benchmarks/bench_records.py [--minutes 10,60] [--rate 1000] [--channels 3] [--repeats 5]
                                       [--dialects comma,semicolon,tab,decimal_comma,quoted,iso8601,bom]
                                       [--trees /path/before,/path/after] [--out build/bench_records] [--json build/bench_records.json]
                                       [--cases cases/measured_yard.yaml,...]

For each length and dialect a file of a time column and ``--channels`` acceleration columns at ``--rate`` Hz is written
once (seeded): ``comma`` (``,``), ``semicolon`` (``;``), ``tab``, ``decimal_comma`` (``;`` and ``3,14``), ``quoted``
(every number in double quotes), ``iso8601`` (the time column as ISO-8601 stamps) and ``bom`` (a UTF-8 byte-order mark
before the header). Each tree of ``--trees`` (a femref checkout, put first on ``sys.path`` of a child process) then
reads every file through :func:`femref.sensing.record_files.open_columns`, the path the run and validation take,
``--repeats`` times, the trees alternating within each repeat; the child's CPU time (``time.process_time``) of the read
is the measure. The table gives the median CPU time, MB/s and samples/s (rows × columns read) per tree and the ratio.
The first tree's columns are checked bit for bit against every other tree's (a digest of each column, whatever the chunks).

``--cases``: instead, each measured case is run by ``femref run CASE -o <out>/<tree>.h5`` in a child process of each
tree, ``--repeats`` times alternating, and the child's CPU time (user + system, from ``getrusage``) and wall time
are compared: what a user's run of the case costs, validation, reading, estimators and the event file together.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

DIALECTS = ("comma", "semicolon", "tab", "decimal_comma", "quoted", "iso8601", "bom")
SEPARATOR = {"comma": ",", "semicolon": ";", "tab": "\t", "decimal_comma": ";", "quoted": ",", "iso8601": ",", "bom": ","}

CHILD = """
import hashlib, json, sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from femref.sensing.record_files import open_columns
path, channels, iso = Path(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "1"
options = {"decimal": "," if "decimal_comma" in path.name else "."}
if iso:
    options["timestamps"] = "time"
requests = [(f"a{k}", f"channel c/{k}") for k in range(channels)] + [("time", "time")]
digests, rows = [hashlib.sha256() for _ in range(channels + 1)], 0
start = time.process_time()
with open_columns(path, requests, "csv", options) as (_, _, chunks):
    for chunk in chunks:
        rows += chunk[0].size
        for digest, part in zip(digests, chunk):
            digest.update(part.tobytes())
cpu = time.process_time() - start
print(json.dumps({"cpu": cpu, "rows": rows, "digest": "".join(d.hexdigest() for d in digests)}))
"""


def write_file(path: Path, dialect: str, minutes: float, rate: float, channels: int, seed: int = 1) -> None:
    """A record of ``minutes`` at ``rate`` Hz in ``dialect`` (module docstring), written in blocks of 10⁵ rows."""
    rng = np.random.default_rng(seed)
    separator = SEPARATOR[dialect]
    rows = int(minutes * 60 * rate)
    origin = datetime(2026, 3, 1, 6, 0, 0)
    with path.open("w", encoding="utf-8-sig" if dialect == "bom" else "utf-8", newline="") as out:
        out.write(separator.join(["time"] + [f"a{k}" for k in range(channels)]) + "\n")
        for first in range(0, rows, 100_000):
            n = min(100_000, rows - first)
            index = np.arange(first, first + n)
            values = rng.normal(0.0, 0.5, (n, channels)).round(6)
            if dialect == "iso8601":
                times = [(origin + timedelta(microseconds=int(k * 1e6 / rate))).isoformat(timespec="microseconds") for k in index]
            else:
                times = [repr(float(t)) for t in index / rate]
            cells = [[repr(float(v)) for v in row] for row in values]
            lines = []
            for t, row in zip(times, cells):
                line = [t, *row]
                if dialect == "decimal_comma":
                    line = [cell.replace(".", ",") for cell in line]
                elif dialect == "quoted":
                    line = [f'"{cell}"' for cell in line]
                lines.append(separator.join(line))
            out.write("\n".join(lines) + "\n")


def read_cost(tree: str, path: Path, channels: int, dialect: str) -> dict:
    """One child read of ``path`` with the femref of ``tree``: its CPU time (s), rows and digest."""
    done = subprocess.run([sys.executable, "-c", CHILD, tree, str(path), str(channels), "1" if dialect == "iso8601" else "0"],
                          capture_output=True, text=True, check=True, env={"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"})
    return json.loads(done.stdout.strip().splitlines()[-1])


def run_cost(tree: str, case: Path, out: Path) -> tuple[float, float]:
    """``(cpu, wall)`` (s) of ``femref run case -o out`` in a child process running the femref of ``tree``."""
    code = f"import sys; sys.path.insert(0, {tree!r}); from femref.cli import main; main()"
    before, start = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run([sys.executable, "-c", code, "run", str(case), "-o", str(out)], capture_output=True, check=True,
                   env={"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"})
    wall, after = time.perf_counter() - start, resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall


def compare_cases(cases: list[Path], trees: list[str], repeats: int, out: Path) -> list[dict]:
    """Each case run by every tree, ``repeats`` times alternating: median CPU and wall time per tree."""
    report = []
    for case in cases:
        costs: dict[str, list[tuple[float, float]]] = {tree: [] for tree in trees}
        for _ in range(repeats):
            for k, tree in enumerate(trees):
                costs[tree].append(run_cost(tree, case, out / f"{case.stem}_{k}.h5"))
        line: dict = {"case": str(case)}
        text = f"{case.name:<24}"
        for tree in trees:
            cpu, wall = statistics.median(c for c, _ in costs[tree]), statistics.median(w for _, w in costs[tree])
            line[tree] = {"cpu_s": cpu, "wall_s": wall, "all": costs[tree]}
            text += f" | CPU {cpu:7.2f} s wall {wall:7.2f} s"
        if len(trees) > 1:
            line["ratio"] = line[trees[0]]["cpu_s"] / line[trees[-1]]["cpu_s"]
            text += f" | CPU {line['ratio']:5.2f}x"
        print(text, flush=True)
        report.append(line)
    return report


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", default="10,60")
    parser.add_argument("--rate", type=float, default=1000.0)
    parser.add_argument("--channels", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--dialects", default=",".join(DIALECTS))
    parser.add_argument("--trees", default=str(Path(__file__).resolve().parents[1]))
    parser.add_argument("--out", type=Path, default=Path("build/bench_records"))
    parser.add_argument("--json", type=Path, default=Path("build/bench_records.json"))
    parser.add_argument("--cases", default="")
    args = parser.parse_args(argv)
    trees = args.trees.split(",")
    args.out.mkdir(parents=True, exist_ok=True)
    if args.cases:
        found = compare_cases([Path(case).resolve() for case in args.cases.split(",")], trees, args.repeats, args.out)
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(found, indent=1))
        return
    report = []
    for minutes in [float(m) for m in args.minutes.split(",")]:
        for dialect in args.dialects.split(","):
            path = args.out / f"{dialect}_{minutes:g}min.csv"
            if not path.exists():
                write_file(path, dialect, minutes, args.rate, args.channels)
            size = path.stat().st_size / 1e6
            costs: dict[str, list[float]] = {tree: [] for tree in trees}
            digests = {}
            rows = 0
            for _ in range(args.repeats):
                for tree in trees:
                    found = read_cost(tree, path, args.channels, dialect)
                    costs[tree].append(found["cpu"])
                    digests[tree], rows = found["digest"], found["rows"]
            same = len(set(digests.values())) == 1
            line = {"minutes": minutes, "dialect": dialect, "MB": size, "rows": rows, "same_values": same}
            text = f"{minutes:>4g} min {dialect:<14} {size:7.1f} MB"
            for tree in trees:
                cpu = statistics.median(costs[tree])
                line[tree] = {"cpu_s": cpu, "MB_per_s": size / cpu, "samples_per_s": rows * (args.channels + 1) / cpu, "all": costs[tree]}
                text += f" | {cpu:7.3f} s {size / cpu:7.1f} MB/s {rows * (args.channels + 1) / cpu:10.3g} samples/s"
            if len(trees) > 1:
                ratio = line[trees[0]]["cpu_s"] / line[trees[-1]]["cpu_s"]
                line["ratio"] = ratio
                text += f" | {ratio:6.1f}x {'same' if same else 'DIFFERENT'}"
            print(text, flush=True)
            report.append(line)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
