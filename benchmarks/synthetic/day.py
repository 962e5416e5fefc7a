"""A synthetic day at a yard: two recorders at 1 kHz, hourly files, in every record format, with its truth.

    python benchmarks/synthetic/day.py --hours 24 --out build/synthetic/day [--formats csv,hdf5,mdf4,tdms,uff58] [--seed 1]

Recorder ``r1`` on car 1 (rear, centre, front; in g) is the reference clock; recorder ``r2`` on car 2 (rear, centre; in
m/s², CSV with ``;`` and decimal commas) runs 50 ppm fast with an offset, ``c = offset + (1 + 50e-6) t``: 7.3125 s, of
which the case declares the 7 s the installer noted (``clock_offset: -7``), the rest and the drift left to estimate
(``clock_drift: estimate``). It restarts once: it stops for 50–70 s, its clock keeps running but comes back 0.4375 s
behind its line (a new offset), and its new file starts on a whole second. On this:

* impacts, 8.4 an hour (202 in 24 h) at random times at least 20 s apart, each drawn from the fem library of
  :mod:`impacts` (free to roll and coupled, 1–4 m/s, three gears; the cars ring until they rest), placed at a random
  contact instant and sampled by each recorder at its own clock's ticks (cubic interpolation of the 1 kHz records);
* track-joint transients, 2 an hour: a joint's zero-mean Ricker jolts (8–15 Hz, 6–15 m/s²) passing car 2's axles then
  car 1's at 3–10 m/s, the same sign on both cars, no closing — ``not_an_impact`` by its momentum (an outside force);
* noise bursts, 1 an hour: 50–200 ms of white noise (5–10 m/s²) on every channel of one recorder;
* white noise (0.05 m/s²) and a constant offset on every channel.

Nothing else is within 10 s of an impact (slots of :data:`SLOTS` seconds, the event :data:`LEAD` s into its slot), so each
impact is one event. Each recorder writes a file per hour of its own clock (named by the clock time it starts), every
format from the same fixed-point arrays (:mod:`writers`); for each format ``<out>/<format>/day.yaml`` is the measured
case that reads them (``files:`` globs, ``clock_drift: estimate``), and ``<out>/truth.json`` holds each impact's contact
time on the reference clock, type, gear and speed, the transients, bursts, restart and clocks, the files and the
seconds each format took to write.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy.interpolate import CubicSpline

if __package__ in (None, ""):  # run as a script: benchmarks/ on the path for the sibling modules
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from synthetic.impacts import FRICTION_GEAR, LIBRARY, LOWPASS, PROBES, RATE, SENSORS, SimulatedImpact, impact_case, load_library  # noqa: E402
from synthetic.writers import FORMATS, SUFFIX, Dialect, RecorderFile, fixed_point, write  # noqa: E402

G = 9.80665
IMPACTS_PER_HOUR = 8.4
JOINTS_PER_HOUR = 2.0
BURSTS_PER_HOUR = 1.0
SLOTS = {"impact": 21.0, "track_joint": 10.0, "noise_burst": 10.0}
"""s each occurrence holds to itself; an impact's slot (its contact up to 1 s late in it) makes impacts at least 20 s apart."""
LEAD = 5.0
"""s from a slot's start to its occurrence."""
EDGE = 10.0
"""s at the start and end of the day with nothing placed."""
RESTART_GAP = (50.0, 70.0)
"""s recorder r2 is off when it restarts (uniform)."""
RESTART_MARGIN = 20.0
"""s kept clear of anything placed on either side of the restart's gap."""
NOISE = 0.05
"""m/s²: the recorders' white noise."""
DRIFT_PPM = 50.0
CLOCK_OFFSETS = (7.3125, 6.875)
"""s: recorder r2's clock ahead of r1's before and after its restart."""
DECLARED_OFFSET = -7.0
"""s: r2's ``clock_offset`` in the case, what its installer noted (added to its times)."""
TRIGGER = {"trigger": 3.0, "pre": 0.5, "post": 2.5}
CHECKS = {"alarm": 2.5e6, "rated_closure_force": 2.016e6, "wear_tolerance": 0.15}
ESTIMATORS = ["inverse_rigid", "kalman"]


