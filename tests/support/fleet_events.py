"""Synthetic event-store frames (the event store's columns, docs/design.md §10.2) for the wear-trend and fleet-report tests.

A fleet of cars ``C0001…`` whose couplings are recorded once a day per car: each day every car is the rear car of one
recording with a random front car, the coupler's gear is the rear car's (``G0001…``), its closure force the gear's
``closure(day)`` with a Gaussian scatter. Peaks, speeds and event types are drawn at random; the alarm follows
femref.sensing.findings.alarm's rule on the band (certain: the lower end reaches the limit, possible: the upper end).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

START = pd.Timestamp("2026-11-01T00:00:00Z")
RATED = 2.0e6  # N
WEAR_TOLERANCE = 0.15
WEAR_LIMIT = RATED * (1.0 - WEAR_TOLERANCE)  # N
ALARM = 2.5e6  # N
COLUMNS = ("event_key", "recording", "event_index", "time", "track", "files", "cars", "coupler", "car_front", "car_rear", "gear", "event_type",
           "closing_speed", "closing_speed_lower", "closing_speed_upper", "estimator", "peak_force", "peak_force_lower", "peak_force_upper",
           "alarm_limit", "alarm", "closure_force", "closure_status", "wear_limit", "wear", "flags", "femref_version", "calibration", "network",
           "histories")


def alarm_of(lower: float, upper: float, limit: float) -> str:
    return "certain" if lower >= limit else "possible" if upper >= limit else "none"


def fleet_events(cars: int = 20, days: int = 30, seed: int = 0, closure: Callable[[str, float], float] | None = None,
                 scatter: float = 0.015, hot: float = 0.01, saturated: float = 0.01, gaps: float = 0.0) -> pd.DataFrame:
    """events of ``cars`` cars over ``days`` days; ``closure(gear, day)`` the gear's true closure force (N;
    default ``RATED`` for every gear), scattered by ``scatter`` × rated. Peaks are 0.75 MN per m/s of closing speed (below
    the alarm limit) but for a share ``hot`` of impacts at 2.4–3.2 MN; a share ``saturated`` is flagged saturated (its alarm at least possible), a share ``gaps`` flagged with a gap."""
    closure = closure or (lambda gear, day: RATED)
    rng = np.random.default_rng(seed)
    names = [f"C{k + 1:04d}" for k in range(cars)]
    rows = []
    for day in range(days):
        for k, rear in enumerate(names):
            front = names[(k + 1 + int(rng.integers(cars - 1))) % cars]
            gear = f"G{k + 1:04d}"
            recording = f"{(START + pd.Timedelta(days=day)):%Y-%m-%dT%H-%M}_{rear}_{front}_{k}"
            for index in range(1 + int(rng.integers(2))):
                time = START + pd.Timedelta(days=day + float(rng.uniform(0.0, 0.95)))
                kind = rng.choice(["free_to_roll", "coupled", "not_an_impact"], p=[0.6, 0.3, 0.1])
                impact = kind != "not_an_impact"
                speed = float(rng.uniform(0.5, 3.0)) if impact else np.nan
                peak = (float(rng.uniform(2.4e6, 3.2e6)) if rng.uniform() < hot else 0.75e6 * speed) if impact else np.nan
                lower, upper = (0.95 * peak, 1.05 * peak) if impact else (np.nan, np.nan)
                closed = impact and speed > 1.2
                force = closure(gear, (time - START).total_seconds() / 86400.0) + scatter * RATED * float(rng.standard_normal()) if closed else np.nan
                clipped = impact and rng.uniform() < saturated
                gap = rng.uniform() < gaps
                flags = f"saturated: {rear}/front 0.1–0.2 s" if clipped else f"gap: {front}/center 0.3–0.5 s" if gap else ""
                rows.append({
                    "event_key": f"{recording}/{index}", "recording": recording, "event_index": index, "time": time,
                    "track": f"yard {1 + k % 3}", "files": f"{recording}/r1.csv; {recording}/r2.csv", "cars": f"{rear}, {front}",
                    "coupler": "c1", "car_front": front, "car_rear": rear, "gear": gear, "event_type": str(kind),
                    "closing_speed": speed, "closing_speed_lower": 0.9 * speed, "closing_speed_upper": 1.1 * speed,
                    "estimator": "inverse_rigid" if impact else "", "peak_force": peak, "peak_force_lower": lower, "peak_force_upper": upper,
                    "alarm_limit": ALARM, "alarm": ("possible" if clipped and upper < ALARM else alarm_of(lower, upper, ALARM)) if impact else "none",
                    "closure_force": force, "closure_status": "closed" if closed else ("not_closed" if impact else ""),
                    "wear_limit": WEAR_LIMIT, "wear": ("worn" if force < WEAR_LIMIT else "ok") if closed else "unknown",
                    "flags": flags, "femref_version": "0.1.0",
                    "calibration": "", "network": "", "histories": f"events/{recording}.h5#events/{index}",
                })
    frame = pd.DataFrame(rows, columns=list(COLUMNS))
    frame["time"] = pd.to_datetime(frame["time"], utc=True).astype("datetime64[ns, UTC]")
    frame["event_index"] = frame["event_index"].astype("int64")
    return frame


def linear_gear(gear: str, start: float, crossing_day: float, limit: float = WEAR_LIMIT) -> Callable[[str, float], float]:
    """Closure forces: ``gear`` falls linearly from ``start`` (N) at day 0 through ``limit`` at ``crossing_day``; every other
    gear stays at ``RATED``."""
    rate = (start - limit) / crossing_day
    return lambda name, day: start - rate * day if name == gear else RATED
