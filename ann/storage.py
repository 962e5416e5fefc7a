"""Save and load a trained feature pipeline + network as plain arrays (``.npz``).

No pickle anywhere: every entry is a numeric or unicode numpy array, written
with ``numpy.savez`` and read with ``numpy.load(..., allow_pickle=False)``.
Keys are namespaced ``pipeline/…``, ``network/…``; ``format_version`` and
``network_kind`` say how to rebuild the objects, and ``metadata`` is a JSON
string (units, training data, scores, …).  A loaded network predicts with
numpy alone; no scikit-learn object is stored or needed.

Reading is checked before anything large is allocated, so that a hostile or broken
file is refused with :class:`ModelFileError` (a ``ValueError``) instead of exhausting
memory or giving a network that predicts NaN:

1. the zip directory is read first: every member must be one of the arrays a file of
   its network kind holds (by name; unknown members are refused unread), stored or
   deflated, and all members together may declare at most :data:`MAX_FILE_BYTES`
   uncompressed;
2. each member's ``.npy`` header is read before its data: a plain number, boolean or
   text dtype, at most :data:`MAX_ARRAY_VALUES` values, and a shape whose size is
   exactly the data the member holds (a header cannot ask for more memory than the
   file declares);
3. the arrays must fit together: shapes of the scaler and of every layer, the feature
   count the pipeline settings give, record sizes up to :data:`MAX_RECORD_VALUES`,
   at most :data:`MAX_LAYERS` layers; every weight, bias, centre, width and scaler
   value must be finite.
"""

from __future__ import annotations

import json
import math
import os
import re
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from typing import IO, Any

import numpy as np
from numpy.lib import format as npy_format

from ann.backprop import UNITS
from ann.features import NORMALISATIONS, FeaturePipeline
from ann.networks import ACTIVATIONS, BASES, NETWORKS, MLPForceRegressor, MomentumMLP, RBFNetwork

FORMAT_VERSION = 1

#: Most bytes all arrays of a model file may declare uncompressed (the networks in cases/networks hold 0.3 MB).
MAX_FILE_BYTES = 256 * 2**20
#: Most values in one array of a model file.
MAX_ARRAY_VALUES = 2**25
#: Most values in one record the pipeline reads or resamples to (channels × samples, channels × length).
MAX_RECORD_VALUES = 2**24
#: Most layers of a multilayer perceptron in a model file.
MAX_LAYERS = 64
#: Longest ``.npy`` header read (numpy's own default).
MAX_HEADER_BYTES = 10_000


class ModelFileError(ValueError):
    """A file that is not a well-formed ann model file; the message names the file and the broken rule."""


Network = MLPForceRegressor | MomentumMLP | RBFNetwork


@dataclass(frozen=True)
class Estimator:
    """A fitted pipeline and network used together: records in, forces out.

    Predictions always go through the saved pipeline, so the network never sees
    features computed with other settings or another scaler.
    """

    pipeline: FeaturePipeline
    network: Network

    def predict(self, records: np.ndarray, rate: float, extras: np.ndarray | None = None) -> np.ndarray:
        """Forces for records ``(N, channels, samples)`` sampled at ``rate`` Hz.

        ``extras`` (N, k): the known scalar inputs named by ``pipeline.settings.extras``.
        """
        return self.network.predict(self.pipeline.transform(records, rate, extras))


def save(path: str | os.PathLike, pipeline: FeaturePipeline, network: Network, metadata: dict[str, Any]) -> None:
    """Write ``pipeline``, ``network`` and JSON-serialisable ``metadata`` to ``path`` (.npz)."""
    try:
        metadata_json = json.dumps(metadata)
    except TypeError as exc:
        raise ValueError(f"metadata must be JSON-serialisable: {exc}") from exc
    arrays: dict[str, np.ndarray] = {
        "format_version": np.array(FORMAT_VERSION, dtype=np.int64),
        "network_kind": np.array(network.kind),
        "metadata": np.array(metadata_json),
    }
    arrays.update({f"pipeline/{k}": v for k, v in pipeline.to_arrays().items()})
    arrays.update({f"network/{k}": v for k, v in network.to_arrays().items()})
    for key, value in arrays.items():
        assert np.asarray(value).dtype != object, f"{key} would need pickle"
    with open(path, "wb") as handle:  # a file handle stops savez appending ".npz"
        np.savez(handle, **arrays)


