"""The work of a sweep's samples on a Dask worker: the sweep (once per worker) and each sample's values in,
fixed-length arrays out.

:func:`run_samples` takes the sweep — its validated base case, pickled, unpickled once per worker
(:func:`sweep_of`) — and a batch of samples as ``(index, substitutions)``: each sample's case is derived
by substitution (:meth:`femref.sweep.spec.Sweep.sample_case`, validated once, here) and built, and the batch's
model runs are run together (:func:`femref.sweep.batch.run_models`: those of one scene structure stepped by one
compiled call). It never raises: any failure — a substitution that breaks a rule, a model run that fails, an
exception anywhere — comes back as the ``error`` text of the sample's record, so one bad sample never stops a
sweep. A record is a plain dict (cheap to ship back to the client)::

    error                       ""  or why the sample failed
    probes, couplers, models    channel, coupler and model-run names in scene order
    <model>/records             (channels, record_length) m/s²   femref.sensing.records (measured if the case has a measurement)
    <model>/coupler_force       (couplers, force_length) N, compression positive, np.interp onto record_times
    <model>/peak_coupler_force  (couplers,) N: max of the full force history (not of the resampled one)
    <model>/wall_time_s         () s
"""

from __future__ import annotations

import dataclasses
import functools
import os
import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np

from femref.case import CaseError, ImpactCase
from femref.run.budget import check_budget
from femref.run.costs import BUDGET_VARIABLE
from femref.results import ModelResult
from femref.run.runner import add_measured_records
from femref.scene import ImpactScene
from femref.scene.build import scene_from_case
from femref.sensing.records import acceleration_histories, fixed_length_records, record_times
from femref.sweep.batch import run_models
from femref.sweep.derive import derive_case
from femref.sweep.spec import Sweep

__all__ = ["BUDGET_NEUTRAL", "run_samples", "sample_records", "scene_records", "scene_with_values"]


def run_samples(sweep: Sweep | bytes, samples: list[tuple[int, dict[str, Any]]]) -> list[dict[str, Any]]:
    """The record of each ``(index, substitutions)`` of ``sweep`` (or of the sweep pickled: :func:`sweep_of`), in one
    task: a cheap sample (a rigid run costs a millisecond) would otherwise cost less than the scheduling and shipping
    of its own task. The samples' model runs of one scene structure are stepped together
    (:func:`femref.sweep.batch.run_models`)."""
    sweep = sweep_of(sweep) if isinstance(sweep, bytes) else sweep
    values_only = _values_only(sweep)
    base = _base_scene(sweep) if values_only else None
    budget_checked = _budget_checked_once(sweep, os.environ.get(BUDGET_VARIABLE, ""))
    scenes: list[ImpactScene | dict[str, Any]] = []
    for index, substitutions in samples:
        source = f"{sweep.source} sample {index}"
        try:
            case = derive_case(sweep.base_case, sweep.resolved_base, substitutions, sweep.base_dir, source)
        except CaseError as invalid:
            scenes.append({"error": str(invalid)})
            continue
        scenes.append(_built(case, sweep.base_dir, source, budget_checked, base))
    return scene_records(scenes, sweep.spec.outputs.record_length, sweep.spec.outputs.force_length)


@functools.lru_cache(maxsize=4)
def sweep_of(pickled: bytes) -> Sweep:
    """The sweep of its pickled bytes, unpickled once per worker process (a task carries the bytes, a few kB: a
    worker that its nanny restarts gets them with its next task, where data scattered to it would be lost)."""
    return pickle.loads(pickled)  # noqa: S301 - the client's own sweep, through Dask's own pickling


#: Key paths whose values no work-budget prediction reads (:func:`femref.run.budget.predict`): a sweep that draws
#: only these has every sample's budget equal to its base case's (tests/sweep/test_run.py checks the prediction).
#: They are also the values that reach a scene only as a car's ``velocity`` or a field of its ``measurement``
#: (:func:`femref.scene.build.impact_scene_from_case` copies them): such a sample's scene is the base scene with
#: them (:func:`scene_with_values`).
BUDGET_NEUTRAL = re.compile(r"cars\.\d+\.velocity|measurement\.(seed|noise|pitch_rate_noise)")
_MEASUREMENT_VALUES = ("seed", "noise", "pitch_rate_noise")


def _values_only(sweep: Sweep) -> bool:
    """Whether every sample of ``sweep`` substitutes only :data:`BUDGET_NEUTRAL` key paths (its drawn parameters and
    the noise seed the sampling adds)."""
    return all(BUDGET_NEUTRAL.fullmatch(path) for path in sweep.spec.parameters)


@functools.lru_cache(maxsize=8)
def _base_scene(sweep: Sweep) -> ImpactScene:
    """The base case's scene, built once per worker and sweep (a sweep is one object on a worker, :func:`sweep_of`)."""
    return scene_from_case(sweep.base_case, sweep.base_dir)


