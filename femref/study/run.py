"""Run a network study: the sweeps, the training of every network on every source, the scores.

:func:`run_study` does, in ``out_dir``:

1. one sweep per set (:mod:`femref.sweep`, on Dask; resumable): ``<set>.sweep.yaml`` (the
   sweep file, runnable on its own with ``femref sweep``) and ``<set>.h5``;
2. for each training source ``s`` (a model of the ``train`` set) and each network ``n``:
   a feature pipeline fitted on ``s``'s records of the training split, the network trained
   on ``log`` of ``s``'s peak force (:mod:`ann.networks`), scored on the held-out
   validation split of its own source, saved as ``networks/<s>_<n>.npz`` with the
   metadata contract of :mod:`femref.sensing.network` (so ``femref run`` can use it);
3. on every evaluation set: each network and each inverse estimator
   (:mod:`femref.models.inverse`, on the same fixed-length fem records) against the fem
   peak force, ``e = |P̂ − P_fem| / P_fem`` per sample, summarised by its mean and 95th
   percentile (:func:`error_summary`);
4. ``study.h5`` (every per-sample estimate and error) and ``study.md`` (the table).

The networks see what a railroad has: the records of the sensors (``probes``) and, if the
study says so, the car masses (waybill). The inverse estimators also know the body
profiles. Every estimator reads the same stored records.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import yaml
from numpy.typing import NDArray

from femref import __version__
from femref.case import load_case
from femref.case.errors import CaseError, Problem
from femref.sensing.records import record_times
from femref.core.catalog import ESTIMATORS as INVERSE_ESTIMATORS  # scored next to the networks: every one femref has
from femref.results import atomic_path
from femref.study.spec import TRAIN, StudyFile
from femref.sweep import Sweep, SweepData, parse_sweep, read_sweep, run_sweep
from femref.sweep.keypaths import assign_key_path

@dataclass(frozen=True)
class ErrorSummary:
    """Relative peak-force errors of one estimator on one set."""

    mean: float
    p95: float
    bias: float
    samples: int


def error_summary(estimate: NDArray[np.float64], reference: NDArray[np.float64]) -> ErrorSummary:
    """``e = |P̂ − P|/P``: mean, 95th percentile (linear interpolation), mean signed error ``(P̂ − P)/P``."""
    estimate, reference = np.asarray(estimate, dtype=float), np.asarray(reference, dtype=float)
    if estimate.shape != reference.shape or reference.size == 0:
        raise ValueError(f"need matching non-empty arrays, got {estimate.shape} and {reference.shape}")
    signed = (estimate - reference) / reference
    error = np.abs(signed)
    return ErrorSummary(float(np.mean(error)), float(np.percentile(error, 95.0)), float(np.mean(signed)), int(reference.size))


@dataclass
class TrainedNetwork:
    """One network trained on one source: where it is saved and how it did on its own source."""

    name: str
    source: str
    network: str
    path: Path
    training_samples: int
    validation: ErrorSummary
    training_time_s: float
    estimator: Any = field(repr=False)


@dataclass
class SetScores:
    """Estimates and errors of every estimator on one evaluation set (fem reference)."""

    name: str
    reference: NDArray[np.float64]
    estimates: dict[str, NDArray[np.float64]]
    summaries: dict[str, ErrorSummary]
    inference_time_s: dict[str, float]


@dataclass
class StudyOutcome:
    study: StudyFile
    out_dir: Path
    networks: list[TrainedNetwork]
    sets: dict[str, SetScores]
    sweeps_wall_time_s: dict[str, float]

    def table_rows(self) -> list[dict[str, Any]]:
        """One row per estimator: source, network, own-source validation error, then mean/p95 per evaluation set."""
        rows = []
        for trained in self.networks:
            row = {"estimator": trained.name, "trained on": trained.source, "network": trained.network, "own source": trained.validation}
            row.update({name: scores.summaries[trained.name] for name, scores in self.sets.items()})
            rows.append(row)
        for name in INVERSE_ESTIMATORS:
            row = {"estimator": name, "trained on": "—", "network": "inverse", "own source": None}
            row.update({s: scores.summaries[name] for s, scores in self.sets.items() if name in scores.summaries})
            rows.append(row)
        return rows

    def markdown(self) -> str:
        sets = list(self.sets)
        head = ["estimator", "trained on", "own-source mean"] + [f"{s} mean / p95" for s in sets]
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for row in self.table_rows():
            own = row["own source"]
            cells = [row["estimator"], row["trained on"], "—" if own is None else f"{own.mean:.2%}"]
            cells += [f"{row[s].mean:.2%} / {row[s].p95:.2%}" if s in row else "—" for s in sets]
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------ sweeps


def base_case_data(study: StudyFile, study_dir: Path, source: str) -> dict[str, Any]:
    """The resolved base case with ``base_overrides`` applied (plain data, validated)."""
    path = study_dir / study.base
    if not path.is_file():
        raise CaseError(Problem(("base",), f"base case file not found: {path}", study.base), source)
    data = load_case(path).model_dump(mode="json")
    for key, value in study.base_overrides.items():
        try:
            assign_key_path(data, key, value)
        except LookupError as error:
            raise CaseError(Problem(("base_overrides", key), str(error)), source) from None
    data["estimators"] = []
    return data


def set_sweep_data(study: StudyFile, name: str, base: dict[str, Any]) -> dict[str, Any]:
    """The sweep file of set ``name``: the base inline, shared parameters updated by the set's."""
    spec = study.sets[name]
    return {
        "case": base,
        "samples": spec.samples,
        "seed": spec.seed,
        "models": list(spec.models),
        "parameters": {**study.parameters, **spec.parameters},
        "outputs": {"record_length": study.record_length, "force_length": study.force_length},
    }