def load(path: str | os.PathLike) -> tuple[FeaturePipeline, Network, dict[str, Any]]:
    """Read ``(pipeline, network, metadata)`` written by ``save``.

    Raises :class:`ModelFileError` (a ``ValueError``) naming the file when it is not a
    zip archive, its format version is not this module's, or it breaks one of the checks
    of the module docstring; ``OSError`` when it cannot be read at all.
    """
    where = os.fspath(path)
    try:
        with zipfile.ZipFile(path) as archive:
            arrays = _read_arrays(archive, where)
    except (zipfile.BadZipFile, EOFError, NotImplementedError, RuntimeError) as error:
        # a truncated or corrupt archive, a bad CRC, an encrypted member
        raise ModelFileError(f"{where}: not a readable zip archive (.npz): {error}") from None
    try:
        metadata = json.loads(str(arrays["metadata"]))
    except json.JSONDecodeError as error:
        raise ModelFileError(f"{where}: metadata is not JSON text: {error}") from None
    except RecursionError:
        raise ModelFileError(f"{where}: metadata is JSON nested too deeply to read") from None
    kind = str(arrays["network_kind"])
    pipeline_arrays, network_arrays = _section(arrays, "pipeline/"), _section(arrays, "network/")
    try:
        features = _check_pipeline_arrays(pipeline_arrays)
        _NETWORK_CHECKS[kind](network_arrays, features)
    except ModelFileError as error:
        raise ModelFileError(f"{where}: {error}") from None
    pipeline = FeaturePipeline.from_arrays(pipeline_arrays)
    network = NETWORKS[kind].from_arrays(network_arrays)
    return pipeline, network, metadata


def load_estimator(path: str | os.PathLike) -> tuple[Estimator, dict[str, Any]]:
    """``load`` wrapped as an ``Estimator`` plus the metadata."""
    pipeline, network, metadata = load(path)
    return Estimator(pipeline, network), metadata


def _section(arrays: dict[str, np.ndarray], prefix: str) -> dict[str, np.ndarray]:
    return {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}


# -- reading a model file without trusting it (module docstring) -------------

NUMBER, INTEGER, BOOLEAN, TEXT = "iuf", "iu", "b", "U"

