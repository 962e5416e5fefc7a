"""Record files read as hostile input: regular files only, nothing read from outside the file named, bounded before allocation.

:mod:`femref.sensing.recordings` reads a recorder's columns through :func:`read_columns`, which keeps to the rules of
docs/design.md §3.7, each refusal a :class:`RecordError` naming the file, the column or dataset and the rule: regular
files only (:func:`femref.core.files.regular_file`); nothing read from outside the file the case names
(:func:`femref.sensing.hdf5_checks.check_plain_dataset`; soft links inside it followed, at most :data:`MAX_SOFT_LINKS`
in a row); sizes bounded before allocation (:data:`MAX_RECORD_BYTES` by ``stat``, :data:`MAX_RECORD_SAMPLES`,
:data:`MAX_RECORD_VALUES`: an HDF5 dataset's shape is checked before a byte of it is read, a CSV file is read no
further than one row past the limit); a CSV column read by a name the header gives twice is refused.

A CSV file is parsed by numpy's C reader (``numpy.loadtxt``, only the columns read, a chunk of
lines at a time) into one array allocated for the file's line count, so reading holds the columns
and one chunk; a file numpy cannot take (an empty cell, which is a gap, a short row, a text cell,
a bad quote) is read again row by row with Python's ``csv``, which finds the first bad cell or row
for the message.
"""

from __future__ import annotations

import csv
import itertools
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

from femref.core.files import NotRegularFile, regular_file
from femref.sensing.hdf5_checks import HDF5ObjectError, check_plain_dataset

__all__ = ["HDF5_SUFFIXES", "MAX_RECORD_BYTES", "MAX_RECORD_SAMPLES", "MAX_RECORD_VALUES", "MAX_SOFT_LINKS", "RecordError", "SampleLimit",
           "read_columns"]

HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")
"""File name endings read as HDF5; any other file is CSV."""
MAX_RECORD_BYTES = 2**30
"""Largest CSV record file (bytes, 1 GiB), by ``stat`` before it is opened. Two hours at 1 kHz of a recorder's
time and five channels written with 12 digits is about 0.6 GB."""
MAX_RECORD_SAMPLES = 2**24
"""Most samples per channel of one file (1.68e7): 4.7 h at 1 kHz, 5.6 min at the highest rate allowed (50 kHz,
:data:`femref.sensing.recordings.MAX_RECORD_RATE`); a recorder's stream is cut into files shorter than a shift."""
MAX_RECORD_VALUES = 2**26
"""Most values (samples × (channels + the time column)) of all record files read together, a case's (6.7e7, 512 MiB as
floats). Two recorders, five channels, two hours at 1 kHz hold 5.0e7."""
CSV_CHUNK_ROWS = 1 << 18
"""Lines of a CSV file parsed by numpy at a time (about 10 MB of text)."""
MAX_SOFT_LINKS = 16
"""Most soft links followed in a row to reach a dataset (HDF5's own default); more is a loop."""
class RecordError(ValueError):
    """A record file that cannot be read as declared: the message names the file, channel and rule."""


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


Request = tuple[str | int | None, str]
"""``(column or dataset, what)``: a column to read and how messages name it (``channel hammer/front``, ``time``)."""


def read_columns(path: Path, requests: Sequence[Request], limit: SampleLimit) -> list[NDArray[np.float64]]:
    """Each requested column of the record file at ``path`` as floats (module docstring); no two of the arrays share
    memory (a column requested twice is copied), so the caller may scale them in place."""
    name = path.name
    try:
        status = regular_file(path)
    except FileNotFoundError:
        raise RecordError(f"{name}: file not found ({path})") from None
    except NotRegularFile as error:
        raise RecordError(f"{name}: {error} ({path}); a record is read only from a regular file") from None
    except OSError as error:
        raise RecordError(f"{name}: cannot read the file: {error.strerror or error}") from None
    if path.suffix.lower() in HDF5_SUFFIXES:
        return _hdf5_columns(path, requests, limit)
    if status.st_size > MAX_RECORD_BYTES:
        raise RecordError(f"{name}: the file holds {status.st_size / 2**20:.4g} MiB; a CSV record file may hold at most "
                          f"{MAX_RECORD_BYTES // 2**20} MiB: cut the stream into shorter files")
    return _csv_columns(path, requests, limit)


