"""Network (``ann``) estimators: a saved :mod:`ann.storage` network read on the fem sensor records.

A network estimator estimates the peak compression of one coupler over the impact from
a stack of fixed-length acceleration records, made exactly as the sweep files that
trained it store them (:mod:`femref.sensing.records`)::

    records = fixed_length_records(t, a, probes, record_length, record_end)     (channels, record_length)
    P̂ = predict(records[None], rate)[0],   rate = (record_length − 1)/record_end  (Hz)

with ``t, a`` the fem run's measured records when the scene has a measurement chain,
else its own sensor accelerations (:func:`femref.sensing.records.acceleration_histories`),
and ``P̂`` in N, compression positive: an estimate of ``max_t P(t)`` of coupler
``coupler``. It gives no force history.

The file's JSON metadata is the contract (:class:`NetworkContract`, docs/design.md §6.3); the only scalar inputs
femref supplies are ``car_mass/<car>`` (kg, the mass a railroad knows from the waybill). :func:`read_network`
checks the contract for any scene; the case schema (:mod:`femref.case.estimators`) checks it against the scene.
``ann`` is imported only when a network is read: ``femref`` imports ``ann``, never the
reverse.
"""

from __future__ import annotations

import math
import os
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from femref.sensing.records import fixed_length_records, record_rate
from femref.sensing.measurement import Measurement

if TYPE_CHECKING:  # pragma: no cover - typing only
    from ann.storage import Estimator

#: What a network estimates (the only target femref scores so far).
TARGETS: tuple[str, ...] = ("peak_coupler_force",)
#: Where the training records came from: the fem run's measurement chain, or its own sensor accelerations.
RECORD_SOURCES: tuple[str, ...] = ("measured", "model")
#: Metadata keys the runner relies on.
REQUIRED_KEYS: tuple[str, ...] = ("target", "coupler", "probes", "record_length", "record_end", "record_source", "measurement")
#: Prefix of the one kind of scalar network input femref supplies: ``car_mass/<car>`` (kg).
CAR_MASS = "car_mass/"
#: First bytes of a zip archive (an .npz file).
ZIP_MAGIC = b"PK\x03\x04"
#: Relative tolerance of rate comparisons (that of ``ann.features``).
RATE_RTOL = 1e-9


class NetworkFileError(ValueError):
    """A network file that no scene can use: unreadable, not an ann file, or a broken contract."""


@dataclass(frozen=True)
class NetworkContract:
    """What a network file promises (module docstring): its input records and its output; ``kind`` the network kind
    (``mlp``, ``rbf``)."""

    target: str
    coupler: str
    probes: tuple[str, ...]
    record_length: int
    record_end: float
    record_source: str
    measurement: Measurement | None
    kind: str
    training: dict[str, Any] = field(default_factory=dict)
    extras: tuple[str, ...] = ()

    @property
    def mass_inputs(self) -> tuple[str, ...]:
        """The cars whose masses the network takes, in input order."""
        return tuple(name[len(CAR_MASS) :] for name in self.extras)

    @property
    def rate(self) -> float:
        """Sampling rate of the records (Hz), ``(record_length − 1)/record_end``."""
        return record_rate(self.record_length, self.record_end)

    @classmethod
    def from_metadata(cls, metadata: Any, kind: str) -> "NetworkContract":
        """The contract of a file's metadata; raises :class:`NetworkFileError` naming the bad key."""
        if not isinstance(metadata, Mapping):
            raise NetworkFileError(f"the network metadata must be a mapping of keys, not a {type(metadata).__name__}")
        missing = [key for key in REQUIRED_KEYS if key not in metadata]
        if missing:
            raise NetworkFileError(f"the network metadata lacks the required key(s) {', '.join(missing)} (required: {', '.join(REQUIRED_KEYS)})")
        target, coupler, probes = metadata["target"], metadata["coupler"], metadata["probes"]
        length, end, source = metadata["record_length"], metadata["record_end"], metadata["record_source"]
        if target not in TARGETS:
            raise NetworkFileError(f"metadata target is {target!r}; femref reads networks of target {', '.join(TARGETS)}")
        if not isinstance(coupler, str) or not coupler:
            raise NetworkFileError(f"metadata coupler must be a coupler name, got {coupler!r}")
        if not isinstance(probes, list) or not probes or not all(isinstance(p, str) for p in probes) or len(set(probes)) != len(probes):
            raise NetworkFileError(f"metadata probes must be a non-empty list of distinct probe names <car>/<sensor>, got {probes!r}")
        if isinstance(length, bool) or not isinstance(length, int) or length < 2:
            raise NetworkFileError(f"metadata record_length must be an integer >= 2, got {length!r}")
        if not (_real(end) and end > 0.0):
            raise NetworkFileError(f"metadata record_end must be a positive time in s, got {end!r}")
        if source not in RECORD_SOURCES:
            raise NetworkFileError(f"metadata record_source must be one of {', '.join(RECORD_SOURCES)}, got {source!r}")
        measurement = _measurement_of(metadata["measurement"], source)
        training = metadata.get("training", {})
        if not isinstance(training, Mapping):
            raise NetworkFileError(f"metadata training must be a mapping, got {type(training).__name__}")
        return cls(target, coupler, tuple(probes), int(length), float(end), source, measurement, kind, dict(training))


