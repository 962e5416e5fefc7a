"""Measured acceleration records: a recorder's CSV, HDF5, MDF4, TDMS or UFF58 files read as one stream, chunk by chunk, in SI units.

A recorder (:class:`RecordFile`) writes one file or a sequence of them (a logger's hourly files, read in order as one
stream). Each file holds sample times (a column, dataset or channel, or a uniform ``rate`` from a ``start``) and one
column, dataset or channel per accelerometer (:mod:`femref.sensing.formats`). :class:`RecorderReader` yields the
stream in chunks of at most :data:`~femref.sensing.record_files.CHUNK_SAMPLES` samples (read when it starts):

    t = offset + unit_t · t_file − drift · 1e-6 · (unit_t · t_file − t_first)     (s; the clock offset added, a declared drift removed)
    a = unit_a · a_file               (m/s²; units ACCELERATION_UNITS, g = 9.80665 m/s² exactly)

A unit is the one declared or the file's own (MDF4, TDMS, UFF58 metadata); when both are given they must agree.
Times continue across a recorder's files: a rate-only time makes consecutive files contiguous (each file's first
sample one step after the previous file's last), a time column gives each file's own times (an ISO-8601 column: in s
from the first file's first stamp), and a later file's first time must come after the previous file's last.

Each probe (``<car>/<sensor>``) keeps its recorder's time axis: two recorders may sample at different rates and their
clocks may differ by a known offset. A recorder's rate is the declared rate, or 1 / the median time step of its
stream's first :data:`STEP_SAMPLES` samples (the same for any chunk size and any cutting into files).

**Errors** (:class:`RecordError`, naming the file, the channel or time source, the sample and the rule; docs/design.md
§3.7): what :mod:`femref.sensing.record_files` refuses, an unknown unit, fewer than two samples in a file, a time that
is not finite or does not increase (within a file, or from one file to the next: both files named), a rate above
:data:`MAX_RECORD_RATE`, a channel with no finite value or not one per time, the same probe in two places. The stream
finds them where they are, which for a long stream is during the run (nothing is written under the output's name then).

**Quality, not errors** (:mod:`femref.sensing.quality`): *gaps*, *saturated* and *implausible* stretches, kept per
probe as :class:`QualityInterval` for the events they fall in to carry.
"""

from __future__ import annotations

import glob
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.sensing import record_files
from femref.sensing.record_files import WHOLE_FILE_FORMATS, RecordError, format_of, key_of, open_columns
from femref.sensing.quality import QualityInterval, QualityTracker

ACCELERATION_UNITS: dict[str, float] = {"m/s^2": 1.0, "g": 9.80665, "mm/s^2": 1.0e-3}
"""Acceleration units a channel may declare, and their value in m/s²."""
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1.0e-3, "iso8601": 1.0}
"""Time units a time column, dataset or channel may declare, and their value in s (``iso8601``: a CSV column of
ISO-8601 timestamps, read in s from the first)."""
UNIT_SPELLINGS = {"m/s²": "m/s^2", "m/s2": "m/s^2", "m s-2": "m/s^2", "mm/s²": "mm/s^2", "mm/s2": "mm/s^2", "G": "g", "sec": "s"}
"""Other spellings of the units above that files' metadata use."""
MAX_RECORD_RATE = 50_000.0
"""Highest sampling rate of a record (Hz), declared or 1 / the median time step. Shock and impact loggers on rail cars
sample at 1–20 kHz: the accelerometers' usable band ends near 10 kHz, and the impact's content (the cars' axial modes,
the gear's closure) lies below 1 kHz. A faster record holds nothing more of the impact and multiplies every event's
grid (:data:`MAX_EVENT_VALUES`); time stamps nanoseconds apart ask for a GHz grid."""
STEP_SAMPLES = 1 << 18
"""Samples at the start of each file that give its median step (the recorder's rate: its first file's), whatever the
chunk size the stream reads (a file up to this long: its median step, as when files were read whole)."""
PROBE_SAMPLES = 4096
"""Samples at the start of each file :func:`probe_recorder` reads when the case is validated (its rate from them)."""
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
    """One recorder: its file ``path`` (or its sequence ``files``, read in order as one stream; ``path`` is the first),
    its times, its clock offset (s, added to them), its channels and the anti-alias filter its channels passed before
    sampling (None: not declared); ``format`` (None: by suffix) and the CSV ``separator`` (None: sniffed) and
    ``decimal``; its name ``recorder`` ("": the first file's stem) and its ``clock_drift``: ppm (its clock gains this
    many µs a second from its first sample, removed from its times) or ``estimate`` (:mod:`femref.sensing.clock`)."""

    path: Path
    time: TimeSource
    clock_offset: float
    channels: tuple[ChannelSource, ...]
    anti_alias: AntiAlias | None = None
    format: str | None = None
    separator: str | None = None
    decimal: str = "."
    files: tuple[Path, ...] = ()
    recorder: str = ""
    clock_drift: float | str = 0.0
    probed_rate: float | None = field(default=None, compare=False)
    """The rate (Hz) :func:`probe_recorder` found when the case was validated (None: not probed)."""

    @property
    def paths(self) -> tuple[Path, ...]:
        """The recorder's files in the order they are read."""
        return self.files or (self.path,)

    @property
    def name(self) -> str:
        """The recorder's name: ``recorder``, or its first file's stem."""
        return self.recorder or self.path.stem

    @property
    def label(self) -> str:
        """How messages name the recorder's files: the file's name, or the first and last of its sequence."""
        paths = self.paths
        return paths[0].name if len(paths) == 1 else f"{paths[0].name} … {paths[-1].name} ({len(paths)} files)"

    @property
    def estimated_clock(self) -> bool:
        """Whether the recorder's clock is mapped onto the reference recorder's by estimation."""
        return self.clock_drift == "estimate"