#: Top-level and pipeline members: name → (dtype kinds, allowed ndims, required).
_TOP_MEMBERS: dict[str, tuple[str, tuple[int, ...], bool]] = {
    "format_version": (INTEGER, (0,), True),
    "network_kind": (TEXT, (0,), True),
    "metadata": (TEXT, (0,), True),
}
_PIPELINE_MEMBERS: dict[str, tuple[str, tuple[int, ...], bool]] = {
    "length": (INTEGER, (0,), True),
    "rate": (NUMBER, (0,), True),
    "lowpass": (NUMBER, (0,), True),
    "spectrum": (BOOLEAN, (0,), True),
    "normalise": (TEXT, (0,), True),
    "extras": (TEXT, (1,), False),  # files before the extras have none
    "channels": (INTEGER, (0,), True),
    "samples": (INTEGER, (0,), True),
    "mean": (NUMBER, (1,), True),
    "scale": (NUMBER, (1,), True),
}
#: Network members of each kind: fixed names, and per-layer names ``<prefix><i>`` (i < layers).
_NETWORK_MEMBERS: dict[str, dict[str, tuple[str, tuple[int, ...], bool]]] = {
    "mlp": {
        "activation": (TEXT, (0,), True),
        "layers": (INTEGER, (0,), True),
        "target_mean": (NUMBER, (0, 1), True),
        "target_scale": (NUMBER, (0, 1), True),
        "n_iter": (INTEGER, (0,), True),
        "converged": (BOOLEAN, (0,), True),
        "log_target": (BOOLEAN, (0,), False),  # files before the log target have none
        "loss_curve": (NUMBER, (1,), False),  # files before the loss curve have none
    },
    "momentum_mlp": {
        "units": (TEXT, (1,), True),
        "layers": (INTEGER, (0,), True),
        "target_offset": (NUMBER, (0, 1), True),
        "target_scale": (NUMBER, (0, 1), True),
        "n_iter": (INTEGER, (0,), True),
        "converged": (BOOLEAN, (0,), True),
        "log_target": (BOOLEAN, (0,), True),
        "loss_curve": (NUMBER, (1,), True),
        "learning_rate": (NUMBER, (0,), True),
        "momentum": (NUMBER, (0,), True),
        "epochs": (INTEGER, (0,), True),
        "batch_size": (INTEGER, (0,), True),
        "alpha": (NUMBER, (0,), True),
        "tol": (NUMBER, (0,), True),
        "n_iter_no_change": (INTEGER, (0,), True),
        "seed": (INTEGER, (0,), True),
    },
    "rbf": {
        "basis": (TEXT, (0,), True),
        "centres": (NUMBER, (2,), True),
        "width": (NUMBER, (0,), True),
        "weights": (NUMBER, (1, 2), True),
        "log_target": (BOOLEAN, (0,), False),
    },
}
_LAYER_MEMBERS: dict[str, dict[str, tuple[str, tuple[int, ...], bool]]] = {
    "mlp": {"coef_": (NUMBER, (2,), True), "intercept_": (NUMBER, (1,), True)},
    "momentum_mlp": {
        "coef_": (NUMBER, (2,), True),
        "intercept_": (NUMBER, (1,), True),
        "last_step_coef_": (NUMBER, (2,), True),
        "last_step_intercept_": (NUMBER, (1,), True),
    },
    "rbf": {},
}
_NPY = ".npy"


def _members_of(kind: str) -> tuple[dict[str, tuple[str, tuple[int, ...], bool]], dict[str, tuple[str, tuple[int, ...], bool]]]:
    """The fixed members (full names) and the per-layer member prefixes (full names) of a file of ``kind``."""
    fixed = dict(_TOP_MEMBERS)
    fixed.update({f"pipeline/{k}": v for k, v in _PIPELINE_MEMBERS.items()})
    fixed.update({f"network/{k}": v for k, v in _NETWORK_MEMBERS[kind].items()})
    return fixed, {f"network/{k}": v for k, v in _LAYER_MEMBERS[kind].items()}


