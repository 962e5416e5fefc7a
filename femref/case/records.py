"""A measured case's recorders (``records``): each one's file or files, format, time source, clock and channels.

Checked here as keys; :meth:`femref.case.measured.MeasuredCase` probes the files the keys name
(:func:`femref.sensing.recordings.probe_recorder`). :meth:`RecordFileSpec.source` is the recorder as
:mod:`femref.sensing.recordings` reads it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import AfterValidator, Field, PrivateAttr, ValidationInfo, field_validator, model_serializer, model_validator
from pydantic_core import PydanticCustomError

from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.fields import CaseModel, PositiveReal, Real, name_rule, resolve_case_path
from femref.sensing import recordings
from femref.sensing.record_files import format_of

__all__ = ["AntiAliasSpec", "ChannelName", "ChannelSpec", "RecordFileSpec", "SOURCE_KEYS", "TimeSpec"]


def _unit_rule(units: dict[str, float], what: str):
    def rule(unit: str) -> str:
        if unit not in units:
            raise problems_error([Problem((), f"unknown {what} unit{did_you_mean(unit, list(units))}; units: {', '.join(units)}", unit)])
        return unit

    return rule


AccelerationUnit = Annotated[str, AfterValidator(_unit_rule(recordings.ACCELERATION_UNITS, "acceleration"))]
TimeUnit = Annotated[str, AfterValidator(_unit_rule(recordings.TIME_UNITS, "time"))]
Column = int | str


def _channel_name(name: str) -> str:
    car, _, sensor = name.partition("/")
    if not sensor or "/" in sensor:
        raise PydanticCustomError("channel_name", "channels are named <car>/<sensor>")
    name_rule("car")(car)
    name_rule("sensor")(sensor)
    return name


ChannelName = Annotated[str, AfterValidator(_channel_name)]


class _FormatKeys(CaseModel):
    """A model whose ``format_keys`` (the keys of record formats beyond CSV and HDF5) are written out only when they
    differ from their defaults: the resolved case of a CSV or HDF5 record reads as it did before those formats."""

    format_keys: ClassVar[tuple[str, ...]] = ()

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Any) -> Any:
        data = handler(self)
        return {key: value for key, value in data.items() if key not in self.format_keys or getattr(self, key) != type(self).model_fields[key].default}


SOURCE_KEYS = "column (CSV), dataset (HDF5), channel (MDF4 channel name, TDMS group/channel, UFF58 record id1)"


class ChannelSpec(_FormatKeys):
    """Where one probe's acceleration is in its file: a CSV ``column`` (header name or 0-based index), an
    HDF5 ``dataset`` (path) or an MDF4, TDMS or UFF58 ``channel``, and its unit."""

    format_keys: ClassVar[tuple[str, ...]] = ("channel",)

    column: Column | None = Field(default=None, description="CSV column: header name or 0-based index. Exactly one of column, dataset, channel.")
    dataset: str | None = Field(default=None, description="HDF5 dataset path. Exactly one of column, dataset, channel.")
    channel: str | None = Field(default=None, description="MDF4 channel name, TDMS group/channel or UFF58 record id1. "
                                                          "Exactly one of column, dataset, channel.")
    unit: AccelerationUnit | None = Field(default=None, description=f"Unit of the values: {', '.join(recordings.ACCELERATION_UNITS)}. "
                                                                      "Default: the file's own (MDF4, TDMS, UFF58), which a declared unit must equal; "
                                                                      "required when the file gives none.")

    @model_validator(mode="after")
    def _one_source(self) -> "ChannelSpec":
        if sum(getattr(self, key) is not None for key in ("column", "dataset", "channel")) != 1:
            raise problems_error([Problem((), f"give exactly one of {SOURCE_KEYS}")])
        return self


class TimeSpec(_FormatKeys):
    """A file's sample times: a column, dataset or channel with its unit, or a uniform ``rate`` from ``start``."""

    format_keys: ClassVar[tuple[str, ...]] = ("channel",)

    column: Column | None = Field(default=None, description="CSV time column: header name or 0-based index.")
    dataset: str | None = Field(default=None, description="HDF5 time dataset path.")
    channel: str | None = Field(default=None, description="MDF4 time (master) channel, TDMS group/channel or UFF58 record holding the times.")
    unit: TimeUnit = Field(default="s", description=f"Unit of the times: {', '.join(recordings.TIME_UNITS)} (iso8601: a CSV column of "
                                                   "ISO-8601 timestamps, in s from the first); a unit the file gives must equal it. Default s.")
    rate: Annotated[PositiveReal, Field(le=recordings.MAX_RECORD_RATE)] | None = Field(
        default=None, description=f"Sampling rate (Hz) of a file without a time column, at most {recordings.MAX_RECORD_RATE:g}."
    )
    start: Real = Field(default=0.0, description="Time of the first sample (s) with a rate. Default 0.")

    @model_validator(mode="after")
    def _one_source(self) -> "TimeSpec":
        sources = [key for key in ("column", "dataset", "channel", "rate") if getattr(self, key) is not None]
        if len(sources) != 1:
            raise problems_error([Problem((), f"give exactly one of {SOURCE_KEYS} or rate (Hz, with start)", sources or None)])
        return self


class AntiAliasSpec(CaseModel):
    """The recorder's analogue anti-alias low-pass, applied to every channel of its file before sampling."""

    corner: PositiveReal = Field(description="Corner frequency (Hz), below the file's Nyquist frequency (rate/2). Required.")
    order: Annotated[int, Field(ge=1, le=8)] = Field(default=4, description="Butterworth order, 1–8. Default 4.")


