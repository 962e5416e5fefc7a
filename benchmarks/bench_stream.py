"""The synthetic day through ``femref run``: cost, memory, every impact found once, and each event as cut by hand.

    python benchmarks/bench_stream.py [--hours 24] [--formats csv,hdf5,mdf4,tdms,uff58] [--lengths 1,4,12,24]
                                      [--length-format csv] [--out build/bench_stream] [--json build/bench_stream.json] [--margin 0.05] [--no-cut] [--keep]

For each format the day of benchmarks/synthetic/day.py (seed 1) is written, run by ``femref run <format>/day.yaml -o
events.h5`` in a child process (wall time; peak memory: the child's VmHWM, :data:`PEAK_MEMORY_CHILD`) and scored
against its truth.json:

* **impacts**: an event whose window (``start``–``end``) holds an impact's contact matches it; each impact is found
  once (one event of an impact type), missed (none) or split (more); an event of an impact type matching nothing is a
  phantom; the impact type is compared with the truth's, and the trigger's delay after the contact is reported;
* **transients**: the events at a track joint or noise burst (its time in the window or :data:`TRANSIENT_LEAD` before
  it), and whether each is ``not_an_impact``;
* **hand cut**: each event's samples are cut by hand from the recorders' files (read by femref's reader, the
  samples of the event's grid and :data:`MARGIN` either side), recorder r2's times shifted by its declared
  ``clock_offset`` and the clock correction the run reports for the event (``/events/<i>/clock/r2`` ``correction``),
  linearly interpolated onto the event's grid, and run through the event pipeline
  (:func:`femref.run.measured.event_result`: classification, estimators, closing speed, closure, wear, alarm) with the
  window and flags the stream decided; every number, string and history of the run's event and the cut's (but wall
  times, the clock group and estimator settings) is compared, numbers to :data:`RTOL`. What it checks: that the
  stream's buffers, chunk and file boundaries and clock mapping hand the estimators the same samples as a plain slice of
  the files (a cut re-triggered as a short case of its own would differ by design: its running baseline has no
  stream around it).

Then the day is written and run at each of ``--lengths`` hours in ``--length-format``: the wall time's slope (s per
hour of recording, least squares) and the peak memory at each length (flat: the longest over the shortest). A table
is printed and the numbers written to ``--json``. Files are deleted after each run unless ``--keep``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

from synthetic import day  # noqa: E402
from synthetic.writers import FORMATS  # noqa: E402

TRANSIENT_LEAD = 0.5
"""s: an event belongs to a joint or burst whose time lies in its window or up to this before it (a joint jolts car 2
first, car 1 up to 1.4 s later)."""
MARGIN = 0.05
"""s of records either side of an event's window in its hand cut (interpolation needs the samples around the window)."""
RTOL = 1e-9
IMPACT_TYPES = ("free_to_roll", "coupled")
SKIPPED = ("wall_time_s", "settings", "clock")
"""Keys of an event not compared with its hand cut: wall times, estimator settings (they hold timings) and the clock
group (the hand cut declares the correction instead)."""


@dataclass(frozen=True)
class RunCost:
    """A child run's ``wall`` time (s), peak resident memory (``peak_mb``, MB: its VmHWM), exit code and the end of its stderr."""

    wall: float
    peak_mb: float
    returncode: int
    stderr: str


PEAK_MEMORY_CHILD = ("import atexit, os\n"
                     "def peak():\n"
                     "    with open('/proc/self/status') as status, open(os.environ['BENCH_VMHWM'], 'w') as out:\n"
                     "        out.write(next(line for line in status if line.startswith('VmHWM')).split()[1])\n"
                     "atexit.register(peak)\n"
                     "from femref.cli import main\n"
                     "main()\n")
"""``femref`` in the child, writing its VmHWM (kB) at exit to the file ``$BENCH_VMHWM``. Not the child's ``ru_maxrss``:
Linux carries the parent's peak into it across fork and exec."""


def femref_child(arguments: list[str], cwd: Path, log: Path) -> tuple[float, float, int, str]:
    """``femref ARGUMENTS`` in a child process (working directory ``cwd``, not the tree: femref from the path, output
    to ``log``): its wall time (s), peak memory (MB), exit code and the end of its output."""
    peak = log.with_suffix(".vmhwm")
    peak.unlink(missing_ok=True)
    started = time.perf_counter()
    with open(log, "w+") as output:
        code = subprocess.call([sys.executable, "-c", PEAK_MEMORY_CHILD, *arguments], stdout=output, stderr=subprocess.STDOUT, cwd=cwd,
                               env={**os.environ, "BENCH_VMHWM": str(peak.resolve())})
        wall = time.perf_counter() - started
        output.seek(0)
        tail = output.read()[-4000:]
    return wall, (float(peak.read_text()) / 1024.0 if peak.exists() else math.nan), code, tail


