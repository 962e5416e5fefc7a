"""HDF5 record files (h5py): one-dimensional datasets by path, each checked before a byte of it is read.

Nothing is read from outside the file (:func:`femref.sensing.hdf5_checks.check_plain_dataset`: no external storage,
external links or virtual datasets; soft links inside it followed, at most :data:`MAX_SOFT_LINKS` in a row).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

from femref.sensing.formats.base import ColumnInfo, RecordError, Request
from femref.sensing.hdf5_checks import HDF5ObjectError, check_plain_dataset

__all__ = ["MAX_SOFT_LINKS", "Reader"]

MAX_SOFT_LINKS = 16
"""Most soft links followed in a row to reach a dataset (HDF5's own default); more is a loop."""


class Reader:
    """An HDF5 record file's datasets (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.name = path.name
        try:
            self.h5 = h5py.File(path, "r")
        except OSError as error:
            raise RecordError(f"{self.name}: cannot read the file as HDF5: {error}") from None
        self.selected: list[tuple[h5py.Dataset, str]] = []

    def __enter__(self) -> Reader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.h5.close()

    def select(self, requests: Sequence[Request]) -> list[ColumnInfo]:
        self.selected = [(self._checked(key, what), f"{self.name}: {what} (dataset {key!r})") for key, what in requests]
        return [ColumnInfo(None, dataset.size, True, label, dataset.ndim != 1) for dataset, label in self.selected]

    def chunks(self, size: int) -> Iterator[list[NDArray[np.float64]]]:
        """At most ``size`` samples of each one-dimensional dataset per chunk (an (n, 1) or (1, n) dataset whole in the first)."""
        total = max((dataset.size for dataset, _ in self.selected), default=0)
        for start in range(0, total, size):
            chunk = []
            for dataset, label in self.selected:
                try:  # an (n, 1) or (1, n) dataset comes whole in the first chunk
                    part = dataset[start : start + size] if dataset.ndim == 1 else (dataset[()] if start == 0 else np.empty(0))
                    chunk.append(np.asarray(part, dtype=float).reshape(-1))
                except (OSError, ValueError, TypeError) as error:
                    raise RecordError(f"{label}: cannot read the dataset: {error}") from None
            yield chunk

    def _checked(self, key: str | int | None, what: str) -> h5py.Dataset:
        """The dataset at ``key``, its links resolved inside the file, its storage, type, shape and chunks checked, unread."""
        label = f"{self.name}: {what} (dataset {key!r})"
        dataset = _resolve(self.h5, key, label) if isinstance(key, str) else None
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
