"""Run a network study: the sweeps, the training of every network on every source, the scores.

:func:`run_study` does, in ``out_dir``:

1. one sweep per set (:mod:`femref.sweep`, on Dask; resumable): ``<set>.sweep.yaml`` (the
   sweep file, runnable on its own with ``femref sweep``) and ``<set>.h5``;
2. for each training source ``s`` (a model of the ``train`` set) and each network ``n``:
   a feature pipeline and the network trained on ``log`` of ``s``'s peak force, scored on the
   held-out validation split of its own source, saved as ``networks/<s>_<n>[_<type>].npz`` with the
   metadata contract of :mod:`femref.sensing.network` (so ``femref run`` can use it)
   (:func:`train_networks`);
3. on every evaluation set: each network and each inverse estimator against the fem peak force,
   ``e = |P̂ − P_fem| / P_fem`` per sample (:func:`evaluate_set`, :func:`error_summary`);
4. ``study.h5`` (:func:`write_study`) and ``study.md`` (the table); ``femref report study.h5``
   draws them (:mod:`femref.report.study`).

Every file of the study folder is written under a temporary name and renamed when complete
(:func:`femref.core.publishing.atomic_path`; the sweep files by :mod:`femref.sweep`): a step that fails
or is interrupted leaves no file half-written under its final name, and ``femref study`` says
``error: study failed: …`` and exits 1 (the sweeps keep what they stored; the same command resumes).

The networks see what a railroad has: the records of the sensors (``probes``) and, if the
study says so, the car masses (waybill). The inverse estimators also know the body
profiles. Every estimator reads the same stored records.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from femref import __version__
from femref.case import load_case
from femref.case.errors import CaseError, Problem
from femref.sensing.records import record_times
from femref.core.catalog import ESTIMATORS as INVERSE_ESTIMATORS
from femref.core.threads import one_blas_thread  # scored next to the networks: every one femref has
from femref.core.hdf5_writing import hdf5_writer
from femref.core.publishing import atomic_path
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
    """``e = |P̂ − P|/P``: mean, 95th percentile (linear interpolation), mean signed error ``(P̂ − P)/P``.

    Samples without an estimate (NaN: an impact of a type its estimator has no network for) are left
    out; ``samples`` counts the rest (all NaN: NaN statistics over 0 samples)."""
    estimate, reference = np.asarray(estimate, dtype=float), np.asarray(reference, dtype=float)
    if estimate.shape != reference.shape or reference.size == 0:
        raise ValueError(f"need matching non-empty arrays, got {estimate.shape} and {reference.shape}")
    kept = ~np.isnan(estimate)
    if not np.any(kept):
        return ErrorSummary(float("nan"), float("nan"), float("nan"), 0)
    estimate, reference = estimate[kept], reference[kept]
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
    loss_curve: NDArray[np.float64] = field(default_factory=lambda: np.empty(0), repr=False)
    impact_type: str | None = None  # the type it was trained on and reads (``impact_types``), None: every type


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

    def table_rows(self) -> list[dict[str, Any]]:
        """One row per estimator: source, network, own-source validation error, then mean/p95 per evaluation set."""
        heads = [(t.name, t.source, t.network, t.validation) for t in self.networks]
        heads += [(label, source, f"{network} by impact type", None) for label, (source, network) in _routed_labels(self.networks).items()]
        heads += [(name, "—", "inverse", None) for name in INVERSE_ESTIMATORS]
        return [{"estimator": name, "trained on": source, "network": network, "own source": own,
                 **{s: scores.summaries[name] for s, scores in self.sets.items() if name in scores.summaries}}
                for name, source, network, own in heads]

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
        _write_text(out_dir / f"{name}.sweep.yaml", yaml.safe_dump(d, sort_keys=False, default_flow_style=None, width=100))
    return sweeps


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


def feature_settings(study: StudyFile, train: SetData) -> Any:
    """The study's :class:`ann.features.FeatureSettings` for the set's records (rate) and cars (mass inputs)."""
    from ann.features import FeatureSettings

    return FeatureSettings(rate=train.data.record_rate, **_feature_fields(study, list(train.car_names)))


@dataclass(frozen=True)
class InitialNetwork:
    """A saved network a study network continues training from: its file, pipeline, network and metadata."""

    path: Path
    pipeline: Any
    network: Any
    metadata: dict[str, Any]


def _initial_problem(name: str, rule: str, value: Any) -> Problem:
    return Problem(("networks", name, "mlp", "initial"), rule, value)


def initial_networks(study: StudyFile, study_dir: Path, source: str = "<study>") -> dict[str, InitialNetwork]:
    """Read every ``initial`` network (relative to the study file) and check that training can continue from it.

    Checked before any sweep runs: the file is an ``ann`` network file; its network has the
    entry's layout (hidden layers, units per layer, log target); its feature pipeline computes
    what the study's ``features`` and ``car_masses`` ask for. The records' rate, the probes and
    the coupler are checked in :func:`train_networks`, once the records exist. Raises
    :class:`CaseError` at ``networks.<name>.mlp.initial``.
    """
    import ann.storage as storage

    found: dict[str, InitialNetwork] = {}
    problems: list[Problem] = []
    cars: list[str] | None = None
    for name, spec in study.networks.items():
        if getattr(spec, "initial", None) is None:
            continue
        path = study_dir / spec.initial
        if not path.is_file():
            problems.append(_initial_problem(name, f"saved network file not found: {path}", spec.initial))
            continue
        try:
            pipeline, network, metadata = storage.load(path)
            spec.build().continue_from(network)
        except (ValueError, OSError, KeyError) as error:
            problems.append(_initial_problem(name, f"{path}: {error}", spec.initial))
            continue
        if cars is None:
            cars = [car["name"] for car in base_case_data(study, study_dir, source)["cars"]]
        wanted = _feature_fields(study, cars)
        saved = {key: getattr(pipeline.settings, key) for key in wanted}
        if saved != wanted:
            problems.append(_initial_problem(name, f"{path}: its feature pipeline {_describe(saved)} is not this study's {_describe(wanted)}", spec.initial))
            continue
        found[name] = InitialNetwork(path, pipeline, network, metadata)
    if problems:
        raise CaseError(problems, source)
    return found


def _feature_fields(study: StudyFile, cars: list[str]) -> dict[str, Any]:
    """The study's feature settings without the records' rate."""
    f = study.features
    extras = tuple(f"car_mass/{car}" for car in cars) if study.car_masses else ()
    return {"length": f.length, "lowpass": f.lowpass, "spectrum": f.spectrum, "normalise": f.normalise, "extras": extras}


def _describe(fields: dict[str, Any]) -> str:
    return "(" + ", ".join(f"{key} {list(value) if isinstance(value, tuple) else value}" for key, value in fields.items()) + ")"


def _check_initial_contract(name: str, initial: InitialNetwork, settings: Any, study: StudyFile, probes: list[str]) -> list[Problem]:
    """What only the records tell: the rate the pipeline reads, the probes and the coupler of the saved network."""
    problems = []
    if initial.pipeline.settings != settings:
        problems.append(_initial_problem(name, f"{initial.path}: its pipeline reads records at {initial.pipeline.settings.rate:g} Hz, these are at {settings.rate:g} Hz", str(initial.path)))
    for key, wanted in (("probes", probes), ("coupler", study.coupler)):
        if initial.metadata.get(key) != wanted:
            problems.append(_initial_problem(name, f"{initial.path}: it was trained with {key} {initial.metadata.get(key)}, this study has {wanted}", str(initial.path)))
    return problems


def train_networks(
    study: StudyFile,
    train: SetData,
    probes: list[str],
    out_dir: Path,
    initial: dict[str, InitialNetwork] | None = None,
    source: str = "<study>",
) -> list[TrainedNetwork]:
    """A pipeline and network per (source, network), saved with the femref network contract.

    A network named in ``initial`` (:func:`initial_networks`) keeps that saved pipeline and
    continues training from the saved weights; the others start afresh. With ``impact_types``,
    a pipeline and network per (source, network, impact type), each on the training and
    validation records of its type only (:func:`impact_types` of the source's own records).
    """
    from ann.splits import split_indices

    from reduced.signal_tools import IMPACT_KINDS

    initial = initial or {}
    fit_rows, validation_rows, _ = split_indices(train.index.size, (1.0 - study.validation_fraction, study.validation_fraction, 0.0), seed=0)
    settings = feature_settings(study, train)
    problems = [p for name, start in initial.items() for p in _check_initial_contract(name, start, settings, study, probes)]
    if problems:
        raise CaseError(problems, source)
    (out_dir / "networks").mkdir(parents=True, exist_ok=True)
    trained = []
    for source_model in study.sets[TRAIN].models:
        if not study.impact_types:
            splits = {None: (fit_rows, validation_rows)}
        else:
            kinds = impact_types(study, train, source_model)
            splits = {kind: (fit_rows[kinds[fit_rows] == kind], validation_rows[kinds[validation_rows] == kind]) for kind in IMPACT_KINDS}
            short = {kind: rows[0].size for kind, rows in splits.items() if rows[0].size < MIN_TYPE_SAMPLES or rows[1].size == 0}
            if short:
                counts = ", ".join(f"{np.count_nonzero(kinds == kind)} {kind.replace('_', '-')}" for kind in IMPACT_KINDS)
                rule = (f"a network per impact type needs at least {MIN_TYPE_SAMPLES} training and 1 validation impacts of each type; "
                        f"the train set's {source_model} records classify as {counts} — vary the coupler contact "
                        "(e.g. couplers.0.contact: {choice: [compression_only, bilateral]}) or add samples")
                raise CaseError(Problem(("impact_types",), rule), source)
        for name, spec in study.networks.items():
            for kind, (fit, validation) in splits.items():
                trained.append(_train_network(study, train, probes, out_dir, source, settings, source_model, name, spec, initial.get(name),
                                              fit, validation, kind))
    return trained


MIN_TYPE_SAMPLES = 4
"""Fewest training records of an impact type a per-type network is trained on."""


def _train_network(study: StudyFile, train: SetData, probes: list[str], out_dir: Path, source: str, settings: Any, source_model: str,
                   name: str, spec: Any, start: InitialNetwork | None, fit_rows: NDArray[np.int64], validation_rows: NDArray[np.int64],
                   kind: str | None) -> TrainedNetwork:
    """One pipeline and network trained on ``source_model``'s records of ``fit_rows``, scored on ``validation_rows``, saved as
    ``networks/<source_model>_<name>[_<kind>].npz``."""
    import ann.storage as storage
    from ann.features import FeaturePipeline

    data = train.data
    masses = train.car_masses if study.car_masses else None
    records, peaks = train.records(source_model, probes), train.peaks(source_model, study.coupler)
    started = time.perf_counter()
    if start is None:
        pipeline = FeaturePipeline(settings).fit(records[fit_rows], data.record_rate, _rows(masses, fit_rows))
        network = spec.build()
    else:
        pipeline = start.pipeline
        network = spec.build().continue_from(start.network)
    features = pipeline.transform(records[fit_rows], data.record_rate, _rows(masses, fit_rows))
    try:
        network.fit(features, peaks[fit_rows])
    except ValueError as error:  # a diverging momentum run: the settings are at fault
        raise CaseError(Problem(("networks", name), f"training on {source_model} records failed: {error}"), source) from None
    elapsed = time.perf_counter() - started
    estimator = storage.Estimator(pipeline, network)
    validation = error_summary(estimator.predict(records[validation_rows], data.record_rate, _rows(masses, validation_rows)), peaks[validation_rows])
    label = f"{source_model}_{name}" + ("" if kind is None else f"_{kind}")
    path = out_dir / "networks" / f"{label}.npz"
    loss_curve = np.asarray(getattr(network, "loss_curve_", ()), dtype=float)  # an RBF network has none
    metadata = {
        "target": "peak_coupler_force",
        "coupler": study.coupler,
        "probes": probes,
        "record_length": data.record_length,
        "record_end": data.record_end,
        "record_source": data.record_source,
        "measurement": data.measurement,
        "training": {
            "source_model": source_model,
            "network": name,
            "impact_type": kind or "any",
            "samples": int(fit_rows.size),
            "validation_samples": int(validation_rows.size),
            "validation_mean_error": validation.mean,
            "validation_p95_error": validation.p95,
            "training_time_s": elapsed,
            "epochs": int(loss_curve.size),
            "initial": None if start is None else str(start.path),
            "sweep": str(data.path),
            "spec_hash": data.spec_hash,
        },
    }
    with atomic_path(path) as tmp:  # a failure (or interrupt) while saving leaves no half-written network file
        storage.save(tmp, pipeline, network, metadata)
    return TrainedNetwork(label, source_model, name, path, int(fit_rows.size), validation, elapsed, estimator, loss_curve, kind)


def impact_types(study: StudyFile, data: SetData, model: str) -> NDArray[np.str_]:
    """Each ok sample's impact type from its stored records of ``model``: ``free_to_roll`` or ``coupled`` by the zero
    harmonic of the study coupler's relative acceleration (:func:`femref.sensing.findings.classify_records`, each car
    at its sensor nearest the centre), ``unknown`` where the records cannot be classified."""
    from femref.sensing.findings import classify_records

    t = record_times(data.data.record_length, data.data.record_end)
    stored = data.data.records[model]
    kinds = []
    for i, scene in zip(data.index, data.scenes):
        coupler = next(c for c in scene.couplers if c.name == study.coupler)
        records = {p: stored[i, c] for c, p in enumerate(data.data.probes)}
        try:
            kinds.append(classify_records(scene.cars, coupler, t, records).kind)
        except ValueError:
            kinds.append("unknown")
    return np.array(kinds)


def _routed_labels(networks: list[TrainedNetwork]) -> dict[str, tuple[str, str]]:
    """``<source>_<network>`` → (source, network) of the networks trained per impact type."""
    return {f"{t.source}_{t.network}": (t.source, t.network) for t in networks if t.impact_type is not None}


def _rows(masses: NDArray[np.float64] | None, rows: NDArray[np.int64]) -> NDArray[np.float64] | None:
    return None if masses is None else masses[rows]


def evaluate_set(study: StudyFile, name: str, data: SetData, networks: list[TrainedNetwork], probes: list[str]) -> SetScores:
    """Every network and inverse estimator on the set's fem records, against its fem peak force; networks trained
    per impact type as one estimate ``<source>_<network>``, each record read by the network of its classified type
    (NaN for a record that cannot be classified)."""
    reference = data.peaks("fem", study.coupler)
    records = data.records("fem", probes)
    masses = data.car_masses if study.car_masses else None
    estimates: dict[str, NDArray[np.float64]] = {}
    timing: dict[str, float] = {}
    kinds = impact_types(study, data, "fem") if any(t.impact_type is not None for t in networks) else None
    for trained in networks:
        started = time.perf_counter()
        if trained.impact_type is None:
            estimates[trained.name] = trained.estimator.predict(records, data.data.record_rate, masses)
            timing[trained.name] = (time.perf_counter() - started) / max(1, reference.size)
            continue
        label = f"{trained.source}_{trained.network}"  # its type's rows of the routed estimate
        routed = estimates.setdefault(label, np.full(reference.size, np.nan))
        rows = np.flatnonzero(kinds == trained.impact_type)
        if rows.size:
            routed[rows] = trained.estimator.predict(records[rows], data.data.record_rate, _rows(masses, rows))
        timing[label] = timing.get(label, 0.0) + (time.perf_counter() - started) / max(1, reference.size)
    estimates.update(inverse_estimates(study, data))
    summaries = {key: error_summary(value, reference) for key, value in estimates.items()}
    return SetScores(name, reference, estimates, summaries, timing)


def inverse_estimates(study: StudyFile, data: SetData) -> dict[str, NDArray[np.float64]]:
    """Peak of each inverse estimator's force history, from the stored fixed-length fem records."""
    from femref.estimators.inverse import ESTIMATORS

    t = record_times(data.data.record_length, data.data.record_end)
    all_records = data.data.records["fem"]
    out = {name: np.empty(data.index.size) for name in INVERSE_ESTIMATORS}
    for row, (i, scene) in enumerate(zip(data.index, data.scenes)):
        records = {p: all_records[i, c] for c, p in enumerate(data.data.probes)}
        for name in INVERSE_ESTIMATORS:
            out[name][row] = float(np.max(ESTIMATORS[name](scene, t, records)[study.coupler]))
    return out


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
    initial = initial_networks(study, study_dir, source)  # a bad initial network stops the study before its sweeps
    sweeps = prepare_sweeps(study, study_dir, out_dir, source)
    for name, sweep in sweeps.items():
        run_sweep(sweep, out_dir / f"{name}.h5", scheduler=scheduler, workers=workers, client=client, progress=progress)
    sets = {name: read_set(sweep, out_dir / f"{name}.h5") for name, sweep in sweeps.items()}
    probes = list(study.probes) if study.probes is not None else list(sets[TRAIN].data.probes)
    unknown = [p for p in probes if p not in sets[TRAIN].data.probes]
    if unknown:
        raise CaseError(Problem(("probes",), f"not sensors of the base case: {', '.join(unknown)}; sensors: {', '.join(sets[TRAIN].data.probes)}"), source)
    with one_blas_thread():  # small dense products: BLAS threads only spin against each other (4× the wall time on 2 busy cores)
        networks = train_networks(study, sets[TRAIN], probes, out_dir, initial, source)
    scores = {name: evaluate_set(study, name, sets[name], networks, probes) for name in study.evaluation_sets}
    outcome = StudyOutcome(study, out_dir, networks, scores)
    write_study(outcome, out_dir / "study.h5")
    _write_text(out_dir / "study.md", outcome.markdown())
    return outcome


