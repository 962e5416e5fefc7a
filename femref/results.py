"""Model results and the HDF5 result file (layout: docs/design.md §4.1), written atomically.

Publishing (issue 18). Every temporary is named ``.<final name>.femref-<pid>.tmp`` (a folder of field files
``.<result name>.femref-<pid>.fields.tmp``) in the target folder, so a later write of the same final name removes
the leftovers of a killed run (:func:`femref.core.publishing.remove_leftovers`). The field files are written first,
their names and SHA-256 recorded in the result (attribute ``field_files`` of ``/<model>/fields``), then renamed
into place, and the result file is renamed last: a kill leaves either the previous pair or new field files beside
the previous result, which :func:`field_files_match` reports. ``FEMREF_TEST_PAUSE_BEFORE_PUBLISH`` (seconds) is a
test hook only: it sleeps between writing the temporaries and the renames, so a test can kill a run there.

Time axes as dimension scales, for xarray: each history group (a probe's, a coupler's, ``energy``) holds its model's
axis as a hard link named ``time`` (harmonic runs: ``omega``, plus ``lambda`` as a second coordinate) to one HDF5
dimension scale attached to its datasets; ``/<model>/measured/time`` is the measured histories' own scale. The
model-level ``/<model>/time`` stays a plain copy: a scale there would be visible (netCDF-4 rules) in ``fields/``
and ``measured/``, whose own differently sized ``time`` would then be misread and break ``xarray.open_datatree``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref import __version__
from femref.core.catalog import SCENE_GROUP
from femref.core.hdf5_writing import hdf5_writer
from femref.core.publishing import create_temporary, atomic_path, discard_temporary, remove_leftovers

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
    **dict.fromkeys(("kinetic", "strain", "dissipated", "external_work", "body_dissipated", "coupler_stored", "coupler_dissipated", "total"), "J"),
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


#: Test hook only (issue 18): seconds to sleep between writing a result's temporaries and renaming them.
TEST_PAUSE_VARIABLE = "FEMREF_TEST_PAUSE_BEFORE_PUBLISH"
#: Attribute of ``/<model>/fields``: JSON ``{field file name: SHA-256 hex digest}`` of its XDMF + HDF5 pair.
FIELD_FILES_ATTRIBUTE = "field_files"
#: Axis names: linked into every history group as coordinates (readers listing outputs skip them).
AXIS_NAMES = ("time", "omega", "lambda")

def field_file_paths(output: str | Path, models: Sequence[str]) -> list[Path]:
    """The field files a result file ``output`` gets beside it for each of ``models`` that writes fields:
    ``<stem>_<model>_fields.xdmf`` and its HDF5 companion ``<stem>_<model>_fields.h5``
    (:func:`field_file_name`; meshio names the companion after the XDMF file)."""
    output = Path(output)
    pairs = [output.with_name(field_file_name(output, model)) for model in models]
    return [file for xdmf in pairs for file in (xdmf, xdmf.with_suffix(".h5"))]


def result_field_files(results: str | Path, name: str = "RESULTS.h5") -> dict[str, Path]:
    """The field files of the result file ``results`` as inputs for :func:`check_output_path`, keyed
    ``XDMF field file of model <model> of <name>`` (``HDF5 field file …``): the names it records, or for a file
    written before they were, the names femref gives them (:func:`field_file_paths`). ``OSError`` when ``results``
    is not a readable HDF5 file."""
    results = Path(results)
    found: dict[str, Path] = {}
    with h5py.File(results, "r") as h5:
        for model, group in h5.items():
            if not (isinstance(group, h5py.Group) and isinstance(group.get("fields"), h5py.Group)):
                continue
            try:
                names = sorted(dict(json.loads(group["fields"].attrs[FIELD_FILES_ATTRIBUTE])))
            except (KeyError, TypeError, ValueError):  # none recorded (or unreadable): the names femref gives them
                names = [path.name for path in field_file_paths(results, [model])]
            for file in names:
                kind = {".xdmf": "XDMF field file", ".h5": "HDF5 field file"}.get(Path(file).suffix, f"field file {file}")
                found[f"{kind} of model {model} of {name}"] = results.parent / file
    return found


def write_results(
    path: str | Path,
    case_yaml: str,
    results: list[ModelResult],
    scores: dict[str, dict[str, Any]] | None = None,
    extra: Callable[[h5py.File], None] | None = None,
    scene: dict[str, Any] | None = None,
) -> list[Path]:
    """Write the result file and its field files (module docstring: publishing); return the paths written.

    ``scene``: the resolved scene's facts (``Scene.facts()``), attributes of ``/scene``; ``extra(h5)`` adds groups of
    its own (e.g. ``/choice``) before the file is renamed.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    with contextlib.ExitStack() as cleanup:
        staged: dict[str, list[Path]] = {}
        if any(result.fields for result in results):
            staging = create_temporary(path, part="fields", folder=True)
            cleanup.callback(discard_temporary, staging)  # and its writer sidecar
            for result in results:
                if result.fields:
                    staged[result.model] = _write_xdmf_pair(staging, field_file_name(path, result.model), result.fields)
        published = []
        with atomic_path(path) as tmp_name:
            with hdf5_writer(tmp_name) as h5:  # a full disk: one OSError, never an HDF5 crash
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
                    if result.model in staged:
                        digests = {file.name: _sha256(file) for file in staged[result.model]}
                        h5[f"{result.model}/fields"].attrs[FIELD_FILES_ATTRIBUTE] = json.dumps(digests, sort_keys=True)
                for model, metrics in (scores or {}).items():
                    group = h5.require_group(f"scores/{model}")
                    for key, value in metrics.items():
                        group.attrs[key] = value
                if extra is not None:
                    extra(h5)
            _test_pause()
            for files in staged.values():  # the field files first, the result (on leaving the block) last
                published += _publish(files, path.parent)
    return [path, *published]