def femref_run(case: Path, output: Path) -> RunCost:
    """``femref run case -o output`` in a child process, timed, with its peak memory."""
    return RunCost(*femref_child(["run", str(case.resolve()), "-o", str(output.resolve())], case.parent, output.with_suffix(".log")))


def read_event_file(path: Path) -> list[dict[str, Any]]:
    """Every event of an event file as a flat ``{key path: value}`` (attributes and datasets), in index order."""
    events = []
    with h5py.File(path, "r") as h5:
        for name in sorted(h5["events"], key=int):
            flat: dict[str, Any] = {}

            def visit(key: str, item: Any, flat: dict[str, Any] = flat) -> None:
                if isinstance(item, h5py.Dataset):
                    flat[key] = item[()]
                for attr, value in item.attrs.items():
                    flat[f"{key}@{attr}" if key else attr] = value.decode() if isinstance(value, bytes) else value

            group = h5["events"][name]
            visit("", group)
            group.visititems(visit)
            flat["index"] = int(name)
            events.append(flat)
    return events


def score(events: list[dict[str, Any]], truth: dict[str, Any]) -> dict[str, Any]:
    """Impacts found once, missed, split; phantoms; type agreement; the transients' events and their classes."""
    impacts = truth["impacts"]
    matches: list[list[int]] = [[] for _ in impacts]
    claimed = set()
    for k, event in enumerate(events):
        for i, impact in enumerate(impacts):
            if event["start"] <= impact["time"] <= event["end"]:
                matches[i].append(k)
                claimed.add(k)
    transients: dict[str, list[str]] = {"track_joint": [], "noise_burst": []}
    for other in truth["not_impacts"]:
        near = [e for e in events if e["start"] - TRANSIENT_LEAD <= other["time"] <= e["end"]]
        transients[other["kind"]] += [e["impact_type"] for e in near] or ["not found"]
        claimed |= {events.index(e) for e in near}
    found_once = [m for m in matches if len(m) == 1 and events[m[0]]["impact_type"] in IMPACT_TYPES]
    phantoms = [e["trigger_time"] for k, e in enumerate(events) if k not in claimed and e["impact_type"] != "not_an_impact"]
    types = [events[m[0]]["impact_type"] == impacts[i]["type"] for i, m in enumerate(matches) if len(m) == 1]
    delays = [events[m[0]]["trigger_time"] - impacts[i]["time"] for i, m in enumerate(matches) if len(m) == 1]
    return {
        "impacts": len(impacts), "events": len(events), "found_once": len(found_once), "missed": sum(not m for m in matches),
        "split": sum(len(m) > 1 for m in matches), "phantoms": len(phantoms), "phantom_times": phantoms,
        "type_agrees": int(sum(types)), "type_differs": int(len(types) - sum(types)),
        "trigger_delay_s": [min(delays, default=math.nan), max(delays, default=math.nan)],
        "transients": {kind: {"count": len(classes), "not_an_impact": classes.count("not_an_impact"), "classes": sorted(set(classes))}
                       for kind, classes in transients.items()},
        "unclaimed_not_an_impact": sum(k not in claimed and e["impact_type"] == "not_an_impact" for k, e in enumerate(events)),
    }


def requests(record: dict[str, Any]) -> tuple[str, list[tuple[Any, str]], list[str]]:
    """A case record's key (column, dataset, channel), its reader requests (time first) and its probes."""
    key = next(k for k in ("column", "dataset", "channel") if k in record["time"])
    probes = list(record["channels"])
    return key, [(record["time"][key], "time")] + [(record["channels"][p][key], f"channel {p}") for p in probes], probes


class RecorderFiles:
    """A recorder's files (a case record's ``files`` glob) read on demand through femref's reader, two kept at a time."""

    def __init__(self, folder: Path, record: dict[str, Any]) -> None:
        self.record = record
        self.paths = sorted(p for pattern in record["files"] for p in folder.glob(pattern))
        self.starts = [day.file_start(p.stem) for p in self.paths]
        self.cache: dict[Path, list[np.ndarray]] = {}

    def window(self, start: float, end: float) -> list[np.ndarray]:
        """Time and channels of the samples with times in ``[start, end]`` (s, the recorder's clock)."""
        from femref.sensing.record_files import MAX_RECORD_SAMPLES, SampleLimit, format_of, read_columns

        first = max(int(np.searchsorted(self.starts, start, side="right")) - 1, 0)
        last = max(int(np.searchsorted(self.starts, end, side="right")) - 1, 0)
        parts = []
        for path in self.paths[first : last + 1]:
            if path not in self.cache:
                _, asked, _ = requests(self.record)
                options = {k: self.record[k] for k in ("separator", "decimal") if k in self.record}
                self.cache[path] = read_columns(path, asked, SampleLimit(MAX_RECORD_SAMPLES, "bench"), format_of(path), options)[0]
                while len(self.cache) > 2:
                    self.cache.pop(next(iter(self.cache)))
            columns = self.cache[path]
            inside = (columns[0] >= start) & (columns[0] <= end)
            parts.append([c[inside] for c in columns])
        return [np.concatenate([p[k] for p in parts]) for k in range(len(parts[0]))]