def prepare_sweeps(study: StudyFile, study_dir: Path, out_dir: Path, source: str = "<study>") -> dict[str, Sweep]:
    """Validate every set's sweep and write ``<set>.sweep.yaml`` into ``out_dir``."""
    base = base_case_data(study, study_dir, source)
    data = {name: set_sweep_data(study, name, base) for name in study.sets}
    sweeps = {name: parse_sweep(d, source=f"{source} sets.{name}", base_dir=study_dir) for name, d in data.items()}
    out_dir.mkdir(parents=True, exist_ok=True)  # only once every set is valid
    for name, d in data.items():
        (out_dir / f"{name}.sweep.yaml").write_text(yaml.safe_dump(d, sort_keys=False, default_flow_style=None, width=100))
    return sweeps


# ------------------------------------------------------------------------------------ data


@dataclass(frozen=True)
class SetData:
    """The usable samples of one set: records, peak forces per model, and each sample's scene."""

    sweep: Sweep
    data: SweepData
    index: NDArray[np.int64]  # sample indices with status ok
    scenes: tuple[Any, ...]  # ImpactScene of each ok sample, in index order

    @property
    def car_names(self) -> tuple[str, ...]:
        return tuple(car.name for car in self.scenes[0].cars) if self.scenes else ()

    @property
    def car_masses(self) -> NDArray[np.float64]:
        """``(n_ok, cars)`` total car masses (kg) of each sample."""
        return np.array([[car.mass for car in scene.cars] for scene in self.scenes]).reshape(len(self.scenes), len(self.car_names))

    def records(self, model: str, probes: list[str]) -> NDArray[np.float64]:
        channels = [self.data.probes.index(p) for p in probes]
        return self.data.records[model][self.index][:, channels, :]

    def peaks(self, model: str, coupler: str) -> NDArray[np.float64]:
        return self.data.peak_coupler_force[model][self.index, self.data.couplers.index(coupler)]


def read_set(sweep: Sweep, path: Path) -> SetData:
    """Read a set's sweep file and rebuild the scene of each ok sample (car masses, estimator geometry)."""
    from femref.scene.build import scene_from_case

    data = read_sweep(path)
    index = np.flatnonzero(data.ok)
    scenes = tuple(scene_from_case(sweep.sample_case(sweep.sample(int(i))), sweep.base_dir) for i in index)
    return SetData(sweep, data, index, scenes)


