"""MDF4 record files (asammdf, the ``formats`` extra): channels by name, units and sample counts from their blocks.

The file is opened from a file object; a channel group's record count (``cycles_nr``) is its sample count, read
before its data; the channels of one file must share a channel group (one time base; its master channel, e.g.
``time``, is the time). Any exception of asammdf on a corrupt file is a RecordError.
"""

from __future__ import annotations

import gc
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from asammdf import MDF
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request

__all__ = ["Reader"]


@contextmanager
def _half_built_objects_quiet() -> Iterator[None]:
    """asammdf's MDF4 object left half-built by a corrupt file raises in ``__del__`` when collected, which Python
    prints as a traceback; the file is already a RecordError, so that one report is dropped inside the block."""
    previous = sys.unraisablehook

    def hook(unraisable: object) -> None:
        if "MDF4.__del__" not in getattr(getattr(unraisable, "object", None), "__qualname__", ""):
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        gc.collect()
        sys.unraisablehook = previous


class Reader:
    """An MDF4 record file (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.name = path.name
        self.handle = path.open("rb")
        identification = self.handle.read(16)
        if not identification.startswith(b"MDF     4."):  # asammdf's half-built object on other bytes prints a traceback when collected
            self.handle.close()
            raise RecordError(f"{self.name}: not an MDF4 file (it does not begin with 'MDF     4.', the identification of MDF version 4)")
        self.handle.seek(0)
        failure = None
        with _half_built_objects_quiet():
            try:
                self.mdf = MDF(self.handle)
            except Exception as error:  # asammdf raises what its parser meets on a corrupt file
                failure = str(error)
        if failure is not None:
            self.handle.close()
            raise RecordError(f"{self.name}: cannot read the file as MDF4: {failure}")
        self.selected: list[tuple[str, int, int, str]] = []

    def __enter__(self) -> Reader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.mdf.close()
        self.handle.close()

    def select(self, requests: Sequence[Request]) -> list[ColumnInfo]:
        infos = []
        self.selected = []
        for key, what in requests:
            label = f"{self.name}: {what} (channel {key!r})"
            places = self.mdf.whereis(str(key))
            if not places:
                names = sorted(self.mdf.channels_db)
                raise RecordError(f"{label}: no such channel (channels: {', '.join(names[:20])}{', …' if len(names) > 20 else ''})")
            if len(places) > 1:
                raise RecordError(f"{label}: {len(places)} channel groups hold a channel {key!r} (groups {', '.join(str(g) for g, _ in places)}); "
                                  "a record's channels are named once")
            group, index = places[0]
            if self.selected and group != self.selected[0][1]:
                raise RecordError(f"{label}: is in channel group {group}, {self.selected[0][0]!r} in group {self.selected[0][1]}; "
                                  "a record's channels share one channel group (one time base)")
            blocks = self.mdf.groups[group]
            infos.append(ColumnInfo(blocks.channels[index].unit or None, int(blocks.channel_group.cycles_nr), True, label))
            self.selected.append((str(key), group, index, label))
        return infos

    def chunks(self, size: int) -> Iterator[list[NDArray[np.float64]]]:
        total = int(self.mdf.groups[self.selected[0][1]].channel_group.cycles_nr) if self.selected else 0
        for start in range(0, total, size):
            chunk = []
            for key, group, index, label in self.selected:
                try:
                    samples, _ = self.mdf.get(key, group, index, samples_only=True, record_offset=start, record_count=size)
                    chunk.append(np.asarray(samples, dtype=float).reshape(-1))
                except Exception as error:  # a truncated data block, a type that is not a number
                    raise RecordError(f"{label}: cannot read the channel: {error}") from None
            yield chunk
