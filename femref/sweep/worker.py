"""The work of a sweep's samples on a Dask worker: the sweep (once per worker) and each sample's values in,
fixed-length arrays out.

:func:`run_samples` takes the sweep — its validated base case, pickled, unpickled once per worker
(:func:`sweep_of`) — and a batch of samples as ``(index, substitutions)``: each sample's case is derived
by substitution (:meth:`femref.sweep.spec.Sweep.sample_case`, validated once, here), built and run. It is the
one place where a batch of samples of one scene structure meets the models: a stepping batched over samples
plugs in here. It never raises: any failure — a substitution that breaks a rule, a model run that fails, an
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
from femref.run.runner import add_measured_records, load_compiled_loop, run_model
from femref.scene.build import scene_from_case
from femref.sensing.records import acceleration_histories, fixed_length_records, record_times
from femref.sweep.derive import derive_case
from femref.sweep.spec import Sweep

__all__ = ["run_samples", "sample_records"]


def run_samples(sweep: Sweep | bytes, samples: list[tuple[int, dict[str, Any]]]) -> list[dict[str, Any]]:
    """The record of each ``(index, substitutions)`` of ``sweep`` (or of the sweep pickled: :func:`sweep_of`), in one
    task: a cheap sample (a rigid run costs milliseconds) would otherwise cost less than the scheduling and shipping
    of its own task."""
    sweep = sweep_of(sweep) if isinstance(sweep, bytes) else sweep
    records = []
    base_checked = _budget_checked_once(sweep, os.environ.get(BUDGET_VARIABLE, ""))
    for index, substitutions in samples:
        source = f"{sweep.source} sample {index}"
        try:
            case = derive_case(sweep.base_case, sweep.resolved_base, substitutions, sweep.base_dir, source)
        except CaseError as invalid:
            records.append({"error": str(invalid)})
            continue
        records.append(sample_records(case, sweep.base_dir, sweep.spec.outputs.record_length, sweep.spec.outputs.force_length,
                                      source=source, budget_checked=base_checked))
    return records


@functools.lru_cache(maxsize=4)
def sweep_of(pickled: bytes) -> Sweep:
    """The sweep of its pickled bytes, unpickled once per worker process (a task carries the bytes, a few kB: a
    worker that its nanny restarts gets them with its next task, where data scattered to it would be lost)."""
    return pickle.loads(pickled)  # noqa: S301 - the client's own sweep, through Dask's own pickling


#: Key paths whose values no work-budget prediction reads (:func:`femref.run.budget.predict`): a sweep that draws
#: only these has every sample's budget equal to its base case's (tests/sweep/test_run.py checks the prediction).
BUDGET_NEUTRAL = re.compile(r"cars\.\d+\.velocity|measurement\.(seed|noise|pitch_rate_noise)")


@functools.lru_cache(maxsize=8)
def _budget_checked_once(sweep: Sweep, budget: str) -> bool:
    """Whether the base case's budget check holds for every sample: no parameter can change the prediction
    (:data:`BUDGET_NEUTRAL`) and the base scene is within the budget (``budget``: ``FEMREF_BUDGET`` as set) —
    checked once per worker, sweep and budget (a sweep is one object on a worker, :func:`sweep_of`: the cache is
    keyed on it)."""
    if not all(BUDGET_NEUTRAL.fullmatch(path) for path in sweep.spec.parameters):
        return False
    try:
        check_budget(scene_from_case(sweep.base_case, sweep.base_dir), sweep.source)
    except CaseError:
        return False  # each sample is refused with its own name
    return True


def sample_records(case: ImpactCase, base_dir: Path, record_length: int, force_length: int, *, source: str = "<sample>",
                   budget_checked: bool = False) -> dict[str, Any]:
    """Build and run one validated impact case — its budget checked (unless ``budget_checked``), its model runs
    and their measured records, no estimators, scores or self-check (the sweep file keeps none of them) — and give
    its records, coupler forces and wall times per model (module docstring). Never raises."""
    try:
        scene = scene_from_case(case, Path(base_dir))
        if not budget_checked:
            check_budget(scene, source)
        load_compiled_loop(scene)
        results = [run_model(scene, run) for run in scene.runs]
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
