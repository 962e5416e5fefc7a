"""An event's rows in the event store (:mod:`femref.fleet.store`), made from its full result on the worker.

Per coupler of the recording one ``events`` row: the event's type, closing speed, alarm, wear and flags, and the
coupler's primary estimate (:func:`femref.sensing.findings.primary`: the first force history with a number and a
bound, else the first with a number — the one the alarm and the closure read) with its closure. A coupler's cars are
the recording's cars ``k`` (``car_rear``, at the coupler's −x side) and ``k + 1`` (``car_front``), as a measured case
orders them. Per estimate one ``estimates`` row. Missing numbers are NaN, missing texts empty.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np

from femref import __version__
from femref.events import EventResult
from femref.fleet.manifest import Recording
from femref.sensing.findings import primary

__all__ = ["RecordingFacts", "event_rows"]


@dataclass(frozen=True)
class RecordingFacts:
    """What every row of one recording shares: the recording (cars, couplers, gears, limits), its record files,
    calibration and networks (``; ``-joined paths relative to the manifest's folder) and its event file (relative to
    the store's folder)."""

    recording: Recording
    files: str
    calibration: str
    network: str
    histories: str

    @classmethod
    def of(cls, recording: Recording, base_dir: Path, histories: str) -> "RecordingFacts":
        """The facts of ``recording``, its paths made relative to ``base_dir`` (the manifest's folder)."""
        return cls(recording, "; ".join(_relative(path, base_dir) for path in recording.record_files),
                   "" if recording.calibration is None else _relative(recording.calibration, base_dir),
                   "; ".join(_relative(path, base_dir) for path in recording.networks), histories)


def _relative(path: Path, base_dir: Path) -> str:
    """``path`` relative to ``base_dir`` where it lies below it (``..`` otherwise), with ``/``."""
    return Path(os.path.relpath(path, base_dir)).as_posix()


def _number(value: float | None) -> float:
    return math.nan if value is None else float(value)


def event_rows(facts: RecordingFacts, couplers: Any, event: EventResult) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The ``events`` and ``estimates`` rows of ``event`` (with its histories) of the recording of ``facts``, whose
    scene has ``couplers`` (module docstring)."""
    recording = facts.recording
    key = f"{recording.name}/{event.index}"
    primaries = primary(couplers, event.estimates)
    closures = {closure.coupler: closure for closure in event.closures}
    shared = {
        "event_key": key, "recording": recording.name, "event_index": int(event.index),
        "time": recording.start + timedelta(seconds=float(event.trigger_time)), "track": recording.track, "files": facts.files,
        "cars": ", ".join(recording.cars), "event_type": event.impact_type, "closing_speed": float(event.closing_speed),
        "closing_speed_lower": float(event.closing_speed_lower), "closing_speed_upper": float(event.closing_speed_upper),
        "alarm_limit": _number(recording.alarm_limit), "alarm": event.alarm, "wear_limit": _number(recording.wear_limit), "wear": event.wear,
        "flags": "; ".join(event.flags), "femref_version": __version__, "calibration": facts.calibration, "network": facts.network,
        "histories": f"{facts.histories}#/events/{event.index}",
    }
    events = []
    for k, coupler in enumerate(couplers):
        estimate = primaries.get(coupler.name)
        peak = estimate.peak if estimate is not None else (math.nan, math.nan, math.nan)
        closure = closures.get(coupler.name)
        events.append({
            **shared, "coupler": coupler.name, "car_rear": recording.cars[coupler.rear], "car_front": recording.cars[coupler.front],
            "gear": recording.gears[k], "estimator": "" if estimate is None else estimate.estimator,
            "peak_force": peak[0], "peak_force_lower": peak[1], "peak_force_upper": peak[2],
            "closure_force": math.nan if closure is None else float(closure.closure_force), "closure_status": "" if closure is None else closure.status,
        })
    estimates = []
    for estimate in event.estimates:
        peak, lower, upper = estimate.peak
        time_of_peak = float(estimate.time[estimate.peak_index]) if estimate.ok and np.size(estimate.time) else math.nan
        estimates.append({"event_key": key, "coupler": estimate.coupler, "estimator": estimate.estimator, "status": estimate.status,
                          "peak_force": peak, "lower": lower, "upper": upper, "time_of_peak": time_of_peak})
    return events, estimates
