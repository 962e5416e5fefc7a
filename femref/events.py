"""Event results of a measured case and their HDF5 groups (docs/design.md §4.5), written atomically.

Layout (every quantity carries its unit as the attribute ``units``)::

    /                                     attrs: femref_version, case_yaml, created
    /scene                                attrs: kind = measured, cars, couplers (JSON)
    /events/<k>/                          attrs: start, end, trigger_time (s), trigger_probe, flags (JSON),
                                          impact_type, zero_harmonic_ratio, classification_confidence,
                                          closing_speed, closing_speed_lower, closing_speed_upper (m/s: the
                                          speed and its interval), closing_speed_source (records | given |
                                          none), closing_speed_basis, epsilon, alarm, alarm_basis, wear, wear_basis
    /events/<k>/records/time, <car>/<sensor>          the event's records on one grid (s, m/s²)
    /events/<k>/<estimator>/<coupler>/time, force, force_lower, force_upper
                                          attrs: peak_force, peak_lower, peak_upper (N), bound
                                          (covariance | calibrated | none), in_calibrated_range, status, message
    /events/<k>/closure/<coupler>         attrs: status (closed | not closed | ambiguous), closure_force (N),
                                          closure_time (s), estimator, message

Bands are 95 % (lower, upper); an estimator without a bound stores NaN bands and
``bound = none``. The file is written under a temporary name and renamed when complete.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref import __version__
from femref.core.catalog import SCENE_GROUP
from femref.core.publishing import atomic_path

EVENTS_GROUP = "events"
BOUNDS = ("covariance", "calibrated", "none")
CLOSURE_STATUSES = ("closed", "not closed", "ambiguous")
WEAR_STATUSES = ("ok", "worn", "unknown")
ALARM_STATUSES = ("none", "possible", "certain")


@dataclass
class ForceEstimate:
    """One estimator's force history of one coupler over an event, with its 95 % band.

    ``lower``/``upper`` are NaN where there is no bound (``bound == "none"``); the peak's band
    is the band at the peak's sample. ``status`` is ``ok`` or why there is no number (then
    ``force`` is NaN and the message says what went wrong).
    """

    estimator: str
    coupler: str
    time: NDArray[np.float64]
    force: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    bound: str = "none"
    in_calibrated_range: bool | None = None
    status: str = "ok"
    message: str = ""
    wall_time_s: float = 0.0
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def peak_index(self) -> int:
        """Sample of the largest compression."""
        return int(np.nanargmax(self.force)) if self.ok else -1

    @property
    def peak(self) -> tuple[float, float, float]:
        """``(peak, lower, upper)`` (N): the largest compression and its band (NaN without a bound or a number)."""
        if not self.ok:
            return (np.nan, np.nan, np.nan)
        k = self.peak_index
        return (float(self.force[k]), float(self.lower[k]), float(self.upper[k]))


@dataclass
class ClosureResult:
    """The draft gear's closure on one coupler, from ``estimator``'s force history and the stroke made of it:
    ``status`` closed / not closed / ambiguous with its reason (``message``); the closure force (N) and time
    (s) where the coupler's compliance drops (:func:`reduced.signal_tools.detect_closure_force`), the force's
    95 % profile interval (N), the stiffening (open over closed compliance there), the change point's F-test
    p-value and the fit's RMS stroke residual over the stroke travel (NaN where not found)."""

    coupler: str
    estimator: str
    status: str
    closure_force: float = np.nan
    closure_time: float = np.nan
    message: str = ""
    force_lower: float = np.nan
    force_upper: float = np.nan
    stiffening: float = np.nan
    p_value: float = np.nan
    residual: float = np.nan


@dataclass
class EventResult:
    """One impact event of a measured case and everything found about it."""

    index: int
    start: float
    end: float
    trigger_time: float
    trigger_probe: str
    flags: tuple[str, ...]
    time: NDArray[np.float64]
    records: dict[str, NDArray[np.float64]]
    impact_type: str = "unknown"
    zero_harmonic_ratio: float = np.nan
    classification_confidence: float = np.nan
    closing_speed: float = np.nan
    closing_speed_lower: float = np.nan
    closing_speed_upper: float = np.nan
    closing_speed_source: str = "none"
    closing_speed_basis: str = ""
    epsilon: float = np.nan
    estimates: list[ForceEstimate] = field(default_factory=list)
    closures: list[ClosureResult] = field(default_factory=list)
    alarm: str = "none"
    alarm_basis: str = ""
    wear: str = "unknown"
    wear_basis: str = ""


