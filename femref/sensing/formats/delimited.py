"""CSV and TSV record files: a header row, then one sample per row, read a chunk of lines at a time.

The separator is ``,``, ``;`` or a tab, declared or taken from the header line (a tab if it holds one, else ``;``
if it holds one, else ``,``); a UTF-8 byte-order mark is skipped; numbers may be quoted, and with ``decimal: ","``
written with a decimal comma. The rule for a cell is Python's: ``float(cell.strip())`` (a decimal comma read as a
point), an empty cell or ``nan`` (any case) a gap (NaN), anything else an error naming the file, row and column. A
chunk is parsed by a C reader, only the columns read: pandas' (``pandas.read_csv``, its C engine) for a file of
:data:`PANDAS_BYTES` or more or once pandas is imported, else numpy's (``numpy.loadtxt``); both round every number
correctly, as ``float`` does, so their values are Python's to the bit. A chunk the C reader cannot take as Python would
(a text cell, a bad quote, a row of another length than the first, a line of blanks, a ``-nan``) is read again row by
row with Python's ``csv``, which names the first bad cell or row. A time column of ISO-8601 timestamps (``timestamps``,
the column) is read by ``datetime.fromisoformat``, stamp by stamp, each in seconds from the first sample (or from
``origin``, a recorder's first file's). A column read by a name the header gives twice is refused.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import sys
import warnings
from collections.abc import Iterator, Sequence
from datetime import datetime
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request

__all__ = ["PANDAS_BYTES", "PARSERS", "SEPARATORS", "Reader"]

SEPARATORS = {",": "comma", ";": "semicolon", "\t": "tab"}
"""Separators a CSV file may use, and their names in a case."""
PANDAS_BYTES = 1 << 23
"""Size (bytes, 8 MiB) from which a file is parsed by pandas rather than numpy: pandas parses 3–5× faster, and its
import (~0.2 s CPU) pays off near 10 MB of records."""
PARSERS = ("pandas", "numpy", "rows")
"""How a chunk is parsed: pandas' or numpy's C reader (a chunk it cannot take: row by row), or row by row only."""
BLOCK_BYTES = 1 << 23
"""Most bytes read at a time by the pandas parse (8 MiB; a chunk's lines are read in as many reads as they need)."""
_BOM = b"\xef\xbb\xbf"
GAP_SPELLINGS = ["", *(a + b + c for a in "nN" for b in "aA" for c in "nN")]
"""Cells that are gaps (NaN) as the C reader matches them: empty or ``nan`` in any case (a cell with blanks around it
goes to the row-by-row reading, which strips it)."""


class Reader:
    """A CSV or TSV record file (module docstring); ``separator`` None: from the header line; ``parser`` one of
    :data:`PARSERS` (None: pandas or numpy by the file's size, module docstring)."""

    def __init__(self, path: Path, separator: str | None = None, decimal: str = ".", timestamps: str | int | None = None,
                 origin: datetime | None = None, parser: str | None = None) -> None:
        self.path, self.name, self.decimal, self.timestamps = path, path.name, decimal, timestamps
        if parser not in (None, *PARSERS):
            raise ValueError(f"parser {parser!r}: one of {', '.join(PARSERS)} or None")
        self.parser = parser  # None: by the file's size (module docstring)
        try:
            with path.open("rb") as raw:
                bom = raw.read(len(_BOM)) == _BOM
            with path.open(newline="", encoding="utf-8-sig") as handle:
                first = next((line for line in handle if line.strip()), "")
                self.separator = separator or next((s for s in ("\t", ";") if s in first), ",")
                handle.seek(0)
                rows = csv.reader(handle, delimiter=self.separator, strict=True)
                header = next((row for row in rows if row), None)
                self.header_lines = rows.line_num
                handle.seek(0)
                head = [handle.readline() for _ in range(self.header_lines)]
                self.header_bytes = len("".join(head).encode("utf-8")) + (len(_BOM) if bom else 0)  # where the samples start
                self.line_end = "\r" if head and head[-1].endswith("\r") else "\n"  # a file of lone \r line ends is read line by line
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
        """The selected columns, at most ``size`` lines at a time."""
        count = 0
        parser = self.parser or ("pandas" if "pandas" in sys.modules or self.path.stat().st_size >= PANDAS_BYTES else "numpy")
        try:
            pieces: Iterator[tuple[bytes | list[str], int]] = (
                self._byte_pieces(size) if parser == "pandas" and self.line_end != "\r" else self._line_pieces(size))
            for piece, rows in pieces:
                if isinstance(piece, bytes):  # pandas' piece; read again as text lines if it cannot take it
                    block = self._by_pandas(piece, rows, count)
                    lines = list(io.StringIO(piece.decode("utf-8"), newline="")) if block is None else []
                else:
                    block, lines = (self._by_numpy(piece) if parser != "rows" else None), piece
                block = block if block is not None else self._by_rows(lines, count)
                count += block.shape[1]
                yield [block[self.used.index(index)] for index in self.selection]
        except (OSError, UnicodeDecodeError) as error:
            raise RecordError(f"{self.name}: cannot read the file: {error}") from None
        if count < 2:
            raise RecordError(f"{self.name}: needs a header row and at least two rows of samples, has {count + 1} row(s)")

    def _line_pieces(self, size: int) -> Iterator[tuple[list[str], int]]:
        """The lines after the header, ``size`` at a time (with -1: rows not counted)."""
        with self.path.open(newline="", encoding="utf-8-sig") as handle:
            for _ in range(self.header_lines):
                next(handle)
            while lines := list(itertools.islice(handle, size)):
                yield lines, -1

    def _byte_pieces(self, size: int) -> Iterator[tuple[bytes, int]]:
        """The bytes after the header cut at line ends (``\\n``), ``size`` lines at a time (the last piece: the rest),
        read :data:`BLOCK_BYTES` at a time at most; each piece with its rows: its lines but the empty ones."""
        step = min(BLOCK_BYTES, 64 * size)
        with self.path.open("rb") as handle:
            handle.seek(self.header_bytes)
            rest, at_end = b"", False
            while True:
                parts, found = [rest], rest.count(b"\n")
                while found < size and not at_end:
                    more = handle.read(step)
                    at_end = not more
                    parts.append(more)
                    found += more.count(b"\n")
                data = b"".join(parts)
                if not data:
                    return
                raw = np.frombuffer(data, dtype=np.uint8)
                ends = np.flatnonzero(raw == 10)[:size]
                cut = int(ends[-1]) + 1 if ends.size == size else len(data)
                piece, rest = data[:cut], data[cut:]
                starts = np.concatenate([[0], ends[:-1] + 1]).astype(np.intp) if ends.size else np.empty(0, dtype=np.intp)
                length = ends - starts
                empty = np.count_nonzero((length == 0) | ((length == 1) & (raw[starts] == 13)))
                lines = ends.size + (cut > (int(ends[-1]) + 1 if ends.size else 0))
                yield piece, lines - empty

    def _by_numpy(self, lines: list[str]) -> NDArray[np.float64] | None:
        """``lines`` parsed by ``numpy.loadtxt``; None where it cannot take them (and for ISO-8601 times)."""
        if self.clock in self.used:
            return None
        if self.decimal == ",":
            lines = [line.replace(",", ".") for line in lines]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a chunk of blank lines only ("input contained no data")
                return np.loadtxt(lines, delimiter=self.separator, quotechar='"', comments=None, usecols=self.used, ndmin=2).T
        except ValueError:
            return None

    def _by_pandas(self, data: bytes, rows: int, before: int) -> NDArray[np.float64] | None:
        """The lines of ``data`` (``rows`` of them not empty) parsed by pandas' C reader (an ISO-8601 column as text,
        then stamp by stamp); None where it cannot take them as Python would: an error, or another row count (it skips
        a line of blanks, which Python's ``csv`` reads as a row of gaps; it ends a line at a lone ``\\r`` too)."""
        import pandas as pd

        if data.startswith(_BOM):  # a byte-order mark past the header is a cell's (pandas would drop it)
            return None
        types = {index: str if index == self.clock else np.float64 for index in self.used}
        try:
            frame = pd.read_csv(io.BytesIO(data), sep=self.separator, header=None, usecols=self.used, dtype=types, engine="c", encoding="utf-8",
                                quotechar='"', decimal=self.decimal, keep_default_na=False, na_values=GAP_SPELLINGS, comment=None)
        except (ValueError, TypeError, OverflowError):  # pandas' ParserError, EmptyDataError and UnicodeDecodeError are ValueErrors
            return None
        if len(frame) != rows:
            return None
        block = np.empty((len(self.used), rows))
        for k, index in enumerate(self.used):
            if index != self.clock:
                block[k] = frame[index].to_numpy(dtype=np.float64)
                continue
            try:
                block[k] = [self._seconds(stamp.strip(), before + row + 2) for row, stamp in enumerate(frame[index].tolist())]
            except (RecordError, AttributeError):  # a bad stamp, or a gap (NaN): the rows name it
                return None
        return block

    def _by_rows(self, lines: list[str], before: int) -> NDArray[np.float64]:
        """``lines`` read row by row with Python's ``csv`` and ``float``: RecordError at the first bad cell or row."""
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
    """Line ends (``\\n``) in the file, plus one for a last line without one: counted in 16 MiB reads, nothing kept but
    the count, which is kept for the file as it is (:data:`LINE_COUNTS`: validation and the run count a file once)."""
    status = path.stat()
    key = (str(path.resolve()), status.st_dev, status.st_ino, status.st_size, status.st_mtime_ns)
    if key in LINE_COUNTS:
        return LINE_COUNTS[key]
    lines, last = 0, b"\n"
    with path.open("rb") as handle:
        while data := handle.read(1 << 24):
            lines += data.count(b"\n")
            last = data[-1:]
    if len(LINE_COUNTS) >= 256:
        LINE_COUNTS.clear()
    LINE_COUNTS[key] = lines + (last != b"\n")
    return LINE_COUNTS[key]


LINE_COUNTS: dict[tuple[str, int, int, int, int], int] = {}
"""Line counts of the files counted in this process, keyed on the file's path, device, inode, size and modification
time (ns): a file changed or replaced is counted again."""
