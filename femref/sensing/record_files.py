"""Record files read as hostile input: regular files only, nothing read from outside the file named, bounded before allocation.

:mod:`femref.sensing.recordings` reads a recorder's columns through :func:`read_columns`, which keeps to the rules of
docs/design.md §3.7, each refusal a :class:`RecordError` naming the file, the column, channel or dataset and the rule:
regular files only (:func:`femref.core.files.regular_file`); nothing read from outside the file the case names (each
reader of :mod:`femref.sensing.formats`, chosen by :func:`open_reader`, opens that file alone); sizes bounded before allocation (:data:`MAX_RECORD_BYTES`
by ``stat`` for text files, :data:`MAX_RECORD_SAMPLES`, :data:`MAX_RECORD_VALUES`: the sample counts a file's headers
give are checked before a sample is read; a text file, whose line count bounds its samples, is read no further than one
row past the limit). Every format is read chunk by chunk (:data:`CHUNK_SAMPLES`) into one array per column.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.core.files import NotRegularFile, regular_file
from femref.sensing.formats.base import ColumnInfo, RecordError, RecordReader, Request
from femref.sensing.formats.hdf5 import MAX_SOFT_LINKS

__all__ = ["CHUNK_SAMPLES", "FORMATS", "MAX_RECORD_BYTES", "MAX_RECORD_SAMPLES", "MAX_RECORD_VALUES", "MAX_SOFT_LINKS", "SUFFIXES", "ColumnInfo",
           "RecordError", "RecordReader", "Request", "SampleLimit", "format_of", "key_of", "open_reader", "read_columns"]

MAX_RECORD_BYTES = 2**30
"""Largest text (CSV, UFF58) record file (bytes, 1 GiB), by ``stat`` before it is opened. Two hours at 1 kHz of a
recorder's time and five channels written with 12 digits is about 0.6 GB."""
MAX_RECORD_SAMPLES = 2**24
"""Most samples per channel of one file (1.68e7): 4.7 h at 1 kHz, 5.6 min at the highest rate allowed (50 kHz,
:data:`femref.sensing.recordings.MAX_RECORD_RATE`); a recorder's stream is cut into files shorter than a shift."""
MAX_RECORD_VALUES = 2**26
"""Most values (samples × (channels + the time column)) of all record files read together, a case's (6.7e7, 512 MiB as
floats). Two recorders, five channels, two hours at 1 kHz hold 5.0e7."""
CHUNK_SAMPLES = 1 << 18
"""Samples per column read at a time (a CSV chunk is about 10 MB of text)."""


FORMATS: dict[str, tuple[str, str, str | None]] = {
    "csv": ("delimited", "column", None),
    "hdf5": ("hdf5", "dataset", None),
    "mdf4": ("mdf4", "channel", "asammdf"),
    "tdms": ("tdms", "channel", "nptdms"),
    "uff58": ("uff58", "channel", "pyuff"),
}
"""Format → (its module here, the case key naming a column of it, the package of the ``formats`` extra it needs)."""
SUFFIXES = {".csv": "csv", ".tsv": "csv", ".txt": "csv", ".h5": "hdf5", ".hdf5": "hdf5", ".hdf": "hdf5", ".mf4": "mdf4", ".mdf": "mdf4",
            ".tdms": "tdms", ".uff": "uff58", ".unv": "uff58"}
"""File name endings and the format each means; any other file is CSV unless its ``format:`` is declared."""


def format_of(path: Path, declared: str | None = None) -> str:
    """The format of the file at ``path``: ``declared``, else by suffix (:data:`SUFFIXES`), else ``csv``."""
    return declared or SUFFIXES.get(path.suffix.lower(), "csv")


def key_of(fmt: str) -> str:
    """The case key (``column``, ``dataset``, ``channel``) naming a column of a ``fmt`` file."""
    return FORMATS[fmt][1]


def open_reader(path: Path, fmt: str, options: dict[str, Any]) -> RecordReader:
    """The reader of ``fmt`` on the regular file at ``path``, opened with the format's ``options`` (CSV: separator, decimal)."""
    module, _, package = FORMATS[fmt]
    if package is not None:
        try:
            importlib.import_module(package)
        except ImportError:
            raise RecordError(f"{path.name}: reading {fmt.upper()} files needs the package {package}: "
                              "pip install 'femref[formats]'") from None
    reader: RecordReader = importlib.import_module(f"femref.sensing.formats.{module}").Reader(path, **options)
    return reader


