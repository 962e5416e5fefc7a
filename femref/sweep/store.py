"""The HDF5 sweep file: one row per sample, written as samples finish, resumable.

Its layout, the contract the networks read: docs/design.md §4.4 (:data:`_ARRAYS` the per-model datasets).
Only the sweep's client writes. Work goes to ``<output>.partial``, flushed after every
stored batch of samples; once every sample is stored (ok or failed) it is renamed to ``<output>``.
Opening again with the same sweep (same ``spec_hash``) resumes: stored samples are
skipped, a larger ``samples`` extends the datasets (unlimited along N); a file is never
shrunk. A file of another sweep is refused and left untouched.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref import __version__
from femref.case import CaseError, Problem
from femref.sensing.records import record_rate
from femref.results import UNITS
from femref.sweep.spec import Sweep

__all__ = ["FAILED", "NOT_RUN", "OK", "SweepData", "SweepLayout", "SweepStore", "partial_path", "read_sweep"]

NOT_RUN, OK, FAILED = 0, 1, 2
_TEXT = h5py.string_dtype("utf-8")
_ARRAYS = {  # per-model dataset → (shape after N from the layout, units)
    "records": (lambda lay: (len(lay.probes), lay.record_length), UNITS["acceleration"]),
    "coupler_force": (lambda lay: (len(lay.couplers), lay.force_length), UNITS["force"]),
    "peak_coupler_force": (lambda lay: (len(lay.couplers),), UNITS["force"]),
    "wall_time_s": (lambda lay: (), "s"),
}
#: The root attributes :func:`read_sweep` reads (but ``models``) and how each is read.
_ATTRS = {
    "femref_version": str, "created": str, "sweep_yaml": str, "base_case_yaml": str, "spec_hash": str, "seed": int,
    "probes": json.loads, "couplers": json.loads, "record_length": int, "force_length": int, "record_end": float,
    "record_rate": float, "record_source": str, "measurement": json.loads,
}


def partial_path(output: str | Path) -> Path:
    """Where the sweep into ``output`` is written until every sample is stored."""
    output = Path(output)
    return output.with_name(output.name + ".partial")


@dataclass(frozen=True)
class SweepLayout:
    """What fixes the array shapes and the meaning of the records: names and lengths from the base case."""

    models: tuple[str, ...]
    probes: tuple[str, ...]
    couplers: tuple[str, ...]
    record_length: int
    force_length: int
    record_end: float
    measurement: dict[str, Any] | None

    @classmethod
    def of(cls, sweep: Sweep) -> "SweepLayout":
        from femref.scene.build import scene_from_case

        scene = scene_from_case(sweep.base_case, sweep.base_dir)
        measurement = sweep.base_case.measurement
        return cls(
            models=tuple(scene.models),
            probes=tuple(scene.probes),
            couplers=tuple(c.name for c in scene.couplers),
            record_length=sweep.spec.outputs.record_length,
            force_length=sweep.spec.outputs.force_length,
            record_end=float(scene.end),
            measurement=None if measurement is None else measurement.model_dump(mode="json"),
        )

    @property
    def record_source(self) -> str:
        return "model" if self.measurement is None else "measured"

    def mismatch(self, record: dict[str, Any]) -> str:
        """Why a worker's record does not fit this layout ("" if it does)."""
        for key in ("models", "probes", "couplers"):
            if tuple(record[key]) != getattr(self, key):
                return f"this sample's {key} ({', '.join(record[key])}) differ from the sweep's ({', '.join(getattr(self, key))})"
        return ""


