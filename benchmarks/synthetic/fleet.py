"""A synthetic month of a fleet: single-impact recordings of 24 cars over 30 days, one gear wearing, as a fleet manifest.

    python benchmarks/synthetic/fleet.py --out build/synthetic/fleet [--days 30] [--cars 24] [--seed 1] [--check 6]

Every car is the default scene's loaded hopper with three accelerometers (rear, centre, front) and its own draft gear,
the fleet's friction gear (:data:`impacts.FLEET_FRICTION_GEAR`, rated closure force 2.016 MN). A recording is one impact
of a car (rear, moving at 1.50–1.62 m/s: the gear closes solid) into another at rest, simulated by femref's fem model
(:mod:`impacts`, 32 elements per car) and written by two recorders, one per car, each a CSV file (the rear car's in g,
the front car's in m/s²) with 2 s of noise (0.05 m/s²) before the impact and 3 s after; the coupler's gear is the rear
car's. Each day the worn car ``C0007`` has one recording and two other pairs of cars one each, at random hours.

Gear ``G0007`` wears: its loading curve (its closure force with it) is ``s(d) = 1 − 0.15 d / 28`` times the rated one on
day ``d`` (days from the first midnight), so its closure force crosses the wear limit — rated × (1 − wear_tolerance), 0.85
of 2.016 MN, contract D's ``wear_limit`` — on day 28. The other gears keep a factor of their own, 1 ± 0.02 (normal, within
0.96–1.04), constant. ``<out>/manifest.yaml`` is the fleet manifest (contract C), ``<out>/truth.json`` the worn gear, its
crossing day and time, and each recording's gear factor, true closure force and speed.

``--check N`` verifies the wear is visible without the fleet runner: it expands N of the worn gear's recordings, spread
over the month, into measured cases (each recorder one ``file:``, today's schema), runs them as ``femref run`` does
(:func:`femref.run.measured.run_measured`) and prints each event's closure force against the truth; it fails unless
most are ``closed`` (:data:`CLOSED_SHARE`) and those decline as the gear wears (:data:`SLOPE_TOLERANCE`).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import numpy as np
import yaml

if __package__ in (None, ""):  # run as a script: benchmarks/ on the path for the sibling modules
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from synthetic.impacts import FLEET_FRICTION_GEAR, ImpactSpec, SimulatedImpact, impact_case, load_impact  # noqa: E402
from synthetic.writers import Dialect, RecorderFile, fixed_point, write  # noqa: E402

G = 9.80665
START = datetime(2026, 11, 1, tzinfo=timezone.utc)
WORN_CAR = "C0007"
WEAR_LOSS = 0.15
"""The worn gear's closure force lost by :data:`CROSSING_DAY`, equal to the wear tolerance: it crosses the limit then."""
CROSSING_DAY = 28.0
OTHERS_PER_DAY = 2
SCATTER = 0.02
"""The other gears' factors: normal about 1 with this standard deviation, clipped to ±2 of it."""
SPEEDS = (1.50, 1.62)
"""m/s: the rear car's speed, uniform (the gear closes solid; its peak force stays within ~1.5× the closure force, where
femref's closure detector reads the kink: :data:`impacts.FLEET_FRICTION_GEAR`)."""
ELEMENTS = 32
FLEET_GEAR = "fleet_friction_gear"
RATE = 1000.0
LOWPASS = 100.0
TIME_DECIMALS = 4
QUIET_BEFORE, QUIET_AFTER = 2.0, 3.0
NOISE = 0.05
SENSORS = {"rear": -8.3, "center": 0.0, "front": 8.3}
CLOSED_SHARE = 0.6
"""--check: the least share of the worn gear's events whose closure femref finds ``closed`` (the rest ``ambiguous``)."""
SLOPE_TOLERANCE = 0.3
"""--check: the found closure force's trend (N/day, the closed events) within this fraction of the wear's."""
def rated_closure() -> float:
    """N: the fleet gear's loading at its solid closure, ``k₁δ_s + k₃δ_s³``."""
    gear = FLEET_FRICTION_GEAR["friction_gear"]
    cubic, closure = gear["loading"]["cubic"], gear["solid_closure"]
    return cubic["linear_stiffness"] * closure + cubic["cubic_stiffness"] * closure**3


