"""The synthetic fleet month through ``femref fleet``: the same store with 1 and 2 workers, throughput, and the worn gear
flagged before its closure force crosses the wear limit.

    python benchmarks/bench_fleet.py [--fleet build/synthetic/fleet] [--out build/bench_fleet] [--json build/bench_fleet.json]

The fleet of benchmarks/synthetic/fleet.py (written first if ``--fleet`` holds no manifest) is run by ``femref fleet
MANIFEST -o OUT --workers N --no-progress`` in a child process for N = 1 and 2, each into a fresh folder: wall time,
the client's peak memory (its VmHWM; the workers are processes of their own), events and record megabytes per second.
The two stores' events (:func:`femref.fleet.store.read_events`, sorted by event and coupler) must be equal, every
column. Then the worn gear's trend (:func:`femref.fleet.wear.gear_trends`) is replayed day by day, each day seeing
only the events up to its midnight: the first day the worn gear is ``wearing`` or ``worn`` must come before the day
its closure force crosses the wear limit (truth.json's ``crossing_day``), and no other gear may be flagged on any
day. The report's page (``OUT/report/index.html`` or wherever ``femref fleet`` says it wrote it) is looked for.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
from pathlib import Path
from typing import Any

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_stream import femref_child  # noqa: E402
from synthetic import fleet  # noqa: E402

FLAGGED = ("wearing", "worn")


def femref_fleet(manifest: Path, out: Path, workers: int) -> dict[str, Any]:
    """``femref fleet manifest -o out --workers N --no-progress`` in a child process: wall time, the client's peak
    memory (its VmHWM; the workers are processes of their own), exit code, its output."""
    arguments = ["fleet", str(manifest.resolve()), "-o", str(out.resolve()), "--workers", str(workers), "--no-progress"]
    wall, peak, code, output = femref_child(arguments, out.parent, out.parent / f"{out.name}.log")
    return {"workers": workers, "wall_s": wall, "client_peak_mb": peak, "returncode": code, "output": output}


def same_store(first: Path, second: Path) -> tuple[bool, str]:
    """Whether the two stores' events are equal, every column (rows sorted by event and coupler), and if not, why."""
    import pandas as pd

    from femref.fleet.store import read_events

    a, b = (read_events(p).sort_values(["event_key", "coupler"], kind="stable").reset_index(drop=True) for p in (first, second))
    try:
        pd.testing.assert_frame_equal(a, b, check_exact=True)
    except AssertionError as error:
        return False, str(error)[:2000]
    return True, f"{len(a)} rows equal"


def wear_replay(store: Path, truth: dict[str, Any]) -> dict[str, Any]:
    """The gears' trend statuses day by day from the store's events (module docstring)."""
    import pandas as pd

    from femref.fleet.store import read_events
    from femref.fleet.wear import gear_trends

    events = read_events(store)
    start = pd.Timestamp(truth["start"])
    worn, statuses, others_flagged = truth["worn_gear"], [], []
    for day in range(1, truth["days"] + 1):
        trends = gear_trends(events, now=start + pd.Timedelta(days=day))
        trend = trends.get(worn)
        statuses.append(trend.status if trend else "no events")
        others_flagged += [(day, gear) for gear, t in trends.items() if gear != worn and t.status in FLAGGED]
    first = next((day for day, status in enumerate(statuses, start=1) if status in FLAGGED), None)
    final = gear_trends(events)[worn]
    rows = events[events["gear"] == worn]
    worn_rows = rows[rows["wear"] == "worn"]
    return {
        "worn_gear": worn, "crossing_day": truth["crossing_day"], "first_flag_day": first, "statuses": statuses,
        "flagged_before_crossing": first is not None and first < truth["crossing_day"], "other_gears_flagged": others_flagged,
        "final_status": final.status, "final_slope_n_per_day": final.slope, "true_slope_n_per_day": -fleet.WEAR_LOSS * truth["rated_closure_force"] / fleet.CROSSING_DAY,
        "forecast_crossing": str(final.crossing), "forecast_interval": [str(final.crossing_early), str(final.crossing_late)],
        "true_crossing": truth["crossing_time"], "closed_events": final.events, "worn_gear_events": len(rows),
        "first_event_marked_worn": str(worn_rows["time"].min()) if len(worn_rows) else None,
    }


def record_megabytes(manifest: Path) -> float:
    """MB of the record files the manifest names."""
    data = yaml.safe_load(manifest.read_text())
    return sum((manifest.parent / r["file"]).stat().st_size for recording in data["recordings"] for r in recording["records"]) / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleet", type=Path, default=Path("build/synthetic/fleet"))
    parser.add_argument("--out", type=Path, default=Path("build/bench_fleet"))
    parser.add_argument("--json", type=Path, default=Path("build/bench_fleet.json"))
    args = parser.parse_args()
    manifest = args.fleet / "manifest.yaml"
    if not manifest.exists():
        fleet.write_fleet(args.fleet)
    truth = json.loads((args.fleet / "truth.json").read_text())
    megabytes = record_megabytes(manifest)
    runs = []
    for workers in (1, 2):
        out = args.out / f"workers_{workers}"
        shutil.rmtree(out, ignore_errors=True)
        out.parent.mkdir(parents=True, exist_ok=True)
        run = femref_fleet(manifest, out, workers)
        store = out / "events.sqlite"
        if store.exists():  # the store is whole even when a later step (the report) failed: the exit code is kept
            from femref.fleet.store import read_events

            events = read_events(store)
            run.update(events=int(events["event_key"].nunique()), rows=len(events), events_per_s=events["event_key"].nunique() / run["wall_s"],
                       megabytes_per_s=megabytes / run["wall_s"], report=[str(p) for p in sorted(out.rglob("index.html"))[:1]])
        runs.append(run)
        print(json.dumps({k: v for k, v in run.items() if k != "output"}), flush=True)
    results: dict[str, Any] = {"recordings": len(truth["recordings"]), "record_megabytes": megabytes, "runs": runs, "machine": {"cpus": os.cpu_count(),
                               "load_average": os.getloadavg()}}
    stores = [args.out / f"workers_{w}" / "events.sqlite" for w in (1, 2)]
    if all(s.exists() for s in stores):
        results["same_store"], results["store_difference"] = same_store(*stores)
        results["wear"] = wear_replay(stores[0], truth)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(results, indent=1, default=str))
    print(f"\n{results['recordings']} recordings, {megabytes:.0f} MB of records")
    for r in runs:
        print(f"workers {r['workers']}: exit {r['returncode']}, {r['wall_s']:.1f} s, {r.get('events', '-')} events, "
              f"{r.get('events_per_s', math.nan):.2f} events/s, {r.get('megabytes_per_s', math.nan):.2f} MB/s, client peak {r['client_peak_mb']:.0f} MB")
    if "wear" in results:
        w = results["wear"]
        print(f"stores equal: {results['same_store']} ({results['store_difference'][:200]})")
        print(f"{w['worn_gear']}: first flagged on day {w['first_flag_day']} (crosses on day {w['crossing_day']:g}): "
              f"{'before' if w['flagged_before_crossing'] else 'NOT before'} the crossing; final {w['final_status']}, slope "
              f"{w['final_slope_n_per_day'] / 1e3:.2f} kN/day (true {w['true_slope_n_per_day'] / 1e3:.2f}), forecast crossing {w['forecast_crossing']} "
              f"[{w['forecast_interval'][0]}, {w['forecast_interval'][1]}] (true {w['true_crossing']}); other gears flagged: {w['other_gears_flagged'] or 'none'}")


if __name__ == "__main__":
    main()
