"""A femref result file (docs/design.md §4) read into plain dataclasses for the report.

Everything the report shows is read here, once, so that the figure and page modules
never touch HDF5. A file that is missing, is not HDF5, or is not a femref result file
(no ``case_yaml`` root attribute) raises :class:`ReportInputError`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import yaml
from numpy.typing import NDArray

from femref.core.catalog import CHOICE_GROUP, SCENE_GROUP, SCORES_GROUP
from femref.results import AXIS_NAMES, field_files_match

FAILED = "failed"


class ReportInputError(ValueError):
    """The input is not a readable femref result file; the message says why."""


@dataclass(frozen=True)
class ModelData:
    """One model's group: status, axis and outputs (arrays in SI units, as stored).

    ``axis_name`` is ``"time"`` (s) or ``"lambda"`` (1), or None when the group stores
    none (a peak-only network estimator, or a model sharing the reference's time grid).
    ``probes`` maps a probe name (``<car>/<sensor>`` in impacts) to its outputs;
    ``couplers`` maps a coupler to ``force`` (N, history) and/or ``peak_force`` (N, a
    scalar array; impacts also ``closure``, m, compression positive); ``measured`` holds the
    measurement chain's records and their ``time``; ``energy`` the energy bookkeeping (J; impacts:
    ``kinetic``, ``strain``, ``body_dissipated``, ``coupler_stored``, ``coupler_dissipated``, ``total``).
    """

    name: str
    status: str
    message: str
    wall_time_s: float
    axis_name: str | None = None
    axis: NDArray | None = None
    probes: dict[str, dict[str, NDArray]] = field(default_factory=dict)
    couplers: dict[str, dict[str, NDArray]] = field(default_factory=dict)
    measured_time: NDArray | None = None
    measured: dict[str, NDArray] = field(default_factory=dict)
    fields: dict[str, NDArray] = field(default_factory=dict)
    energy: dict[str, NDArray] = field(default_factory=dict)
    outside_range: list[tuple[float, float]] = field(default_factory=list)  # (t0, t1) s where a quasi-rigid car is outside its range
    outside_limit: float = math.nan  # the ε_loc above which it is (femref.run.validity)

    @property
    def ok(self) -> bool:
        return self.status != FAILED


@dataclass(frozen=True)
class Rung:
    """One rung of a tolerance run's ladder (``/choice``, one row of its datasets), cheapest first."""

    label: str
    family: str
    resolution: int
    predicted_cost_us: float
    ran: bool
    status: str
    wall_time_s: float
    peak_coupler_force: float
    estimate: float
    basis: str


@dataclass(frozen=True)
class Choice:
    """A tolerance run's model choice (``/choice``, written by :mod:`femref.choice.output`).

    ``estimate`` is the chosen run's estimated relative error of ``output``; ``met`` whether
    it is within ``tolerance``; ``rungs`` the ladder, cheapest first.
    """

    tolerance: float
    output: str
    output_description: str
    chosen: str
    met: bool
    estimate: float
    basis: str
    epsilon_load: float
    rungs: list[Rung]


@dataclass(frozen=True)
class Epsilon:
    """The scene's small parameter ``ε = (T_wave/T_load)²`` as the run stored it, or why it is not there."""

    value: float | None
    problem: str = ""


@dataclass(frozen=True)
class ResultFile:
    """Everything the report shows of one result file."""

    path: Path
    femref_version: str
    created: str
    case_yaml: str
    kind: str
    models: dict[str, ModelData]
    scores: dict[str, dict[str, Any]]
    epsilon: Epsilon
    choice: Choice | None = None
    field_file_problems: tuple[str, ...] = ()  # ParaView field files beside the result that are not its own (femref.results.field_files_match)

    @property
    def ok_models(self) -> list[ModelData]:
        return [m for m in self.models.values() if m.ok]

    @property
    def failed_models(self) -> list[ModelData]:
        return [m for m in self.models.values() if not m.ok]