def expand_files(patterns: Sequence[str | Path], base: Path) -> list[Path]:
    """The files of ``patterns`` (paths or globs, relative to ``base``): each pattern's matches sorted by name, in the
    order of the patterns; a pattern without a wildcard is its own path, whether it exists or not."""
    found: list[Path] = []
    for pattern in patterns:
        path = Path(pattern).expanduser()
        path = path if path.is_absolute() else base / path
        if glob.has_magic(str(pattern)):
            found += sorted(Path(p) for p in glob.glob(str(path)))
        else:
            found.append(path)
    return found


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
    """Every recorded probe's :class:`Channel`, in the order declared: a stream held whole (tests, short records)."""

    channels: dict[str, Channel]

    @property
    def span(self) -> tuple[float, float]:
        """The time span every channel covers (s)."""
        return max(c.time[0] for c in self.channels.values()), min(c.time[-1] for c in self.channels.values())


@dataclass
class _Columns:
    """Columns of one file whose chunks may differ in length (an (n, 1) HDF5 dataset comes whole): the samples not yet
    taken, and each column's count so far."""

    pending: list[NDArray[np.float64]]
    counts: list[int]

    def take(self, parts: list[NDArray[np.float64]]) -> list[NDArray[np.float64]]:
        """Add a chunk's parts; return the samples every column now has (as many of each)."""
        for k, part in enumerate(parts):
            self.pending[k] = part if self.pending[k].size == 0 else np.concatenate([self.pending[k], part])
            self.counts[k] += part.size
        n = min(p.size for p in self.pending)
        taken = [p[:n] for p in self.pending]
        self.pending = [p[n:] for p in self.pending]
        return taken


