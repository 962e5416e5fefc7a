"""UFF58 record files (pyuff, the ``formats`` extra): function-at-node records named by their ``id1``.

A channel is a record's ordinate, its unit the record's ``ordinate_axis_units_lab``; the time is the abscissa of the
record the time names (``abscissa_axis_units_lab``). Each record's header (``num_pts``) is read before its data; pyuff
reads a record whole, so a chunk is a slice of it. pyuff opens the named file only; any exception of it on a
corrupt file is a RecordError.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pyuff
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request

__all__ = ["Reader"]


class Reader:
    """A UFF58 record file (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.name = path.name
        try:
            self.uff = pyuff.UFF(str(path))
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
                columns.append(np.asarray(self.uff.read_sets(number)[field], dtype=float).reshape(-1))
            except Exception as error:  # a truncated record, complex ordinates
                raise RecordError(f"{label}: cannot read the record: {error}") from None
        for start in range(0, max((column.size for column in columns), default=0), size):
            yield [column[start : start + size] for column in columns]
