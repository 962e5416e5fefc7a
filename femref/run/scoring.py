"""Scores of an impact model (or inverse estimator) result against the reference (fem) result.

Both results carry ``axes["time"]`` (s), ``couplers[c]["force"]`` (N, compression
positive) and ``probes["<car>/<sensor>"]["acceleration"]`` (m/s²). The time axes may
differ (an estimator on records measured at another rate): the comparison runs on the
result's samples inside the common interval ``[max(t0, t0_ref), min(t1, t1_ref)]``,
with the reference linearly interpolated there (``np.interp``). A peak the result's
grid does not sample is then missed by both alike.

Metrics (floats; names fixed, they become HDF5 attributes of ``/scores/<model>``)::

    coupler_force_peak_error_<c>       |max P − max P_ref| / max P_ref           (peak compression)
    coupler_force_peak_time_error_<c>  t(max P) − t(max P_ref)                   (s, signed)
    coupler_force_rms_error_<c>        rms(P − P_ref) / rms(P_ref)
    acceleration_rms_error_<p>         rms(a − a_ref) / rms(a_ref)
    acceleration_peak_error_<p>        |max|a| − max|a_ref|| / max|a_ref|
    coupler_force_peak_error_max, coupler_force_rms_error_max, acceleration_rms_error_max

for every coupler and probe present in both results.

A result that estimates peaks only — a network estimator, ``couplers[c]["peak_force"]``
(N, one value) and no time axis — is scored on those peaks alone
(:func:`score_peak_estimates`): ``coupler_force_peak_error_<c> = |P̂ − max P_ref| / max P_ref``
with ``max P_ref`` over the whole reference history, and ``coupler_force_peak_error_max``.
It has no histories, so no peak-time, rms or acceleration metrics. A relative metric whose
reference scale vanishes — ``max P_ref ≤ 0`` (the coupler never compressed; then the
peak time is undefined too), ``rms(P_ref) = 0``, ``max|a_ref| = 0`` — is **NaN**: the
relative error of a signal that is not there is undefined, and NaN cannot be mistaken
for a good score. It is decided before dividing, so no RuntimeWarning is raised. The
aggregates are the maxima over the finite per-item values, and are left out when
there is none. Checked on shifted and scaled synthetic pulses with known errors
(``tests/run/test_scoring.py``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.core.catalog import REFERENCES
from femref.results import ModelResult

Metrics = dict[str, float]


def score_impact(reference: ModelResult, result: ModelResult) -> Metrics:
    """Coupler-force and acceleration errors of ``result`` against ``reference`` (module docstring).

    A result of peak estimates only (no time axis) goes to :func:`score_peak_estimates`.
    Raises ValueError when either result failed, lacks a time axis, or the two time
    axes have fewer than two of the result's samples in common.
    """
    if _peaks_only(result):
        return score_peak_estimates(reference, result)
    t_ref, t = _time_axis(reference), _time_axis(result)
    window = _common_window(t_ref, t)
    tw = t[window]
    metrics: Metrics = {}
    for name in sorted(set(reference.couplers) & set(result.couplers)):
        ref = np.interp(tw, t_ref, _series(reference.couplers[name], "force", reference.model, f"coupler {name}", t_ref.size))
        mine = _series(result.couplers[name], "force", result.model, f"coupler {name}", t.size)[window]
        metrics.update(coupler_force_errors(name, tw, mine, ref))
    for name in sorted(p for p in set(reference.probes) & set(result.probes) if _has_acceleration(reference, result, p)):
        ref = np.interp(tw, t_ref, _series(reference.probes[name], "acceleration", reference.model, f"probe {name}", t_ref.size))
        mine = _series(result.probes[name], "acceleration", result.model, f"probe {name}", t.size)[window]
        metrics.update(acceleration_errors(name, mine, ref))
    metrics.update(_aggregates(metrics))
    return metrics


def score_peak_estimates(reference: ModelResult, result: ModelResult) -> Metrics:
    """Peak coupler-force errors of a result that holds peak estimates ``couplers[c]["peak_force"]`` only.

    ``coupler_force_peak_error_<c> = |P̂ − max P_ref| / max P_ref`` (NaN when the reference
    never compresses, ``max P_ref ≤ 0``) for every coupler in both results, and the
    aggregate ``coupler_force_peak_error_max``. Raises ValueError when either result failed,
    the reference lacks a time axis or a force history, or a peak is not one value.
    """
    t_ref = _time_axis(reference)
    if not result.ok:
        raise ValueError(f"cannot score model {result.model!r}: its status is {result.status!r} ({result.message})")
    metrics: Metrics = {}
    for name in sorted(set(reference.couplers) & set(result.couplers)):
        ref = _series(reference.couplers[name], "force", reference.model, f"coupler {name}", t_ref.size)
        metrics[f"coupler_force_peak_error_{name}"] = _peak_error(_peak_estimate(result, name), float(np.max(ref)))
    metrics.update(_aggregates(metrics))
    return metrics


def _peaks_only(result: ModelResult) -> bool:
    """A result of peak estimates: coupler ``peak_force`` values and no time axis (a network estimator)."""
    return result.ok and "time" not in result.axes and any("peak_force" in out for out in result.couplers.values())


def _peak_estimate(result: ModelResult, name: str) -> float:
    outputs = result.couplers[name]
    if "peak_force" not in outputs:
        raise ValueError(f"model {result.model!r}: coupler {name} has no 'peak_force' estimate")
    value = np.asarray(outputs["peak_force"], dtype=float)
    if value.size != 1:
        raise ValueError(f"model {result.model!r}: coupler {name} peak_force has shape {value.shape}, expected one value")
    return float(value.reshape(-1)[0])


def _peak_error(peak: float, peak_ref: float) -> float:
    """``|P − P_ref| / P_ref`` of peak compressions, NaN when the reference never compresses (``P_ref ≤ 0``)."""
    return abs(peak - peak_ref) / peak_ref if peak_ref > 0.0 else math.nan


def coupler_force_errors(name: str, time: NDArray[np.float64], force: NDArray[np.float64], reference: NDArray[np.float64]) -> Metrics:
    """Peak, peak-time and rms errors of one coupler force on a shared time axis (NaN where undefined)."""
    peak_ref = float(np.max(reference))
    k, k_ref = int(np.argmax(force)), int(np.argmax(reference))
    compressed = peak_ref > 0.0
    return {
        f"coupler_force_peak_error_{name}": _peak_error(float(force[k]), peak_ref),
        f"coupler_force_peak_time_error_{name}": float(time[k] - time[k_ref]) if compressed else math.nan,
        f"coupler_force_rms_error_{name}": _relative_rms(force, reference),
    }


def acceleration_errors(name: str, acceleration: NDArray[np.float64], reference: NDArray[np.float64]) -> Metrics:
    """Rms and peak-magnitude errors of one probe's acceleration (NaN where the reference is zero)."""
    peak_ref = float(np.max(np.abs(reference)))
    peak = float(np.max(np.abs(acceleration)))
    return {
        f"acceleration_rms_error_{name}": _relative_rms(acceleration, reference),
        f"acceleration_peak_error_{name}": abs(peak - peak_ref) / peak_ref if peak_ref > 0.0 else math.nan,
    }