class SweepStore:
    """The open ``.partial`` sweep file: which samples are stored, and storing more."""

    def __init__(self, h5: h5py.File, output: Path, sweep: Sweep, layout: SweepLayout) -> None:
        self.h5, self.output, self.sweep, self.layout = h5, output, sweep, layout

    @classmethod
    def open(cls, output: str | Path, sweep: Sweep, layout: SweepLayout) -> "SweepStore":
        """Open (resume, extend) or create ``<output>.partial`` for ``sweep``; the final file moves back if present.

        Raises :class:`CaseError` when ``output`` or its ``.partial`` holds another sweep or is
        no sweep file; nothing is overwritten then.
        """
        output = Path(output)
        partial = partial_path(output)
        existing = [p for p in (output, partial) if p.exists()]
        if len(existing) == 2:
            cls._refuse(output, f"both {output.name} and {partial.name} exist; remove the one you do not want")
        if existing:
            cls._check(existing[0], sweep)
            if existing[0] == output:
                os.replace(output, partial)
            h5 = h5py.File(partial, "r+")
            store = cls(h5, output, sweep, layout)
            store._extend(sweep.size)
            return store
        output.parent.mkdir(parents=True, exist_ok=True)
        h5 = h5py.File(partial, "w")
        store = cls(h5, output, sweep, layout)
        try:
            store._create()
        except BaseException:
            h5.close()
            partial.unlink(missing_ok=True)
            raise
        return store

    @classmethod
    def stored_status(cls, output: str | Path, sweep: Sweep) -> NDArray[np.int8] | None:
        """The sample status of a complete ``output`` of this sweep (None if there is none); checks the hash."""
        output = Path(output)
        if not output.exists() or partial_path(output).exists():
            return None
        cls._check(output, sweep)
        with h5py.File(output, "r") as h5:
            return h5["samples/status"][...]

    @staticmethod
    def _refuse(path: Path, rule: str) -> None:
        raise CaseError(Problem((), f"{rule}; nothing was overwritten"), str(path))

    @classmethod
    def _check(cls, path: Path, sweep: Sweep) -> None:
        try:
            with h5py.File(path, "r") as h5:
                stored = h5.attrs.get("spec_hash")
        except OSError:
            cls._refuse(path, "exists and is not an HDF5 file; choose another output (-o)")
        if stored is None:
            cls._refuse(path, "exists and is not a femref sweep file; choose another output (-o)")
        if stored != sweep.spec_hash:
            rule = (
                f"holds another sweep (spec_hash {stored[:12]}…, this sweep {sweep.spec_hash[:12]}…): only samples may change "
                "between runs into one file; choose another output (-o) or remove the file"
            )
            cls._refuse(path, rule)

    def _create(self) -> None:
        h5, sweep, layout, n = self.h5, self.sweep, self.layout, self.sweep.size
        from femref.case import resolved_yaml

        h5.attrs.update(
            femref_version=__version__, created=datetime.now(timezone.utc).isoformat(timespec="seconds"), sweep_yaml=sweep.resolved_yaml(),
            base_case_yaml=resolved_yaml(sweep.base_case), spec_hash=sweep.spec_hash, seed=sweep.spec.seed,
            models=json.dumps(list(layout.models)), probes=json.dumps(list(layout.probes)), couplers=json.dumps(list(layout.couplers)),
            record_length=layout.record_length, force_length=layout.force_length, record_end=layout.record_end,
            record_rate=record_rate(layout.record_length, layout.record_end), record_source=layout.record_source,
            measurement=json.dumps(layout.measurement),
        )
        for path, distribution in sweep.spec.parameters.items():
            values = distribution.stored_values()
            dtype, fill = (np.float64, np.nan) if values is None else (np.int64, -1)
            ds = self._rows(h5.require_group("parameters"), path, (), dtype, fill, n)
            ds.attrs["distribution"] = json.dumps(distribution.model_dump(mode="json", exclude_none=True))
            if values is not None:
                ds.attrs["values"] = json.dumps(values)
        samples = h5.create_group("samples")
        self._rows(samples, "status", (), np.int8, NOT_RUN, n)
        self._rows(samples, "error", (), _TEXT, "", n)
        for model in layout.models:
            group = h5.create_group(model)
            for name, (shape_of, units) in _ARRAYS.items():
                self._rows(group, name, shape_of(layout), np.float64, np.nan, n).attrs["units"] = units
        h5.flush()

    @staticmethod
    def _rows(group: h5py.Group, name: str, shape: tuple[int, ...], dtype: Any, fill: Any, n: int) -> h5py.Dataset:
        """A dataset of ``n`` rows of ``shape``, one chunk per row, growable along the rows."""
        return group.create_dataset(name, shape=(n, *shape), maxshape=(None, *shape), chunks=(1, *shape) if shape else (1024,), dtype=dtype, fillvalue=fill)

    def _extend(self, n: int) -> None:
        """Grow every row dataset to ``n`` rows (new rows not run); record the larger sweep."""
        if n <= self.size:
            return
        self.h5.attrs["sweep_yaml"] = self.sweep.resolved_yaml()

        def grow(_: str, item: Any) -> None:
            if isinstance(item, h5py.Dataset):
                item.resize(n, axis=0)

        self.h5.visititems(grow)
        self.h5.flush()

    @property
    def size(self) -> int:
        return int(self.h5["samples/status"].shape[0])

    @property
    def status(self) -> NDArray[np.int8]:
        return self.h5["samples/status"][...]

    def pending(self, retry_failed: bool = False) -> list[int]:
        """Indices to run: not run yet, and failed ones when ``retry_failed``."""
        status = self.status
        todo = status == NOT_RUN if not retry_failed else status != OK
        return [int(i) for i in np.flatnonzero(todo)]

    def store_batch(self, indices: list[int], stored_parameters: list[dict[str, float | int]], records: list[dict[str, Any]]) -> list[str]:
        """Store the samples ``indices`` (increasing) with their parameters and records (worker records, or
        ``{"error": …}``), one write per dataset, and flush once; each sample's error, ``""`` if it is ok
        (a record that does not fit the layout fails with the mismatch)."""
        h5 = self.h5
        rows = np.asarray(indices, dtype=np.int64)
        if rows.size > 1 and not np.all(np.diff(rows) > 0):
            raise ValueError(f"sample indices must be increasing, got {indices}")
        errors = [record.get("error", "") or self.layout.mismatch(record) for record in records]
        selection = slice(int(rows[0]), int(rows[-1]) + 1) if rows[-1] - rows[0] + 1 == rows.size else rows
        for path in stored_parameters[0]:
            h5[f"parameters/{path}"][selection] = np.array([p[path] for p in stored_parameters])
        for model in self.layout.models:
            for name in _ARRAYS:
                ds = h5[f"{model}/{name}"]
                block = np.full((rows.size, *ds.shape[1:]), np.nan)
                for k, (record, error) in enumerate(zip(records, errors)):
                    if not error:
                        block[k] = record[f"{model}/{name}"]
                ds[selection] = block
        h5["samples/error"][selection] = errors
        h5["samples/status"][selection] = np.array([FAILED if error else OK for error in errors], dtype=np.int8)
        h5.flush()
        return errors

    @contextmanager
    def released(self) -> Iterator[None]:
        """The file closed during the block (no handle for a forked process to inherit), open again after it."""
        self.h5.close()
        try:
            yield
        finally:
            self.h5 = h5py.File(partial_path(self.output), "r+")

    def close(self) -> bool:
        """Close the file; rename ``.partial`` to the output when every sample is stored. True if renamed."""
        complete = not np.any(self.status == NOT_RUN)
        self.h5.close()
        if complete:
            os.replace(partial_path(self.output), self.output)
        return complete