# ------------------------------------------------------------------------------------ training


def feature_settings(study: StudyFile, train: SetData) -> Any:
    """The study's :class:`ann.features.FeatureSettings` for the set's records (rate) and cars (mass inputs)."""
    from ann.features import FeatureSettings

    extras = tuple(f"car_mass/{car}" for car in train.car_names) if study.car_masses else ()
    f = study.features
    return FeatureSettings(length=f.length, rate=train.data.record_rate, lowpass=f.lowpass, spectrum=f.spectrum, normalise=f.normalise, extras=extras)


def train_networks(study: StudyFile, train: SetData, probes: list[str], out_dir: Path) -> list[TrainedNetwork]:
    """A pipeline and network per (source, network), saved with the femref network contract."""
    import ann.storage as storage
    from ann.features import FeaturePipeline
    from ann.splits import split_indices

    data = train.data
    masses = train.car_masses if study.car_masses else None
    fit_rows, validation_rows, _ = split_indices(train.index.size, (1.0 - study.validation_fraction, study.validation_fraction, 0.0), seed=0)
    settings = feature_settings(study, train)
    (out_dir / "networks").mkdir(parents=True, exist_ok=True)
    trained = []
    for source in study.sets[TRAIN].models:
        records, peaks = train.records(source, probes), train.peaks(source, study.coupler)
        for name, spec in study.networks.items():
            started = time.perf_counter()
            pipeline = FeaturePipeline(settings).fit(records[fit_rows], data.record_rate, _rows(masses, fit_rows))
            network = spec.build().fit(pipeline.transform(records[fit_rows], data.record_rate, _rows(masses, fit_rows)), peaks[fit_rows])
            elapsed = time.perf_counter() - started
            estimator = storage.Estimator(pipeline, network)
            validation = error_summary(estimator.predict(records[validation_rows], data.record_rate, _rows(masses, validation_rows)), peaks[validation_rows])
            label = f"{source}_{name}"
            path = out_dir / "networks" / f"{label}.npz"
            metadata = {
                "target": "peak_coupler_force",
                "coupler": study.coupler,
                "probes": probes,
                "record_length": data.record_length,
                "record_end": data.record_end,
                "record_source": data.record_source,
                "measurement": data.measurement,
                "training": {
                    "source_model": source,
                    "network": name,
                    "samples": int(fit_rows.size),
                    "validation_samples": int(validation_rows.size),
                    "validation_mean_error": validation.mean,
                    "validation_p95_error": validation.p95,
                    "training_time_s": elapsed,
                    "sweep": str(data.path),
                    "spec_hash": data.spec_hash,
                },
            }
            storage.save(path, pipeline, network, metadata)
            trained.append(TrainedNetwork(label, source, name, path, int(fit_rows.size), validation, elapsed, estimator))
    return trained


def _rows(masses: NDArray[np.float64] | None, rows: NDArray[np.int64]) -> NDArray[np.float64] | None:
    return None if masses is None else masses[rows]


# ------------------------------------------------------------------------------------ evaluation


def evaluate_set(study: StudyFile, name: str, data: SetData, networks: list[TrainedNetwork], probes: list[str]) -> SetScores:
    """Every network and inverse estimator on the set's fem records, against its fem peak force."""
    reference = data.peaks("fem", study.coupler)
    records = data.records("fem", probes)
    masses = data.car_masses if study.car_masses else None
    estimates: dict[str, NDArray[np.float64]] = {}
    timing: dict[str, float] = {}
    for trained in networks:
        started = time.perf_counter()
        estimates[trained.name] = trained.estimator.predict(records, data.data.record_rate, masses)
        timing[trained.name] = (time.perf_counter() - started) / max(1, reference.size)
    estimates.update(inverse_estimates(study, data))
    summaries = {key: error_summary(value, reference) for key, value in estimates.items()}
    return SetScores(name, reference, estimates, summaries, timing)