def field_file_name(path: str | Path, model: str) -> str:
    """The XDMF field file of ``model`` beside the result file ``path``: ``<stem>_<model>_fields.xdmf``."""
    return f"{Path(path).stem}_{model}_fields.xdmf"


def field_files_match(path: str | Path) -> list[str]:
    """Problems of the field files recorded in the result file ``path``: missing, or not the ones it was written with
    (left by another run, module docstring); empty when all match (or none is recorded, a file before issue 18)."""
    path = Path(path)
    problems = []
    with h5py.File(path, "r") as h5:
        recorded = {
            model: group["fields"].attrs[FIELD_FILES_ATTRIBUTE]
            for model, group in h5.items()
            if isinstance(group, h5py.Group) and isinstance(group.get("fields"), h5py.Group) and FIELD_FILES_ATTRIBUTE in group["fields"].attrs
        }
    for model, text in recorded.items():
        try:
            digests = dict(json.loads(text))
        except (TypeError, ValueError):
            problems.append(f"{path}: /{model}/fields attribute {FIELD_FILES_ATTRIBUTE} is not a JSON object of file names and SHA-256")
            continue
        for name, digest in sorted(digests.items()):
            file = path.parent / name
            if not file.is_file():
                problems.append(f"{file}: field file of model {model} missing")
            elif _sha256(file) != digest:
                problems.append(f"{file}: field file of model {model} is not the one {path.name} was written with (SHA-256 differs): another run's")
    return problems