@dataclass(frozen=True)
class Recorder:
    """A recorder: its ``name``, the ``probes`` it records with their file ``columns``, its ``unit`` (g or m/s²) and the
    decimals it writes, its channels' constant offsets (in its unit) and the CSV dialect it writes."""

    name: str
    probes: tuple[str, ...]
    unit: str
    decimals: int
    offsets: tuple[float, ...]
    dialect: Dialect

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(probe.replace("/", "_") for probe in self.probes)

    @property
    def scale(self) -> float:
        """Its unit in m/s²."""
        return G if self.unit == "g" else 1.0


RECORDERS = (
    Recorder("r1", PROBES[:3], "g", 6, (0.002, -0.001, 0.0015), Dialect(",", ".")),
    Recorder("r2", PROBES[3:], "m/s^2", 5, (0.02, -0.03), Dialect(";", ",")),
)


@dataclass(frozen=True)
class Clock:
    """A recorder's clock ``c = offset + (1 + drift_ppm·1e-6) t`` over reference times ``[start, end)`` (s)."""

    start: float
    end: float
    offset: float
    drift_ppm: float

    def reading(self, t: np.ndarray | float) -> np.ndarray | float:
        return self.offset + (1.0 + self.drift_ppm * 1e-6) * t

    def reference(self, c: np.ndarray | float) -> np.ndarray | float:
        return (c - self.offset) / (1.0 + self.drift_ppm * 1e-6)


@dataclass(frozen=True)
class Occurrence:
    """Something on the track at reference time ``time`` (s): an ``impact`` (``library`` its index), a ``track_joint`` or a
    ``noise_burst``, with what draws it (``params``)."""

    kind: str
    time: float
    params: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Day:
    """The day's plan: its length (s), the occurrences in time order, the recorders' clocks (r2's restart between its two)."""

    seconds: float
    occurrences: tuple[Occurrence, ...]
    clocks: dict[str, tuple[Clock, ...]]
    seed: int


def plan_day(hours: float, library: Sequence[SimulatedImpact], seed: int = 1) -> Day:
    """Place the impacts, joints, bursts and r2's restart at random (module docstring); ValueError if they do not fit."""
    rng = np.random.default_rng([seed, 0])
    seconds = hours * 3600.0
    kinds = (["impact"] * math.ceil(IMPACTS_PER_HOUR * hours) + ["track_joint"] * math.ceil(JOINTS_PER_HOUR * hours)
             + ["noise_burst"] * math.ceil(BURSTS_PER_HOUR * hours))
    gap = float(rng.uniform(*RESTART_GAP))
    slots = [str(kind) for kind in rng.permutation([*kinds, "restart"])]
    lengths = [SLOTS[kind] if kind != "restart" else gap + 2 * RESTART_MARGIN for kind in slots]
    free = seconds - 2 * EDGE - sum(lengths)
    if free <= 0:
        raise ValueError(f"{len(slots)} occurrences need {sum(lengths) + 2 * EDGE:.0f} s; a {hours:g} h day has {seconds:.0f} s")
    starts = EDGE + np.sort(rng.uniform(0.0, free, len(slots))) + np.concatenate([[0.0], np.cumsum(lengths[:-1])])
    occurrences, stop = [], math.nan
    for kind, start in zip(slots, starts):
        if kind == "restart":
            stop = float(start + RESTART_MARGIN)
        elif kind == "impact":
            occurrences.append(Occurrence(kind, float(start + LEAD + rng.uniform(0.0, 1.0)), {"library": int(rng.integers(len(library)))}))
        elif kind == "track_joint":
            occurrences.append(Occurrence(kind, float(start + LEAD), {
                "speed": float(rng.uniform(3.0, 10.0)), "frequency": float(rng.uniform(8.0, 15.0)),
                "amplitude": {"car1": float(rng.uniform(6.0, 15.0)), "car2": float(rng.uniform(6.0, 15.0))}}))
        else:
            occurrences.append(Occurrence(kind, float(start + LEAD), {
                "recorder": str(rng.choice([r.name for r in RECORDERS])), "duration": float(rng.uniform(0.05, 0.2)),
                "level": float(rng.uniform(5.0, 10.0)), "seed": int(rng.integers(2**31))}))
    first, second = CLOCK_OFFSETS
    clocks = {"r1": (Clock(0.0, seconds, 0.0, 0.0),),
              "r2": (Clock(0.0, stop, first, DRIFT_PPM), Clock(stop + gap, seconds, second, DRIFT_PPM))}
    return Day(seconds, tuple(occurrences), clocks, seed)


