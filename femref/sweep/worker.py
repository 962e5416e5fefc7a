"""The work of a sweep's samples on a Dask worker: the sweep (once per worker) and each sample's values in,
fixed-length arrays out.

:func:`run_samples` takes the sweep — its validated base case, shipped to each worker once
(``Client.scatter``) — and a batch of samples as ``(index, substitutions)``: each sample's case is derived
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

:func:`run_sample` runs one case given as data (parsed whole): the path of a case file, for comparison.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from femref.case import CaseError, ImpactCase, parse_case
from femref.run import run_scene
from femref.scene.build import scene_from_case
from femref.sensing.records import acceleration_histories, fixed_length_records, record_times
from femref.sweep.derive import derive_case
from femref.sweep.spec import Sweep

__all__ = ["run_sample", "run_samples", "sample_records"]


def run_samples(sweep: Sweep, samples: list[tuple[int, dict[str, Any]]]) -> list[dict[str, Any]]:
    """The record of each ``(index, substitutions)`` of ``sweep``, in one task: a cheap sample (a rigid run costs
    milliseconds) would otherwise cost less than the scheduling and shipping of its own task."""
    records = []
    for index, substitutions in samples:
        try:
            case = derive_case(sweep.base_case, sweep.resolved_base, substitutions, sweep.base_dir, f"{sweep.source} sample {index}")
        except CaseError as invalid:
            records.append({"error": str(invalid)})
            continue
        records.append(sample_records(case, sweep.base_dir, sweep.spec.outputs.record_length, sweep.spec.outputs.force_length))
    return records


def run_sample(case_data: dict[str, Any], base_dir: str, record_length: int, force_length: int) -> dict[str, Any]:
    """Parse one case given as data, build and run it: :func:`sample_records` (a case that does not parse: its error)."""
    try:
        case = parse_case(case_data, source="<sample>", base_dir=Path(base_dir))
    except Exception as error:  # the sweep records it as the sample's failure and goes on
        return {"error": f"{type(error).__name__}: {error}"}
    return sample_records(case, Path(base_dir), record_length, force_length)


def sample_records(case: ImpactCase, base_dir: Path, record_length: int, force_length: int) -> dict[str, Any]:
    """Build and run one validated impact case; its records, coupler forces and wall times per model (module
    docstring). Never raises."""
    try:
        scene = scene_from_case(case, Path(base_dir))
        outcome = run_scene(scene)
        probes = list(scene.probes)
        couplers = [coupler.name for coupler in scene.couplers]
        out: dict[str, Any] = {"error": "", "probes": probes, "couplers": couplers, "models": [r.model for r in outcome.results]}
        force_times = record_times(force_length, scene.end)
        for result in outcome.results:
            if not result.ok:
                return {"error": f"model {result.model} failed: {result.message}"}
            time, histories = acceleration_histories(result)
            forces = [result.couplers[c]["force"] for c in couplers]
            out[f"{result.model}/records"] = fixed_length_records(time, histories, probes, record_length, scene.end)
            out[f"{result.model}/coupler_force"] = np.array([np.interp(force_times, result.axes["time"], f) for f in forces]).reshape(len(couplers), force_length)
            out[f"{result.model}/peak_coupler_force"] = np.array([np.max(f) for f in forces], dtype=float)
            out[f"{result.model}/wall_time_s"] = float(result.wall_time_s)
        return out
    except Exception as error:  # the sweep records it as the sample's failure and goes on
        return {"error": f"{type(error).__name__}: {error}"}