@dataclass(frozen=True)
class SweepData:
    """A sweep file read into memory (complete or ``.partial``); ``ok`` marks the usable samples."""

    path: Path
    femref_version: str
    created: str
    sweep_yaml: str
    base_case_yaml: str
    spec_hash: str
    seed: int
    models: list[str]
    probes: list[str]
    couplers: list[str]
    record_length: int
    force_length: int
    record_end: float
    record_rate: float
    record_source: str
    measurement: dict[str, Any] | None
    parameters: dict[str, NDArray | list[Any]]
    distributions: dict[str, dict[str, Any]]
    status: NDArray[np.int8]
    error: list[str]
    records: dict[str, NDArray[np.float64]]
    coupler_force: dict[str, NDArray[np.float64]]
    peak_coupler_force: dict[str, NDArray[np.float64]]
    wall_time_s: dict[str, NDArray[np.float64]]

    @property
    def ok(self) -> NDArray[np.bool_]:
        return self.status == OK

    @property
    def size(self) -> int:
        return int(self.status.size)

    @property
    def complete(self) -> bool:
        return not np.any(self.status == NOT_RUN)


def read_sweep(path: str | Path) -> SweepData:
    """Read a sweep file; choice and non-numeric grid parameters come back as lists of their values.

    ``path`` may name the ``.partial`` file; a missing final file falls back to its ``.partial``.
    """
    path = Path(path)
    if not path.exists() and partial_path(path).exists():
        path = partial_path(path)
    with h5py.File(path, "r") as h5:
        attrs = dict(h5.attrs)
        models = json.loads(attrs["models"])
        parameters: dict[str, NDArray | list[Any]] = {}
        distributions = {}
        for name, ds in h5.get("parameters", {}).items():
            distributions[name] = json.loads(ds.attrs["distribution"])
            if "values" in ds.attrs:
                values = json.loads(ds.attrs["values"])
                parameters[name] = [values[k] if k >= 0 else None for k in ds[...]]
            else:
                parameters[name] = ds[...]
        arrays = {name: {model: h5[f"{model}/{name}"][...] for model in models} for name in _ARRAYS}
        return SweepData(
            path=path, models=models, parameters=parameters, distributions=distributions, status=h5["samples/status"][...],
            error=list(h5["samples/error"].asstr()[...]), **{key: read(attrs[key]) for key, read in _ATTRS.items()}, **arrays,
        )