def hand_cut(folder: Path, scene: Any, case: dict[str, Any], files: list[RecorderFiles], event: dict[str, Any], margin: float = MARGIN
             ) -> dict[str, Any]:
    """The event's window cut by hand from the recorders' files (module docstring) and run through the event pipeline
    (:func:`femref.run.measured.event_result`) of ``scene`` (the day's case); the cut's event, flat as
    :func:`read_event_file` gives it."""
    from femref.estimators import plug_ins
    from femref.events import event_file
    from femref.run.measured import event_result
    from femref.sensing.recordings import ACCELERATION_UNITS
    from femref.sensing.stream import CutEvent
    from femref.sensing.trigger import Event

    t = np.asarray(event["records/time"], dtype=float)
    records: dict[str, np.ndarray] = {}
    for recorder in files:
        record = recorder.record
        offset = float(record.get("clock_offset", 0.0))
        correction = 0.0 if record is case["records"][0] else float(event[f"clock/{record['recorder']}@correction"])
        grid = t - correction
        columns = recorder.window(grid[0] - offset - margin, grid[-1] - offset + margin)
        own = columns[0] + offset
        _, _, probes = requests(record)
        for probe, values in zip(probes, columns[1:]):
            records[probe] = np.interp(grid, own, values * ACCELERATION_UNITS[record["channels"][probe]["unit"]])
    flags = tuple(json.loads(event["flags"])) if isinstance(event.get("flags"), str) else tuple(event.get("flags", ()))
    cut = CutEvent(Event(event["index"], event["start"], event["end"], event["trigger_time"], event["trigger_probe"], flags), t, records)
    folder.mkdir(parents=True, exist_ok=True)
    with event_file(folder / "cut.h5", {}) as sink:
        sink(event_result(scene, plug_ins(scene), cut))
    (found,) = read_event_file(folder / "cut.h5")
    return found


def differences(run: dict[str, Any], cut: dict[str, Any]) -> tuple[float, list[str]]:
    """The largest relative difference of the two events' numbers and histories, and the keys that differ beyond
    :data:`RTOL` (a string, a shape, a key only one has)."""
    keys = {k for k in run.keys() | cut.keys() if not any(part in k for part in SKIPPED) and k != "index"}
    worst, differ = 0.0, []
    for key in sorted(keys):
        if key not in run or key not in cut:
            differ.append(f"{key} (only in the {'run' if key in run else 'cut'})")
            continue
        a, b = run[key], cut[key]
        if isinstance(a, str) or isinstance(b, str):
            if a != b:
                differ.append(key)
            continue
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        if a.shape != b.shape:
            differ.append(f"{key} (shape {a.shape} against {b.shape})")
            continue
        both = np.isfinite(a) & np.isfinite(b)
        if not np.array_equal(np.isfinite(a), np.isfinite(b)):
            differ.append(f"{key} (NaN in one)")
            continue
        scale = max(float(np.max(np.abs(a[both]), initial=0.0)), 1e-300)
        relative = float(np.max(np.abs(a[both] - b[both]), initial=0.0)) / scale
        worst = max(worst, relative)
        if relative > RTOL:
            differ.append(f"{key} ({relative:.2g})")
    return worst, differ