class RecorderReader:
    """A recorder's files read in sequence as one stream (module docstring): :meth:`chunks` yields
    ``(t, a)`` — times (s, offset and declared drift applied) and the channels' accelerations (channels × samples, m/s²).

    While it reads: :attr:`rate` (Hz, once the first chunk is in), :attr:`quality` (the channels'
    :class:`~femref.sensing.quality.QualityTracker`), :attr:`first_time` and :attr:`last_time` (s), the samples,
    bytes and files read, and :attr:`restarts`, the gaps between or within files (a logger restart)."""

    def __init__(self, record: RecordFile, chunk: int | None = None) -> None:
        self.record, self.chunk = record, record_files.CHUNK_SAMPLES if chunk is None else chunk
        self.rate: float | None = record.time.rate
        self.quality = QualityTracker(len(record.channels))
        self.first_time, self.last_time = math.nan, math.nan
        self.samples, self.bytes, self.files = 0, 0, 0
        self.restarts: list[QualityInterval] = []
        self._finite = np.zeros(len(record.channels), dtype=bool)
        self._origin: object | None = None  # an ISO-8601 column's first stamp, shared by the recorder's files
        self._file_time = math.nan  # the recorder's first time as its files give it (declared drift's origin)
        self._next_index = 0  # a rate-only time: the next sample's index in the recorder's stream
        self._last_file_time = -math.inf
        _check_units(record)

    @property
    def probes(self) -> list[str]:
        return [source.probe for source in self.record.channels]

    def chunks(self) -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """The stream, file after file, chunk by chunk; RecordError where a rule is broken."""
        previous: tuple[str, float] | None = None  # the previous file's name and last time (the file's own clock)
        held: list[tuple[NDArray[np.float64], NDArray[np.float64], float]] = []  # read before the rate is known
        count = 0
        for path in self.record.paths:
            for t, a, step in self._file(path, previous):
                if self.rate is None:
                    held.append((t, a, step))
                    count += t.size
                    if count < STEP_SAMPLES:
                        continue
                    self._rate_from(path.name, held)
                    yield from (self._clocked(*piece) for piece in held)
                    held = []
                    continue
                yield self._clocked(t, a, step)
            previous = (path.name, self._last_file_time)
        if held:
            self._rate_from(self.record.paths[-1].name, held)
            yield from (self._clocked(*piece) for piece in held)
        self.quality.finish()
        for source, finite in zip(self.record.channels, self._finite):
            if not finite:
                raise RecordError(f"{self.record.label}: channel {source.probe}: no finite value")

    def _file(self, path: Path, previous: tuple[str, float] | None) -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64], float]]:
        """One file's chunks: times as read (s), accelerations (m/s²) and the file's median step (s)."""
        record, name = self.record, path.name
        rate = record.time.rate
        fmt, requests, options = _requests(record, path, self._origin)
        with open_columns(path, requests, fmt, options, size=self.chunk) as (reader, infos, parts):
            self.files += 1
            self.bytes += path.stat().st_size
            units = [_unit(f"{name}: channel {source.probe}", source.unit, infos[k].unit, ACCELERATION_UNITS) for k, source in enumerate(record.channels)]
            scales = np.array([ACCELERATION_UNITS[unit] for unit in units])
            time_scale = TIME_UNITS[_unit(f"{name}: time", record.time.unit, infos[-1].unit, TIME_UNITS)] if rate is None else 1.0
            columns = _Columns([np.empty(0)] * len(requests), [0] * len(requests))
            median_step, count, last = math.nan, 0, previous[1] if previous is not None else -math.inf
            held: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []  # the chunks read before the file's median step is known
            for chunk in parts:
                taken = columns.take(chunk)
                n = taken[0].size
                if n == 0:
                    continue
                if rate is None:
                    t = taken[-1] * time_scale
                    _check_time(name, t, count, last, previous if count == 0 else None)
                else:
                    t = record.time.start + (self._next_index + np.arange(n)) / rate
                    self._next_index += n
                count, last = count + n, float(t[-1])
                a = np.array(taken[: len(record.channels)]) * scales[:, None]
                if math.isnan(median_step):
                    held.append((t, a))
                    if count < STEP_SAMPLES:
                        continue
                    median_step = _median_step(np.concatenate([piece for piece, _ in held]), rate)
                    yield from ((*piece, median_step) for piece in held)
                    held = []
                    continue
                yield t, a, median_step
            if held:
                median_step = _median_step(np.concatenate([piece for piece, _ in held]), rate)
                yield from ((*piece, median_step) for piece in held)
            totals = columns.counts
            self._last_file_time = last
            if rate is None and count < 2:
                raise RecordError(f"{name}: time: needs at least two samples, has {count}")
            expected = totals[-1] if rate is None else max(totals)
            for source, total in zip(record.channels, totals):
                if total != expected:
                    raise RecordError(f"{name}: channel {source.probe}: {total} samples against {expected} sample times")
            if fmt == "csv" and rate is None and record.time.unit == "iso8601":
                self._origin = reader.origin

    def _rate_from(self, name: str, held: list[tuple[NDArray[np.float64], NDArray[np.float64], float]]) -> None:
        """The recorder's rate (Hz): 1 / the median step of the stream's first :data:`STEP_SAMPLES` samples."""
        t = np.concatenate([piece[0] for piece in held])[:STEP_SAMPLES]
        step = float(np.median(np.diff(t)))
        if 1.0 / step > MAX_RECORD_RATE:
            raise RecordError(f"{name}: time: the median step {step:.3g} s is a rate of {1.0 / step:.4g} Hz, above {MAX_RECORD_RATE:g} Hz, "
                              "the highest a rail-car recorder samples at (a time column in the wrong unit?)")
        self.rate = 1.0 / step

    def _clocked(self, t: NDArray[np.float64], a: NDArray[np.float64], median_step: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The chunk on the recorder's corrected clock, its quality counted."""
        record = self.record
        if math.isnan(self._file_time):
            self._file_time = float(t[0])
        drift = record.clock_drift
        if isinstance(drift, (int, float)) and drift != 0.0:
            t = t - drift * 1e-6 * (t - self._file_time)
        t += record.clock_offset
        if math.isnan(self.first_time):
            self.first_time = float(t[0])
        self.last_time = float(t[-1])
        self.samples += t.size
        self._finite |= np.isfinite(a).any(axis=1)
        self.restarts += self.quality.feed(t, a, median_step)
        return t, a


def _median_step(t: NDArray[np.float64], rate: float | None) -> float:
    """A file's median step (s) over its first :data:`STEP_SAMPLES` samples, whatever the chunk size (its gaps: steps
    :data:`~femref.sensing.quality.GAP_STEP` times longer)."""
    t = t[:STEP_SAMPLES]
    if t.size < 2:
        return 1.0 / rate if rate is not None else math.inf
    return float(np.median(np.diff(t)))


def _requests(record: RecordFile, path: Path, origin: object | None) -> tuple[str, list[tuple[str | int | None, str]], dict[str, object]]:
    """``(format, requests, reader options)`` of one of ``record``'s files: its channels' columns, then its time column
    (none for a rate); ``origin``: an ISO-8601 time column's first stamp, from the recorder's first file."""
    name, rate, fmt = path.name, record.time.rate, format_of(path, record.format)
    key = key_of(fmt)
    requests = [(getattr(source, key), f"channel {source.probe}") for source in record.channels]
    options: dict[str, object] = {}
    if fmt == "csv":
        options = {"separator": record.separator, "decimal": record.decimal}
        if rate is None and record.time.unit == "iso8601":
            options.update(timestamps=record.time.column, origin=origin)
    elif record.time.unit == "iso8601" and rate is None:
        raise RecordError(f"{name}: time: unit iso8601 is for a CSV column of ISO-8601 timestamps; this file is {fmt.upper()}")
    if rate is None:
        requests.append((getattr(record.time, key), "time"))
    for reference, what in requests:
        if reference is None:
            raise RecordError(f"{name}: {what}: a {fmt.upper()} file's columns are named by {key}: give {key}")
    return fmt, requests, options


@dataclass(frozen=True)
class RecorderHead:
    """What the start of a recorder's files tells (:func:`probe_recorder`): its rate (Hz), its first time and its last
    (s, on its clock with the offset), the last ``exact`` when its last file fits the probe's chunk, else from the
    sample count the file's headers give (a CSV file's lines: an upper bound)."""

    rate: float
    first_time: float
    last_time: float
    exact: bool


def probe_recorder(record: RecordFile) -> RecorderHead:
    """Each of ``record``'s files opened, its columns and units resolved and its first :data:`PROBE_SAMPLES` samples
    read (times finite and increasing, the rate within :data:`MAX_RECORD_RATE`, each file starting after the previous
    one did), without reading the files through; RecordError naming the file and the rule. A file after the first of a
    format whose reader holds the whole file (UFF58) is only opened and its columns resolved: its span is taken to
    follow the previous file's at the rate found."""
    _check_units(record)
    rate, start, origin = record.time.rate, math.nan, None
    index, first, last, exact = 0, math.nan, math.nan, False
    for number, path in enumerate(record.paths):
        name = path.name
        fmt, requests, options = _requests(record, path, origin)
        with open_columns(path, requests, fmt, options, size=PROBE_SAMPLES) as (reader, infos, parts):
            for k, source in enumerate(record.channels):
                _unit(f"{name}: channel {source.probe}", source.unit, infos[k].unit, ACCELERATION_UNITS)
            if number > 0 and fmt in WHOLE_FILE_FORMATS:
                step = 1.0 / (rate if rate is not None else start)
                samples = max(info.samples for info in infos)
                last, exact = last + samples * step, False
                index += samples
                continue
            chunk = next(parts, None)
            whole = chunk is not None and next(parts, None) is None
            n = min((part.size for part in chunk), default=0) if chunk is not None else 0
            samples = n if whole else max(infos[-1].samples, n)
            if rate is None:
                t = chunk[-1][:n] * TIME_UNITS[_unit(f"{name}: time", record.time.unit, infos[-1].unit, TIME_UNITS)] if chunk is not None else np.empty(0)
                if t.size < 2:
                    raise RecordError(f"{name}: time: needs at least two samples, has {t.size}")
                _check_time(name, t, 0, -math.inf, None)
                step = float(np.median(np.diff(t)))
                if 1.0 / step > MAX_RECORD_RATE:
                    raise RecordError(f"{name}: time: the median step {step:.3g} s is a rate of {1.0 / step:.4g} Hz, above {MAX_RECORD_RATE:g} Hz, "
                                      "the highest a rail-car recorder samples at (a time column in the wrong unit?)")
                start = 1.0 / step if math.isnan(start) else start
                if t[0] <= first - record.clock_offset:
                    raise RecordError(f"{name}: time goes back: its first sample t = {t[0]:.9g} s is not after the previous file's first; "
                                      "a recorder's files are read in name order as one stream")
                file_first, file_last = float(t[0]), float(t[-1]) if whole else float(t[0]) + (samples - 1) * step
                origin = getattr(reader, "origin", None)
            else:
                file_first = record.time.start + index / rate
                file_last = record.time.start + (index + samples - 1) / rate
                index += samples
        first = file_first + record.clock_offset if math.isnan(first) else first
        last, exact = file_last + record.clock_offset, whole
    return RecorderHead(rate if rate is not None else start, first, last, exact)


def read_records(files: Sequence[RecordFile], chunk: int | None = None) -> Recordings:
    """Every channel of every recorder held whole, on its own time axis (module docstring): the stream of
    :class:`RecorderReader` joined, for short records and tests; RecordError for a bad file."""
    channels: dict[str, Channel] = {}
    where: dict[str, str] = {}
    for record in files:
        for source in record.channels:
            if source.probe in where:
                raise RecordError(f"{record.path.name}: channel {source.probe}: also recorded in {where[source.probe]}; one channel per probe")
            where[source.probe] = record.path.name
    for record in files:
        reader = RecorderReader(record, chunk)
        parts = list(reader.chunks())
        time = np.concatenate([t for t, _ in parts])
        values = np.concatenate([a for _, a in parts], axis=1)
        assert reader.rate is not None
        for k, source in enumerate(record.channels):
            channels[source.probe] = Channel(source.probe, time, values[k], float(reader.rate), record.label, tuple(reader.quality.intervals(k)),
                                             record.anti_alias)
    return Recordings(channels)


def _check_units(record: RecordFile) -> None:
    name = record.path.name
    for source in record.channels:
        if source.unit is not None and source.unit not in ACCELERATION_UNITS:
            raise RecordError(f"{name}: channel {source.probe}: unknown unit {source.unit!r}; units: {', '.join(ACCELERATION_UNITS)}")
    rate = record.time.rate
    if rate is None and record.time.unit not in TIME_UNITS:
        raise RecordError(f"{name}: time: unknown unit {record.time.unit!r}; units: {', '.join(TIME_UNITS)}")
    if rate is not None and not (math.isfinite(rate) and 0.0 < rate <= MAX_RECORD_RATE):
        raise RecordError(f"{name}: time: rate {rate:g} Hz is outside (0, {MAX_RECORD_RATE:g}] Hz, the rates a rail-car recorder samples at")


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


def _check_time(name: str, time: NDArray[np.float64], before: int, last: float, previous: tuple[str, float] | None) -> None:
    """The times of a chunk whose first sample is the file's ``before + 1``-th, after ``last`` (s: the previous chunk's
    last); ``previous``: the previous file's name and last time, for a file's first chunk."""
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise RecordError(f"{name}: time: sample {before + bad[0] + 1} is not a finite number")
    if before == 0 and previous is not None and time[0] <= previous[1]:
        raise RecordError(f"{name}: time goes back from file {previous[0]} to file {name}: its first sample t = {time[0]:.9g} s is not after "
                          f"the last of {previous[0]}, t = {previous[1]:.9g} s; a recorder's files are read in name order as one stream")
    joined = np.concatenate([[last], time]) if before > 0 else time
    back = np.flatnonzero(np.diff(joined) <= 0.0)
    if back.size:
        j = int(back[0])
        k = j if before > 0 else j + 1  # the index in ``time`` of the sample that does not increase
        rule = "is duplicated" if joined[j + 1] == joined[j] else "goes back"
        raise RecordError(f"{name}: time must increase strictly; sample {before + k + 1} (t = {time[k]:.9g} s) {rule} after t = {joined[j]:.9g} s")


__all__ = ["AntiAlias", "ACCELERATION_UNITS", "MAX_EVENT_VALUES", "MAX_RECORD_RATE", "TIME_UNITS", "Channel", "ChannelSource", "QualityInterval",
           "PROBE_SAMPLES", "STEP_SAMPLES", "RecordError", "RecordFile", "RecorderHead", "RecorderReader", "Recordings", "TimeSource", "expand_files", "probe_recorder",
           "read_records"]