def read_result_file(path: str | Path) -> ResultFile:
    """Read the result file at ``path``; raise :class:`ReportInputError` for bad input."""
    path = Path(path)
    if not path.exists():
        raise ReportInputError(f"{path}: result file not found")
    if not path.is_file():
        raise ReportInputError(f"{path}: not a file")
    if not h5py.is_hdf5(path):
        raise ReportInputError(f"{path}: not an HDF5 file")
    try:
        with h5py.File(path, "r") as h5:
            return _read_open_file(path, h5)
    except OSError as error:
        raise ReportInputError(f"{path}: cannot read the HDF5 file: {error}") from None


def _read_open_file(path: Path, h5: h5py.File) -> ResultFile:
    if "case_yaml" not in h5.attrs:
        raise ReportInputError(f"{path}: not a femref result file (no 'case_yaml' root attribute)")
    case_yaml = _text(h5.attrs["case_yaml"])
    models = {
        name: _read_model(name, group)
        for name, group in h5.items()
        if name not in (SCORES_GROUP, SCENE_GROUP, CHOICE_GROUP) and isinstance(group, h5py.Group)
    }
    choice = _choice(h5[CHOICE_GROUP]) if isinstance(h5.get(CHOICE_GROUP), h5py.Group) else None
    if choice is not None:  # a tolerance run's models in the ladder's order, cheapest first
        order = {rung.label: k for k, rung in enumerate(choice.rungs)}
        models = dict(sorted(models.items(), key=lambda item: order.get(item[0], len(order))))
    scores = {}
    if SCORES_GROUP in h5:
        scores = {name: attrs_of(group.attrs) for name, group in h5[SCORES_GROUP].items()}
    return ResultFile(
        path=path,
        femref_version=_text(h5.attrs.get("femref_version", "unknown")),
        created=_text(h5.attrs.get("created", "unknown")),
        case_yaml=case_yaml,
        kind=_scene_kind(case_yaml, models),
        models=models,
        scores=scores,
        epsilon=_epsilon(h5),
        choice=choice,
        field_file_problems=tuple(field_files_match(path)),
    )


def _read_model(name: str, group: h5py.Group) -> ModelData:
    axis_name = next((a for a in ("time", "lambda") if isinstance(group.get(a), h5py.Dataset)), None)
    measured = _datasets_by_parent(group["measured"], "acceleration") if "measured" in group else {}
    return ModelData(
        name=name,
        status=_text(group.attrs.get("status", "ok")),
        message=_text(group.attrs.get("message", "")),
        wall_time_s=float(group.attrs.get("wall_time_s", math.nan)),
        axis_name=axis_name,
        axis=group[axis_name][()] if axis_name else None,
        probes=_datasets_by_parent(group["probes"]) if "probes" in group else {},
        couplers=_datasets_by_parent(group["couplers"]) if "couplers" in group else {},
        measured_time=group["measured/time"][()] if "measured/time" in group else None,
        measured={k: v["acceleration"] for k, v in measured.items()},
        fields={k: v[()] for k, v in group["fields"].items()} if "fields" in group else {},
        energy={k: v[()] for k, v in group["energy"].items() if isinstance(v, h5py.Dataset) and k not in AXIS_NAMES} if "energy" in group else {},
        **_outside_range(group),
    )


def _outside_range(group: h5py.Group) -> dict[str, Any]:
    """``outside_range`` and ``outside_limit`` of :class:`ModelData`: the intervals a quasi-rigid run recorded as
    outside its range and the limit (``settings["quasi_rigid_range"]``, femref.run.validity); none when the
    settings do not parse or hold none."""
    try:
        marked = json.loads(_text(group.attrs.get("settings", "{}"))).get("quasi_rigid_range") or {}
        return {"outside_range": [(float(a), float(b)) for a, b in marked.get("outside", [])], "outside_limit": float(marked.get("limit", math.nan))}
    except (ValueError, TypeError, AttributeError):
        return {}


