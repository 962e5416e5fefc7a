"""The work of one sweep sample, run on a Dask worker: case data in, fixed-length arrays out.

:func:`run_sample` is a top-level function (Dask pickles it by reference; a sweep sends its
samples in batches through :func:`run_samples`) that never raises: any failure — a case
the worker cannot parse, a model run that fails, an exception anywhere — comes back as the
``error`` text of the returned record, so one bad sample never stops a sweep. The record is a plain dict (cheap to ship back to the client)::

    error                       ""  or why the sample failed
    probes, couplers, models    channel, coupler and model-run names in scene order
    <model>/records             (channels, record_length) m/s²   femref.sensing.records (measured if the case has a measurement)
    <model>/coupler_force       (couplers, force_length) N, compression positive, np.interp onto record_times
    <model>/peak_coupler_force  (couplers,) N: max of the full force history (not of the resampled one)
    <model>/wall_time_s         () s
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from femref.case import parse_case
from femref.sensing.records import acceleration_histories, fixed_length_records, record_times
from femref.run import run_scene
from femref.scene.build import scene_from_case

__all__ = ["run_sample", "run_samples"]


def run_sample(case_data: dict[str, Any], base_dir: str, record_length: int, force_length: int) -> dict[str, Any]:
    """Parse, build and run one sample's impact case; its records, coupler forces and wall times per model."""
    try:
        case = parse_case(case_data, source="<sample>", base_dir=Path(base_dir))
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


def run_samples(cases: list[dict[str, Any]], base_dir: str, record_length: int, force_length: int) -> list[dict[str, Any]]:
    """:func:`run_sample` of each case, in one task: a cheap sample (a rigid run costs milliseconds)
    would otherwise cost less than the scheduling and shipping of its own task."""
    return [run_sample(case, base_dir, record_length, force_length) for case in cases]