def _csv_columns(path: Path, requests: Sequence[Request], limit: SampleLimit) -> list[NDArray[np.float64]]:
    """Columns of a CSV file with a header row (an empty cell or ``nan`` is NaN), by header name or 0-based index."""
    name = path.name
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = csv.reader(handle, strict=True)
            header = next((row for row in rows if row), None)
            header_lines = rows.line_num
    except csv.Error as error:
        raise RecordError(f"{name}: the header row is not valid CSV ({error})") from None
    except (OSError, UnicodeDecodeError) as error:
        raise RecordError(f"{name}: cannot read the file: {error}") from None
    if header is None:
        raise RecordError(f"{name}: needs a header row and at least two rows of samples, has 0 row(s)")
    header = [cell.strip() for cell in header]
    indices = [_column_index(name, header, column, what) for column, what in requests]
    used = sorted(set(indices))
    labels = {index: f"{what} (column {header[index]!r})" for index, (_, what) in reversed(list(zip(indices, requests)))}
    try:
        block, count = _csv_blocks(path, header_lines, used, limit)
    except ValueError:  # an empty cell (a gap), a short row, a text cell, a bad quote: read row by row
        block, count = _csv_rows(path, header_lines, used, labels, limit)
    except (OSError, UnicodeDecodeError) as error:
        raise RecordError(f"{name}: cannot read the file: {error}") from None
    if count < 2:
        raise RecordError(f"{name}: needs a header row and at least two rows of samples, has {count + 1} row(s)")
    if count > limit.samples:
        raise RecordError(f"{name}: holds more than {_count(limit.samples)} rows of samples; {limit.rule}")
    columns = []
    for k, index in enumerate(indices):  # a column read twice is copied: each request's array is its own
        column = block[used.index(index), :count]
        columns.append(column.copy() if index in indices[:k] else column)
    return columns


def _csv_blocks(path: Path, header_lines: int, used: list[int], limit: SampleLimit) -> tuple[NDArray[np.float64], int]:
    """``(block, rows)``: the ``used`` columns as the rows of one array (each column contiguous, so a channel is a view of
    it), parsed :data:`CSV_CHUNK_ROWS` lines at a time by ``numpy.loadtxt``. The array is allocated once for the
    file's line count (at most ``limit`` + 1 rows; grown only if a line count underestimates, as lone ``\\r`` line ends
    do), so the peak is the columns read and one chunk. ValueError from numpy for anything it cannot parse."""
    capacity = min(max(_line_count(path) - header_lines, 0), limit.samples + 1)
    block = np.empty((len(used), capacity))
    count = 0
    with path.open(newline="", encoding="utf-8") as handle:
        for _ in range(header_lines):
            next(handle)
        while count <= limit.samples:
            lines = list(itertools.islice(handle, CSV_CHUNK_ROWS))
            if not lines:
                break
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a chunk of blank lines only ("input contained no data")
                chunk = np.loadtxt(lines, delimiter=",", quotechar='"', comments=None, usecols=used, ndmin=2)
            rows = min(chunk.shape[0], limit.samples + 1 - count)
            if count + rows > block.shape[1]:
                block = _grown(block, count, min(max(2 * block.shape[1], count + rows), limit.samples + 1))
            block[:, count : count + rows] = chunk[:rows].T
            count += rows
    return block, count


def _line_count(path: Path) -> int:
    """Line ends (``\\n``) in the file, plus one for a last line without one: counted in 16 MiB reads, nothing kept."""
    lines, last = 0, b"\n"
    with path.open("rb") as handle:
        while data := handle.read(1 << 24):
            lines += data.count(b"\n")
            last = data[-1:]
    return lines + (last != b"\n")


def _grown(block: NDArray[np.float64], count: int, capacity: int) -> NDArray[np.float64]:
    """``block`` with room for ``capacity`` rows per column, its first ``count`` kept."""
    grown = np.empty((block.shape[0], capacity))
    grown[:, :count] = block[:, :count]
    return grown


def _column_index(name: str, header: list[str], column: str | int | None, what: str) -> int:
    if isinstance(column, int):
        if not 0 <= column < len(header):
            raise RecordError(f"{name}: {what} (column {column}): no such column; the file has {len(header)} columns")
        return column
    if column not in header:
        raise RecordError(f"{name}: {what} (column {column!r}): no such column (columns: {', '.join(header)})")
    places = [k for k, cell in enumerate(header) if cell == column]
    if len(places) > 1:
        raise RecordError(f"{name}: {what} (column {column!r}): the header names {len(places)} columns {column!r} "
                          f"(0-based columns {', '.join(map(str, places))}); name each column once, or give the column by its index")
    return places[0]