def _measurement_of(chain: Any, source: str) -> Measurement | None:
    """The training chain: a mapping {rate, lowpass, noise, seed} for measured records, null for model records."""
    if source == "model":
        if chain is not None:
            raise NetworkFileError(f"metadata measurement must be null for record_source model (records without a measurement chain), got {chain!r}")
        return None
    if not isinstance(chain, Mapping):
        raise NetworkFileError(f"metadata measurement must be a mapping {{rate, lowpass, noise, seed}} for record_source measured, got {chain!r}")
    values = {}
    for key in ("rate", "lowpass"):
        value = chain.get(key)
        if value is not None and not (_real(value) and value > 0.0):
            raise NetworkFileError(f"metadata measurement.{key} must be null or a positive number of Hz, got {value!r}")
        values[key] = None if value is None else float(value)
    noise, seed = chain.get("noise", 0.0), chain.get("seed", 0)
    if not (_real(noise) and noise >= 0.0):
        raise NetworkFileError(f"metadata measurement.noise must be a number >= 0 (m/s²), got {noise!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise NetworkFileError(f"metadata measurement.seed must be an integer >= 0, got {seed!r}")
    return Measurement(rate=values["rate"], lowpass=values["lowpass"], noise=float(noise), seed=seed)


def _real(value: Any) -> bool:
    """A finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def read_network(path: str | os.PathLike) -> tuple["Estimator", NetworkContract]:
    """The estimator and contract of the network file at ``path``; :class:`NetworkFileError` (a ValueError) for a
    missing or unreadable file, one that is not an ``ann.storage`` model file (whose own checks run before its arrays
    are allocated), a broken contract (module docstring), or a pipeline that does not read the records it describes."""
    from ann.storage import load_estimator

    path = Path(path)
    try:
        with open(path, "rb") as handle:
            if handle.read(len(ZIP_MAGIC)) != ZIP_MAGIC:
                raise NetworkFileError(f"{path} is not an ann network file (ann.storage .npz): not an .npz archive")
        estimator, metadata = load_estimator(path)
    except FileNotFoundError:
        raise NetworkFileError(f"network file {path} does not exist") from None
    except IsADirectoryError:
        raise NetworkFileError(f"network file {path} is a directory") from None
    except OSError as error:
        raise NetworkFileError(f"cannot read network file {path}: {error.strerror or error}") from None
    except NetworkFileError:
        raise
    except (ValueError, KeyError, TypeError, AttributeError, EOFError, zipfile.BadZipFile) as error:
        # ann.storage's own ValueError (format version, network kind), or an archive without its arrays
        detail = str(error) if str(path) in str(error) else f"{path}: {error}"
        raise NetworkFileError(f"not a usable ann network file (ann.storage .npz): {detail}") from None
    contract = NetworkContract.from_metadata(metadata, estimator.network.kind)
    _check_pipeline(estimator, contract)
    return estimator, replace(contract, extras=tuple(estimator.pipeline.settings.extras))


def _check_pipeline(estimator: "Estimator", contract: NetworkContract) -> None:
    """The pipeline reads records of the contract's rate, channel count and length."""
    pipeline = estimator.pipeline
    if not math.isclose(pipeline.settings.rate, contract.rate, rel_tol=RATE_RTOL):
        raise NetworkFileError(
            f"the network's pipeline reads records at {pipeline.settings.rate:g} Hz, but record_length {contract.record_length} "
            f"over record_end {contract.record_end:g} s makes {contract.rate:g} Hz"
        )
    if pipeline.channels != len(contract.probes):
        raise NetworkFileError(f"the network's pipeline was fitted on {pipeline.channels} channels, but metadata lists {len(contract.probes)} probes")
    if pipeline.samples != contract.record_length:
        raise NetworkFileError(f"the network's pipeline was fitted on records of {pipeline.samples} samples, but record_length is {contract.record_length}")
    unknown = [name for name in pipeline.settings.extras if not (name.startswith(CAR_MASS) and len(name) > len(CAR_MASS))]
    if unknown:
        raise NetworkFileError(f"the network takes the input(s) {', '.join(unknown)}; femref supplies only {CAR_MASS}<car> (car mass, kg)")


@dataclass(frozen=True, eq=False)
class AnnEstimator:
    """A network estimator of a scene: result-group ``name``, the file it came from, the loaded network."""

    name: str
    path: Path
    estimator: "Estimator"
    contract: NetworkContract

    @classmethod
    def load(cls, name: str, path: str | os.PathLike) -> "AnnEstimator":
        """Read the network file (:func:`read_network`; raises :class:`NetworkFileError`)."""
        estimator, contract = read_network(path)
        return cls(name, Path(path), estimator, contract)

    @property
    def coupler(self) -> str:
        return self.contract.coupler

    def records(self, time: ArrayLike, histories: Mapping[str, ArrayLike]) -> np.ndarray:
        """The network's input ``(channels, record_length)`` from acceleration histories on ``time``."""
        c = self.contract
        return fixed_length_records(time, histories, c.probes, c.record_length, c.record_end)

    def peak_force(self, time: ArrayLike, histories: Mapping[str, ArrayLike], car_masses: Mapping[str, float] | None = None) -> float:
        """``P̂ = predict(records[None], rate, masses)[0]`` (N, compression positive; module docstring).

        ``car_masses`` (car name → kg) must hold the cars of :attr:`NetworkContract.mass_inputs`.
        """
        masses = car_masses or {}
        missing = [car for car in self.contract.mass_inputs if car not in masses]
        if missing:
            raise ValueError(f"network {self.path} needs the mass of car(s) {', '.join(missing)}")
        extras = np.array([[masses[car] for car in self.contract.mass_inputs]]) if self.contract.extras else None
        prediction = np.asarray(self.estimator.predict(self.records(time, histories)[None], self.contract.rate, extras), dtype=float)
        if prediction.size != 1:
            raise ValueError(f"network {self.path} predicted {prediction.size} values for one record stack; a peak-force network predicts one")
        return float(prediction.reshape(-1)[0])

    @property
    def settings(self) -> dict[str, Any]:
        """What the result file records of the estimator: file, network kind, contract, the scalar entries of the
        training summary."""
        c = self.contract
        chain = None if c.measurement is None else {"rate": c.measurement.rate, "lowpass": c.measurement.lowpass, "noise": c.measurement.noise, "seed": c.measurement.seed}
        return {
            "network": str(self.path),
            "kind": c.kind,
            "target": c.target,
            "coupler": c.coupler,
            "probes": list(c.probes),
            "record_length": c.record_length,
            "record_end": c.record_end,
            "record_rate": c.rate,
            "record_source": c.record_source,
            "extras": list(c.extras),
            "training_measurement": chain,
            "training": {k: v for k, v in c.training.items() if v is None or isinstance(v, (str, int, float, bool))},
        }


@dataclass(frozen=True, eq=False)
class ImpactTypeNetworks:
    """One network per impact type under one estimator ``name``: ``P̂ = P̂_k(records)`` with ``k`` = free_to_roll or
    coupled from the zero harmonic of the relative acceleration (:func:`femref.sensing.findings.classify_records`).
    The source study trained its networks on one kind of impact at a time: a network trained on free-to-roll
    impacts has never seen the rebound of a coupled one. An impact of a type without a network gets no estimate."""

    name: str
    by_type: Mapping[str, AnnEstimator]

    @property
    def coupler(self) -> str:
        return next(iter(self.by_type.values())).coupler

    def network_for(self, impact_type: str) -> AnnEstimator:
        """The network of ``impact_type``; ValueError naming the types this estimator has."""
        if impact_type not in self.by_type:
            have = ", ".join(self.by_type)
            raise ValueError(f"estimator {self.name} has no network for {impact_type.replace('_', '-')} impacts (it has: {have})")
        return self.by_type[impact_type]

    @property
    def settings(self) -> dict[str, Any]:
        """Each network's :attr:`AnnEstimator.settings` under its impact type."""
        return {"by_impact_type": {kind: network.settings for kind, network in self.by_type.items()}}


NetworkEstimator = AnnEstimator | ImpactTypeNetworks
"""A network estimator of a scene: one network, or one per impact type."""

__all__ = ["RECORD_SOURCES", "REQUIRED_KEYS", "TARGETS", "AnnEstimator", "ImpactTypeNetworks", "NetworkContract", "NetworkEstimator",
           "NetworkFileError", "read_network"]
