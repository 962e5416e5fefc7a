"""CSV and TSV record files: a header row, then one sample per row, read a chunk of lines at a time.

The separator is ``,``, ``;`` or a tab, declared or taken from the header line (a tab if it holds one, else ``;``
if it holds one, else ``,``); a UTF-8 byte-order mark is skipped; numbers may be quoted, and with ``decimal: ","``
written with a decimal comma. A chunk is parsed by numpy's C reader (``numpy.loadtxt``, only the columns read); one
numpy cannot take (an empty cell, which is a gap, a short row, a text cell, a bad quote) is read again row by row with
Python's ``csv``, which names the first bad cell or row. A time column of ISO-8601 timestamps (``timestamps``, the
column) is read row by row, each in seconds from the first sample (or from ``origin``, a recorder's first file's). A column read by a name the header gives twice
is refused.
"""

from __future__ import annotations

import csv
import itertools
import math
import warnings
from collections.abc import Iterator, Sequence
from datetime import datetime
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request

__all__ = ["SEPARATORS", "Reader"]

SEPARATORS = {",": "comma", ";": "semicolon", "\t": "tab"}
"""Separators a CSV file may use, and their names in a case."""


class Reader:
    """A CSV or TSV record file (module docstring); ``separator`` None: from the header line."""

    def __init__(self, path: Path, separator: str | None = None, decimal: str = ".", timestamps: str | int | None = None,
                 origin: datetime | None = None) -> None:
        self.path, self.name, self.decimal, self.timestamps = path, path.name, decimal, timestamps
        try:
            with path.open(newline="", encoding="utf-8-sig") as handle:
                first = next((line for line in handle if line.strip()), "")
                self.separator = separator or next((s for s in ("\t", ";") if s in first), ",")
                handle.seek(0)
                rows = csv.reader(handle, delimiter=self.separator, strict=True)
                header = next((row for row in rows if row), None)
                self.header_lines = rows.line_num
        except csv.Error as error:
            raise RecordError(f"{self.name}: the header row is not valid CSV ({error})") from None
        except (OSError, UnicodeDecodeError) as error:
            raise RecordError(f"{self.name}: cannot read the file: {error}") from None
        if header is None:
            raise RecordError(f"{self.name}: needs a header row and at least two rows of samples, has 0 row(s)")
        if decimal == "," and self.separator == ",":
            raise RecordError(f"{self.name}: the case declares a decimal comma, and the header line is separated by commas; "
                              "a file with decimal commas separates its cells by ; or a tab")
        self.header = [cell.strip() for cell in header]
        self.used: list[int] = []
        self.selection: list[int] = []
        self.labels: dict[int, str] = {}
        self.clock: int | None = None
        self.origin = origin  # the stamp timestamps count from (None: this file's first)

    def __enter__(self) -> Reader:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def select(self, requests: Sequence[Request]) -> list[ColumnInfo]:
        indices = [self._index(column, what) for column, what in requests]
        self.used = sorted(set(indices))
        self.labels = {index: f"{what} (column {self.header[index]!r})" for index, (_, what) in reversed(list(zip(indices, requests)))}
        self.clock = None if self.timestamps is None else self._index(self.timestamps, "time")
        self.selection = indices
        lines = max(_line_count(self.path) - self.header_lines, 0)
        return [ColumnInfo(None, lines, False, f"{self.name}: {self.labels[index]}") for index in indices]

    def chunks(self, size: int) -> Iterator[list[NDArray[np.float64]]]:
        """The selected columns, ``size`` lines at a time."""
        count = 0
        try:
            with self.path.open(newline="", encoding="utf-8-sig") as handle:
                for _ in range(self.header_lines):
                    next(handle)
                while lines := list(itertools.islice(handle, size)):
                    block = self._parsed(lines, count)
                    count += block.shape[1]
                    yield [block[self.used.index(index)] for index in self.selection]
        except (OSError, UnicodeDecodeError) as error:
            raise RecordError(f"{self.name}: cannot read the file: {error}") from None
        if count < 2:
            raise RecordError(f"{self.name}: needs a header row and at least two rows of samples, has {count + 1} row(s)")

    def _parsed(self, lines: list[str], before: int) -> NDArray[np.float64]:
        """The used columns of ``lines`` as the rows of one array (each column contiguous); ``before``: rows read already."""
        if self.clock not in self.used:
            if self.decimal == ",":
                lines = [line.replace(",", ".") for line in lines]
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", UserWarning)  # a chunk of blank lines only ("input contained no data")
                    return np.loadtxt(lines, delimiter=self.separator, quotechar='"', comments=None, usecols=self.used, ndmin=2).T
            except ValueError:
                pass
        rows = []
        try:
            for row in csv.reader(lines, delimiter=self.separator, strict=True):
                if row:
                    rows.append([self._cell(row, index, before + len(rows) + 2) for index in self.used])
        except csv.Error as error:
            raise RecordError(f"{self.name}: row {before + len(rows) + 2} is not valid CSV ({error}); check its quotes") from None
        return np.array(rows, dtype=float).reshape(-1, len(self.used)).T

    def _cell(self, row: list[str], index: int, row_number: int) -> float:
        cell = row[index].strip() if index < len(row) else ""
        if index == self.clock:
            return self._seconds(cell, row_number)
        if cell == "" or cell.lower() == "nan":
            return math.nan
        try:
            return float(cell.replace(",", ".") if self.decimal == "," else cell)
        except ValueError:
            hint = "; a time column of ISO-8601 timestamps declares unit: iso8601" if self.labels[index].startswith("time") else ""
            raise RecordError(f"{self.name}: {self.labels[index]}: row {row_number} is not a number ({cell!r}){hint}") from None

    def _seconds(self, cell: str, row_number: int) -> float:
        """An ISO-8601 timestamp in seconds from the first sample's."""
        try:
            stamp = datetime.fromisoformat(cell)
            if self.origin is None:
                self.origin = stamp
            return (stamp - self.origin).total_seconds()
        except (ValueError, TypeError) as error:
            raise RecordError(f"{self.name}: {self.labels[self.clock]}: row {row_number} is not an ISO-8601 timestamp ({cell!r}: {error})") from None

    def _index(self, column: str | int | None, what: str) -> int:
        name, header = self.name, self.header
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


def _line_count(path: Path) -> int:
    """Line ends (``\\n``) in the file, plus one for a last line without one: counted in 16 MiB reads, nothing kept."""
    lines, last = 0, b"\n"
    with path.open("rb") as handle:
        while data := handle.read(1 << 24):
            lines += data.count(b"\n")
            last = data[-1:]
    return lines + (last != b"\n")