def _csv_rows(path: Path, header_lines: int, used: list[int], labels: dict[int, str], limit: SampleLimit) -> tuple[NDArray[np.float64], int]:
    """``(block, rows)`` as :func:`_csv_blocks`, row by row with Python's ``csv`` into an array grown by doubling up to
    ``limit`` + 1 rows: a short row's missing cells and empty cells are NaN; the first cell that is not a number, or a
    row that is not CSV (a quote never closed), is a :class:`RecordError` naming its row (the header is row 1; blank
    lines do not count)."""
    name = path.name
    block = np.empty((len(used), min(1024, limit.samples + 1)))
    count = 0
    with path.open(newline="", encoding="utf-8") as handle:
        rows = csv.reader(handle, strict=True)
        for _ in range(header_lines):
            next(handle)
        while count <= limit.samples:
            try:
                row = next(rows)
            except StopIteration:
                break
            except csv.Error as error:
                raise RecordError(f"{name}: row {count + 2} is not valid CSV ({error}); check its quotes") from None
            except UnicodeDecodeError as error:
                raise RecordError(f"{name}: cannot read the file: {error}") from None
            if not row:
                continue
            if count == block.shape[1]:
                block = _grown(block, count, min(2 * count, limit.samples + 1))
            for j, index in enumerate(used):
                block[j, count] = _cell(name, labels[index], row, index, count + 2)
            count += 1
    return block, count


def _cell(name: str, label: str, row: list[str], index: int, row_number: int) -> float:
    cell = row[index].strip() if index < len(row) else ""
    if cell == "" or cell.lower() == "nan":
        return math.nan
    try:
        return float(cell)
    except ValueError:
        raise RecordError(f"{name}: {label}: row {row_number} is not a number ({cell!r})") from None


def _hdf5_columns(path: Path, requests: Sequence[Request], limit: SampleLimit) -> list[NDArray[np.float64]]:
    """One-dimensional datasets of an HDF5 file, as floats, each checked before it is read (module docstring)."""
    name = path.name
    try:
        h5 = h5py.File(path, "r")
    except OSError as error:
        raise RecordError(f"{name}: cannot read the file as HDF5: {error}") from None
    with h5:
        datasets = [_checked_dataset(h5, name, dataset, what, limit) for dataset, what in requests]
        columns = []
        for dataset, (key, what) in zip(datasets, requests):
            try:
                columns.append(np.asarray(dataset[()], dtype=float).reshape(-1))
            except (OSError, ValueError, TypeError) as error:
                raise RecordError(f"{name}: {what} (dataset {key!r}): cannot read the dataset: {error}") from None
        return columns


def _checked_dataset(h5: h5py.File, name: str, key: str | int | None, what: str, limit: SampleLimit) -> h5py.Dataset:
    """The dataset at ``key``, its links resolved inside the file, its storage, type, shape and chunks checked, unread."""
    label = f"{name}: {what} (dataset {key!r})"
    dataset = _resolve(h5, key, label) if isinstance(key, str) else None
    if not isinstance(dataset, h5py.Dataset):
        raise RecordError(f"{label}: no such dataset")
    try:
        check_plain_dataset(dataset, max_values=math.prod(dataset.shape or ()), kinds="biuf")
    except HDF5ObjectError as error:
        raise RecordError(f"{label}: {error}") from None
    shape = dataset.shape if dataset.shape is not None else ()
    extent = tuple(n for n in shape if n != 1)
    if len(shape) == 0 or len(extent) > 1:
        raise RecordError(f"{label}: must be one-dimensional, has shape {extent if len(shape) else shape}")
    if dataset.size > limit.samples:
        raise RecordError(f"{label}: holds {_count(dataset.size)} samples; {limit.rule}")
    return dataset


def _resolve(h5: h5py.File, key: str, label: str) -> object | None:
    """The object at path ``key`` in ``h5`` (None when there is none), each link looked at before it is followed:
    an external link is refused, soft links are followed inside the file, at most :data:`MAX_SOFT_LINKS` in a row."""
    parts = [part for part in key.split("/") if part not in ("", ".")]
    done: list[str] = []
    node: object = h5
    hops = 0
    while parts:
        part = parts.pop(0)
        if not isinstance(node, h5py.Group):
            return None
        link = node.get(part, getlink=True)
        if link is None:
            return None
        if isinstance(link, h5py.ExternalLink):
            raise RecordError(f"{label}: /{'/'.join([*done, part])} is an external link to {link.filename}:{link.path}; "
                              "a record is read only from the file the case names")
        if isinstance(link, h5py.SoftLink):
            hops += 1
            if hops > MAX_SOFT_LINKS:
                raise RecordError(f"{label}: more than {MAX_SOFT_LINKS} soft links in a row (a loop of soft links: /{'/'.join([*done, part])} → {link.path})")
            target = [p for p in link.path.split("/") if p not in ("", ".")]
            parts = (target if link.path.startswith("/") else [*done, *target]) + parts
            done, node = [], h5
            continue
        if not isinstance(link, h5py.HardLink):
            raise RecordError(f"{label}: /{'/'.join([*done, part])} is a link of a kind this reader does not follow")
        node = node[part]
        done.append(part)
    return node