def _read_arrays(archive: zipfile.ZipFile, where: str) -> dict[str, np.ndarray]:
    """Every array of the archive, checked against the zip directory and their ``.npy`` headers first."""
    infos: dict[str, zipfile.ZipInfo] = {}
    for info in archive.infolist():
        key = info.filename[: -len(_NPY)] if info.filename.endswith(_NPY) else info.filename
        if key in infos:
            raise ModelFileError(f"{where}: the archive holds the member {info.filename} twice")
        infos[key] = info
    if "format_version" not in infos:
        raise ModelFileError(f"{where} is not an ann model file (no format_version)")
    total = sum(info.file_size for info in infos.values())
    if total > MAX_FILE_BYTES:
        raise ModelFileError(
            f"{where}: its members declare {total} bytes uncompressed, more than the {MAX_FILE_BYTES} bytes "
            "an ann model file may hold (refused unread)"
        )
    arrays = {"format_version": _read_member(archive, infos["format_version"], "format_version", _TOP_MEMBERS["format_version"], where)}
    version = int(arrays["format_version"])
    if version != FORMAT_VERSION:
        raise ModelFileError(f"{where} has ann model format version {version}, but this code reads version {FORMAT_VERSION}")
    if "network_kind" not in infos:
        raise ModelFileError(f"{where}: missing member network_kind")
    arrays["network_kind"] = _read_member(archive, infos["network_kind"], "network_kind", _TOP_MEMBERS["network_kind"], where)
    kind = str(arrays["network_kind"])
    if kind not in NETWORKS:
        raise ModelFileError(f"{where}: unknown network kind {kind!r}; known: {tuple(NETWORKS)}")
    fixed, per_layer = _members_of(kind)
    layer_name = re.compile("(" + "|".join(re.escape(p) for p in per_layer) + r")(0|[1-9][0-9]*)$") if per_layer else None
    specs: dict[str, tuple[str, tuple[int, ...], bool]] = {}
    unknown = []
    for key, info in infos.items():
        found = layer_name.match(key) if layer_name is not None else None
        if key in fixed:
            specs[key] = fixed[key]
        elif found is not None:
            specs[key] = per_layer[found.group(1)]
        else:
            unknown.append(info.filename)
    if unknown:
        shown = ", ".join(unknown[:5]) + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else "")
        raise ModelFileError(
            f"{where}: unknown member(s) {shown}; an ann model file of kind {kind} holds only format_version, "
            "network_kind, metadata and its pipeline/ and network/ arrays (refused unread)"
        )
    missing = [key for key, (_, _, required) in fixed.items() if required and key not in infos]
    if missing:
        raise ModelFileError(f"{where}: missing member(s) {', '.join(missing)}")
    for key, spec in specs.items():
        if key not in arrays:
            arrays[key] = _read_member(archive, infos[key], key, spec, where)
    return arrays


def _read_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, key: str, spec: tuple[str, tuple[int, ...], bool], where: str) -> np.ndarray:
    """One ``.npy`` member: its header checked against the zip directory and ``spec`` before its data is read."""
    kinds, ndims, _ = spec
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise ModelFileError(f"{where}: member {key}: compression method {info.compress_type} is not one numpy writes (stored or deflated)")
    with archive.open(info) as stream:
        shape, fortran_order, dtype = _npy_header(stream, key, where)
        data_bytes = info.file_size - stream.tell()
        if dtype.kind not in kinds or dtype.fields is not None or dtype.subdtype is not None:
            raise ModelFileError(f"{where}: member {key}: dtype {dtype.str} is not {_KIND_NAMES[kinds]}")
        if len(shape) not in ndims:
            want = " or ".join(f"{n}-dimensional" for n in ndims)
            raise ModelFileError(f"{where}: member {key} must be {want}, got shape {shape}")
        count = math.prod(shape)
        if count > MAX_ARRAY_VALUES:
            raise ModelFileError(f"{where}: member {key}: its header declares shape {shape}, more than {MAX_ARRAY_VALUES} values (refused unread)")
        if count * dtype.itemsize != data_bytes:
            raise ModelFileError(
                f"{where}: member {key}: its header declares shape {shape} of {dtype.str} ({count * dtype.itemsize} bytes), "
                f"but the member holds {data_bytes} bytes of data (refused unread)"
            )
        data = stream.read(data_bytes)
        if len(data) != data_bytes:
            raise ModelFileError(f"{where}: member {key} ends after {len(data)} of its {data_bytes} bytes")
    if count == 0 or dtype.itemsize == 0:
        return np.zeros(shape, dtype=dtype)
    return np.frombuffer(data, dtype=dtype, count=count).reshape(shape, order="F" if fortran_order else "C").copy()


_KIND_NAMES = {NUMBER: "a number array", INTEGER: "an integer array", BOOLEAN: "a boolean array", TEXT: "a text array"}