def scene_with_values(base: ImpactScene, case: ImpactCase) -> ImpactScene:
    """``scene_from_case(case)`` of a case that differs from ``base``'s only at :data:`BUDGET_NEUTRAL` key paths: the
    base scene (its car bodies, and what is cached on them) with the case's car velocities and measurement values."""
    cars = tuple(car if car.velocity == spec.velocity else dataclasses.replace(car, velocity=spec.velocity) for car, spec in zip(base.cars, case.cars))
    measurement = base.measurement
    if measurement is not None and case.measurement is not None:
        measurement = dataclasses.replace(measurement, **{name: getattr(case.measurement, name) for name in _MEASUREMENT_VALUES})
    return dataclasses.replace(base, cars=cars, measurement=measurement)


@functools.lru_cache(maxsize=8)
def _budget_checked_once(sweep: Sweep, budget: str) -> bool:
    """Whether the base case's budget check holds for every sample: no parameter can change the prediction
    (:data:`BUDGET_NEUTRAL`) and the base scene is within the budget (``budget``: ``FEMREF_BUDGET`` as set) —
    checked once per worker, sweep and budget (a sweep is one object on a worker, :func:`sweep_of`: the cache is
    keyed on it)."""
    if not _values_only(sweep):
        return False
    try:
        check_budget(_base_scene(sweep), sweep.source)
    except CaseError:
        return False  # each sample is refused with its own name
    return True


def sample_records(case: ImpactCase, base_dir: Path, record_length: int, force_length: int, *, source: str = "<sample>",
                   budget_checked: bool = False) -> dict[str, Any]:
    """Build and run one validated impact case — its budget checked (unless ``budget_checked``), its model runs
    and their measured records, no estimators, scores or self-check (the sweep file keeps none of them) — and give
    its records, coupler forces and wall times per model (module docstring). Never raises."""
    return scene_records([_built(case, base_dir, source, budget_checked)], record_length, force_length)[0]


def _built(case: ImpactCase, base_dir: Path, source: str, budget_checked: bool, base: ImpactScene | None = None) -> ImpactScene | dict[str, Any]:
    """The scene of ``case`` (from ``base`` by :func:`scene_with_values` if given), its budget checked unless
    ``budget_checked``; or the sample's failed record."""
    try:
        scene = scene_with_values(base, case) if base is not None else scene_from_case(case, Path(base_dir))
        if not budget_checked:
            check_budget(scene, source)
        return scene
    except Exception as error:  # the sweep records it as the sample's failure and goes on
        return {"error": f"{type(error).__name__}: {error}"}


def scene_records(scenes: list[ImpactScene | dict[str, Any]], record_length: int, force_length: int) -> list[dict[str, Any]]:
    """The record of each of ``scenes`` (a scene, or the record of a sample that failed already): their model runs,
    those of one scene structure stepped together (:func:`femref.sweep.batch.run_models`). Never raises."""
    built = [(k, scene) for k, scene in enumerate(scenes) if not isinstance(scene, dict)]
    records: list[dict[str, Any]] = [scene if isinstance(scene, dict) else {} for scene in scenes]
    try:
        results = run_models([scene for _, scene in built])
    except Exception as error:  # the sweep records it as each sample's failure and goes on
        for k, _ in built:
            records[k] = {"error": f"{type(error).__name__}: {error}"}
        return records
    for (k, scene), runs in zip(built, results):
        records[k] = _records_of(scene, runs, record_length, force_length)
    return records


def _records_of(scene: ImpactScene, results: list[ModelResult], record_length: int, force_length: int) -> dict[str, Any]:
    """One sample's record from its model results (module docstring). Never raises."""
    try:
        probes = list(scene.probes)
        couplers = [coupler.name for coupler in scene.couplers]
        out: dict[str, Any] = {"error": "", "probes": probes, "couplers": couplers, "models": [r.model for r in results]}
        force_times = record_times(force_length, scene.end)
        for result in results:
            if not result.ok:
                return {"error": f"model {result.model} failed: {result.message}"}
            if scene.measurement is not None:
                add_measured_records(scene, result)
            time, histories = acceleration_histories(result)
            forces = [result.couplers[c]["force"] for c in couplers]
            out[f"{result.model}/records"] = fixed_length_records(time, histories, probes, record_length, scene.end)
            out[f"{result.model}/coupler_force"] = np.array([np.interp(force_times, result.axes["time"], f) for f in forces]).reshape(len(couplers), force_length)
            out[f"{result.model}/peak_coupler_force"] = np.array([np.max(f) for f in forces], dtype=float)
            out[f"{result.model}/wall_time_s"] = float(result.wall_time_s)
        return out
    except Exception as error:  # the sweep records it as the sample's failure and goes on
        return {"error": f"{type(error).__name__}: {error}"}
