"""UFF58 record files (pyuff, the ``formats`` extra): function-at-node records named by their ``id1``.

A channel is a record's ordinate, its unit the record's ``ordinate_axis_units_lab``; the time is the abscissa of the
record the time names (``abscissa_axis_units_lab``). Each record's header (``num_pts``) is read before its data; a
record is read whole (an ASCII one's fields converted by numpy, :meth:`Reader.ascii_column`), so a chunk is a slice
of it. The file's records are found by a scan of :data:`SCAN_BYTES` at a time (:class:`_ScannedUFF`: pyuff's own
scan holds the whole file and every record's lines at once, 2.5× the file: 542 MB for an hour of three channels at
1 kHz, which put a day's streamed run over 1 GB). pyuff opens the named file only; any exception of it on a corrupt
file is a RecordError.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import BinaryIO

import numpy as np
import pyuff
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request

__all__ = ["Reader"]

SCAN_BYTES = 1 << 24
"""Bytes read at a time while the file's records are found."""
TAG = b"    -1"
"""The line that opens and closes each record of a universal file."""


class _ScannedUFF(pyuff.UFF):
    """pyuff's universal file whose records (``_block_ind``, ``_set_types``, ``_set_formats``) are found as pyuff finds
    them — every ``    -1`` followed by a line end, the file's end or blanks to column 80; pairs of them a record's
    first and last byte; the record's type the first six characters of its second line, ``b`` after them binary — but
    reading :data:`SCAN_BYTES` at a time, and only a record's first lines for its type."""

    def refresh(self) -> bool:
        self._refreshed = False
        with open(self._filename, "rb") as handle:
            tags = _tags(handle)
            blocks = len(tags) // 2
            self._block_ind = np.column_stack([tags[0 : 2 * blocks : 2], tags[1 : 2 * blocks : 2] - 1]) if blocks else []
            self._n_sets = blocks
            self._set_types = np.zeros(blocks, dtype=int)
            self._set_formats = np.zeros(blocks)
            for k in range(blocks):
                handle.seek(int(tags[2 * k]))
                lines = handle.read(256).splitlines()
                if len(lines) > 1 and lines[1][:6].strip().isdigit():
                    self._set_types[k] = int(lines[1][0:6])
                    self._set_formats[k] = float(lines[1][6:7].lower() == b"b")
        self._refreshed = True
        return True


def _tags(handle: BinaryIO) -> NDArray[np.int64]:
    """The byte offsets of the record tags of a universal file (:class:`_ScannedUFF`), read :data:`SCAN_BYTES` at a time."""
    found: list[int] = []
    offset, carry = 0, b""
    while True:
        piece = handle.read(SCAN_BYTES)
        data = carry + piece
        end = len(data) if not piece else len(data) - 80  # a tag this close to the piece's end is judged with the next
        at = data.find(TAG)
        while at != -1 and at < end:
            after = data[at + 6 : at + 80]
            if at + 6 == len(data) and not piece or after[:1] in (b"\n", b"\r") or after == b" " * 74:
                found.append(offset + at)
            at = data.find(TAG, at + 1)
        if not piece:
            return np.asarray(found, dtype=np.int64)
        keep = max(end, 0)
        offset, carry = offset + keep, data[keep:]


class Reader:
    """A UFF58 record file (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.path, self.name = path, path.name
        try:
            self.uff = _ScannedUFF(str(path))
            numbers = [n for n, kind in enumerate(self.uff.get_set_types()) if int(kind) == 58]
            self.headers = {str(header["id1"]).strip(): (n, header) for n in numbers for header in [self.uff.read_sets(n, header_only=True)]}
        except Exception as error:  # pyuff raises what its parser meets on a corrupt file
            raise RecordError(f"{self.name}: cannot read the file as UFF58: {error}") from None
        if not self.headers:
            raise RecordError(f"{self.name}: holds no UFF58 record (dataset 58, a function at a node)")
        self.selected: list[tuple[int, str, str]] = []

    def __enter__(self) -> Reader:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def ascii_column(self, number: int, field: str) -> NDArray[np.float64] | None:
        """Record ``number``'s ``data`` or ``x`` read as pyuff reads it — ``abscissa_min + k · abscissa_inc`` and the
        ordinates of fixed-width fields (``6E13.5`` single, ``4E20.12`` double precision) — but each field converted by
        numpy rather than one by one in Python (6× faster), when the record is ASCII, real and evenly spaced, its lines
        full but the last and its fields as many as ``num_pts``; None otherwise (pyuff reads it)."""
        header = next(h for n, h in self.headers.values() if n == number)
        kind, blocks = int(header.get("ord_data_type", 0)), getattr(self.uff, "_block_ind", None)
        if header.get("binary") or int(header.get("abscissa_spacing", 0)) != 1 or kind not in (2, 4) or blocks is None:
            return None
        count = int(header["num_pts"])
        if field == "x":
            return header["abscissa_min"] + np.arange(count) * header["abscissa_inc"]
        start, end = (int(i) for i in blocks[number])
        with self.path.open("rb") as handle:
            handle.seek(start)
            lines = handle.read(end - start + 1).splitlines()[13:]
        width, per_line = (13, 6) if kind == 2 else (20, 4)
        if not lines or any(len(line) != width * per_line for line in lines[:-1]):
            return None
        last = lines[-1]
        fields = len(last) // width
        while fields and not last[(fields - 1) * width : fields * width].strip():
            fields -= 1  # blank fields closing the last line (pyuff leaves them out)
        if (len(lines) - 1) * per_line + fields != count:
            return None
        return np.frombuffer(b"".join(lines)[: count * width], dtype=f"S{width}").astype(float)

    def select(self, requests: Sequence[Request]) -> list[ColumnInfo]:
        infos = []
        self.selected = []
        for key, what in requests:
            label = f"{self.name}: {what} (channel {key!r})"
            if str(key) not in self.headers:
                raise RecordError(f"{label}: no such record (records by id1: {', '.join(list(self.headers)[:20])})")
            number, header = self.headers[str(key)]
            field, unit = ("x", "abscissa_axis_units_lab") if what == "time" else ("data", "ordinate_axis_units_lab")
            infos.append(ColumnInfo(str(header.get(unit, "")).strip() or None, int(header["num_pts"]), True, label))
            self.selected.append((number, field, label))
        return infos

    def chunks(self, size: int) -> Iterator[list[NDArray[np.float64]]]:
        columns = []
        for number, field, label in self.selected:
            try:
                column = self.ascii_column(number, field)
                if column is None:
                    column = np.asarray(self.uff.read_sets(number)[field], dtype=float).reshape(-1)
                columns.append(column)
            except Exception as error:  # a truncated record, complex ordinates
                raise RecordError(f"{label}: cannot read the record: {error}") from None
        for start in range(0, max((column.size for column in columns), default=0), size):
            yield [column[start : start + size] for column in columns]