def _npy_header(stream: IO[bytes], key: str, where: str) -> tuple[tuple[int, ...], bool, np.dtype]:
    """``(shape, fortran_order, dtype)`` of the ``.npy`` header at the start of ``stream``."""
    try:
        version = npy_format.read_magic(stream)
        if version == (1, 0):
            shape, fortran_order, dtype = npy_format.read_array_header_1_0(stream, max_header_size=MAX_HEADER_BYTES)
        elif version == (2, 0):
            shape, fortran_order, dtype = npy_format.read_array_header_2_0(stream, max_header_size=MAX_HEADER_BYTES)
        else:
            raise ValueError(f".npy format version {version[0]}.{version[1]}; numpy writes these arrays as 1.0 or 2.0")
    except (ValueError, TypeError, SyntaxError, RecursionError) as error:
        raise ModelFileError(f"{where}: member {key} is not a readable .npy array: {error}") from None
    if any(n < 0 for n in shape):
        raise ModelFileError(f"{where}: member {key}: its header declares the shape {shape}")
    return tuple(shape), bool(fortran_order), dtype


def _finite(arrays: dict[str, np.ndarray], *keys: str, section: str = "network/") -> None:
    for key in keys:
        values = np.asarray(arrays[key], dtype=float)
        bad = int(np.count_nonzero(~np.isfinite(values)))
        if bad:
            raise ModelFileError(f"{section}{key} holds {bad} non-finite value(s) (NaN or infinity); weights and scalers must be finite numbers")


def _shape(arrays: dict[str, np.ndarray], key: str, expected: tuple[int, ...], why: str, section: str = "network/") -> None:
    if arrays[key].shape != expected:
        raise ModelFileError(f"{section}{key} has shape {arrays[key].shape}, but {why} makes it {expected}")