def _sha256(file: Path) -> str:
    digest = hashlib.sha256()
    with open(file, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _test_pause() -> None:
    """Test hook only: sleep ``$FEMREF_TEST_PAUSE_BEFORE_PUBLISH`` seconds (unset: none) before the renames."""
    seconds = os.environ.get(TEST_PAUSE_VARIABLE)
    if seconds:
        time.sleep(float(seconds))


def _publish(files: list[Path], folder: Path) -> list[Path]:
    """Rename each of ``files`` (in a staging folder on the same file system) into ``folder``."""
    for file in files:
        os.replace(file, folder / file.name)
    return [folder / file.name for file in files]


def _dataset(group: h5py.Group, name: str, data: NDArray) -> h5py.Dataset:
    ds = group.create_dataset(name, data=np.asarray(data))
    if name in UNITS:
        ds.attrs["units"] = UNITS[name]
    return ds


def _write_model(group: h5py.Group, result: ModelResult) -> None:
    group.attrs["status"] = result.status
    group.attrs["message"] = result.message
    group.attrs["wall_time_s"] = float(result.wall_time_s)
    group.attrs["settings"] = json.dumps(result.settings, default=_json_default, sort_keys=True)
    for name, axis in result.axes.items():
        _dataset(group, name, axis)
    items = [*(("probes/" + p, out) for p, out in result.probes.items()), *(("couplers/" + c, out) for c, out in result.couplers.items()),
             *([("energy", result.energy)] if result.energy else [])]
    histories = []
    for path, outputs in items:
        histories.append(sub := group.require_group(path))
        for name, data in outputs.items():
            _dataset(sub, name, data)
    if result.energy and "energy_balance_error" in result.settings:
        group["energy"].attrs["balance_error"] = float(result.settings["energy_balance_error"])
    axis = next((name for name in ("time", "omega") if name in result.axes), None)
    if axis is not None:
        extra = {"lambda": result.axes["lambda"]} if axis == "omega" and "lambda" in result.axes else {}
        _link_axis(histories, axis, result.axes[axis], extra)
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
        if "time" in sub:
            probes = [sub[name] for name in list(result.measured) + list(result.measured_bending) if name != "time"]
            _link_axis(list({g.name: g for g in probes}.values()), "time", sub["time"], {}, scale=sub["time"])
    if result.fields:
        sub = group.create_group("fields")
        for name, data in result.fields.items():
            _dataset(sub, name, data)
        if {"x", "u", "time"} <= sub.keys() and sub["u"].shape == (len(sub["time"]), len(sub["x"])):
            for axis, name in enumerate(("time", "x")):  # the field's own axes (its times are a subset)
                sub[name].make_scale(name)
                sub["u"].dims[axis].attach_scale(sub[name])


def _link_axis(groups: list[h5py.Group], name: str, values, extra: dict[str, NDArray], scale: h5py.Dataset | None = None) -> None:
    """Make ``values`` the dimension scale ``name`` of the first axis of every dataset in ``groups`` that runs along
    it, one scale object hard-linked into each such group with the ``extra`` coordinates (module docstring: time
    axes). ``scale`` is an existing dataset to use (the measured ``time``); else the first group gets a new one."""
    size = len(values)
    coordinates: dict[str, h5py.Dataset] = {}
    for group in groups:
        along = [ds for key, ds in group.items() if isinstance(ds, h5py.Dataset) and key not in AXIS_NAMES and ds.ndim >= 1 and ds.shape[0] == size]
        if not along:
            continue
        if scale is None:
            scale = _dataset(group, name, values)
        if not scale.is_scale:
            scale.make_scale(name)
        if name not in group:
            group[name] = scale
        for coordinate, data in extra.items():
            if coordinate not in coordinates:
                coordinates[coordinate] = _dataset(group, coordinate, data)
                coordinates[coordinate].dims[0].attach_scale(scale)
            elif coordinate not in group:
                group[coordinate] = coordinates[coordinate]
        for ds in along:
            ds.dims[0].attach_scale(scale)
            if extra:
                ds.attrs["coordinates"] = " ".join(extra)


def _write_xdmf_pair(folder: Path, name: str, fields: dict[str, NDArray]) -> list[Path]:
    """Write the XDMF + HDF5 time series of the displacement field on the 1D mesh (points padded to 3D: meshio
    and VTK need three components) as the file ``name`` and its companion into ``folder``; return both paths."""
    import meshio

    x, u, times = fields["x"], fields["u"], fields["time"]
    points = np.zeros((x.size, 3))
    points[:, 0] = x
    cells = [("line", np.stack([np.arange(x.size - 1), np.arange(1, x.size)], axis=1))]
    before = set(folder.iterdir())
    # meshio opens the companion .h5 relative to the working directory: write from inside the folder
    with contextlib.chdir(folder), meshio.xdmf.TimeSeriesWriter(name) as writer:
        writer.write_points_cells(points, cells)
        for t, values in zip(times, u):
            writer.write_data(float(t), point_data={"u": np.asarray(values, dtype=float)})
    return sorted(set(folder.iterdir()) - before)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