DEFAULTS = {
    "events": {"trigger": 3.0, "pre": 0.5, "post": 2.0},
    "estimators": ["kalman", "inverse_rigid"],
    "checks": {"alarm": 3.0e6, "rated_closure_force": rated_closure(), "wear_tolerance": WEAR_LOSS},
}
"""What every recording shares: kalman first, the primary estimate whose force the closure is read from."""


@dataclass(frozen=True)
class Recording:
    """One impact: its ``start`` (the wall-clock time of t = 0 of its records), the ``rear`` car (moving; its gear is the
    coupler's) and the ``front`` car, the rear car's ``speed`` (m/s) and its gear's factor ``scale``."""

    start: datetime
    rear: str
    front: str
    speed: float
    scale: float

    @property
    def name(self) -> str:
        return f"{self.start:%Y-%m-%dT%H-%M}_{self.rear}_{self.front}"

    @property
    def day(self) -> float:
        """Days from the first midnight to the impact."""
        return (self.start - START).total_seconds() / 86400.0 + QUIET_BEFORE / 86400.0


def gear_of(car: str) -> str:
    return "G" + car[1:]


def wear_factor(day: float) -> float:
    """The worn gear's closure force over its rated one on ``day``: ``1 − 0.15 d / 28``."""
    return 1.0 - WEAR_LOSS * day / CROSSING_DAY


def plan_fleet(days: int, cars: int, seed: int = 1) -> list[Recording]:
    """The month's recordings in time order (module docstring)."""
    rng = np.random.default_rng(seed)
    names = [f"C{k:04d}" for k in range(1, cars + 1)]
    if WORN_CAR not in names:
        raise ValueError(f"the fleet needs {WORN_CAR}: at least {int(WORN_CAR[1:])} cars, got {cars}")
    others = [name for name in names if name != WORN_CAR]
    factors = {name: float(np.clip(rng.normal(1.0, SCATTER), 1 - 2 * SCATTER, 1 + 2 * SCATTER)) for name in others}
    recordings = []
    for day in range(days):
        pairs = [(WORN_CAR, str(rng.choice(others)))] + [tuple(str(c) for c in rng.choice(others, 2, replace=False)) for _ in range(OTHERS_PER_DAY)]
        hours = np.sort(rng.uniform(6.0, 20.0, len(pairs)))
        for (rear, front), hour in zip(pairs, hours):
            start = START + timedelta(days=day, minutes=int(hour * 60))
            speed = float(np.round(rng.uniform(*SPEEDS), 3))
            recording = Recording(start, rear, front, speed, 1.0)
            scale = wear_factor(recording.day) if rear == WORN_CAR else factors[rear]
            recordings.append(Recording(start, rear, front, speed, round(scale, 6)))
    return sorted(recordings, key=lambda r: r.start)


def simulated(recording: Recording) -> SimulatedImpact:
    """The recording's impact (cached fem run): the fleet gear scaled by its factor, three sensors on each car."""
    spec = ImpactSpec(FLEET_GEAR, recording.speed, gear_scale=recording.scale, elements=ELEMENTS, rate=RATE, lowpass=LOWPASS)
    return load_impact(spec, sensors={"car1": SENSORS, "car2": SENSORS})


