"""Record-file formats: which reader opens a file (a declared ``format:``, else its suffix), and the key naming its columns.

Each format is one module with a ``Reader`` class (:class:`~femref.sensing.formats.base.RecordReader`); the readers of
MDF4 (asammdf), TDMS (npTDMS) and UFF58 (pyuff) need the ``formats`` extra, and a file of theirs without it is a
:class:`RecordError` naming the extra to install.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from femref.sensing.formats.base import ColumnInfo, RecordError, RecordReader, Request

__all__ = ["FORMATS", "SUFFIXES", "ColumnInfo", "RecordError", "RecordReader", "Request", "format_of", "key_of", "open_reader"]

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
