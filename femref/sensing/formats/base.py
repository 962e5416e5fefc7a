"""The record-reader protocol: a named file's columns, their units and sample counts before a sample is read, then chunks.

A reader (one module per format, :mod:`femref.sensing.formats`) opens one regular file and nothing beside it;
:meth:`RecordReader.select` resolves the requested columns, channels or datasets to :class:`ColumnInfo` (unit from
the file's metadata when it has one, sample count from its headers, so the size bounds of
:mod:`femref.sensing.record_files` are checked before allocation); :meth:`RecordReader.chunks` then yields them
together, at most ``size`` samples each. A corrupt file is a :class:`RecordError` naming the file and the rule.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["ColumnInfo", "RecordError", "RecordReader", "Request"]


class RecordError(ValueError):
    """A record file that cannot be read as declared: the message names the file, channel and rule."""


Request = tuple[str | int | None, str]
"""``(column, channel or dataset; what)``: what to read and how messages name it (``channel hammer/front``, ``time``)."""


@dataclass(frozen=True)
class ColumnInfo:
    """A selected column: its ``unit`` as the file declares it (None: the file says none), its ``samples`` from the file's
    headers, ``exact`` or (text files) an upper bound, the lines after the header, and how messages name it (``label``);
    ``whole``: the reader holds the whole column in memory (an (n, 1) HDF5 dataset), so its size is bounded."""

    unit: str | None
    samples: int
    exact: bool
    label: str
    whole: bool = False


class RecordReader(Protocol):
    """One open record file (a context manager: leaving it closes the file)."""

    def select(self, requests: Sequence[Request]) -> list[ColumnInfo]:
        """The requested columns, checked and resolved, unread; RecordError naming the file, the request and the rule."""
        ...

    def chunks(self, size: int) -> Iterator[list[NDArray[np.float64]]]:
        """The selected columns as floats, at most ``size`` samples each per chunk, in the order selected."""
        ...

    def __enter__(self) -> RecordReader: ...

    def __exit__(self, *exc: object) -> None: ...