JOINT_AXLES = {"car2": (0.0, 1.8), "car1": (5.0, 6.8)}
"""m each axle runs after the first reaches the joint: car 2's trailing truck, then car 1's leading truck."""


def ricker(t: np.ndarray, at: float, frequency: float) -> np.ndarray:
    """The zero-mean Ricker wavelet ``(1 − 2u²) e^{−u²}``, ``u = π f (t − at)``."""
    u = (np.pi * frequency * (t - at)) ** 2
    return (1.0 - 2.0 * u) * np.exp(-u)


def joint_acceleration(joint: Occurrence, car: str, t: np.ndarray) -> np.ndarray:
    """Car ``car``'s rigid acceleration (m/s², every probe alike) at reference times ``t`` from ``joint``."""
    p = joint.params
    return p["amplitude"][car] * sum(ricker(t, joint.time + s / p["speed"], p["frequency"]) for s in JOINT_AXLES[car])


def span(occurrence: Occurrence, library: Sequence[SimulatedImpact]) -> tuple[float, float]:
    """Reference times (s) outside which ``occurrence`` adds nothing to any record."""
    p = occurrence.params
    if occurrence.kind == "impact":
        return occurrence.time, occurrence.time + float(library[p["library"]].time[-1])
    if occurrence.kind == "track_joint":
        return occurrence.time - 0.5, occurrence.time + max(s for axles in JOINT_AXLES.values() for s in axles) / p["speed"] + 0.5
    return occurrence.time, occurrence.time + p["duration"]


class Signals:
    """The physical accelerations (m/s²) of the day's occurrences at any reference times."""

    def __init__(self, day: Day, library: Sequence[SimulatedImpact]) -> None:
        self.day, self.library = day, library
        self.spans = [span(o, library) for o in day.occurrences]
        self.splines = [CubicSpline(impact.time, np.column_stack([impact.accelerations[p] for p in PROBES])) for impact in library]

    def accelerations(self, recorder: Recorder, t: np.ndarray, ticks: np.ndarray) -> np.ndarray:
        """``(len(t), channels)``: what ``recorder``'s probes feel at reference times ``t`` (its clock's ``ticks``, ms)."""
        out = np.zeros((t.size, len(recorder.probes)))
        columns = [PROBES.index(p) for p in recorder.probes]
        for occurrence, (start, end) in zip(self.day.occurrences, self.spans):
            if end < t[0] or start > t[-1]:
                continue
            inside = slice(int(np.searchsorted(t, start, side="left")), int(np.searchsorted(t, end, side="right")))  # t increases
            if occurrence.kind == "impact":
                out[inside] += self.splines[occurrence.params["library"]](t[inside] - occurrence.time)[:, columns]
            elif occurrence.kind == "track_joint":
                for k, probe in enumerate(recorder.probes):
                    out[inside, k] += joint_acceleration(occurrence, probe.split("/")[0], t[inside])
            elif occurrence.params["recorder"] == recorder.name:
                out[inside] += self._burst(occurrence, recorder, ticks[inside])
        return out

    def _burst(self, burst: Occurrence, recorder: Recorder, ticks: np.ndarray) -> np.ndarray:
        """The burst's white noise at ``ticks`` (ms of its recorder's clock): one draw from its first tick, whichever file holds them."""
        clock = next(c for c in self.day.clocks[recorder.name] if c.start <= burst.time < c.end)
        first = math.floor(float(clock.reading(burst.time)) * RATE)
        window = math.ceil(burst.params["duration"] * RATE) + 2
        draws = np.random.default_rng(burst.params["seed"]).normal(0.0, burst.params["level"], (window, len(recorder.probes)))
        return draws[np.clip(ticks - first, 0, window - 1)]


@dataclass(frozen=True)
class FilePlan:
    """One file of a recorder: its ticks ``[first, stop)`` (ms of the recorder's clock) and the clock."""

    recorder: Recorder
    first: int
    stop: int
    clock: Clock
    index: int

    @property
    def stem(self) -> str:
        seconds = self.first / RATE
        return f"{self.recorder.name}_{int(seconds // 3600):02d}-{int(seconds % 3600 // 60):02d}-{seconds % 60:06.3f}"