def _choice(group: h5py.Group) -> Choice:
    """``/choice``: its attributes and one :class:`Rung` per row of its datasets (missing columns read as unknown)."""
    labels = [_text(v) for v in group["label"][()]] if "label" in group else []
    n = len(labels)

    def column(name: str, default: Any) -> list:
        if name not in group or group[name].shape != (n,):
            return [default] * n
        values = group[name][()]
        return [_text(v) if isinstance(v, bytes) else v.item() if isinstance(v, np.generic) else v for v in values]

    columns = zip(*(column(name, default) for name, default, _ in _RUNG_COLUMNS))
    rungs = [Rung(label, *(read(value) for (_, _, read), value in zip(_RUNG_COLUMNS, row))) for label, row in zip(labels, columns)]
    attrs = attrs_of(group.attrs)
    return Choice(**{name: read(attrs.get(name, default)) for name, default, read in _CHOICE_ATTRS}, rungs=rungs)


def _same(value: Any) -> Any:
    return value


#: ``/choice``'s datasets after ``label``, in :class:`Rung`'s order: name, value when missing, how it is read.
_RUNG_COLUMNS = (("family", "", _same), ("resolution", 0, int), ("predicted_cost", math.nan, float), ("ran", False, bool),
                 ("status", "", _same), ("wall_time_s", math.nan, float), ("peak_coupler_force", math.nan, float),
                 ("estimate", math.inf, float), ("basis", "", _same))
#: ``/choice``'s attributes, in :class:`Choice`'s order.
_CHOICE_ATTRS = (("tolerance", math.nan, float), ("output", "", str), ("output_description", "", str), ("chosen", "", str),
                 ("met", False, bool), ("estimate", math.inf, float), ("basis", "", str), ("epsilon_load", math.nan, float))


def _datasets_by_parent(group: h5py.Group, only: str | None = None) -> dict[str, dict[str, NDArray]]:
    """Datasets under ``group`` (named ``only``, or all) keyed by their parent's path (the probe or coupler name), then their name."""
    found: dict[str, dict[str, NDArray]] = {}

    def visit(name: str, obj: Any) -> None:
        if isinstance(obj, h5py.Dataset) and "/" in name:
            parent, leaf = name.rsplit("/", 1)
            if leaf in AXIS_NAMES:  # the model's axis, linked into each history group as its coordinate
                return
            if only is None or leaf == only:
                found.setdefault(parent, {})[leaf] = obj[()]

    group.visititems(visit)
    return found


def _scene_kind(case_yaml: str, models: dict[str, ModelData]) -> str:
    """``kind`` of the resolved case; if the YAML cannot say, guessed from the stored outputs."""
    try:
        data = yaml.safe_load(case_yaml)
    except yaml.YAMLError:
        data = None
    if isinstance(data, dict) and isinstance(data.get("kind"), str):
        return data["kind"]
    if any(m.axis_name == "lambda" for m in models.values()):
        return "harmonic"
    return "impact" if any(m.couplers for m in models.values()) else "transient"


def _epsilon(h5: h5py.File) -> Epsilon:
    """``ε`` as the run stored it in ``/scene`` (files written before it was stored have none)."""
    facts = h5.get(SCENE_GROUP)
    if not isinstance(facts, h5py.Group) or "epsilon" not in facts.attrs:
        return Epsilon(None, "this result file does not record it (written by a femref without /scene)")
    return Epsilon(float(facts.attrs["epsilon"]))


def _text(value: Any) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


def attrs_of(attrs: h5py.AttributeManager) -> dict[str, Any]:
    """HDF5 attributes as Python scalars and strings (:func:`attr_value`)."""
    return {key: attr_value(value) for key, value in attrs.items()}


def attr_value(value: Any) -> Any:
    """An HDF5 attribute as a Python scalar or string."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.generic) or (isinstance(value, np.ndarray) and value.ndim == 0):
        return value.item()
    return value