@dataclass(frozen=True)
class SampleLimit:
    """The most samples per column a file may hold (``samples``) and the rule that sets it (``rule``, for messages)."""

    samples: int
    rule: str

    @classmethod
    def for_file(cls, columns: int, values_left: int) -> SampleLimit:
        """The limit of a file of ``columns`` columns (time and channels) when ``values_left`` of
        :data:`MAX_RECORD_VALUES` remain for it: :data:`MAX_RECORD_SAMPLES`, or less when the values run out first."""
        per_file = f"a record file holds at most {_count(MAX_RECORD_SAMPLES)} samples per channel ({MAX_RECORD_SAMPLES / 3.6e6:.2g} h at 1 kHz)"
        if values_left // columns >= MAX_RECORD_SAMPLES:
            return cls(MAX_RECORD_SAMPLES, per_file)
        share = max(values_left, 0) // columns
        rule = (f"the record files of a case hold at most {_count(MAX_RECORD_VALUES)} values in all, time columns included "
                f"({MAX_RECORD_VALUES * 8 / 2**20:.3g} MiB as floats); {_count(max(values_left, 0))} are left for this file's {columns} columns, "
                f"{_count(share)} samples each")
        return cls(share, rule)


def _count(n: int) -> str:
    """``1000`` as ``1000``, ``16777216`` as ``1.68e7``."""
    if n < 100_000:
        return str(n)
    mantissa, _, exponent = f"{n:.3g}".partition("e")
    return f"{mantissa}e{int(exponent)}"


def read_columns(path: Path, requests: Sequence[Request], limit: SampleLimit, fmt: str = "csv", options: dict[str, Any] | None = None
                 ) -> tuple[list[NDArray[np.float64]], list[str | None]]:
    """``(columns, units)``: each requested column of the ``fmt`` record file at ``path`` as floats, and its unit as the
    file declares it (None: it does not), read through the format's reader (:mod:`femref.sensing.formats`) chunk by chunk
    into arrays allocated once for the sample counts its headers give, checked against ``limit`` first (module
    docstring). No two of the arrays share memory, so the caller may scale them in place."""
    name = path.name
    try:
        status = regular_file(path)
    except FileNotFoundError:
        raise RecordError(f"{name}: file not found ({path})") from None
    except NotRegularFile as error:
        raise RecordError(f"{name}: {error} ({path}); a record is read only from a regular file") from None
    except OSError as error:
        raise RecordError(f"{name}: cannot read the file: {error.strerror or error}") from None
    if fmt not in ("hdf5", "mdf4", "tdms") and status.st_size > MAX_RECORD_BYTES:
        raise RecordError(f"{name}: the file holds {status.st_size / 2**20:.4g} MiB; a {fmt.upper()} record file may hold at most "
                          f"{MAX_RECORD_BYTES // 2**20} MiB: cut the stream into shorter files")
    with open_reader(path, fmt, options or {}) as reader:
        infos = reader.select(requests)
        for info in infos:
            if info.exact and info.samples > limit.samples:
                raise RecordError(f"{info.label}: holds {_count(info.samples)} samples; {limit.rule}")
        columns = [np.empty(min(info.samples, limit.samples + 1)) for info in infos]
        counts = [0] * len(infos)
        for chunk in reader.chunks(CHUNK_SAMPLES):
            for k, part in enumerate(chunk):
                rows = min(part.size, limit.samples + 1 - counts[k])
                if counts[k] + rows > columns[k].size:  # a line count that underestimates (lone \r line ends)
                    columns[k] = _grown(columns[k], counts[k], min(max(2 * columns[k].size, counts[k] + rows), limit.samples + 1))
                columns[k][counts[k] : counts[k] + rows] = part[:rows]
                counts[k] += rows
            if max(counts, default=0) > limit.samples:
                raise RecordError(f"{name}: holds more than {_count(limit.samples)} rows of samples; {limit.rule}")
    for info, count in zip(infos, counts):
        if info.exact and count != info.samples:
            raise RecordError(f"{info.label}: the file's headers give {info.samples} samples, its data {count}: the file is truncated or corrupt")
    return [column[:count] for column, count in zip(columns, counts)], [info.unit for info in infos]


def _grown(column: NDArray[np.float64], count: int, capacity: int) -> NDArray[np.float64]:
    """``column`` with room for ``capacity`` samples, its first ``count`` kept."""
    grown = np.empty(capacity)
    grown[:count] = column[:count]
    return grown