EVENT_UNITS = {
    "start": "s", "end": "s", "trigger_time": "s", "closing_speed": "m/s", "closing_speed_lower": "m/s", "closing_speed_upper": "m/s", "epsilon": "1",
    "zero_harmonic_ratio": "1", "classification_confidence": "1",
}


def write_events(path: str | Path, scene_facts: dict[str, Any], events: list[EventResult], case_yaml: str = "") -> Path:
    """Write the event results to ``path`` (atomically) and return the path."""
    path = Path(path)
    with atomic_path(path) as temporary:
        with h5py.File(temporary, "w") as h5:
            h5.attrs["femref_version"] = __version__
            h5.attrs["case_yaml"] = case_yaml
            h5.attrs["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
            scene = h5.create_group(SCENE_GROUP)
            scene.attrs["kind"] = "measured"
            for key, value in scene_facts.items():
                scene.attrs[key] = json.dumps(value)
            root = h5.create_group(EVENTS_GROUP)
            for event in events:
                _write_event(root.create_group(str(event.index)), event)
    return path


def _write_event(group: h5py.Group, event: EventResult) -> None:
    for key in ("start", "end", "trigger_time", "closing_speed", "closing_speed_lower", "closing_speed_upper", "epsilon", "zero_harmonic_ratio",
                "classification_confidence"):
        group.attrs[key] = float(getattr(event, key))
    group.attrs["units"] = json.dumps(EVENT_UNITS)
    for key in ("trigger_probe", "impact_type", "closing_speed_source", "closing_speed_basis", "alarm", "alarm_basis", "wear", "wear_basis"):
        group.attrs[key] = getattr(event, key)
    group.attrs["flags"] = json.dumps(list(event.flags))
    records = group.create_group("records")
    _dataset(records, "time", event.time, "s")
    for probe, values in event.records.items():
        _dataset(records, probe, values, "m/s^2")
    for estimate in event.estimates:
        sub = group.require_group(estimate.estimator).create_group(estimate.coupler)
        _dataset(sub, "time", estimate.time, "s")
        for name, values in (("force", estimate.force), ("force_lower", estimate.lower), ("force_upper", estimate.upper)):
            _dataset(sub, name, values, "N (compression positive)")
        peak, lower, upper = estimate.peak
        sub.attrs.update(peak_force=peak, peak_lower=lower, peak_upper=upper, bound=estimate.bound, status=estimate.status,
                         message=estimate.message, wall_time_s=estimate.wall_time_s, settings=json.dumps(estimate.settings))
        if estimate.in_calibrated_range is None:
            sub.attrs["in_calibrated_range"] = "n/a"  # no calibration covers this estimate: no range it holds in
        else:
            sub.attrs["in_calibrated_range"] = str(bool(estimate.in_calibrated_range)).lower()
        sub.attrs["units"] = json.dumps({"peak_force": "N", "peak_lower": "N", "peak_upper": "N", "wall_time_s": "s"})
    closures = group.create_group("closure")
    for closure in event.closures:
        sub = closures.create_group(closure.coupler)
        sub.attrs.update(status=closure.status, closure_force=closure.closure_force, closure_time=closure.closure_time,
                         force_lower=closure.force_lower, force_upper=closure.force_upper, stiffening=closure.stiffening,
                         p_value=closure.p_value, residual=closure.residual, estimator=closure.estimator, message=closure.message)
        sub.attrs["units"] = json.dumps({"closure_force": "N", "closure_time": "s", "force_lower": "N", "force_upper": "N",
                                         "stiffening": "1", "p_value": "1", "residual": "1 (of the stroke travel)"})


def _dataset(group: h5py.Group, name: str, data: NDArray, units: str) -> None:
    dataset = group.create_dataset(name, data=np.asarray(data, dtype=float))
    dataset.attrs["units"] = units


__all__ = ["ALARM_STATUSES", "BOUNDS", "CLOSURE_STATUSES", "EVENTS_GROUP", "WEAR_STATUSES", "ClosureResult", "EventResult", "ForceEstimate", "write_events"]
