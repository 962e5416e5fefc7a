"""End-load histories of a transient case: a number or ``{half_sine|ramp_step|csv: …}`` (registry :data:`SIGNALS`).

A CSV file is read and checked when the case is loaded, so a missing or broken file is a case error; its size is
checked first (:func:`femref.core.signals.check_csv_size`), so a huge record is refused in milliseconds. The
samples read are kept with the validated spec: :meth:`CsvSignal.build` reads the file again only when its size or
``st_mtime_ns`` changed since. The load levels are offered by :meth:`SignalSpec.level_problems` to the loads
model, which knows whether the load is a force or a moment (:mod:`femref.case.single`).
"""

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import Field, PlainValidator, PrivateAttr, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from femref.case.errors import Problem, problems_error
from femref.case.fields import NonNegativeReal, PositiveReal, Real, TaggedSpec, tagged_union, resolve_case_path
from femref.case.plausibility import Bound, plausible
from femref.core import signals

__all__ = [
    "SIGNALS",
    "AnySignal",
    "ConstantSignal",
    "CsvSignal",
    "HalfSineSignal",
    "RampStepSignal",
    "SignalSpec",
]


class SignalSpec(TaggedSpec):
    """An end-load history ``f(t)`` (N or N·m), built into a ``femref.core.signals`` object."""

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        """The signal object; ``base_dir`` resolves a relative CSV path (default: working directory)."""
        raise NotImplementedError

    @property
    def is_zero(self) -> bool:
        """True when the history is zero at all times (as far as known without reading files)."""
        return False

    def level_problems(self, bound: Bound) -> list[Problem]:
        """Levels of the history (the constant, the amplitude, a record's largest ``|value|``) outside ``bound``,
        with key paths below the load (``half_sine.amplitude``, ``csv.path``; none for a plain number)."""
        raise NotImplementedError


def _level_problem(path: tuple[str, ...], bound: Bound, value: float, note: str = "") -> list[Problem]:
    """A problem at ``path`` when ``value`` lies outside ``bound`` (``note`` says where the value comes from)."""
    rule = bound.rule(value)
    return [] if rule is None else [Problem(path, note + rule, value)]


#: Pulse lengths and rise times (s), within ``BOUNDS["load_time"]`` (a rise of 0 is a step).
LoadTime = Annotated[PositiveReal, plausible("load_time")]
RiseTime = Annotated[NonNegativeReal, plausible("load_time")]


class ConstantSignal(SignalSpec):
    """A constant load switched on at ``t = 0`` (a step); written as a plain number."""

    tag: ClassVar[str] = "constant"
    number_field: ClassVar[str | None] = "value"
    value: Real = Field(description="Load after t = 0 (N or N·m). Required.")

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        return signals.Constant(self.value)

    @property
    def is_zero(self) -> bool:
        return self.value == 0.0

    def level_problems(self, bound: Bound) -> list[Problem]:
        return _level_problem((), bound, self.value)


class PulseSignal(SignalSpec):
    """A history of level ``amplitude`` (N or N·m), zero before its ``start``."""

    amplitude: Real

    @property
    def is_zero(self) -> bool:
        return self.amplitude == 0.0

    def level_problems(self, bound: Bound) -> list[Problem]:
        return _level_problem((self.tag, "amplitude"), bound, self.amplitude)


class HalfSineSignal(PulseSignal):
    """``A sin(π (t − start)/duration)`` during the pulse, zero elsewhere."""

    tag: ClassVar[str] = "half_sine"
    amplitude: Real = Field(description="Peak load A (N or N·m). Required.")
    duration: LoadTime = Field(description="Pulse length (s), > 0 (plausible: 1e-7–1e5 s). Required.")
    start: NonNegativeReal = Field(default=0.0, description="Pulse start (s), >= 0. Default 0.")

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        return signals.HalfSine(self.amplitude, self.duration, self.start)


class RampStepSignal(PulseSignal):
    """A linear rise from 0 at ``start`` to ``amplitude`` at ``start + rise``, then held."""

    tag: ClassVar[str] = "ramp_step"
    amplitude: Real = Field(description="Held load (N or N·m). Required.")
    rise: RiseTime = Field(description="Rise time (s), >= 0 (0 is a step; plausible: 1e-7–1e5 s). Required.")
    start: NonNegativeReal = Field(default=0.0, description="Start of the rise (s), >= 0. Default 0.")

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        return signals.RampStep(self.amplitude, self.rise, self.start)


def _csv_column(value: Any) -> int | str:
    if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    if isinstance(value, str) and value.strip():
        return value
    raise PydanticCustomError("csv_column", "must be a column name or a 0-based column index")


CsvColumn = Annotated[int | str, PlainValidator(_csv_column)]


