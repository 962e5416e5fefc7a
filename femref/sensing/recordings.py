"""Measured acceleration records: CSV, HDF5, MDF4, TDMS or UFF58 files of real recorders, read into SI units with their quality.

A recorder's file holds sample times (a column, dataset or channel, or a uniform ``rate``
from a ``start``) and one column, dataset or channel per accelerometer (:mod:`femref.sensing.formats`).
:func:`read_records` reads every declared file and channel:

    t = offset + unit_t · t_file      (s; the file's clock offset added)
    a = unit_a · a_file               (m/s²; units ACCELERATION_UNITS, g = 9.80665 m/s² exactly)

A unit is the one declared or the file's own (MDF4, TDMS, UFF58 metadata); when both are given they must agree.

Each probe (``<car>/<sensor>``) keeps its own time axis: two recorders may sample at
different rates and their clocks may differ by a known offset. A channel's rate is the
declared rate, or 1 / the median time step.

**Errors** (:class:`RecordError`, naming the file, the channel or time source and the rule; docs/design.md §3.7):
what :mod:`femref.sensing.record_files` refuses, an unknown unit, fewer than two samples, a time that is not
finite or does not increase, a rate above :data:`MAX_RECORD_RATE`, a channel with no finite value or not one per
time, the same probe in two places.

**Quality, not errors** (:func:`_quality`): *gaps*, *saturated* and *implausible* stretches, kept per probe as
:class:`QualityInterval` for the events they fall in to carry.

What validation read is kept (:class:`RecordRead`, with the file's :func:`file_stamp`):
:func:`read_records` takes a file's channels from its ``kept`` read while the file is
unchanged, so a case's records are parsed once, not once to validate and again to run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.sensing import record_files
from femref.sensing.record_files import format_of, key_of
from femref.sensing.record_files import RecordError, SampleLimit, read_columns

ACCELERATION_UNITS: dict[str, float] = {"m/s^2": 1.0, "g": 9.80665, "mm/s^2": 1.0e-3}
"""Acceleration units a channel may declare, and their value in m/s²."""
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1.0e-3, "iso8601": 1.0}
"""Time units a time column, dataset or channel may declare, and their value in s (``iso8601``: a CSV column of
ISO-8601 timestamps, read in s from the first)."""
UNIT_SPELLINGS = {"m/s²": "m/s^2", "m/s2": "m/s^2", "m s-2": "m/s^2", "mm/s²": "mm/s^2", "mm/s2": "mm/s^2", "G": "g", "sec": "s"}
"""Other spellings of the units above that files' metadata use."""
GAP_STEP = 1.5
"""A time step longer than this many median steps is a gap."""
SATURATED_RUN = 3
"""Samples in a row at a channel's extreme that make it saturated."""
MAX_RECORD_RATE = 50_000.0
"""Highest sampling rate of a record (Hz), declared or 1 / the median time step. Shock and impact loggers on rail cars
sample at 1–20 kHz: the accelerometers' usable band ends near 10 kHz, and the impact's content (the cars' axial modes,
the gear's closure) lies below 1 kHz. A faster record holds nothing more of the impact and multiplies every event's
grid (:data:`MAX_EVENT_VALUES`); time stamps nanoseconds apart ask for a GHz grid."""
PLAUSIBLE_ACCELERATION = 1000.0 * 9.80665
"""Largest |a| (m/s², 1000 g) a car-body accelerometer records of a coupling impact. The hardest yard impact (~4.5 MN,
the gear solid) decelerates even an empty 20 t car by 4.5e6 / 2e4 = 225 m/s² (23 g) as a rigid body; ringing near the
coupler multiplies that locally by a few, and shock loggers' ranges end at ±200–500 g. A sample beyond is a glitch, a
wrong unit or a sensor knocked loose: flagged ``implausible``, never taken silently."""
MAX_EVENT_VALUES = 2_000_000
"""Most values of one event's records on its grid (:func:`femref.sensing.trigger.window`: ``max_window × rate``
samples, the highest channel rate, times the channels), checked when the case is loaded: a fixed ceiling on what one
event may ask, whatever the estimators. The default 5 s window of five channels at 50 kHz holds 1.25e6. At the limit
an event's records are 16 MB and ``inverse_rigid`` holds about 0.5 GB (240 bytes a value, measured on a 250 s window);
the costlier estimators (kalman) are priced below it by the work budget (:mod:`femref.run.event_budget`)."""


