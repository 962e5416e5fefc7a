"""Save and load a trained feature pipeline + network as plain arrays (``.npz``).

No pickle anywhere: every entry is a numeric or unicode numpy array, written
with ``numpy.savez`` and read with ``numpy.load(..., allow_pickle=False)``.
Keys are namespaced ``pipeline/…``, ``network/…``; ``format_version`` and
``network_kind`` say how to rebuild the objects, and ``metadata`` is a JSON
string (units, training data, scores, …).  A loaded network predicts with
numpy alone; no scikit-learn object is stored or needed.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from ann.features import FeaturePipeline
from ann.networks import NETWORKS, MLPForceRegressor, MomentumMLP, RBFNetwork

FORMAT_VERSION = 1

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

    Raises ``ValueError`` when the file's format version is not this module's.
    """
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    if "format_version" not in arrays:
        raise ValueError(f"{os.fspath(path)} is not an ann model file (no format_version)")
    version = int(arrays["format_version"])
    if version != FORMAT_VERSION:
        raise ValueError(
            f"{os.fspath(path)} has ann model format version {version}, "
            f"but this code reads version {FORMAT_VERSION}"
        )
    kind = str(arrays["network_kind"])
    if kind not in NETWORKS:
        raise ValueError(f"{os.fspath(path)}: unknown network kind {kind!r}; known: {tuple(NETWORKS)}")
    pipeline = FeaturePipeline.from_arrays(_section(arrays, "pipeline/"))
    network = NETWORKS[kind].from_arrays(_section(arrays, "network/"))
    return pipeline, network, json.loads(str(arrays["metadata"]))


def load_estimator(path: str | os.PathLike) -> tuple[Estimator, dict[str, Any]]:
    """``load`` wrapped as an ``Estimator`` plus the metadata."""
    pipeline, network, metadata = load(path)
    return Estimator(pipeline, network), metadata


def _section(arrays: dict[str, np.ndarray], prefix: str) -> dict[str, np.ndarray]:
    return {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}