@dataclass(frozen=True, eq=False)
class _CsvRead:
    """What :class:`CsvSignal` validation read: the file (absolute), its :func:`_stamp` before reading, the two columns;
    equal when all are (pydantic compares private attributes in ``==`` of cases)."""

    path: Path
    stamp: tuple[int, int] | None
    times: np.ndarray
    values: np.ndarray

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, _CsvRead):
            return NotImplemented
        return (self.path, self.stamp) == (other.path, other.stamp) and np.array_equal(self.times, other.times) and np.array_equal(self.values, other.values)

    def __hash__(self) -> int:
        return hash((self.path, self.stamp))


def _stamp(path: Path) -> tuple[int, int] | None:
    """``(st_size, st_mtime_ns)`` of ``path``, None when it cannot be stat'ed (then :meth:`CsvSignal.build` reads it)."""
    try:
        status = path.stat()
    except OSError:
        return None
    return (status.st_size, status.st_mtime_ns)


class CsvSignal(SignalSpec):
    """Samples from a CSV file, interpolated linearly, zero outside the recorded times. ``path`` is stored resolved,
    so the resolved case reads the same file from anywhere; the largest ``|value|`` and the samples read are kept
    private (not in the resolved case) for :meth:`level_problems` and :meth:`build`."""

    tag: ClassVar[str] = "csv"
    path: Path = Field(description="CSV file, relative to the case file's directory. Required.")
    time_column: CsvColumn = Field(default=0, description="Time column (s): header name or 0-based index. Default 0.")
    value_column: CsvColumn = Field(default=1, description="Load column (N or N·m): header name or 0-based index. Default 1.")
    _peak: tuple[float, int] | None = PrivateAttr(default=None)  # (the value of largest magnitude, its 1-based data row), set when read
    _read: _CsvRead | None = PrivateAttr(default=None)  # the samples validation read and the file's stamp then (see build)

    @field_validator("path", mode="after")
    @classmethod
    def _resolve(cls, path: Path, info: ValidationInfo) -> Path:
        return resolve_case_path(path, info)

    @model_validator(mode="after")
    def _readable(self) -> "CsvSignal":
        problem = self._file_problem()
        if problem is not None:
            raise problems_error([Problem(("path",), problem)])
        return self

    def _file_problem(self) -> str | None:
        try:
            stamp = _stamp(self.path)  # before reading: a change while it is read shows as a later stamp in build
            times, values = signals.read_csv_columns(self.path, self.time_column, self.value_column)
        except FileNotFoundError:
            return f"CSV file {self.path} does not exist"
        except OSError as error:
            return f"cannot read CSV file {self.path}: {error.strerror or error}"
        except ValueError as error:  # too large (CsvTooLarge, before reading), empty, missing column, a cell that is not a number
            return str(error)
        if times.size < 2:
            return f"CSV file {self.path} needs two or more samples, has {times.size}"
        for name, column in (("time", times), ("value", values)):
            bad = np.flatnonzero(~np.isfinite(column))
            if bad.size:
                return f"CSV file {self.path}: {name} in data row {bad[0] + 1} is not a finite number ({column[bad[0]]})"
        steps = np.flatnonzero(np.diff(times) <= 0.0)
        if steps.size:
            k = steps[0]
            return f"CSV file {self.path}: time must increase strictly; data row {k + 2} has t = {times[k + 1]} after t = {times[k]}"
        row = int(np.argmax(np.abs(values)))
        self._peak = (float(values[row]), row + 1)
        self._read = _CsvRead(self.path.absolute(), stamp, times, values)
        return None

    def level_problems(self, bound: Bound) -> list[Problem]:
        if self._peak is None:
            return []
        value, row = self._peak
        return _level_problem((self.tag, "path"), bound, value, f"CSV file {self.path}, data row {row} (the largest |value|): ")

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        """The record as a :class:`~femref.core.signals.Tabulated` signal, from the samples validation read when the
        file is unchanged since (same path, size and ``st_mtime_ns``); read again otherwise (or if never read)."""
        path = self.path if self.path.is_absolute() else Path(base_dir or Path.cwd()) / self.path
        read = self._read
        if read is not None and read.stamp is not None and read.path == path.absolute() and read.stamp == _stamp(path):
            return signals.Tabulated(read.times, read.values)
        return signals.Tabulated.from_csv(path, self.time_column, self.value_column)


#: Load-signal kinds by case-file name ("constant" is written as a plain number).
SIGNALS: Mapping[str, type[SignalSpec]] = {
    "constant": ConstantSignal,
    "half_sine": HalfSineSignal,
    "ramp_step": RampStepSignal,
    "csv": CsvSignal,
}

AnySignal = tagged_union(SIGNALS, "signal kind", number_tag="constant")