def _relative_rms(values: NDArray[np.float64], reference: NDArray[np.float64]) -> float:
    """``rms(v − r)/rms(r)``, NaN when ``rms(r) = 0``."""
    scale = float(np.sqrt(np.mean(reference**2)))
    if not scale > 0.0:
        return math.nan
    return float(np.sqrt(np.mean((values - reference) ** 2))) / scale


AGGREGATES: dict[str, str] = {
    "coupler_force_peak_error_max": "coupler_force_peak_error_",
    "coupler_force_rms_error_max": "coupler_force_rms_error_",
    "acceleration_rms_error_max": "acceleration_rms_error_",
}
"""Aggregate metric → prefix of the per-item metrics it is the maximum of."""


def _aggregates(metrics: Metrics) -> Metrics:
    out: Metrics = {}
    for name, prefix in AGGREGATES.items():
        values = [v for k, v in metrics.items() if k.startswith(prefix) and math.isfinite(v)]
        if values:
            out[name] = max(values)
    return out


def _time_axis(result: ModelResult) -> NDArray[np.float64]:
    if not result.ok:
        raise ValueError(f"cannot score model {result.model!r}: its status is {result.status!r} ({result.message})")
    if "time" not in result.axes:
        raise ValueError(f"model {result.model!r} has no time axis (axes: {', '.join(result.axes) or 'none'})")
    t = np.asarray(result.axes["time"], dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError(f"model {result.model!r}: the time axis must be 1-D, finite, strictly increasing, >= 2 samples")
    return t


def _common_window(t_ref: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.bool_]:
    """The result's samples inside the common interval of both axes (at least two)."""
    lo, hi = max(t_ref[0], t[0]), min(t_ref[-1], t[-1])
    window = (t >= lo) & (t <= hi)
    if np.count_nonzero(window) < 2:
        raise ValueError(
            f"the time axes overlap in fewer than two of the result's samples "
            f"(reference {t_ref[0]:g}–{t_ref[-1]:g} s, result {t[0]:g}–{t[-1]:g} s)"
        )
    return window


def _series(outputs: dict[str, NDArray], key: str, model: str, what: str, samples: int) -> NDArray[np.float64]:
    """``outputs[key]`` as a float history of ``samples`` values (one per time)."""
    if key not in outputs:
        raise ValueError(f"model {model!r}: {what} has no {key!r} history")
    values = np.asarray(outputs[key], dtype=float)
    if values.shape != (samples,):
        raise ValueError(f"model {model!r}: {what} {key} has shape {values.shape}, expected ({samples},) like its time axis")
    return values


def _has_acceleration(reference: ModelResult, result: ModelResult, probe: str) -> bool:
    return "acceleration" in reference.probes[probe] and "acceleration" in result.probes[probe]


def score_results(kind: str, results: list[ModelResult]) -> dict[str, dict[str, Any]]:
    """Scores of every ok result of a scene of ``kind`` against its reference (``femref.core.catalog.REFERENCES``)."""
    if kind == "impact":
        return score_impact_results(results)
    return score_single_body(kind, results)


def score_single_body(kind: str, results: list[ModelResult]) -> dict[str, dict[str, Any]]:
    """Relative errors of each model against the reference, per probe and overall.

    ``acceleration_error_<probe> = max|a − a_ref| / max|a_ref|`` over the axis (time or
    frequency), normalised by the reference's peak over all probes (a free end's force is
    zero); ``…_rms_error_<probe>`` is ``rms(a − a_ref)/rms(a_ref)``; the same for the rod's
    axial force; ``speedup`` = reference wall time /
    model wall time.
    """
    by_name = {r.model: r for r in results if r.ok}
    reference = next((by_name[name] for name in REFERENCES[kind] if name in by_name), None)
    if reference is None:
        return {}
    scores: dict[str, dict[str, Any]] = {}
    for result in by_name.values():
        if result is reference:
            continue
        metrics: dict[str, Any] = {"reference": reference.model, "wall_time_s": result.wall_time_s}
        if result.wall_time_s > 0.0:
            metrics["speedup"] = reference.wall_time_s / result.wall_time_s
        worst = worst_rms = 0.0
        scale = {
            quantity: max((float(np.max(np.abs(out[quantity]))) for out in reference.probes.values() if quantity in out), default=0.0)
            for quantity in ("acceleration", "axial_force")
        }
        for probe, outputs in reference.probes.items():
            for quantity in ("acceleration", "axial_force"):
                if quantity in outputs and quantity in result.probes.get(probe, {}):
                    ref = outputs[quantity]
                    error = float(np.max(np.abs(result.probes[probe][quantity] - ref)) / max(scale[quantity], 1e-300))
                    metrics[f"{quantity}_error_{probe}"] = error
                    difference = result.probes[probe][quantity] - ref
                    metrics[f"{quantity}_rms_error_{probe}"] = float(
                        np.sqrt(np.mean(np.abs(difference) ** 2) / max(np.mean(np.abs(ref) ** 2), 1e-300))
                    )
                    if quantity == "acceleration":
                        worst = max(worst, error)
                        worst_rms = max(worst_rms, metrics[f"acceleration_rms_error_{probe}"])
        metrics["acceleration_error_max"] = worst
        metrics["acceleration_rms_error_max"] = worst_rms
        scores[result.model] = metrics
    return scores


def _measured_view(result: ModelResult) -> ModelResult:
    """The measured records of a result as a result of their own (time axis, probe accelerations)."""
    view = ModelResult(result.model)
    view.axes = {"time": result.measured["time"]}
    view.probes = {p: {"acceleration": a} for p, a in result.measured.items() if p != "time"}
    return view


def score_impact_results(results: list[ModelResult]) -> dict[str, dict[str, Any]]:
    """Scores of every ok result against the ``fem`` run, with wall time and speed-up.

    With a measurement chain the sensor accelerations are also scored as measured
    (``measured_acceleration_rms_error_<probe>`` …): in the band the records keep, where
    the cheaper models are meant to be compared.
    """
    reference = next((r for r in results if r.model == REFERENCES["impact"][0] and r.ok), None)
    if reference is None:
        return {}
    scores: dict[str, dict[str, Any]] = {}
    for result in results:
        if result is reference or not result.ok:
            continue
        metrics: dict[str, Any] = {"reference": reference.model, "wall_time_s": result.wall_time_s}
        metrics.update(score_impact(reference, result))
        if reference.measured and result.measured:
            measured = score_impact(_measured_view(reference), _measured_view(result))
            metrics.update({f"measured_{name}": value for name, value in measured.items()})
        if result.wall_time_s > 0.0:
            metrics["speedup"] = reference.wall_time_s / result.wall_time_s
        scores[result.model] = metrics
    return scores


__all__ = ["AGGREGATES", "acceleration_errors", "coupler_force_errors", "score_impact", "score_peak_estimates", "score_results"]