def bench_format(out: Path, fmt: str, hours: float, cut: bool, margin: float = MARGIN) -> dict[str, Any]:
    """Write the day in ``fmt``, run it, score it and (``cut``) compare each event with its hand cut."""
    folder = out / f"day_{hours:g}h"
    started = time.perf_counter()
    truth = day.write_day(folder, hours, [fmt])
    generated = time.perf_counter() - started
    size = sum((folder / fmt / name).stat().st_size for name in truth["files"][fmt]) / 1e6
    output = folder / f"{fmt}_events.h5"
    cost = femref_run(folder / fmt / "day.yaml", output)
    result: dict[str, Any] = {"format": fmt, "hours": hours, "megabytes": size, "write_s": truth["write_seconds"][fmt], "generate_s": generated,
                              "wall_s": cost.wall, "peak_mb": cost.peak_mb, "returncode": cost.returncode}
    if cost.returncode != 0:
        result["stderr"] = cost.stderr
        return result
    events = read_event_file(output)
    result.update(score(events, truth))
    if cut:
        from femref.case import load_case
        from femref.scene.build import scene_from_case

        case = yaml.safe_load((folder / fmt / "day.yaml").read_text())
        scene = scene_from_case(load_case(folder / fmt / "day.yaml"))
        files = [RecorderFiles(folder / fmt, record) for record in case["records"]]
        worst, failing = 0.0, {}
        for event in sorted(events, key=lambda e: e["start"]):
            found = hand_cut(folder / "cut", scene, case, files, event, margin)
            relative, differ = differences(event, found)
            worst = max(worst, relative)
            if differ:
                failing[str(event["index"])] = differ[:8]
        result.update(hand_cut_events=len(events), hand_cut_worst=worst, hand_cut_failing=len(failing), hand_cut_differences=failing)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=24.0)
    parser.add_argument("--formats", default=",".join(FORMATS))
    parser.add_argument("--lengths", default="1,4,12,24")
    parser.add_argument("--length-format", default="csv")
    parser.add_argument("--out", type=Path, default=Path("build/bench_stream"))
    parser.add_argument("--json", type=Path, default=Path("build/bench_stream.json"))
    parser.add_argument("--no-cut", action="store_true", help="skip the hand cuts")
    parser.add_argument("--margin", type=float, default=MARGIN, help="s of records either side of an event's window in its hand cut")
    parser.add_argument("--keep", action="store_true", help="keep the written days")
    args = parser.parse_args()
    results: dict[str, Any] = {"formats": [], "lengths": []}
    for fmt in [f for f in args.formats.split(",") if f]:
        row = bench_format(args.out, fmt, args.hours, not args.no_cut, args.margin)
        results["formats"].append(row)
        print(json.dumps({k: v for k, v in row.items() if k not in ("hand_cut_differences", "phantom_times", "stderr")}), flush=True)
        if not args.keep:
            shutil.rmtree(args.out / f"day_{args.hours:g}h")
    for hours in [float(h) for h in args.lengths.split(",") if h]:
        done = next((r for r in results["formats"] if r["format"] == args.length_format and r["hours"] == hours), None)
        row = done or bench_format(args.out, args.length_format, hours, cut=False)
        results["lengths"].append({k: row[k] for k in ("hours", "wall_s", "peak_mb", "megabytes", "returncode")})
        if not args.keep and done is None:
            shutil.rmtree(args.out / f"day_{hours:g}h")
    lengths = [r for r in results["lengths"] if r["returncode"] == 0]
    if len(lengths) >= 2:
        slope, intercept = np.polyfit([r["hours"] for r in lengths], [r["wall_s"] for r in lengths], 1)
        memory = [r["peak_mb"] for r in lengths]
        results["slope_s_per_hour"], results["intercept_s"] = float(slope), float(intercept)
        results["memory_ratio_longest_to_shortest"] = memory[-1] / memory[0]
    results["machine"] = {"cpus": os.cpu_count(), "load_average": os.getloadavg()}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=1, default=float))
    print(f"\n{'format':>7} {'h':>4} {'MB':>8} {'write s':>8} {'run s':>7} {'peak MB':>8} {'impacts':>7} {'once':>5} {'missed':>6} {'split':>5} "
          f"{'phantom':>7} {'type ok':>7} {'joints n/a':>10} {'bursts n/a':>10} {'cut worst':>9} {'cut bad':>7}")
    for r in results["formats"]:
        t = r.get("transients", {})
        joints, bursts = t.get("track_joint", {}), t.get("noise_burst", {})
        print(f"{r['format']:>7} {r['hours']:4g} {r['megabytes']:8.0f} {r['write_s']:8.1f} {r['wall_s']:7.1f} {r['peak_mb']:8.0f} "
              f"{r.get('impacts', math.nan):7} {r.get('found_once', '-'):>5} {r.get('missed', '-'):>6} {r.get('split', '-'):>5} {r.get('phantoms', '-'):>7} "
              f"{r.get('type_agrees', '-'):>7} {joints.get('not_an_impact', '-')!s:>4}/{joints.get('count', '-')!s:<5} "
              f"{bursts.get('not_an_impact', '-')!s:>4}/{bursts.get('count', '-')!s:<5} {r.get('hand_cut_worst', math.nan):9.1e} {r.get('hand_cut_failing', '-'):>7}")
    for r in results["lengths"]:
        print(f"length {r['hours']:5g} h: {r['wall_s']:7.1f} s, peak {r['peak_mb']:6.0f} MB")
    if "slope_s_per_hour" in results:
        print(f"slope {results['slope_s_per_hour']:.2f} s per hour of recording (intercept {results['intercept_s']:.1f} s); "
              f"memory longest/shortest {results['memory_ratio_longest_to_shortest']:.2f}")


if __name__ == "__main__":
    main()
