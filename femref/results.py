"""Model results and the HDF5 result file of docs/design.md §4, written atomically.

Layout::

    /                                attrs: femref_version, case_yaml, created
    /scene                           attrs: kind, epsilon, wave_travel_time, load_time (s), units (JSON)
    /<model>/                        attrs: status, message, wall_time_s, settings (JSON); a failed impact
                                     run keeps its histories up to the failing step (NaN after)
    /<model>/time | omega, lambda
    /<model>/probes/<probe>/acceleration, displacement (, axial_force; impacts: velocity, and on cars that
                                     bend vertical_* and pitch_* with pitch_rate)
    /<model>/couplers/<coupler>/force
    /<model>/couplers/<coupler>/peak_force   () N, network estimators (ann_<name>): the estimated peak, no time axis
    /<model>/energy/kinetic, strain, dissipated, external_work   (+ attr balance_error)
                                     impacts: kinetic, strain, body_dissipated, coupler_stored,
                                     coupler_dissipated, total
    /<model>/measured/time, /<model>/measured/<probe>/acceleration   (measurement chain)
    /<model>/measured/<probe>/vertical_acceleration, pitch_rate      (measurement chain, cars that bend)
    /<model>/fields/x, /<model>/fields/u
    /scores/<model>/                 attrs: reference, one per metric
    /choice/                         a model choice (femref run --tolerance; femref.choice.output)

The file is written under a temporary name in the target folder and renamed when
complete, so a crash never leaves a truncated file under the final name. Fields are
also written as an XDMF + HDF5 time series (meshio) that ParaView opens directly.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from datetime import datetime, timezone
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref import __version__
from femref.core.catalog import SCENE_GROUP

UNITS = {
    "time": "s",
    "omega": "rad/s",
    "lambda": "1",
    "acceleration": "m/s^2",
    "displacement": "m",
    "velocity": "m/s",
    "vertical_velocity": "m/s (up positive)",
    "pitch_rate": "rad/s (front rising positive)",
    "vertical_acceleration": "m/s^2 (up positive)",
    "vertical_displacement": "m (up positive)",
    "pitch_acceleration": "rad/s^2 (front rising positive)",
    "pitch_displacement": "rad (front rising positive)",
    "axial_force": "N (tension positive)",
    "force": "N (compression positive)",
    "peak_force": "N (compression positive)",
    "x": "m",
    "u": "m",
    "kinetic": "J",
    "strain": "J",
    "dissipated": "J",
    "external_work": "J",
    "body_dissipated": "J",
    "coupler_stored": "J",
    "coupler_dissipated": "J",
    "total": "J",
    "closure": "m (compression positive)",
}


#: The scores' attribute naming each undefined (NaN) metric and why: ``"<metric>: <reason>; …"``.
UNDEFINED = "undefined"
SCENE_UNITS = {"epsilon": "1", "wave_travel_time": "s", "load_time": "s"}


@dataclass
class ModelResult:
    """What every model returns to the runner: outputs, status and work counters."""

    model: str
    status: str = "ok"
    message: str = ""
    wall_time_s: float = 0.0
    settings: dict[str, Any] = field(default_factory=dict)
    axes: dict[str, NDArray] = field(default_factory=dict)  # "time" or "omega" and "lambda"
    probes: dict[str, dict[str, NDArray]] = field(default_factory=dict)
    couplers: dict[str, dict[str, NDArray]] = field(default_factory=dict)
    energy: dict[str, NDArray] = field(default_factory=dict)
    fields: dict[str, NDArray] = field(default_factory=dict)  # "x" (Nx,), "u" (Nt_out, Nx), "time"
    measured: dict[str, NDArray] = field(default_factory=dict)  # "time" and probe → measured acceleration
    measured_bending: dict[str, dict[str, NDArray]] = field(default_factory=dict)  # probe → measured vertical_acceleration, pitch_rate (cars that bend)

    @classmethod
    def failed(cls, model: str, message: str, wall_time_s: float = 0.0, settings: dict | None = None) -> "ModelResult":
        return cls(model=model, status="failed", message=message, wall_time_s=wall_time_s, settings=settings or {})

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def set_probe_outputs(self, probe_names, outputs: dict[str, NDArray]) -> None:
        """Store outputs of shape ``(N_axis, N_probes)`` as per-probe histories, keyed by probe name."""
        self.probes = {name: {k: v[:, j] for k, v in outputs.items()} for j, name in enumerate(probe_names)}


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write; renamed to ``path`` when the block ends without error.

    On any error (or interrupt) the temporary file is removed, so nothing is ever left
    under the final name half-written (docs/design.md §4). The file gets the permissions of
    a newly created file (umask), not ``mkstemp``'s private 0600. Creates the folder.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_results(
    path: str | Path,
    case_yaml: str,
    results: list[ModelResult],
    scores: dict[str, dict[str, Any]] | None = None,
    extra: Callable[[h5py.File], None] | None = None,
    scene: dict[str, Any] | None = None,
) -> list[Path]:
    """Write the result file (and XDMF field files) atomically; return the paths written.

    ``scene`` holds the facts of the resolved scene the report shows (kind, ε and the times it
    is made of: ``Scene.facts()``), written as attributes of ``/scene`` with units. ``extra(h5)``
    adds groups of its own (e.g. ``/choice``) before the file is renamed.
    """
    path = Path(path)
    written = []
    with atomic_path(path) as tmp_name, h5py.File(tmp_name, "w") as h5:
        h5.attrs["femref_version"] = __version__
        h5.attrs["case_yaml"] = case_yaml
        h5.attrs["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        if scene:
            group = h5.create_group(SCENE_GROUP)
            for key, value in scene.items():
                group.attrs[key] = value
            group.attrs["units"] = json.dumps({key: SCENE_UNITS[key] for key in scene if key in SCENE_UNITS})
        for result in results:
            _write_model(h5.create_group(result.model), result)
        for model, metrics in (scores or {}).items():
            group = h5.require_group(f"scores/{model}")
            for key, value in metrics.items():
                group.attrs[key] = value
        if extra is not None:
            extra(h5)
    written.append(path)
    for result in results:
        if result.fields:
            written.extend(write_xdmf_fields(path.with_name(f"{path.stem}_{result.model}_fields.xdmf"), result.fields))
    return written


def _dataset(group: h5py.Group, name: str, data: NDArray) -> None:
    ds = group.create_dataset(name, data=np.asarray(data))
    if name in UNITS:
        ds.attrs["units"] = UNITS[name]


def _write_model(group: h5py.Group, result: ModelResult) -> None:
    group.attrs["status"] = result.status
    group.attrs["message"] = result.message
    group.attrs["wall_time_s"] = float(result.wall_time_s)
    group.attrs["settings"] = json.dumps(result.settings, default=_json_default, sort_keys=True)
    for name, axis in result.axes.items():
        _dataset(group, name, axis)
    for probe, outputs in result.probes.items():
        sub = group.require_group(f"probes/{probe}")
        for name, data in outputs.items():
            _dataset(sub, name, data)
    for coupler, outputs in result.couplers.items():
        sub = group.require_group(f"couplers/{coupler}")
        for name, data in outputs.items():
            _dataset(sub, name, data)
    if result.energy:
        sub = group.create_group("energy")
        for name, data in result.energy.items():
            _dataset(sub, name, data)
        if "energy_balance_error" in result.settings:
            sub.attrs["balance_error"] = float(result.settings["energy_balance_error"])
    if result.measured:
        sub = group.create_group("measured")
        for name, data in result.measured.items():
            if name == "time":
                _dataset(sub, "time", data)
            else:
                _dataset(sub.require_group(name), "acceleration", data)
        for name, outputs in result.measured_bending.items():
            for quantity, data in outputs.items():
                _dataset(sub.require_group(name), quantity, data)
    if result.fields:
        sub = group.create_group("fields")
        for name, data in result.fields.items():
            _dataset(sub, name, data)


def write_xdmf_fields(path: Path, fields: dict[str, NDArray]) -> list[Path]:
    """XDMF + HDF5 time series of the displacement field on the 1D mesh (points padded to 3D).

    Written in a temporary folder and moved into place, so the XDMF file's reference to
    its HDF5 companion stays valid and no partial pair is left behind.
    """
    import meshio

    x, u, times = fields["x"], fields["u"], fields["time"]
    points = np.zeros((x.size, 3))
    points[:, 0] = x
    cells = [("line", np.stack([np.arange(x.size - 1), np.arange(1, x.size)], axis=1))]
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        # meshio opens the companion .h5 relative to the working directory: write from inside tmp
        with contextlib.chdir(tmp), meshio.xdmf.TimeSeriesWriter(path.name) as writer:
            writer.write_points_cells(points, cells)
            for t, values in zip(times, u):
                writer.write_data(float(t), point_data={"u": np.asarray(values, dtype=float)})
        moved = []
        for produced in sorted(Path(tmp).iterdir()):
            target = path.parent / produced.name
            shutil.move(str(produced), target)
            moved.append(target)
    return moved


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