def inverse_estimates(study: StudyFile, data: SetData) -> dict[str, NDArray[np.float64]]:
    """Peak of each inverse estimator's force history, from the stored fixed-length fem records."""
    from femref.models.inverse import ESTIMATORS

    t = record_times(data.data.record_length, data.data.record_end)
    all_records = data.data.records["fem"]
    out = {name: np.empty(data.index.size) for name in INVERSE_ESTIMATORS}
    for row, (i, scene) in enumerate(zip(data.index, data.scenes)):
        records = {p: all_records[i, c] for c, p in enumerate(data.data.probes)}
        for name in INVERSE_ESTIMATORS:
            out[name][row] = float(np.max(ESTIMATORS[name](scene, t, records)[study.coupler]))
    return out


# ------------------------------------------------------------------------------------ the study


def run_study(
    study: StudyFile,
    study_dir: Path,
    out_dir: Path,
    *,
    source: str = "<study>",
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    progress: Any = None,
) -> StudyOutcome:
    """Sweeps, training, evaluation, ``study.h5`` and ``study.md`` in ``out_dir`` (module docstring)."""
    out_dir = Path(out_dir)
    sweeps = prepare_sweeps(study, study_dir, out_dir, source)
    wall: dict[str, float] = {}
    for name, sweep in sweeps.items():
        summary = run_sweep(sweep, out_dir / f"{name}.h5", scheduler=scheduler, workers=workers, client=client, progress=progress)
        wall[name] = summary.wall_time_s
    sets = {name: read_set(sweep, out_dir / f"{name}.h5") for name, sweep in sweeps.items()}
    probes = list(study.probes) if study.probes is not None else list(sets[TRAIN].data.probes)
    unknown = [p for p in probes if p not in sets[TRAIN].data.probes]
    if unknown:
        raise CaseError(Problem(("probes",), f"not sensors of the base case: {', '.join(unknown)}; sensors: {', '.join(sets[TRAIN].data.probes)}"), source)
    networks = train_networks(study, sets[TRAIN], probes, out_dir)
    scores = {name: evaluate_set(study, name, sets[name], networks, probes) for name in study.evaluation_sets}
    outcome = StudyOutcome(study, out_dir, networks, scores, wall)
    write_study(outcome, out_dir / "study.h5")
    (out_dir / "study.md").write_text(outcome.markdown())
    return outcome


def write_study(outcome: StudyOutcome, path: Path) -> None:
    """``study.h5``: per evaluation set the fem reference and every estimator's estimates and errors.

    ``/<set>/reference`` (N,) N; ``/<set>/<estimator>/estimate`` (N,) N with attrs mean, p95,
    bias (relative errors) and inference_time_s (per record); ``/networks/<name>`` attrs:
    source, network, file, training samples and time, own-source validation errors. Written
    to a temporary name and renamed.
    """
    with atomic_path(path) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["femref_version"] = __version__
        h5.attrs["study_yaml"] = yaml.safe_dump(outcome.study.model_dump(mode="json"), sort_keys=False)
        for trained in outcome.networks:
            group = h5.create_group(f"networks/{trained.name}")
            group.attrs.update(
                source=trained.source, network=trained.network, file=str(trained.path), training_samples=trained.training_samples,
                training_time_s=trained.training_time_s, validation_mean_error=trained.validation.mean, validation_p95_error=trained.validation.p95,
            )
        for name, scores in outcome.sets.items():
            group = h5.create_group(name)
            group.create_dataset("reference", data=scores.reference).attrs["units"] = "N"
            for estimator, estimate in scores.estimates.items():
                sub = group.create_group(estimator)
                sub.create_dataset("estimate", data=estimate).attrs["units"] = "N"
                summary = scores.summaries[estimator]
                sub.attrs.update(mean=summary.mean, p95=summary.p95, bias=summary.bias, samples=summary.samples)
                if estimator in scores.inference_time_s:
                    sub.attrs["inference_time_s"] = scores.inference_time_s[estimator]


__all__ = ["ErrorSummary", "StudyOutcome", "error_summary", "run_study"]