@dataclass(frozen=True)
class ChannelSource:
    """Where probe ``<car>/<sensor>`` is in its file: a CSV ``column`` (header name or 0-based index), an HDF5
    ``dataset`` or an MDF4, TDMS or UFF58 ``channel``, in ``unit`` (None: the file's)."""

    probe: str
    column: str | int | None
    dataset: str | None
    unit: str | None
    channel: str | None = None


@dataclass(frozen=True)
class TimeSource:
    """A file's sample times: a ``column``, ``dataset`` or ``channel`` in ``unit``, or ``rate`` (Hz) from ``start`` (s)."""

    column: str | int | None = None
    dataset: str | None = None
    unit: str = "s"
    rate: float | None = None
    start: float = 0.0
    channel: str | None = None


@dataclass(frozen=True)
class AntiAlias:
    """A recorder's analogue anti-alias low-pass: Butterworth of ``order`` at ``corner`` Hz."""

    corner: float
    order: int = 4


@dataclass(frozen=True)
class RecordFile:
    """One recorder's file: its times, its clock offset (s, added to them), its channels and the
    anti-alias filter its channels passed before sampling (None: not declared); ``format`` (None: by suffix) and
    the CSV ``separator`` (None: sniffed) and ``decimal``; ``kept``: what an earlier reading of it gave
    (:class:`RecordRead`, used while the file is unchanged; None: read it)."""

    path: Path
    time: TimeSource
    clock_offset: float
    channels: tuple[ChannelSource, ...]
    anti_alias: AntiAlias | None = None
    format: str | None = None
    separator: str | None = None
    decimal: str = "."
    kept: RecordRead | None = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class QualityInterval:
    """A stretch of a channel not to be trusted: ``reason`` ``gap`` or ``saturated``, from ``start`` to ``end`` (s)."""

    start: float
    end: float
    reason: str


@dataclass(frozen=True, eq=False)
class Channel:
    """One probe's record: times (s), acceleration (m/s², NaN in gaps), rate (Hz), file, quality and the
    recorder's anti-alias filter (None: not declared)."""

    probe: str
    time: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    rate: float
    file: str
    quality: tuple[QualityInterval, ...]
    anti_alias: AntiAlias | None = None


Stamp = tuple[int, int, int, int]
"""``(st_dev, st_ino, st_size, st_mtime_ns)`` of a file: a different file, or the same one rewritten, has another."""


def file_stamp(path: Path) -> Stamp | None:
    """The :data:`Stamp` of ``path``, None when it cannot be ``stat``\\ ed."""
    try:
        status = path.stat()
    except OSError:
        return None
    return (status.st_dev, status.st_ino, status.st_size, status.st_mtime_ns)


@dataclass(frozen=True, eq=False)
class RecordRead:
    """A file's channels as read, and its :func:`file_stamp` taken before the reading (None: unknown, read again).

    Equal when the stamps and every channel's samples are (cases compare what they kept in ``==``)."""

    stamp: Stamp | None
    channels: tuple[Channel, ...]

    @property
    def values(self) -> int:
        """Values held: the samples of the time axis and of each channel."""
        time = self.channels[0].time.size if self.channels else 0  # one time axis for the file's channels
        return time + sum(channel.acceleration.size for channel in self.channels)

    def current(self, path: Path) -> bool:
        """True while the file at ``path`` is the one read, unchanged."""
        return self.stamp is not None and self.stamp == file_stamp(path)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RecordRead):
            return NotImplemented
        return self.stamp == other.stamp and len(self.channels) == len(other.channels) and all(
            a.probe == b.probe and np.array_equal(a.time, b.time) and np.array_equal(a.acceleration, b.acceleration, equal_nan=True)
            for a, b in zip(self.channels, other.channels)
        )

    def __hash__(self) -> int:
        return hash((self.stamp, tuple(channel.probe for channel in self.channels)))


