"""Measured acceleration records: CSV or HDF5 files of real recorders, read into SI units with their quality.

A recorder's file holds sample times (a column or dataset, or a uniform ``rate`` from a
``start``) and one column or dataset per accelerometer channel. :func:`read_records`
reads every declared file and channel:

    t = offset + unit_t · t_file      (s; the file's clock offset added)
    a = unit_a · a_file               (m/s²; units ACCELERATION_UNITS, g = 9.80665 m/s² exactly)

Each probe (``<car>/<sensor>``) keeps its own time axis: two recorders may sample at
different rates and their clocks may differ by a known offset. A channel's rate is the
declared rate, or 1 / the median time step.

**Errors** (:class:`RecordError`, naming the file, the channel or time source and the
rule): a missing or unreadable file; a missing column or dataset; an unknown unit; a cell
that is not a number; fewer than two samples; a time that is not finite, or does not
increase (duplicated or going back: the first offending row is named); a channel whose
length differs from its time axis; a channel with no finite value; the same probe in two
places.

**Quality, not errors**: NaN runs inside a channel and time steps longer than 1.5 × the
median step are *gaps*; runs of three or more samples at a channel's extreme value (the
largest |a| it records, reached by a flat top) are *saturated*. Both are kept per probe as
:class:`QualityInterval` (start, end in s, reason) for the events they fall in to carry.
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

ACCELERATION_UNITS: dict[str, float] = {"m/s^2": 1.0, "g": 9.80665, "mm/s^2": 1.0e-3}
"""Acceleration units a channel may declare, and their value in m/s²."""
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1.0e-3}
"""Time units a time column or dataset may declare, and their value in s."""
GAP_STEP = 1.5
"""A time step longer than this many median steps is a gap."""
SATURATED_RUN = 3
"""Samples in a row at a channel's extreme that make it saturated."""
HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")


Reader = Callable[[str | int | None, str], NDArray[np.float64]]
"""``read(column or dataset, what)``: one column of an open record file, as floats."""


class RecordError(ValueError):
    """A record file that cannot be read as declared: the message names the file, channel and rule."""


@dataclass(frozen=True)
class ChannelSource:
    """Where probe ``<car>/<sensor>`` is in its file: a CSV ``column`` (header name or 0-based index) or an HDF5
    ``dataset``, in ``unit``."""

    probe: str
    column: str | int | None
    dataset: str | None
    unit: str


@dataclass(frozen=True)
class TimeSource:
    """A file's sample times: a ``column`` or ``dataset`` in ``unit``, or ``rate`` (Hz) from ``start`` (s)."""

    column: str | int | None = None
    dataset: str | None = None
    unit: str = "s"
    rate: float | None = None
    start: float = 0.0


@dataclass(frozen=True)
class AntiAlias:
    """A recorder's analogue anti-alias low-pass: Butterworth of ``order`` at ``corner`` Hz."""

    corner: float
    order: int = 4


@dataclass(frozen=True)
class RecordFile:
    """One recorder's file: its times, its clock offset (s, added to them), its channels and the
    anti-alias filter its channels passed before sampling (None: not declared)."""

    path: Path
    time: TimeSource
    clock_offset: float
    channels: tuple[ChannelSource, ...]
    anti_alias: AntiAlias | None = None


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


@dataclass(frozen=True, eq=False)
class Recordings:
    """Every recorded probe's :class:`Channel`, in the order declared."""

    channels: dict[str, Channel]

    @property
    def span(self) -> tuple[float, float]:
        """The time span every channel covers (s)."""
        return max(c.time[0] for c in self.channels.values()), min(c.time[-1] for c in self.channels.values())


def read_records(files: Sequence[RecordFile]) -> Recordings:
    """Every channel of every file in SI units on its own time axis (module docstring); RecordError for a bad file."""
    channels: dict[str, Channel] = {}
    where: dict[str, str] = {}
    for record in files:
        name = record.path.name
        for source in record.channels:
            if source.probe in where:
                raise RecordError(f"{name}: channel {source.probe}: also recorded in {where[source.probe]}; one channel per probe")
            where[source.probe] = name
        for channel in _read_file(record):
            channels[channel.probe] = channel
    return Recordings(channels)


