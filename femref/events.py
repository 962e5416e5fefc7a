"""Event results of a measured case and their HDF5 groups (layout: docs/design.md §4.5), written atomically.

Bands are 95 % (lower, upper); an estimator without a bound stores NaN bands and ``bound = none``.

**Written as the events finish** (:func:`event_file`, :class:`EventWriter`). The file is made under a temporary
name beside the final one (:func:`femref.core.publishing.atomic_path`) with the root attributes ``complete = false``
and ``events_written = 0``; each event is added as soon as it is found (the file opened, the event's group written,
the file closed; then opened again to raise ``events_written`` in place: raised in the same close, a kill while HDF5
flushed could leave the count on disk ahead of the group it counts — a clean-clone CI run saw it). When the last
event is in, ``complete = true`` and the temporary is renamed to the final name. A run killed loses at most the
event in hand: its temporary is an event file of the ``events_written`` events finished before the kill, readable as it is (``femref report`` reads it), and the next run
into the same output removes it as a leftover (:func:`femref.core.publishing.remove_leftovers`). Each history's
``time`` is its group's HDF5 dimension scale, attached to the histories along it (xarray, h5netcdf and HDFView read
it as their coordinate).

**Read back** by :func:`event_rows` (one row per event × estimator × coupler, :data:`TABLE_UNITS`) and
:func:`event_histories` (one event's records and force histories), plain values for :mod:`femref.api`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
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
    diagnostics: dict[str, Any] = field(default_factory=dict)
    """What the records say about themselves (:meth:`femref.sensing.diagnostics.Diagnostics.record`): each car's end
    sensors' agreement, each channel's offset and drift."""


EVENT_UNITS = {
    "start": "s", "end": "s", "trigger_time": "s", "closing_speed": "m/s", "closing_speed_lower": "m/s", "closing_speed_upper": "m/s", "epsilon": "1",
    "zero_harmonic_ratio": "1", "classification_confidence": "1", "momentum_ratio": "1", "momentum_threshold": "1", "velocity_change": "m/s",
    "velocity_change_noise": "m/s",
}


def without_histories(event: EventResult) -> EventResult:
    """``event`` as a summary: every scalar, flag and message kept, its records dropped and each estimate's histories
    cut to the sample of its peak (so ``peak`` is the same) and its settings dropped but its contact instant
    (``contact_time``): what a table of many events reads, at a few kilobytes each."""
    def at_peak(estimate: ForceEstimate) -> ForceEstimate:
        k = slice(estimate.peak_index, estimate.peak_index + 1) if estimate.ok else slice(0, min(1, estimate.force.size))
        return dataclasses.replace(estimate, time=estimate.time[k].copy(), force=estimate.force[k].copy(), lower=estimate.lower[k].copy(),
                                   upper=estimate.upper[k].copy(), settings={key: estimate.settings[key] for key in ("contact_time",) if key in estimate.settings})

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
        """Add ``event``, then count it once its group is closed (flushed) whole (module docstring); the file is closed
        when this returns."""
        with hdf5_writer(self.path, "a") as h5:
            _write_event(h5[EVENTS_GROUP].create_group(str(event.index)), event)
        with hdf5_writer(self.path, "a") as h5:
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
    group.attrs["diagnostics"] = json.dumps(event.diagnostics)
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
    if name == "time":
        dataset.make_scale("time")
    elif "time" in group and group["time"].shape == dataset.shape:
        dataset.dims[0].attach_scale(group["time"])


#: The groups of an event that are no estimator's.
NOT_ESTIMATES = ("records", "closure", "clock")


def finished_events(h5: h5py.File) -> list[str]:
    """The names of the event groups of an open event file in order, those of a killed run's temporary
    (``complete = false``) only the ``events_written`` finished before the kill: the group being written then may
    be there, torn."""
    if EVENTS_GROUP not in h5:
        return []
    names = sorted(h5[EVENTS_GROUP], key=int)
    return names if h5.attrs.get(COMPLETE, True) else [name for name in names if int(name) < int(h5.attrs.get(EVENTS_WRITTEN, 0))]
#: The columns of :func:`event_rows`, in order.
TABLE_COLUMNS = (
    "event", "trigger_time_s", "start_s", "end_s", "trigger_probe", "type", "zero_harmonic_ratio", "classification_confidence",
    "closing_speed_m_per_s", "closing_speed_lower_m_per_s", "closing_speed_upper_m_per_s", "closing_speed_source", "epsilon", "alarm",
    "alarm_limit_N", "wear", "flags", "gap", "saturated", "implausible", "clock_corrected", "estimator", "coupler", "status", "bound",
    "peak_force_N", "peak_force_lower_N", "peak_force_upper_N", "time_of_peak_s", "in_calibrated_range", "above_alarm_limit",
    "closure_status", "closure_force_N", "closure_force_lower_N", "closure_force_upper_N", "closure_time_s", "closure_estimator", "message",
    "wall_time_s",
)
#: The columns of :func:`event_rows` with units, and their units.
TABLE_UNITS = {
    "trigger_time_s": "s", "start_s": "s", "end_s": "s", "closing_speed_m_per_s": "m/s", "closing_speed_lower_m_per_s": "m/s",
    "closing_speed_upper_m_per_s": "m/s", "epsilon": "1", "zero_harmonic_ratio": "1", "classification_confidence": "1", "peak_force_N": "N",
    "peak_force_lower_N": "N", "peak_force_upper_N": "N", "time_of_peak_s": "s", "closure_force_N": "N", "closure_force_lower_N": "N",
    "closure_force_upper_N": "N", "closure_time_s": "s", "alarm_limit_N": "N", "wall_time_s": "s",
}
#: The quality flags of an event (``<reason>: <probe> <from>–<to> s``) that :func:`event_rows` gives a column each.
QUALITY_FLAGS = ("gap", "saturated", "implausible")


class FileKindError(ValueError):
    """A femref file of another kind than its reader reads (an event file given to a reader of simulated results, or
    the reverse), or an event the event file does not hold: the message names the file and the reader to use."""


def is_event_file(h5: h5py.File) -> bool:
    """Whether an open femref file is a measured case's event file."""
    return SCENE_GROUP in h5 and h5[SCENE_GROUP].attrs.get("kind") == "measured"