@dataclass(frozen=True, eq=False)
class Recordings:
    """Every recorded probe's :class:`Channel`, in the order declared."""

    channels: dict[str, Channel]

    @property
    def span(self) -> tuple[float, float]:
        """The time span every channel covers (s)."""
        return max(c.time[0] for c in self.channels.values()), min(c.time[-1] for c in self.channels.values())


def read_records(files: Sequence[RecordFile]) -> Recordings:
    """Every channel of every file in SI units on its own time axis (module docstring); RecordError for a bad file.
    A file whose ``kept`` read is current (:meth:`RecordRead.current`) is not read again."""
    channels: dict[str, Channel] = {}
    where: dict[str, str] = {}
    values_left = record_files.MAX_RECORD_VALUES
    for record in files:
        name = record.path.name
        for source in record.channels:
            if source.probe in where:
                raise RecordError(f"{name}: channel {source.probe}: also recorded in {where[source.probe]}; one channel per probe")
            where[source.probe] = name
        kept = record.kept
        read = kept if kept is not None and kept.current(record.path) else read_record_file(record, values_left)
        values_left -= read.values
        channels.update((channel.probe, channel) for channel in read.channels)
    return Recordings(channels)


def read_record_file(record: RecordFile, values_left: int | None = None) -> RecordRead:
    """The channels of one file (module docstring) with the file's stamp before the reading; ``values_left``: how many
    of :data:`~femref.sensing.record_files.MAX_RECORD_VALUES` the file may still hold (the others' share spent; None:
    all of them)."""
    path, name = record.path, record.path.name
    values_left = record_files.MAX_RECORD_VALUES if values_left is None else values_left
    for source in record.channels:
        if source.unit is not None and source.unit not in ACCELERATION_UNITS:
            raise RecordError(f"{name}: channel {source.probe}: unknown unit {source.unit!r}; units: {', '.join(ACCELERATION_UNITS)}")
    rate = record.time.rate
    if rate is None and record.time.unit not in TIME_UNITS:
        raise RecordError(f"{name}: time: unknown unit {record.time.unit!r}; units: {', '.join(TIME_UNITS)}")
    if rate is not None and not (math.isfinite(rate) and 0.0 < rate <= MAX_RECORD_RATE):
        raise RecordError(f"{name}: time: rate {rate:g} Hz is outside (0, {MAX_RECORD_RATE:g}] Hz, the rates a rail-car recorder samples at")
    fmt = format_of(path, record.format)
    key = key_of(fmt)
    requests = [(getattr(source, key), f"channel {source.probe}") for source in record.channels]
    options: dict[str, object] = {}
    if fmt == "csv":
        options = {"separator": record.separator, "decimal": record.decimal}
        if rate is None and record.time.unit == "iso8601":
            options["timestamps"] = record.time.column
    elif record.time.unit == "iso8601":
        raise RecordError(f"{name}: time: unit iso8601 is for a CSV column of ISO-8601 timestamps; this file is {fmt.upper()}")
    if rate is None:
        requests.append((getattr(record.time, key), "time"))
    for reference, what in requests:
        if reference is None:
            raise RecordError(f"{name}: {what}: a {fmt.upper()} file's columns are named by {key}: give {key}")
    stamp = file_stamp(path)
    columns, found = read_columns(path, requests, SampleLimit.for_file(len(record.channels) + 1, values_left), fmt, options)
    units = [_unit(f"{name}: channel {source.probe}", source.unit, found[k], ACCELERATION_UNITS) for k, source in enumerate(record.channels)]
    values = {source.probe: columns[k] for k, source in enumerate(record.channels)}
    if rate is None:
        time = columns[-1]
        time *= TIME_UNITS[_unit(f"{name}: time", record.time.unit, found[-1], TIME_UNITS)]  # in place: the arrays read are the record's own
        _check_time(name, time)
        rate = 1.0 / float(np.median(np.diff(time)))
        if rate > MAX_RECORD_RATE:
            raise RecordError(f"{name}: time: the median step {1.0 / rate:.3g} s is a rate of {rate:.4g} Hz, above {MAX_RECORD_RATE:g} Hz, "
                              "the highest a rail-car recorder samples at (a time column in the wrong unit?)")
    else:
        time = record.time.start + np.arange(max(v.size for v in values.values())) / rate
    time += record.clock_offset
    channels = []
    for source, unit in zip(record.channels, units):
        a = values[source.probe]
        label = f"{name}: channel {source.probe}"
        if a.size != time.size:
            raise RecordError(f"{label}: {a.size} samples against {time.size} sample times")
        if not np.any(np.isfinite(a)):
            raise RecordError(f"{label}: no finite value")
        a *= ACCELERATION_UNITS[unit]
        channels.append(Channel(source.probe, time, a, float(rate), name, _quality(time, a), record.anti_alias))
    return RecordRead(stamp, tuple(channels))