def _read_file(record: RecordFile) -> list[Channel]:
    path, name = record.path, record.path.name
    if not path.exists():
        raise RecordError(f"{name}: file not found ({path})")
    for source in record.channels:
        if source.unit not in ACCELERATION_UNITS:
            raise RecordError(f"{name}: channel {source.probe}: unknown unit {source.unit!r}; units: {', '.join(ACCELERATION_UNITS)}")
    if record.time.rate is None and record.time.unit not in TIME_UNITS:
        raise RecordError(f"{name}: time: unknown unit {record.time.unit!r}; units: {', '.join(TIME_UNITS)}")
    hdf5 = path.suffix.lower() in HDF5_SUFFIXES
    with (_hdf5_reader(path) if hdf5 else _csv_reader(path)) as read:
        values = {source.probe: read(source.dataset if hdf5 else source.column, f"channel {source.probe}") for source in record.channels}
        raw = None if record.time.rate is not None else read(record.time.dataset if hdf5 else record.time.column, "time")
    if raw is None:
        size = max(v.size for v in values.values())
        time = record.time.start + np.arange(size) / record.time.rate
        rate = float(record.time.rate)  # type: ignore[arg-type]
    else:
        time = raw * TIME_UNITS[record.time.unit]
        _check_time(name, time)
        rate = 1.0 / float(np.median(np.diff(time)))
    time = time + record.clock_offset
    channels = []
    for source in record.channels:
        a = values[source.probe]
        label = f"{name}: channel {source.probe}"
        if a.size != time.size:
            raise RecordError(f"{label}: {a.size} samples against {time.size} sample times")
        if not np.any(np.isfinite(a)):
            raise RecordError(f"{label}: no finite value")
        a = a * ACCELERATION_UNITS[source.unit]
        channels.append(Channel(source.probe, time, a, rate, name, _quality(time, a), record.anti_alias))
    return channels


@contextmanager
def _csv_reader(path: Path) -> Iterator[Reader]:
    """``read(column, what)``: one column of a CSV file with a header row, as floats (an empty cell is NaN)."""
    name = path.name
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = [row for row in csv.reader(handle) if row]
    except (OSError, UnicodeDecodeError) as error:
        raise RecordError(f"{name}: cannot read the file: {error}") from None
    if len(rows) < 3:
        raise RecordError(f"{name}: needs a header row and at least two rows of samples, has {len(rows)} row(s)")
    header = [cell.strip() for cell in rows[0]]

    def read(column: str | int | None, what: str) -> NDArray[np.float64]:
        if isinstance(column, int):
            if not 0 <= column < len(header):
                raise RecordError(f"{name}: {what} (column {column}): no such column; the file has {len(header)} columns")
            index = column
        elif column in header:
            index = header.index(column)
        else:
            raise RecordError(f"{name}: {what} (column {column!r}): no such column (columns: {', '.join(header)})")
        values = np.empty(len(rows) - 1)
        for k, row in enumerate(rows[1:]):
            cell = row[index].strip() if index < len(row) else ""
            if cell == "" or cell.lower() == "nan":
                values[k] = np.nan
                continue
            try:
                values[k] = float(cell)
            except ValueError:
                raise RecordError(f"{name}: {what} (column {header[index]!r}): row {k + 2} is not a number ({cell!r})") from None
        return values

    yield read


@contextmanager
def _hdf5_reader(path: Path) -> Iterator[Reader]:
    """``read(dataset, what)``: one 1-D dataset of an HDF5 file, as floats."""
    name = path.name
    try:
        h5 = h5py.File(path, "r")
    except OSError as error:
        raise RecordError(f"{name}: cannot read the file as HDF5: {error}") from None

    def read(dataset: str | int | None, what: str) -> NDArray[np.float64]:
        if not isinstance(dataset, str) or dataset not in h5 or not isinstance(h5[dataset], h5py.Dataset):
            raise RecordError(f"{name}: {what} (dataset {dataset!r}): no such dataset")
        try:
            values = np.asarray(h5[dataset][()], dtype=float).squeeze()
        except (TypeError, ValueError):
            raise RecordError(f"{name}: {what} (dataset {dataset!r}): not numbers") from None
        if values.ndim != 1:
            raise RecordError(f"{name}: {what} (dataset {dataset!r}): must be one-dimensional, has shape {values.shape}")
        return values

    with h5:
        yield read


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
    """Gaps (NaN runs, long steps) and saturated stretches (flat tops at the channel's extreme) of one channel."""
    intervals = []
    missing = ~np.isfinite(a)
    for first, last in _runs(missing):
        intervals.append(QualityInterval(float(time[max(first - 1, 0)]), float(time[min(last + 1, time.size - 1)]), "gap"))
    steps = np.diff(time)
    for k in np.flatnonzero(steps > GAP_STEP * np.median(steps)):
        intervals.append(QualityInterval(float(time[k]), float(time[k + 1]), "gap"))
    extreme = np.nanmax(np.abs(a))
    if extreme > 0.0:
        at_extreme = np.abs(a) == extreme
        for first, last in _runs(at_extreme):
            if last - first + 1 >= SATURATED_RUN:
                intervals.append(QualityInterval(float(time[first]), float(time[last]), "saturated"))
    return tuple(sorted(intervals, key=lambda q: q.start))


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``(first, last)`` index of every run of True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


__all__ = [
    "AntiAlias",
    "ACCELERATION_UNITS", "TIME_UNITS", "Channel", "ChannelSource", "QualityInterval", "RecordError", "RecordFile",
    "Recordings", "TimeSource", "read_records",
]