def write_recording(folder: Path, recording: Recording, impact: SimulatedImpact, seed: int) -> list[dict[str, Any]]:
    """The recording's two CSV files in ``folder`` (noise before and after the impact); its ``records`` entries."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([seed, int(recording.start.timestamp())])
    before, after = round(QUIET_BEFORE * RATE), round(QUIET_AFTER * RATE)
    time = fixed_point(np.arange(before + impact.time.size + after) / RATE, TIME_DECIMALS)
    records = []
    for model_car, car, unit, dialect in (("car1", recording.rear, "g", Dialect()), ("car2", recording.front, "m/s^2", Dialect(";", ","))):
        scale = G if unit == "g" else 1.0
        channels = {}
        for sensor in SENSORS:
            a = np.concatenate([np.zeros(before), impact.accelerations[f"{model_car}/{sensor}"], np.zeros(after)])
            channels[sensor] = fixed_point((a + rng.normal(0.0, NOISE, a.size)) / scale, 6 if unit == "g" else 5)
        name = f"{car}.csv"
        write(folder / name, "csv", RecorderFile(time, channels, dict.fromkeys(channels, unit), TIME_DECIMALS, 6 if unit == "g" else 5, dialect, car))
        record: dict[str, Any] = {"file": f"recordings/{recording.name}/{name}", "time": {"column": "time_s", "unit": "s"}}
        if dialect != Dialect():
            record.update(separator=dialect.separator, decimal=dialect.decimal)
        record["anti_alias"] = {"corner": LOWPASS, "order": 4}
        record["channels"] = {f"{car}/{sensor}": {"column": sensor, "unit": unit} for sensor in SENSORS}
        records.append(record)
    return records


def manifest(recordings: Sequence[Recording], records: dict[str, list[dict[str, Any]]], cars: int) -> dict[str, Any]:
    """The fleet manifest (contract C)."""
    body = impact_case(ImpactSpec("fleet_friction_gear", 1.6))["cars"][0]["body"]
    names = [f"C{k:04d}" for k in range(1, cars + 1)]
    return {
        "fleet": "synthetic-yard",
        "defaults": copy.deepcopy(DEFAULTS),
        "cars": {name: {"body": body, "sensors": dict(SENSORS)} for name in names},
        "gears": {gear_of(name): {"law": copy.deepcopy(FLEET_FRICTION_GEAR)} for name in names},
        "recordings": [{"name": r.name, "start": r.start.strftime("%Y-%m-%dT%H:%M:%SZ"), "track": f"yard {1 + k % 4}", "cars": [r.rear, r.front],
                        "couplers": [{"name": "c1", "gear": gear_of(r.rear)}], "records": records[r.name]} for k, r in enumerate(recordings)],
    }


def write_fleet(out: Path, days: int = 30, cars: int = 24, seed: int = 1) -> dict[str, Any]:
    """Simulate and write the fleet's recordings, ``out/manifest.yaml`` and ``out/truth.json``; the truth."""
    recordings = plan_fleet(days, cars, seed)
    records = {}
    for k, recording in enumerate(recordings):
        records[recording.name] = write_recording(out / "recordings" / recording.name, recording, simulated(recording), seed)
        print(f"\r{k + 1}/{len(recordings)} recordings", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    data = manifest(recordings, records, cars)
    partial = out / ".manifest.partial.yaml"
    partial.write_text(f"# A synthetic month of {cars} cars (benchmarks/synthetic/fleet.py, seed {seed}); truth: truth.json\n"
                       + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=150))
    partial.replace(out / "manifest.yaml")
    rated = rated_closure()
    limit = rated * (1.0 - DEFAULTS["checks"]["wear_tolerance"])
    facts = {
        "worn_gear": gear_of(WORN_CAR), "worn_car": WORN_CAR, "rated_closure_force": rated, "wear_limit": limit,
        "crossing_day": CROSSING_DAY, "crossing_time": (START + timedelta(days=CROSSING_DAY)).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "start": START.strftime("%Y-%m-%dT%H:%M:%SZ"), "days": days, "cars": cars, "seed": seed,
        "recordings": [{"name": r.name, "gear": gear_of(r.rear), "day": r.day, "scale": r.scale, "closure_force": r.scale * rated, "speed": r.speed}
                       for r in recordings],
    }
    partial = out / ".truth.partial.json"
    partial.write_text(json.dumps(facts, indent=1))
    partial.replace(out / "truth.json")
    return facts