def _write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` under a temporary name, renamed when complete (nothing half-written under ``path``)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_study(outcome: StudyOutcome, path: Path) -> None:
    """``study.h5`` (docs/design.md §4.4): per evaluation set the fem reference and every estimator's estimates and
    errors; per network its facts and ``loss_curve`` (epochs,), empty for an RBF network and an lbfgs-trained MLP."""
    with atomic_path(path) as tmp, hdf5_writer(tmp) as h5:
        h5.attrs["femref_version"] = __version__
        h5.attrs["study_yaml"] = yaml.safe_dump(outcome.study.model_dump(mode="json"), sort_keys=False)
        for trained in outcome.networks:
            group = h5.create_group(f"networks/{trained.name}")
            group.attrs.update(
                source=trained.source, network=trained.network, impact_type=trained.impact_type or "any", file=str(trained.path),
                training_samples=trained.training_samples,
                training_time_s=trained.training_time_s, validation_mean_error=trained.validation.mean, validation_p95_error=trained.validation.p95,
            )
            curve = group.create_dataset("loss_curve", data=np.asarray(trained.loss_curve, dtype=float))
            curve.attrs["units"] = "1"
            curve.attrs["definition"] = "E = squared error / 2 on the scaled log target + L2 penalty, mean over the epoch's batches"
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


__all__ = ["ErrorSummary", "InitialNetwork", "StudyOutcome", "error_summary", "impact_types", "initial_networks", "run_study"]