def attribute_value(value: Any) -> Any:
    """An HDF5 attribute as a Python value (bytes decoded, numpy scalars unwrapped)."""
    if isinstance(value, bytes):
        return value.decode()
    return value.item() if hasattr(value, "item") and getattr(value, "ndim", 1) == 0 else value


def _open_events(path: str | Path) -> h5py.File:
    """The event file at ``path`` opened for reading; FileKindError naming it and its reader when it is not one."""
    h5 = h5py.File(path, "r")
    if not is_event_file(h5):
        models = [name for name, item in h5.items() if isinstance(item, h5py.Group) and "status" in item.attrs]
        h5.close()
        what = f"a simulated result file (models {', '.join(models)})" if models else "not a femref event file"
        raise FileKindError(f"{path}: {what}, not the event file of a measured case: read a simulated result with "
                            "femref.api.open_result (a model as xarray) or femref.api.open_frames (pandas)")
    return h5


def _alarm_limit(h5: h5py.File) -> float:
    """The case's alarm limit (N, ``checks.alarm``), NaN where it sets none."""
    import yaml

    case = yaml.safe_load(attribute_value(h5.attrs.get("case_yaml", "")) or "{}") or {}
    limit = (case.get("checks") or {}).get("alarm")
    return math.nan if limit is None else float(limit)


def event_rows(path: str | Path) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """``(rows, facts)`` of the event file at ``path``: a row per event × estimator × coupler (an event that ran no
    estimator, ``not_an_impact``: one row, estimator and coupler None) in event order, then the case's order of the
    estimators, columns :data:`TABLE_COLUMNS`
    (units: :data:`TABLE_UNITS`); ``facts``: the file's name, version, completeness, events and alarm limit.

    ``time_of_peak_s`` is the history's time at its largest compression; the closure columns are the event's closure of
    the row's coupler (one estimator's, ``closure_estimator``); ``above_alarm_limit`` whether the peak exceeds the
    case's alarm limit; ``gap``, ``saturated``, ``implausible``: a flag of that quality problem; ``clock_corrected``:
    an estimated clock corrected at the event."""
    rows = []
    with _open_events(path) as h5:
        limit = _alarm_limit(h5)
        order = json.loads(attribute_value(h5[SCENE_GROUP].attrs.get("estimators", "[]")))  # the case's order (its networks: after, by name)
        events = h5[EVENTS_GROUP]
        for name in finished_events(h5):
            group = events[name]
            a = {key: attribute_value(value) for key, value in group.attrs.items()}
            flags = json.loads(a.get("flags", "[]"))
            event = {
                "event": int(name), "trigger_time_s": a["trigger_time"], "start_s": a["start"], "end_s": a["end"], "trigger_probe": a["trigger_probe"],
                "type": a["impact_type"], "zero_harmonic_ratio": a["zero_harmonic_ratio"], "classification_confidence": a.get("classification_confidence", math.nan),
                "closing_speed_m_per_s": a["closing_speed"], "closing_speed_lower_m_per_s": a.get("closing_speed_lower", math.nan),
                "closing_speed_upper_m_per_s": a.get("closing_speed_upper", math.nan), "closing_speed_source": a.get("closing_speed_source", ""),
                "epsilon": a["epsilon"], "alarm": a["alarm"], "alarm_limit_N": limit, "wear": a["wear"], "flags": "; ".join(flags),
                **{reason: any(flag.startswith(f"{reason}:") for flag in flags) for reason in QUALITY_FLAGS},
                "clock_corrected": "clock" in group,
            }
            closures = {coupler: {key: attribute_value(value) for key, value in sub.attrs.items()} for coupler, sub in group.get("closure", {}).items()}
            names = sorted((name for name in group if name not in NOT_ESTIMATES), key=lambda name: (order.index(name) if name in order else len(order), name))
            estimates = [(estimator, coupler, data) for estimator in names for coupler, data in group[estimator].items()]
            if not estimates:
                rows.append(event | _estimate_columns(None, None, None, {}, limit))
            for estimator, coupler, data in estimates:
                rows.append(event | _estimate_columns(estimator, coupler, data, closures.get(coupler, {}), limit))
        facts = {"file": str(path), "femref_version": attribute_value(h5.attrs.get("femref_version", "")), "complete": bool(h5.attrs.get(COMPLETE, True)),
                 "events": len(events), "alarm_limit_N": limit}
    return rows, facts