def _check_pipeline_arrays(arrays: dict[str, np.ndarray]) -> int:
    """The pipeline's sizes are sane and fit its scaler; returns its feature count.

    Features per record: ``channels × length`` resampled values, ``channels × (length//2 + 1)``
    spectrum magnitudes with ``spectrum``, 1 (``peak``) or ``channels`` (``channel_peak``) peaks,
    and one value per extra input (:meth:`ann.features.FeaturePipeline._raw_features`).
    """
    length, channels, samples = (int(arrays[k]) for k in ("length", "channels", "samples"))
    normalise = str(arrays["normalise"])
    if channels < 1 or samples < 2 or length < 2:
        raise ModelFileError(f"pipeline channels {channels}, samples {samples}, length {length}: a pipeline reads at least 1 channel of 2 samples, resampled to at least 2")
    if channels * max(samples, length) > MAX_RECORD_VALUES:
        raise ModelFileError(f"pipeline records of {channels} channels × {max(samples, length)} samples exceed {MAX_RECORD_VALUES} values per record")
    if normalise not in NORMALISATIONS:
        raise ModelFileError(f"pipeline/normalise is {normalise!r}; one of {NORMALISATIONS}")
    peaks = {"peak": 1, "channel_peak": channels, "none": 0}[normalise]
    extras = arrays["extras"].size if "extras" in arrays else 0
    features = channels * length + (channels * (length // 2 + 1) if bool(arrays["spectrum"]) else 0) + peaks + extras
    _finite(arrays, "rate", "mean", "scale", section="pipeline/")
    why = f"{channels} channels resampled to {length} samples (spectrum {bool(arrays['spectrum'])}, normalise {normalise}, {extras} extras)"
    for key in ("mean", "scale"):
        _shape(arrays, key, (features,), why, section="pipeline/")
    if np.any(arrays["scale"] <= 0):
        raise ModelFileError("pipeline/scale must be positive (it divides the features)")
    return features


def _check_layers(arrays: dict[str, np.ndarray], features: int, target_key: str, steps: tuple[str, ...] = ()) -> int:
    """A perceptron's layers, ``coef_l (n_{l-1}, n_l)`` and ``intercept_l (n_l,)`` chained from ``n_0 = features``,
    and the target scaling of its ``n_L`` outputs; ``steps`` name per-layer arrays of the same shapes
    (``last_step_coef_``, ``last_step_intercept_``). Every one finite. Returns the number of layers."""
    layers = int(arrays["layers"])
    if not 1 <= layers <= MAX_LAYERS:
        raise ModelFileError(f"network/layers is {layers}; a network has 1 to {MAX_LAYERS} layers")
    prefixes = ("coef_", "intercept_", *steps)
    names = [f"{prefix}{i}" for prefix in prefixes for i in range(layers)]
    missing = [name for name in names if name not in arrays]
    if missing:
        raise ModelFileError(f"network/layers is {layers}, but the file has no network/{', network/'.join(missing)}")
    pattern = re.compile("(" + "|".join(prefixes) + ")[0-9]+$")
    extra = sorted(set(key for key in arrays if pattern.match(key)) - set(names))
    if extra:
        raise ModelFileError(f"network/layers is {layers}, but the file also has network/{', network/'.join(extra)}")
    width = features
    for i in range(layers):
        n = arrays[f"coef_{i}"].shape[1]
        _shape(arrays, f"coef_{i}", (width, n), f"{'the feature count' if i == 0 else f'layer {i - 1}'} of {width}")
        _shape(arrays, f"intercept_{i}", (n,), f"coef_{i} of shape {(width, n)}")
        for step in steps:
            weights = "intercept_" if "intercept" in step else "coef_"
            _shape(arrays, f"{step}{i}", arrays[f"{weights}{i}"].shape, f"{weights}{i}")
        width = n
    _finite(arrays, *names)
    outputs = [(width,), ()] if width == 1 else [(width,)]
    for key in (target_key, "target_scale"):
        if arrays[key].shape not in outputs:
            raise ModelFileError(f"network/{key} has shape {arrays[key].shape}, but the last layer has {width} output(s)")
    _finite(arrays, target_key, "target_scale")
    return layers


def _check_mlp(arrays: dict[str, np.ndarray], features: int) -> None:
    activation = str(arrays["activation"])
    if activation not in ACTIVATIONS:
        raise ModelFileError(f"network/activation {activation!r} is not one of {tuple(ACTIVATIONS)}")
    _check_layers(arrays, features, "target_mean")


def _check_momentum_mlp(arrays: dict[str, np.ndarray], features: int) -> None:
    layers = _check_layers(arrays, features, "target_offset", ("last_step_coef_", "last_step_intercept_"))
    units = [str(u) for u in arrays["units"]]
    if len(units) != layers or any(u not in UNITS for u in units):
        raise ModelFileError(f"network/units is {units}; {layers} unit(s), one per layer, each one of {tuple(UNITS)}")


def _check_rbf(arrays: dict[str, np.ndarray], features: int) -> None:
    centres = arrays["centres"]
    if centres.shape[0] < 2 or centres.shape[1] != features:
        raise ModelFileError(f"network/centres has shape {centres.shape}; an RBF network of {features} features needs (centres >= 2, {features})")
    weights = arrays["weights"]
    if weights.shape[0] != centres.shape[0] + 1:
        raise ModelFileError(f"network/weights has shape {weights.shape}, but {centres.shape[0]} centres and the constant make {centres.shape[0] + 1} rows")
    _finite(arrays, "centres", "width", "weights")
    if not float(arrays["width"]) > 0.0:
        raise ModelFileError(f"network/width must be positive, got {float(arrays['width'])!r}")
    if str(arrays["basis"]) not in BASES:
        raise ModelFileError(f"network/basis {str(arrays['basis'])!r} is not one of {tuple(BASES)}")


#: Shape and finiteness checks of each network kind's arrays, given the pipeline's feature count.
_NETWORK_CHECKS: dict[str, Callable[[dict[str, np.ndarray], int], None]] = {
    "mlp": _check_mlp,
    "momentum_mlp": _check_momentum_mlp,
    "rbf": _check_rbf,
}
