"""End-load histories: half-sine pulses, ramps to a step, and tabulated records.

Every signal is a frozen value object with

* ``__call__(t)`` — the value at times ``t`` (s), vectorised;
* ``derivative(t, order)`` — the first or second time derivative where the signal is
  smooth (the Dirac parts at kinks and jumps are left out: they carry no information a
  low-frequency model can use);
* ``laplace(s)`` — its one-sided Laplace transform ``∫₀^∞ f(t) e^{−st} dt``, for the
  exact time-domain solutions (``femref.exact``);
* ``time_scale`` — the time over which it changes (s), for automatic step sizes and ε;
* ``end`` — the last time at which it changes (s).

A constant load is ``Constant(value)`` (a step at t = 0).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.core.files import NotRegularFile, regular_file


class Signal(Protocol):
    """What the solvers need of a load history."""

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]: ...

    def derivative(self, t: ArrayLike, order: int) -> NDArray[np.float64]: ...

    def laplace(self, s: ArrayLike) -> NDArray[np.complex128]: ...

    @property
    def time_scale(self) -> float: ...

    @property
    def end(self) -> float: ...


@dataclass(frozen=True)
class Constant:
    """``f(t) = value`` for ``t ≥ 0``; Laplace transform ``value/s``."""

    value: float

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        return np.where(t >= 0.0, self.value, 0.0)

    def derivative(self, t: ArrayLike, order: int) -> NDArray[np.float64]:
        return np.zeros(np.shape(t))

    def laplace(self, s: ArrayLike) -> NDArray[np.complex128]:
        s = np.asarray(s, dtype=complex)
        return self.value / s

    @property
    def time_scale(self) -> float:
        return math.inf

    @property
    def end(self) -> float:
        return 0.0


@dataclass(frozen=True)
class HalfSine:
    """``f(t) = A sin(π (t − t0)/T)`` for ``t0 ≤ t ≤ t0 + T``, zero elsewhere.

    Laplace transform (shift theorem on the two sine halves):
    ``F(s) = A (π/T) (e^{−s t0} + e^{−s (t0+T)}) / (s² + (π/T)²)``.
    """

    amplitude: float
    duration: float
    start: float = 0.0

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        tau = t - self.start
        inside = (tau >= 0.0) & (tau <= self.duration)
        return np.where(inside, self.amplitude * np.sin(np.pi * np.clip(tau, 0.0, self.duration) / self.duration), 0.0)

    def derivative(self, t: ArrayLike, order: int) -> NDArray[np.float64]:
        """``A (π/T)ᵏ sin⁽ᵏ⁾(π(t − t0)/T)`` inside the pulse, zero outside."""
        tau = np.asarray(t, dtype=float) - self.start
        inside = (tau >= 0.0) & (tau <= self.duration)
        w = np.pi / self.duration
        phase = w * np.clip(tau, 0.0, self.duration) + order * np.pi / 2.0  # sin⁽ᵏ⁾(θ) = sin(θ + kπ/2)
        return np.where(inside, self.amplitude * w**order * np.sin(phase), 0.0)

    def laplace(self, s: ArrayLike) -> NDArray[np.complex128]:
        s = np.asarray(s, dtype=complex)
        w = np.pi / self.duration
        shifts = np.exp(-s * self.start) + np.exp(-s * (self.start + self.duration))
        return self.amplitude * w * shifts / (s * s + w * w)

    @property
    def time_scale(self) -> float:
        return self.duration

    @property
    def end(self) -> float:
        return self.start + self.duration


@dataclass(frozen=True)
class RampStep:
    """``f(t) = A clip((t − t0)/rise, 0, 1)``: a linear rise to a held step.

    Laplace transform: ``F(s) = A (e^{−s t0} − e^{−s (t0+rise)}) / (rise s²)``;
    for ``rise = 0`` the step ``A e^{−s t0}/s``.
    """

    amplitude: float
    rise: float
    start: float = 0.0

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        if self.rise == 0.0:
            return np.where(t >= self.start, self.amplitude, 0.0)
        return self.amplitude * np.clip((t - self.start) / self.rise, 0.0, 1.0)

    def derivative(self, t: ArrayLike, order: int) -> NDArray[np.float64]:
        """``A/rise`` during the rise (first derivative), zero otherwise and for order 2."""
        t = np.asarray(t, dtype=float)
        if order != 1 or self.rise == 0.0:
            return np.zeros(t.shape)
        return np.where((t >= self.start) & (t <= self.start + self.rise), self.amplitude / self.rise, 0.0)

    def laplace(self, s: ArrayLike) -> NDArray[np.complex128]:
        s = np.asarray(s, dtype=complex)
        if self.rise == 0.0:
            return self.amplitude * np.exp(-s * self.start) / s
        return self.amplitude * (np.exp(-s * self.start) - np.exp(-s * (self.start + self.rise))) / (self.rise * s * s)

    @property
    def time_scale(self) -> float:
        return self.rise if self.rise > 0.0 else math.inf

    @property
    def end(self) -> float:
        return self.start + self.rise


@dataclass(frozen=True, eq=False)
class Tabulated:
    """Linear interpolation of samples ``(times[k], values[k])``, zero outside ``[times[0], times[-1]]``.

    Laplace transform, exact for the piecewise-linear function: on each interval
    ``[a, b]`` with ``f = f_a + k (t − a)``,
    ``∫_a^b f e^{−st} dt = (f_a e^{−sa} − f_b e^{−sb})/s + k (e^{−sa} − e^{−sb})/s²``.
    """

    times: NDArray[np.float64]
    values: NDArray[np.float64]

    def __post_init__(self) -> None:
        times = np.asarray(self.times, dtype=float)
        values = np.asarray(self.values, dtype=float)
        if times.ndim != 1 or times.shape != values.shape or times.size < 2:
            raise ValueError("a tabulated signal needs two or more (time, value) samples of equal count")
        if np.any(np.diff(times) <= 0.0):
            raise ValueError("tabulated times must increase strictly")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)

    @classmethod
    def from_csv(cls, path: str | Path, time_column: str | int = 0, value_column: str | int = 1) -> "Tabulated":
        """Read a CSV with a header row (columns by name) or without one (columns by index)."""
        times, values = read_csv_columns(path, time_column, value_column)
        return cls(times, values)

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        return np.interp(t, self.times, self.values, left=0.0, right=0.0)

    def derivative(self, t: ArrayLike, order: int) -> NDArray[np.float64]:
        """The slope of the interval containing t (first derivative); zero for order 2."""
        t = np.asarray(t, dtype=float)
        if order != 1:
            return np.zeros(t.shape)
        slopes = np.diff(self.values) / np.diff(self.times)
        index = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, slopes.size - 1)
        inside = (t >= self.times[0]) & (t <= self.times[-1])
        return np.where(inside, slopes[index], 0.0)

    def laplace(self, s: ArrayLike) -> NDArray[np.complex128]:
        s = np.asarray(s, dtype=complex)[..., None]
        a, b = self.times[:-1], self.times[1:]
        fa, fb = self.values[:-1], self.values[1:]
        slope = (fb - fa) / (b - a)
        ea, eb = np.exp(-s * a), np.exp(-s * b)
        return np.sum((fa * ea - fb * eb) / s + slope * (ea - eb) / (s * s), axis=-1)

    @property
    def time_scale(self) -> float:
        return float(np.min(np.diff(self.times))) * 10.0 if self.times.size > 2 else float(self.times[-1] - self.times[0])

    @property
    def end(self) -> float:
        return float(self.times[-1])


#: Largest load-record file (bytes), checked by ``os.stat`` before the file is opened: room for wide recorder
#: exports, and a stray multi-gigabyte file is stopped before a byte of it is read.
MAX_CSV_BYTES = 256 * 2**20

#: Most data rows (samples) of a load record: 30 min at 1 kHz fits. The work budget (:mod:`femref.run.budget`)
#: counts the samples again once read; this limit only keeps the reading itself bounded.
MAX_CSV_ROWS = 2_000_000

#: Bytes read from the start and from the end of a record to estimate its bytes per row.
_SAMPLE_BYTES = 64 * 1024


class CsvTooLarge(ValueError):
    """A load record beyond :data:`MAX_CSV_BYTES` or :data:`MAX_CSV_ROWS`; the message names the rule and the size."""


def check_csv_size(path: str | Path) -> int:
    """Refuse a record above :data:`MAX_CSV_BYTES` (by ``os.stat``, before opening it) or of an estimated row
    count above :data:`MAX_CSV_ROWS`; return the estimate.

    The estimate is the file size over the bytes per row of its first and of its last
    :data:`_SAMPLE_BYTES` (complete lines only), the larger of the two, so a record whose rows grow
    longer down the file is not refused for its short first rows. Only these two samples are read.
    Raises :class:`CsvTooLarge`, ``ValueError`` for a path that is not a regular file (a device, a pipe, a loop of links, a
    folder), ``FileNotFoundError`` or ``OSError``.
    """
    path = Path(path)
    try:
        status = regular_file(path)  # a device or a pipe (/dev/zero) has no size and may never end
    except NotRegularFile as error:
        raise ValueError(f"CSV file {path} {error}") from None
    size = status.st_size
    if size > MAX_CSV_BYTES:
        raise CsvTooLarge(f"CSV file {path} holds {_size(size)}; a load record may hold at most {_size(MAX_CSV_BYTES)} "
                          f"and {_count(MAX_CSV_ROWS)} samples (30 min at 1 kHz is 1.8e6)")
    with open(path, "rb") as handle:
        head = handle.read(_SAMPLE_BYTES)
        if size <= _SAMPLE_BYTES:
            rows = head.count(b"\n") + (0 if head.endswith(b"\n") or not head else 1)
        else:
            handle.seek(size - _SAMPLE_BYTES)
            tail = handle.read(_SAMPLE_BYTES)
            rows = int(size / max(_bytes_per_row(head), _bytes_per_row(tail[tail.find(b"\n") + 1 :])))
    if rows > MAX_CSV_ROWS:
        raise CsvTooLarge(f"CSV file {path} holds about {_count(rows)} rows in {_size(size)}; a load record may hold at most "
                          f"{_count(MAX_CSV_ROWS)} samples (30 min at 1 kHz is 1.8e6): resample or cut the record")
    return rows


def _bytes_per_row(sample: bytes) -> float:
    """Mean bytes of the complete lines in ``sample`` (the whole sample when it holds no line end)."""
    lines = sample.count(b"\n")
    return (sample.rfind(b"\n") + 1) / lines if lines else max(len(sample), 1)


def _count(n: float) -> str:
    """``2000000`` as ``2e6``, ``12345678`` as ``1.23e7``, ``512`` as ``512``."""
    mantissa, _, exponent = f"{n:.3g}".partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else mantissa


def _size(n: int) -> str:
    """``314572800`` as ``300 MiB (314572800 bytes)``."""
    return f"{n / 2**20:.3g} MiB ({n} bytes)"


def read_csv_columns(path: str | Path, time_column: str | int, value_column: str | int) -> tuple[NDArray, NDArray]:
    """Two float columns of a CSV file, by header name or by 0-based index.

    The size is checked first (:func:`check_csv_size`, before the file is read) and the data rows are
    counted while reading: the reading stops at row :data:`MAX_CSV_ROWS` + 1 whatever the estimate said.
    Raises :class:`CsvTooLarge` (a ``ValueError``) beyond the limits, ``ValueError`` with the reason when
    the file is empty, a column is missing, or a cell is not a number; ``FileNotFoundError`` when the file
    is absent.
    """
    path = Path(path)
    check_csv_size(path)
    with open(path) as handle:
        lines = (ln.rstrip("\n") for ln in handle if ln.strip() and not ln.lstrip().startswith("#"))
        first_line = next(lines, None)
        if first_line is None:
            raise ValueError(f"CSV file {path} is empty")
        first = [c.strip() for c in first_line.split(",")]
        has_header = not all(is_number(c) for c in first)
        header = first if has_header else None
        first_row = next(lines, None) if has_header else first_line
        if first_row is None:
            raise ValueError(f"CSV file {path} has no data rows")
        rows = itertools.chain([first_row], lines)

        def index_of(column: str | int) -> int:
            if isinstance(column, int):
                return column
            if header is None or column not in header:
                raise ValueError(f"CSV file {path} has no column {column!r} (header: {header})")
            return header.index(column)

        it, iv = index_of(time_column), index_of(value_column)
        times: list[float] = []
        values: list[float] = []
        start = 2 if has_header else 1
        for lineno, row in enumerate(itertools.islice(rows, MAX_CSV_ROWS), start=start):
            cells = row.split(",")  # float() ignores the blanks around a number
            try:
                times.append(float(cells[it]))
                values.append(float(cells[iv]))
            except (IndexError, ValueError):
                raise ValueError(f"CSV file {path}, line {lineno}: expected numbers in columns {it} and {iv}, got {row!r}") from None
        if next(rows, None) is not None:
            raise CsvTooLarge(f"CSV file {path} holds more than {_count(MAX_CSV_ROWS)} samples; a load record may hold at most "
                              f"{_count(MAX_CSV_ROWS)} (30 min at 1 kHz is 1.8e6): resample or cut the record")
    return np.asarray(times), np.asarray(values)


def is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