def _estimate_columns(estimator: str | None, coupler: str | None, data: h5py.Group | None, closure: dict[str, Any], limit: float) -> dict[str, Any]:
    """The estimate's part of a row (module docstring of :func:`event_rows`); ``data`` None: no estimate."""
    e = {} if data is None else {key: attribute_value(value) for key, value in data.attrs.items()}
    peak = e.get("peak_force", math.nan)
    time_of_peak = math.nan
    if data is not None and e.get("status") == "ok":
        force = data["force"][()]
        time_of_peak = float(data["time"][int(np.nanargmax(force))]) if np.isfinite(force).any() else math.nan
    return {
        "estimator": estimator, "coupler": coupler, "status": e.get("status", "not run"), "bound": e.get("bound", "none"),
        "peak_force_N": peak, "peak_force_lower_N": e.get("peak_lower", math.nan), "peak_force_upper_N": e.get("peak_upper", math.nan),
        "time_of_peak_s": time_of_peak, "in_calibrated_range": e.get("in_calibrated_range", "n/a"),
        "above_alarm_limit": bool(peak > limit) if math.isfinite(peak) and math.isfinite(limit) else False,
        "closure_status": closure.get("status", ""), "closure_force_N": closure.get("closure_force", math.nan),
        "closure_force_lower_N": closure.get("force_lower", math.nan), "closure_force_upper_N": closure.get("force_upper", math.nan),
        "closure_time_s": closure.get("closure_time", math.nan), "closure_estimator": closure.get("estimator", ""),
        "message": e.get("message", ""), "wall_time_s": e.get("wall_time_s", math.nan),
    }


def record_datasets(records: h5py.Group) -> dict[str, h5py.Dataset]:
    """An event's ``records`` group by probe (``<car>/<sensor>``, a dataset in its car's group), its time axis apart."""
    found: dict[str, h5py.Dataset] = {}
    records.visititems(lambda name, item: found.__setitem__(name, item) if isinstance(item, h5py.Dataset) and name != "time" else None)
    return found


def event_histories(path: str | Path, event: int) -> dict[str, Any]:
    """Event ``event`` of the event file at ``path``: ``{"time": (t, units), "records": {probe: (a, units)},
    "estimates": {(estimator, coupler): {"time", "force", "force_lower", "force_upper": (values, units)} | attrs},
    "attrs": the event's attributes}``; FileKindError naming the file and its events when it has no such event."""
    with _open_events(path) as h5:
        held = finished_events(h5)
        if str(event) not in held:
            raise FileKindError(f"{path}: no event {event}; the file holds events {', '.join(held) if held else 'none'}")
        group = h5[EVENTS_GROUP][str(event)]

        def read(dataset: h5py.Dataset) -> tuple[NDArray[np.float64], str]:
            return dataset[()], str(attribute_value(dataset.attrs.get("units", "")))

        records = group["records"]
        probes = {probe: read(dataset) for probe, dataset in record_datasets(records).items()}
        estimates = {}
        for estimator, sub in group.items():
            if estimator in NOT_ESTIMATES:
                continue
            for coupler, data in sub.items():
                estimates[(estimator, coupler)] = {key: read(data[key]) for key in ("time", "force", "force_lower", "force_upper")}
                estimates[(estimator, coupler)]["attrs"] = {key: attribute_value(value) for key, value in data.attrs.items()}
        return {"time": read(records["time"]), "records": probes, "estimates": estimates,
                "attrs": {key: attribute_value(value) for key, value in group.attrs.items()}}


__all__ = ["BOUNDS", "CLOCK_UNITS", "COMPLETE", "ClockCorrection", "EVENTS_GROUP", "EVENTS_WRITTEN", "ClosureResult", "FileKindError", "EventResult",
           "EventWriter", "ForceEstimate", "NOT_ESTIMATES", "QUALITY_FLAGS", "TABLE_COLUMNS", "TABLE_UNITS", "attribute_value", "event_file", "event_histories", "event_rows", "finished_events", "record_datasets",
           "is_event_file", "without_histories"]
