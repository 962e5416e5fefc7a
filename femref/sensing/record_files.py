"""Record files read as hostile input: regular files only, nothing read from outside the file named, bounded before allocation.

:mod:`femref.sensing.recordings` reads a recorder's columns through :func:`open_columns`, which keeps to the rules of
docs/design.md §3.7, each refusal a :class:`RecordError` naming the file, the column, channel or dataset and the rule:
regular files only (:func:`femref.core.files.regular_file`); nothing read from outside the file the case names (each
reader of :mod:`femref.sensing.formats`, chosen by :func:`open_reader`, opens that file alone); every format read chunk
by chunk (:data:`CHUNK_SAMPLES`), so memory is bounded by the chunk whatever the file's length. A reader that must hold
a whole file or column (pyuff for UFF58; an (n, 1) HDF5 dataset) is bounded before allocation: :data:`MAX_RECORD_BYTES`
by ``stat``, :data:`MAX_RECORD_SAMPLES` on the sample count its headers give. :func:`read_columns` joins a file's
chunks into arrays within a :class:`SampleLimit` (a file read whole).
"""

from __future__ import annotations

import contextlib
import importlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.core.files import NotRegularFile, regular_file
from femref.sensing.formats.base import ColumnInfo, RecordError, RecordReader, Request
from femref.sensing.formats.hdf5 import MAX_SOFT_LINKS

__all__ = ["CHUNK_SAMPLES", "FORMATS", "MAX_RECORD_BYTES", "MAX_RECORD_SAMPLES", "MAX_SOFT_LINKS", "SUFFIXES", "WHOLE_FILE_FORMATS", "ColumnInfo",
           "RecordError", "RecordReader", "Request", "SampleLimit", "format_of", "key_of", "open_columns", "open_reader", "read_columns"]

MAX_RECORD_BYTES = 2**30
"""Largest record file (bytes, 1 GiB, by ``stat`` before it is opened) of a format whose reader holds the whole file
(:data:`WHOLE_FILE_FORMATS`: pyuff parses a UFF58 file whole). Streamed formats have no byte bound: memory follows the chunk."""
MAX_RECORD_SAMPLES = 2**24
"""Most samples of a column held whole (1.68e7; 4.7 h at 1 kHz, 128 MiB as floats): a UFF58 record, an (n, 1) HDF5
dataset, a file read whole by :func:`read_columns`. A streamed column has no sample bound."""
CHUNK_SAMPLES = 1 << 18
"""Samples per column read at a time (a CSV chunk is about 10 MB of text)."""
WHOLE_FILE_FORMATS = ("uff58",)
"""Formats whose reader holds the whole file (pyuff reads a UFF58 file into memory to find its records)."""


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
    """The most samples per column a file read whole may hold (``samples``) and the rule that sets it (``rule``, for messages)."""

    samples: int
    rule: str

    @classmethod
    def whole(cls) -> SampleLimit:
        """:data:`MAX_RECORD_SAMPLES`, the bound of a column held whole."""
        return cls(MAX_RECORD_SAMPLES, f"a column held whole holds at most {_count(MAX_RECORD_SAMPLES)} samples ({MAX_RECORD_SAMPLES / 3.6e6:.2g} h at 1 kHz)")


def _count(n: int) -> str:
    """``1000`` as ``1000``, ``16777216`` as ``1.68e7``."""
    if n < 100_000:
        return str(n)
    mantissa, _, exponent = f"{n:.3g}".partition("e")
    return f"{mantissa}e{int(exponent)}"


@contextlib.contextmanager
def open_columns(path: Path, requests: Sequence[Request], fmt: str = "csv", options: dict[str, Any] | None = None, size: int = CHUNK_SAMPLES
                 ) -> Iterator[tuple[RecordReader, list[ColumnInfo], Iterator[list[NDArray[np.float64]]]]]:
    """``(reader, infos, chunks)`` of the ``fmt`` record file at ``path`` (module docstring): the columns selected with
    their units and sample counts from the file's headers, and an iterator over their chunks (``size`` samples each)
    that checks, once exhausted, that a file's headers told
    its sample counts true."""
    name = path.name
    try:
        status = regular_file(path)
    except FileNotFoundError:
        raise RecordError(f"{name}: file not found ({path})") from None
    except NotRegularFile as error:
        raise RecordError(f"{name}: {error} ({path}); a record is read only from a regular file") from None
    except OSError as error:
        raise RecordError(f"{name}: cannot read the file: {error.strerror or error}") from None
    if fmt in WHOLE_FILE_FORMATS and status.st_size > MAX_RECORD_BYTES:
        raise RecordError(f"{name}: the file holds {status.st_size / 2**20:.4g} MiB; a {fmt.upper()} record file, read whole, may hold at most "
                          f"{MAX_RECORD_BYTES // 2**20} MiB: cut the stream into shorter files")
    with open_reader(path, fmt, options or {}) as reader:
        infos = reader.select(requests)
        for info in infos:
            if (info.whole or fmt in WHOLE_FILE_FORMATS) and info.exact and info.samples > MAX_RECORD_SAMPLES:
                raise RecordError(f"{info.label}: holds {_count(info.samples)} samples; {SampleLimit.whole().rule}")

        def chunks() -> Iterator[list[NDArray[np.float64]]]:
            counts = [0] * len(infos)
            for chunk in reader.chunks(size):
                for k, part in enumerate(chunk):
                    counts[k] += part.size
                yield [np.asarray(part, dtype=float) for part in chunk]
            for info, count in zip(infos, counts):
                if info.exact and count != info.samples:
                    raise RecordError(f"{info.label}: the file's headers give {info.samples} samples, its data {count}: the file is truncated or corrupt")

        yield reader, infos, chunks()


def read_columns(path: Path, requests: Sequence[Request], limit: SampleLimit, fmt: str = "csv", options: dict[str, Any] | None = None
                 ) -> tuple[list[NDArray[np.float64]], list[str | None]]:
    """``(columns, units)``: each requested column of the ``fmt`` record file at ``path`` read whole, as floats, and
    its unit as the file declares it (None: it does not), within ``limit`` (checked on the headers' sample counts
    before a sample is read; a text file is read no further than one row past it)."""
    with open_columns(path, requests, fmt, options) as (_, infos, chunks):
        for info in infos:
            if info.exact and info.samples > limit.samples:
                raise RecordError(f"{info.label}: holds {_count(info.samples)} samples; {limit.rule}")
        parts: list[list[NDArray[np.float64]]] = [[] for _ in infos]
        counts = [0] * len(infos)
        for chunk in chunks:
            for k, part in enumerate(chunk):
                parts[k].append(part)
                counts[k] += part.size
            if max(counts, default=0) > limit.samples:
                raise RecordError(f"{path.name}: holds more than {_count(limit.samples)} rows of samples; {limit.rule}")
    return [np.concatenate(p) if p else np.empty(0) for p in parts], [info.unit for info in infos]