class RecordFileSpec(_FormatKeys):
    """One recorder: its file or files, format, time source, clock (offset, drift), channels and anti-alias filter."""

    format_keys: ClassVar[tuple[str, ...]] = ("format", "separator", "decimal", "file", "files", "recorder", "clock_drift")

    recorder: str | None = Field(default=None, description="The recorder's name, unique. Default: its first file's stem.")
    file: Path | None = Field(default=None, description="CSV or TSV (header row), HDF5 (.h5, .hdf5), MDF4 (.mf4, .mdf), TDMS (.tdms) or UFF58 "
                                                        "(.uff, .unv) file, relative to the case file's directory. Exactly one of file, files.")
    files: tuple[Path, ...] | None = Field(default=None, description="The recorder's files (paths or globs, relative to the case file's directory), "
                                                                     "each glob's matches sorted by name, read in that order as one stream. "
                                                                     "Exactly one of file, files.")
    format: Literal["csv", "hdf5", "mdf4", "tdms", "uff58"] | None = Field(
        default=None, description="The file's format. Default: by its suffix (above; any other is csv). MDF4, TDMS and UFF58 need femref[formats].")
    separator: Literal[",", ";", "\t"] | None = Field(default=None, description="CSV separator. Default: a tab if the header line holds one, "
                                                                                "else ; if it holds one, else ,.")
    decimal: Literal[".", ","] = Field(default=".", description="CSV decimal mark (',' needs a separator other than ','). Default '.'.")
    time: TimeSpec = Field(description="Sample times: {column | dataset | channel, unit} or {rate, start}. Required.")
    clock_offset: Real = Field(default=0.0, description="Added to this recorder's times (s): recorders' clocks differ. Default 0.")
    clock_drift: Real | Literal["estimate"] = Field(
        default=0.0, description="The recorder's clock drift: ppm (its clock gains this many µs a second from its first sample; removed), or "
                                 "estimate: mapped onto the first recorder's clock by offset and drift fitted to the lags of the impacts both "
                                 "recorded (not for the first recorder, the reference). Default 0.")
    channels: dict[ChannelName, ChannelSpec] = Field(description="<car>/<sensor>: {column | dataset | channel, unit}; at least one. Required.")
    anti_alias: AntiAliasSpec | None = Field(
        default=None,
        description="The recorder's Butterworth low-pass {corner (Hz), order}: kalman models it, networks need it. Default null: not declared.",
    )

    _probed_rate: float | None = PrivateAttr(default=None)  # the rate validation found (MeasuredCase._record_problems)

    @field_validator("file", mode="after")
    @classmethod
    def _resolve(cls, path: Path | None, info: ValidationInfo) -> Path | None:
        return None if path is None else resolve_case_path(path, info)

    @field_validator("files", mode="after")
    @classmethod
    def _expand(cls, patterns: tuple[Path, ...] | None, info: ValidationInfo) -> tuple[Path, ...] | None:
        if patterns is None:
            return None
        if not patterns:
            raise problems_error([Problem((), "name at least one file (a path or a glob)")])
        base = resolve_case_path(Path("."), info)
        problems, found = [], []
        for k, pattern in enumerate(patterns):
            matches = recordings.expand_files([str(pattern)], base)
            if not matches:
                problems.append(Problem((k,), f"the glob matches no file in {base}", str(pattern)))
            found += [path.resolve() for path in matches]
        repeated = sorted({path.name for path in found if found.count(path) > 1})
        if repeated:
            problems.append(Problem((), f"names the same file twice: {', '.join(repeated)}"))
        if problems:
            raise problems_error(problems)
        return tuple(found)

    @field_validator("channels", mode="after")
    @classmethod
    def _some_channels(cls, channels: dict[str, ChannelSpec]) -> dict[str, ChannelSpec]:
        if not channels:
            raise problems_error([Problem((), "name at least one channel <car>/<sensor>: {column | dataset | channel, unit}")])
        return channels

    @model_validator(mode="after")
    def _csv_options(self) -> "RecordFileSpec":
        if (self.file is None) == (self.files is None):
            raise problems_error([Problem(("file",), "give exactly one of file (one file) and files (a recorder's sequence of files)")])
        if self.decimal == "," and self.separator == ",":
            raise problems_error([Problem(("decimal",), "a decimal comma needs a separator other than ',' (';' or a tab)", ",")])
        first = self.paths[0]
        if format_of(first, self.format) != "csv":
            for key in ("separator", "decimal"):
                if key in self.model_fields_set:
                    raise problems_error([Problem((key,), f"is a CSV option; {first.name} is read as {format_of(first, self.format).upper()}")])
        return self

    @property
    def paths(self) -> tuple[Path, ...]:
        """The recorder's files in the order they are read."""
        return self.files if self.files is not None else (self.file,)  # type: ignore[return-value]

    def source(self) -> recordings.RecordFile:
        """The recorder as :mod:`femref.sensing.recordings` reads it."""
        time = self.time
        return recordings.RecordFile(
            path=self.paths[0],
            time=recordings.TimeSource(column=time.column, dataset=time.dataset, unit=time.unit, rate=time.rate, start=time.start, channel=time.channel),
            clock_offset=self.clock_offset,
            channels=tuple(
                recordings.ChannelSource(probe=probe, column=channel.column, dataset=channel.dataset, unit=channel.unit, channel=channel.channel)
                for probe, channel in self.channels.items()
            ),
            anti_alias=None if self.anti_alias is None else recordings.AntiAlias(self.anti_alias.corner, self.anti_alias.order),
            format=self.format,
            separator=self.separator,
            decimal=self.decimal,
            files=self.files or (),
            recorder=self.recorder or "",
            clock_drift=self.clock_drift,
            probed_rate=self._probed_rate,
        )