def expanded_case(data: dict[str, Any], recording: dict[str, Any]) -> dict[str, Any]:
    """One recording of manifest ``data`` as a measured case of today's schema: the defaults, its cars in line with
    their bodies and sensors, its coupler between them (the gear's rating, if it has one, in ``checks``), its records."""
    case = {"kind": "measured", "records": copy.deepcopy(recording["records"]),
            "cars": [{"name": car, **copy.deepcopy(data["cars"][car])} for car in recording["cars"]],
            "couplers": [{"name": c["name"], "between": recording["cars"][k : k + 2]} for k, c in enumerate(recording["couplers"])],
            **copy.deepcopy(data["defaults"])}
    rated = data["gears"][recording["couplers"][0]["gear"]].get("rated_closure_force")
    if rated is not None:
        case["checks"]["rated_closure_force"] = rated
    return case


def check_wear(out: Path, count: int) -> list[tuple[float, float, float, str]]:
    """Run ``count`` of the worn gear's recordings, spread over the month, as measured cases; for each its day, true and
    found closure force (N) and status. AssertionError unless most closed and those decline with the wear."""
    from femref.case import load_case
    from femref.run.measured import run_measured
    from femref.scene.build import scene_from_case

    data = yaml.safe_load((out / "manifest.yaml").read_text())
    truth = {r["name"]: r for r in json.loads((out / "truth.json").read_text())["recordings"]}
    worn = [r for r in data["recordings"] if r["couplers"][0]["gear"] == gear_of(WORN_CAR)]
    rows = []
    for recording in [worn[round(k)] for k in np.linspace(0, len(worn) - 1, count)]:
        path = out / f".check_{recording['name']}.yaml"
        path.write_text(yaml.safe_dump(expanded_case(data, recording), sort_keys=False))
        try:
            events = run_measured(scene_from_case(load_case(path))).events
        finally:
            path.unlink()
        assert len(events) == 1, f"{recording['name']}: {len(events)} events"
        closure = events[0].closures[0]
        rows.append((truth[recording["name"]]["day"], truth[recording["name"]]["closure_force"], closure.closure_force, closure.status))
    for day, true, found, status in rows:
        print(f"day {day:5.2f}: true closure {true / 1e6:.3f} MN, found {found / 1e6:.3f} MN ({status}, {found / true - 1:+.1%})")
    closed = [(day, true, found) for day, true, found, status in rows if status == "closed"]
    assert len(closed) >= CLOSED_SHARE * len(rows), f"{len(closed)} of {len(rows)} worn-gear events closed; at least {CLOSED_SHARE:.0%} should"
    days, true, found = (np.array(column) for column in zip(*closed))
    slope, wear = np.polyfit(days, found, 1)[0], np.polyfit(days, true, 1)[0]
    print(f"{len(closed)} of {len(rows)} closed; their closure force {slope / 1e3:.2f} kN/day against the wear's {wear / 1e3:.2f} kN/day, "
          f"found/true − 1 from {min(found / true) - 1:+.1%} to {max(found / true) - 1:+.1%}")
    assert abs(slope / wear - 1.0) < SLOPE_TOLERANCE, "the found closure force declines with the wear"
    return rows


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("build/synthetic/fleet"))
    parser.add_argument("--days", type=int, default=30)
    parser.add_argument("--cars", type=int, default=24)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--check", type=int, default=0, help="run this many of the worn gear's recordings and check the wear shows")
    args = parser.parse_args(argv)
    facts = write_fleet(args.out, args.days, args.cars, args.seed)
    print(f"{len(facts['recordings'])} recordings of {facts['cars']} cars over {facts['days']} days; {facts['worn_gear']} crosses "
          f"{facts['wear_limit'] / 1e6:.4g} MN on day {facts['crossing_day']:g}")
    if args.check:
        check_wear(args.out, args.check)


if __name__ == "__main__":
    main()