def file_start(stem: str) -> float:
    """The clock time (s) a file starts at, from its name (:attr:`FilePlan.stem`: ``r2_HH-MM-SS.sss``)."""
    hours, minutes, seconds = stem.split("_", 1)[1].split("-")
    return int(hours) * 3600.0 + int(minutes) * 60.0 + float(seconds)


def file_plans(day: Day) -> list[FilePlan]:
    """Each recorder's files: one per hour of its own clock, a new one where its clock starts again (whole seconds)."""
    plans = []
    for recorder in RECORDERS:
        for clock in day.clocks[recorder.name]:
            first = math.ceil(float(clock.reading(clock.start)))  # a (re)started logger's first file begins on a whole second
            last = math.ceil(float(clock.reading(clock.end)) * RATE)
            hour = (first // 3600 + 1) * 3600 * int(RATE)
            edges = [first * int(RATE), *range(hour, last, 3600 * int(RATE)), last]
            for a, b in zip(edges[:-1], edges[1:]):
                if b > a:
                    plans.append(FilePlan(recorder, a, b, clock, len(plans)))  # its index seeds its noise
    return plans


def recorder_file(plan: FilePlan, signals: Signals) -> RecorderFile:
    """The file's time column and channels: the occurrences at its ticks, noise, offsets, in its unit, fixed point."""
    recorder = plan.recorder
    ticks = np.arange(plan.first, plan.stop)
    c = ticks / RATE
    t = np.asarray(plan.clock.reference(c))
    rng = np.random.default_rng([signals.day.seed, 1, plan.index])
    a = signals.accelerations(recorder, t, ticks) + rng.normal(0.0, NOISE, (t.size, len(recorder.probes)))
    values = a / recorder.scale + np.asarray(recorder.offsets)
    channels = {name: fixed_point(values[:, k], recorder.decimals) for k, name in enumerate(recorder.columns)}
    return RecorderFile(fixed_point(c, 3), channels, dict.fromkeys(recorder.columns, recorder.unit), 3, recorder.decimals, recorder.dialect, recorder.name)


def case_data(fmt: str) -> dict[str, Any]:
    """The measured case reading the day's ``fmt`` files (contract A: ``files:`` globs, ``clock_drift: estimate``)."""
    key = {"csv": "column", "hdf5": "dataset"}.get(fmt, "channel")

    def source(recorder: Recorder, column: str) -> str:
        if fmt == "tdms":
            return f"{recorder.name}/{column}"
        return column

    records = []
    for recorder in RECORDERS:
        time_source = recorder.columns[0] if fmt == "uff58" else ("time_s" if fmt == "csv" else "time")
        record: dict[str, Any] = {"recorder": recorder.name, "files": [f"{recorder.name}/{recorder.name}_*{SUFFIX[fmt]}"],
                                  "time": {key: source(recorder, time_source), "unit": "s"}}
        if fmt == "csv" and recorder.dialect != Dialect():
            record.update(separator=recorder.dialect.separator, decimal=recorder.dialect.decimal)
        if recorder is not RECORDERS[0]:
            record.update(clock_offset=DECLARED_OFFSET, clock_drift="estimate")
        record["anti_alias"] = {"corner": LOWPASS, "order": 4}
        record["channels"] = {probe: {key: source(recorder, column), "unit": recorder.unit} for probe, column in zip(recorder.probes, recorder.columns)}
        records.append(record)
    scene = impact_case(LIBRARY[0])  # the day's cars are those of every impact
    cars = [{"name": car["name"], "body": car["body"], "sensors": SENSORS[car["name"]]} for car in scene["cars"]]
    return {"kind": "measured", "records": records, "cars": cars, "couplers": [{"name": "c1", "between": ["car1", "car2"]}],
            "events": dict(TRIGGER), "estimators": list(ESTIMATORS), "checks": dict(CHECKS)}


def truth(day: Day, library: Sequence[SimulatedImpact], files: dict[str, list[str]], seconds: dict[str, float]) -> dict[str, Any]:
    """What the day holds (module docstring), for the benchmark to score a run against."""
    r2 = day.clocks["r2"]

    def on_r2(t: float) -> float | None:
        clock = next((c for c in r2 if c.start <= t < c.end), None)
        return None if clock is None else float(clock.reading(t))

    impacts = [{"time": o.time, "r2_time": on_r2(o.time), "type": library[o.params["library"]].spec.impact_type,
                "gear": library[o.params["library"]].spec.gear, "speed": library[o.params["library"]].spec.speed,
                "peak_force": library[o.params["library"]].peak_force, "library": library[o.params["library"]].spec.name}
               for o in day.occurrences if o.kind == "impact"]
    others = [{"kind": o.kind, "time": o.time, "r2_time": on_r2(o.time), **{k: v for k, v in o.params.items() if k != "seed"}}
              for o in day.occurrences if o.kind != "impact"]
    return {
        "hours": day.seconds / 3600.0, "seconds": day.seconds, "seed": day.seed, "rate": RATE, "noise": NOISE,
        "recorders": {r.name: {"probes": list(r.probes), "unit": r.unit, "reference": r is RECORDERS[0],
                               "declared_clock_offset": 0.0 if r is RECORDERS[0] else DECLARED_OFFSET} for r in RECORDERS},
        "clocks": {name: [asdict(c) for c in clocks] for name, clocks in day.clocks.items()},
        "restart": {"recorder": "r2", "stop": r2[0].end, "resume": r2[1].start, "gap": r2[1].start - r2[0].end},
        "drift_ppm": DRIFT_PPM,
        "friction_gear": FRICTION_GEAR,
        "impacts": impacts,
        "not_impacts": others,
        "files": files,
        "write_seconds": seconds,
    }


def write_day(out: Path, hours: float, formats: Sequence[str] = FORMATS, seed: int = 1,
              library: Sequence[SimulatedImpact] | None = None) -> dict[str, Any]:
    """Write the day's files in ``formats`` under ``out/<format>/``, each format's case and ``out/truth.json``; the truth."""
    unknown = sorted(set(formats) - set(FORMATS))
    if unknown:
        raise ValueError(f"formats: {', '.join(unknown)} unknown; choose from {', '.join(FORMATS)}")
    library = load_library() if library is None else library
    day = plan_day(hours, library, seed)
    signals = Signals(day, library)
    seconds = dict.fromkeys(formats, 0.0)
    files: dict[str, list[str]] = {fmt: [] for fmt in formats}
    for fmt in formats:
        for recorder in RECORDERS:
            (out / fmt / recorder.name).mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    for plan in file_plans(day):
        record = recorder_file(plan, signals)
        for fmt in formats:
            name = f"{plan.recorder.name}/{plan.stem}{SUFFIX[fmt]}"
            begun = time.perf_counter()
            write(out / fmt / name, fmt, record)
            seconds[fmt] += time.perf_counter() - begun
            files[fmt].append(name)
    seconds["signals"] = time.perf_counter() - started - sum(seconds[fmt] for fmt in formats)
    for fmt in formats:
        (out / fmt / "day.yaml").write_text(f"# A synthetic {hours:g} h day (benchmarks/synthetic/day.py, seed {seed}); truth: ../truth.json\n"
                                            + yaml.safe_dump(case_data(fmt), sort_keys=False, default_flow_style=None, width=150))
    facts = truth(day, library, files, seconds)
    partial = out / ".truth.partial.json"
    partial.write_text(json.dumps(facts, indent=1))
    partial.replace(out / "truth.json")
    return facts


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=24.0)
    parser.add_argument("--out", type=Path, default=Path("build/synthetic/day"))
    parser.add_argument("--formats", default=",".join(FORMATS))
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    facts = write_day(args.out, args.hours, args.formats.split(","), args.seed)
    sizes = {fmt: sum((args.out / fmt / name).stat().st_size for name in names) / 1e6 for fmt, names in facts["files"].items()}
    print(f"{facts['hours']:g} h: {len(facts['impacts'])} impacts, {len(facts['not_impacts'])} transients and bursts, r2 restarts at "
          f"{facts['restart']['stop']:.1f} s for {facts['restart']['gap']:.1f} s")
    for fmt, size in sizes.items():
        print(f"  {fmt:>6}: {len(facts['files'][fmt])} files, {size:9.1f} MB, written in {facts['write_seconds'][fmt]:7.1f} s "
              f"({size / max(facts['write_seconds'][fmt], 1e-9):6.1f} MB/s)")
    print(f"  signals: {facts['write_seconds']['signals']:.1f} s")


if __name__ == "__main__":
    main()