def _unit(label: str, declared: str | None, found: str | None, units: dict[str, float]) -> str:
    """The unit of a column: the ``declared`` one, the file's (``found``, spelled as in ``units``), which must agree."""
    if found is None or not found.strip():
        if declared is None:
            raise RecordError(f"{label}: the file gives no unit; declare its unit: {', '.join(units)}")
        return declared
    spelled = UNIT_SPELLINGS.get(found.strip(), found.strip())
    if declared is not None and declared != spelled:
        raise RecordError(f"{label}: the case declares unit {declared!r}, the file gives {found!r}; they must agree")
    if spelled not in units:
        raise RecordError(f"{label}: the file gives unit {found!r}, not one of {', '.join(units)}")
    return spelled


def _check_time(name: str, time: NDArray[np.float64]) -> None:
    if time.size < 2:
        raise RecordError(f"{name}: time: needs at least two samples, has {time.size}")
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise RecordError(f"{name}: time: sample {bad[0] + 1} is not a finite number")
    steps = np.diff(time)
    back = np.flatnonzero(steps <= 0.0)
    if back.size:
        k = int(back[0])
        rule = "is duplicated" if steps[k] == 0.0 else "goes back"
        raise RecordError(f"{name}: time must increase strictly; sample {k + 2} (t = {time[k + 1]:.9g} s) {rule} after t = {time[k]:.9g} s")


def _quality(time: NDArray[np.float64], a: NDArray[np.float64]) -> tuple[QualityInterval, ...]:
    """Gaps (NaN runs, long steps), saturated stretches (flat tops at the channel's extreme) and implausible ones
    (|a| > :data:`PLAUSIBLE_ACCELERATION`) of one channel."""
    intervals = [QualityInterval(float(time[max(first - 1, 0)]), float(time[min(last + 1, time.size - 1)]), "gap")
                 for first, last in _runs(~np.isfinite(a))]
    steps = np.diff(time)
    intervals += [QualityInterval(float(time[k]), float(time[k + 1]), "gap") for k in np.flatnonzero(steps > GAP_STEP * np.median(steps))]
    magnitude = np.abs(a)
    extreme = np.nanmax(magnitude)
    if extreme > 0.0:
        intervals += [QualityInterval(float(time[first]), float(time[last]), "saturated")
                      for first, last in _runs(magnitude == extreme) if last - first + 1 >= SATURATED_RUN]
    intervals += [QualityInterval(float(time[first]), float(time[last]), "implausible") for first, last in _runs(magnitude > PLAUSIBLE_ACCELERATION)]
    return tuple(sorted(intervals, key=lambda q: q.start))


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``(first, last)`` index of every run of True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


__all__ = ["AntiAlias", "ACCELERATION_UNITS", "MAX_EVENT_VALUES", "MAX_RECORD_RATE", "PLAUSIBLE_ACCELERATION", "TIME_UNITS",
           "Channel", "ChannelSource", "QualityInterval", "RecordError", "RecordFile", "RecordRead", "Recordings", "Stamp", "TimeSource",
           "file_stamp", "read_record_file", "read_records"]
