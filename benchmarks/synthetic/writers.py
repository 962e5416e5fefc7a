"""A recorder file in each record format femref reads, written atomically from the same arrays.

Every writer takes the recorder's time column (s on its own clock) and its channels (in the file's units), all fixed
point: ``counts · 10⁻ᵈ`` (:func:`fixed_point`). A decimal text of such a number parses to the same double as the
division ``counts / 10ᵈ`` (both are the double nearest the same rational), so a CSV file, whose cells are written by
:func:`csv_text` with numpy alone (no per-value formatting), reads back bit for bit what the binary formats hold. UFF58
(pyuff) writes its abscissa as a start and an increment (``%13.5e``): the files start on whole seconds, and the reader's
``start + k · 0.001`` differs from ``k / 1000`` by at most an ulp.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

SUFFIX = {"csv": ".csv", "hdf5": ".h5", "mdf4": ".mf4", "tdms": ".tdms", "uff58": ".uff"}
FORMATS = tuple(SUFFIX)
CSV_ROWS = 1 << 19
"""Rows formatted at a time (about 25 MB of text)."""


@dataclass(frozen=True)
class Dialect:
    """A CSV file's ``separator`` and ``decimal`` mark."""

    separator: str = ","
    decimal: str = "."


@dataclass(frozen=True)
class RecorderFile:
    """One file's contents: ``time`` (s, its recorder's clock) and ``channels`` (name → values in ``units[name]``), each
    with the decimals it is fixed to (``time_decimals``, ``decimals``), and the CSV ``dialect``."""

    time: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    time_decimals: int
    decimals: int
    dialect: Dialect
    group: str


def fixed_point(values: np.ndarray, decimals: int) -> np.ndarray:
    """``round(values · 10ᵈ) / 10ᵈ``: the doubles a text of ``d`` decimals reads back exactly."""
    return np.round(values * 10.0**decimals) / 10.0**decimals


def _fields(values: np.ndarray, decimals: int, decimal: bytes) -> tuple[np.ndarray, np.ndarray]:
    """The text of fixed-point ``values`` (``d`` decimals) as right-aligned ASCII codes ``(n, width)`` and which of them
    are kept (the rest pads): ``-12.345`` for -12.345 with d = 3."""
    counts = np.rint(values * 10.0**decimals).astype(np.int64)
    magnitude = np.abs(counts)
    whole = magnitude // 10**decimals
    width = max(len(str(int(whole.max(initial=0)))), 1)
    significant = np.ones(counts.size, np.int64) + sum((whole >= 10**k).astype(np.int64) for k in range(1, width))
    digits = [(magnitude // 10 ** (decimals + k)) % 10 for k in reversed(range(width))]
    columns = [np.where(counts < 0, ord("-"), ord(" "))] + [d + ord("0") for d in digits]
    keep = [counts < 0] + [significant > k for k in reversed(range(width))]
    if decimals:
        columns.append(np.full(counts.size, decimal[0]))
        keep.append(np.ones(counts.size, bool))
        for k in reversed(range(decimals)):
            columns.append((magnitude // 10**k) % 10 + ord("0"))
            keep.append(np.ones(counts.size, bool))
    return np.column_stack(columns).astype(np.uint8), np.column_stack(keep)


def csv_text(columns: list[np.ndarray], decimals: list[int], dialect: Dialect) -> bytes:
    """Rows of fixed-point ``columns`` (each with its ``decimals``) separated by the dialect's separator, one per line."""
    separator = np.full((columns[0].size, 1), ord(dialect.separator), np.uint8)
    newline = np.full((columns[0].size, 1), ord("\n"), np.uint8)
    parts, keeps = [], []
    for k, (values, d) in enumerate(zip(columns, decimals)):
        text, keep = _fields(values, d, dialect.decimal.encode())
        parts += [text, separator if k + 1 < len(columns) else newline]
        keeps += [keep, np.ones_like(separator, bool)]
    return np.concatenate(parts, axis=1)[np.concatenate(keeps, axis=1)].tobytes()


def write_csv(path: Path, record: RecorderFile) -> None:
    names = ["time_s", *record.channels]
    columns = [record.time, *record.channels.values()]
    decimals = [record.time_decimals] + [record.decimals] * len(record.channels)
    with path.open("wb") as handle:
        handle.write((record.dialect.separator.join(names) + "\n").encode())
        for start in range(0, record.time.size, CSV_ROWS):
            handle.write(csv_text([c[start : start + CSV_ROWS] for c in columns], decimals, record.dialect))


def write_hdf5(path: Path, record: RecorderFile) -> None:
    with h5py.File(path, "w") as h5:
        h5.create_dataset("time", data=record.time).attrs["unit"] = "s"
        for name, values in record.channels.items():
            h5.create_dataset(name, data=values).attrs["unit"] = record.units[name]


def write_mdf4(path: Path, record: RecorderFile) -> None:
    from asammdf import MDF, Signal

    with MDF(version="4.10") as mdf:
        mdf.append([Signal(values, record.time, name=name, unit=record.units[name]) for name, values in record.channels.items()])
        mdf.save(path, overwrite=True)


def write_tdms(path: Path, record: RecorderFile) -> None:
    from nptdms import ChannelObject, TdmsWriter

    with TdmsWriter(path) as writer:
        writer.write_segment([ChannelObject(record.group, "time", record.time, {"unit_string": "s"})]
                             + [ChannelObject(record.group, name, values, {"unit_string": record.units[name]}) for name, values in record.channels.items()])


def write_uff58(path: Path, record: RecorderFile) -> None:
    """One function-at-node record (dataset 58, ASCII, real double ordinates, even abscissa) per channel."""
    import pyuff

    axes = {f"{axis}_{key}": value for axis in ("abscissa", "ordinate", "orddenom", "z_axis")
            for key, value in (("spec_data_type", 0), ("len_unit_exp", 0), ("force_unit_exp", 0), ("temp_unit_exp", 0), ("axis_lab", "NONE"),
                               ("axis_units_lab", "NONE"))}
    sets = [axes | {"type": 58, "binary": 0, "func_type": 1, "func_id": node, "ver_num": 0, "load_case_id": 0, "id1": name, "id2": "NONE",
                    "id3": "NONE", "id4": "NONE", "id5": "NONE", "rsp_ent_name": record.group, "rsp_node": node, "rsp_dir": 1, "ref_ent_name": "NONE",
                    "ref_node": 0, "ref_dir": 0, "ord_data_type": 4, "num_pts": values.size, "abscissa_spacing": 1, "abscissa_min": float(record.time[0]),
                    "abscissa_inc": 1e-3, "z_axis_value": 0.0, "n_bytes": 0, "x": record.time, "data": values,
                    "abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": record.units[name]}
            for node, (name, values) in enumerate(record.channels.items(), start=1)]
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")


WRITERS: dict[str, Callable[[Path, RecorderFile], None]] = {"csv": write_csv, "hdf5": write_hdf5, "mdf4": write_mdf4, "tdms": write_tdms,
                                                           "uff58": write_uff58}


def write(path: Path, fmt: str, record: RecorderFile) -> None:
    """``record`` as a ``fmt`` file at ``path``, written under a temporary name and renamed."""
    if fmt == "uff58" and (record.time[0] != round(record.time[0]) or abs(record.time[0]) >= 1e5):
        raise ValueError(f"{path.name}: a UFF58 file's abscissa starts at %13.5e precision: start it on a whole second below 1e5 s, "
                         f"not {record.time[0]!r}")
    partial = path.with_name(f".{path.stem}.partial{path.suffix}")
    WRITERS[fmt](partial, record)
    partial.replace(path)
