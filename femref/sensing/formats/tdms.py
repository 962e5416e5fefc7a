"""TDMS record files (npTDMS, the ``formats`` extra): channels named ``group/channel``, units from ``unit_string``.

The file is opened from a file object, so npTDMS reads no ``.tdms_index`` beside it; a channel's sample count comes
from the segments' metadata, read before its data; any exception of npTDMS on a corrupt file is a RecordError, and so
is a warning it logs (a truncated segment, which it would read short silently).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from nptdms import TdmsFile
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request

__all__ = ["Reader"]


class _Warnings(logging.Handler):
    """npTDMS's warnings, kept."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


@contextmanager
def _refusing_warnings(name: str) -> Iterator[None]:
    """Any warning npTDMS logs inside the block is a RecordError naming the file."""
    caught = _Warnings()
    logger = logging.getLogger("nptdms")
    logger.addHandler(caught)
    try:
        yield
    finally:
        logger.removeHandler(caught)
    if caught.messages:
        raise RecordError(f"{name}: the file is truncated or corrupt (npTDMS: {caught.messages[0]})")


class Reader:
    """A TDMS record file (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.name = path.name
        self.handle = path.open("rb")
        try:
            if self.handle.read(4) != b"TDSm":
                raise RecordError(f"{self.name}: not a TDMS file (it does not begin with 'TDSm')")
            self.handle.seek(0)
            with _refusing_warnings(self.name):
                self.tdms = TdmsFile.open(self.handle)
        except RecordError:
            self.handle.close()
            raise
        except Exception as error:  # npTDMS raises what its parser meets on a corrupt file
            self.handle.close()
            raise RecordError(f"{self.name}: cannot read the file as TDMS: {error}") from None
        self.selected: list[tuple[object, str]] = []

    def __enter__(self) -> Reader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.handle.close()

    def select(self, requests: Sequence[Request]) -> list[ColumnInfo]:
        infos = []
        self.selected = []
        for key, what in requests:
            label = f"{self.name}: {what} (channel {key!r})"
            group, _, channel = str(key).partition("/")
            names = [f"{g.name}/{c.name}" for g in self.tdms.groups() for c in g.channels()]
            if f"{group}/{channel}" not in names:
                raise RecordError(f"{label}: no such channel (channels: {', '.join(names[:20])}{', …' if len(names) > 20 else ''})")
            found = self.tdms[group][channel]
            unit = found.properties.get("unit_string")
            infos.append(ColumnInfo(None if unit is None else str(unit), len(found), True, label))
            self.selected.append((found, label))
        return infos

    def chunks(self, size: int) -> Iterator[list[NDArray[np.float64]]]:
        total = max((len(channel) for channel, _ in self.selected), default=0)
        for start in range(0, total, size):
            chunk = []
            for channel, label in self.selected:
                try:
                    with _refusing_warnings(self.name):
                        chunk.append(np.asarray(channel.read_data(start, size), dtype=float).reshape(-1))
                except RecordError:
                    raise
                except Exception as error:  # a truncated segment, a type that is not a number
                    raise RecordError(f"{label}: cannot read the channel: {error}") from None
            yield chunk
