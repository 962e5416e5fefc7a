"""Event results of a measured case and their HDF5 groups (layout: docs/design.md §4.5), written atomically.

Bands are 95 % (lower, upper); an estimator without a bound stores NaN bands and ``bound = none``.

**Written as the events finish** (:func:`event_file`, :class:`EventWriter`). The file is made under a temporary
name beside the final one (:func:`femref.core.publishing.atomic_path`) with the root attributes ``complete = false``
and ``events_written = 0``; each event is added as soon as it is found (the file opened, the event's group written,
``events_written`` raised, the file closed again); when the last event is in, ``complete = true`` and the temporary
is renamed to the final name. A run killed loses at most the event in hand: its temporary is an event file of the
``events_written`` events finished before the kill, readable as it is (``femref report`` reads it), and the next run
into the same output removes it as a leftover (:func:`femref.core.publishing.remove_leftovers`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref import __version__
from femref.core.catalog import SCENE_GROUP
from femref.core.hdf5_writing import hdf5_writer
from femref.core.publishing import atomic_path

EVENTS_GROUP = "events"
BOUNDS = ("covariance", "calibrated", "none")


@dataclass
class ForceEstimate:
    """One estimator's force history of one coupler (a peak: one sample), with its 95 % band.

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

    def drop_number(self, status: str, message: str) -> None:
        """Make the estimate ``status`` (``failed``, ``implausible``) with ``message`` and no number: its force and band
        NaN on its own time axis."""
        self.status, self.message = status, message
        self.force = np.full(self.force.shape, np.nan)
        self.lower, self.upper = self.force.copy(), self.force.copy()


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


@dataclass(frozen=True)
class ClockCorrection:
    """An event's clock for one non-reference ``recorder`` (:mod:`femref.sensing.clock`): the ``correction`` applied (s,
    added to its times to reach the reference recorder's clock), the ``drift`` (ppm, its clock gains), the event's own
    measured ``lag`` (s, NaN: none measured) and its ``residual`` (lag − correction, s), and how they were found (``basis``)."""

    recorder: str
    correction: float
    drift: float
    lag: float
    residual: float
    basis: str


CLOCK_UNITS = {"correction": "s", "drift": "ppm", "lag": "s", "residual": "s"}


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
    momentum_ratio: float = np.nan
    momentum_threshold: float = np.nan
    velocity_change: float = np.nan
    velocity_change_noise: float = np.nan
    classification_basis: str = ""
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
    clock_corrections: tuple[ClockCorrection, ...] = ()
    """Per recorder whose clock is estimated (``clock_drift: estimate``): its clock at this event."""


EVENT_UNITS = {
    "start": "s", "end": "s", "trigger_time": "s", "closing_speed": "m/s", "closing_speed_lower": "m/s", "closing_speed_upper": "m/s", "epsilon": "1",
    "zero_harmonic_ratio": "1", "classification_confidence": "1", "momentum_ratio": "1", "momentum_threshold": "1", "velocity_change": "m/s",
    "velocity_change_noise": "m/s",
}


def without_histories(event: EventResult) -> EventResult:
    """``event`` as a summary: every scalar, flag and message kept, its records dropped and each estimate's histories
    cut to the sample of its peak (so ``peak`` is the same) and its settings dropped: what a table of many events
    reads, at a few kilobytes each."""
    def at_peak(estimate: ForceEstimate) -> ForceEstimate:
        k = slice(estimate.peak_index, estimate.peak_index + 1) if estimate.ok else slice(0, min(1, estimate.force.size))
        return dataclasses.replace(estimate, time=estimate.time[k].copy(), force=estimate.force[k].copy(), lower=estimate.lower[k].copy(),
                                   upper=estimate.upper[k].copy(), settings={})

    return dataclasses.replace(event, time=event.time[:0].copy(), records={}, estimates=[at_peak(e) for e in event.estimates])


#: Root attributes of an event file while it is written (module docstring).
COMPLETE, EVENTS_WRITTEN = "complete", "events_written"


class EventWriter:
    """Adds events to the event file at ``path`` as they finish (module docstring); :attr:`count` the events written.
    :func:`femref.core.hdf5_writing.hdf5_writer` takes no HDF5 file lock: a reader looking at the events written so far
    does not stop the run (between events the file is closed and whole)."""

    def __init__(self, path: Path, scene_facts: dict[str, Any], case_yaml: str = "") -> None:
        self.path = Path(path)
        self.count = 0
        with hdf5_writer(self.path, "w") as h5:
            h5.attrs["femref_version"] = __version__
            h5.attrs["case_yaml"] = case_yaml
            h5.attrs["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
            h5.attrs[COMPLETE] = False
            h5.attrs[EVENTS_WRITTEN] = 0
            scene = h5.create_group(SCENE_GROUP)
            scene.attrs["kind"] = "measured"
            for key, value in scene_facts.items():
                scene.attrs[key] = json.dumps(value)
            h5.create_group(EVENTS_GROUP)

    def write(self, event: EventResult) -> None:
        """Add ``event`` and count it; the file is closed (flushed) when this returns."""
        with hdf5_writer(self.path, "a") as h5:
            _write_event(h5[EVENTS_GROUP].create_group(str(event.index)), event)
            h5.attrs[EVENTS_WRITTEN] = self.count + 1
        self.count += 1

    def finish(self) -> None:
        """Mark the file complete (every event in)."""
        with hdf5_writer(self.path, "a") as h5:
            h5.attrs[COMPLETE] = True

    def __call__(self, event: EventResult) -> EventResult:
        """The sink :func:`femref.run.measured.run_measured` takes: write ``event`` and give back what the run keeps,
        its summary (:func:`without_histories`: the histories are in the file)."""
        self.write(event)
        return without_histories(event)


@contextlib.contextmanager
def event_file(path: str | Path, scene_facts: dict[str, Any], case_yaml: str = "") -> Iterator[EventWriter]:
    """An :class:`EventWriter` on a temporary beside ``path``, renamed to ``path`` when the block ends without error
    (removed on an error: nothing is ever left half-written under the final name)."""
    with atomic_path(Path(path)) as temporary:
        writer = EventWriter(temporary, scene_facts, case_yaml)
        yield writer
        writer.finish()


def _write_event(group: h5py.Group, event: EventResult) -> None:
    for key in EVENT_UNITS:
        group.attrs[key] = float(getattr(event, key))
    group.attrs["units"] = json.dumps(EVENT_UNITS)
    for key in ("trigger_probe", "impact_type", "classification_basis", "closing_speed_source", "closing_speed_basis", "alarm", "alarm_basis", "wear", "wear_basis"):
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
        in_range = estimate.in_calibrated_range  # None: no calibration covers this estimate, no range it holds in
        sub.attrs["in_calibrated_range"] = "n/a" if in_range is None else str(bool(in_range)).lower()
        sub.attrs["units"] = json.dumps({"peak_force": "N", "peak_lower": "N", "peak_upper": "N", "wall_time_s": "s"})
    if event.clock_corrections:
        clocks = group.create_group("clock")
        for clock in event.clock_corrections:
            clocks.create_group(clock.recorder).attrs.update(correction=clock.correction, drift=clock.drift, lag=clock.lag, residual=clock.residual,
                                                             basis=clock.basis, units=json.dumps(CLOCK_UNITS))
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


__all__ = ["BOUNDS", "CLOCK_UNITS", "COMPLETE", "ClockCorrection", "EVENTS_GROUP", "EVENTS_WRITTEN", "ClosureResult", "EventResult", "EventWriter", "ForceEstimate", "event_file",
           "without_histories"]
