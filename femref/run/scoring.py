"""Every score of a model against the reference: one naming, one policy for a vanishing reference.

Names are ``<quantity>_<statistic>_error_<item>`` (floats; they become HDF5 attributes of
``/scores/<model>``), with ``<quantity>_<statistic>_error_max`` the maximum over the items:

    statistic    meaning                                               used for
    max          max|q − q_ref| / scale (pointwise, over the axis)     single body: acceleration, axial force
    rms          rms(q − q_ref) / rms(q_ref)                           both: acceleration, axial force, coupler force
    peak         |max q − max q_ref| / max q_ref (coupler: compression;  impact: coupler force, acceleration
                 acceleration: magnitudes)
    peak_time    t(max q) − t(max q_ref)  (s, signed)                  impact: coupler force

**Single body** (:func:`score_results`; reference ``exact`` where it ran, else ``fem``).

**Impact** (:func:`score_impact`; reference ``fem``): both results carry ``axes["time"]``
(s), ``couplers[c]["force"]`` (N, compression positive) and
``probes["<car>/<sensor>"]["acceleration"]`` (m/s²). The time axes may differ (each run
steps at its own step; an estimator reads records at another rate): the comparison runs
on the result's samples inside the common interval ``[max(t0, t0_ref), min(t1, t1_ref)]``,
with the reference linearly interpolated there (``np.interp``); a peak the result's grid
does not sample is missed by both alike. Per coupler and per probe (:data:`SCORED_SENSOR_QUANTITIES`), with the
aggregates of :data:`AGGREGATES`; with a measurement chain the same again on the measured records, prefixed
``measured_``. A run whose quasi-rigid cars leave their range somewhere is also scored where they are inside it
(:func:`in_range_errors`). A result of peak estimates only (a network estimator) is scored on those peaks alone
(:func:`score_peak_estimates`).

**A vanishing reference** — a peak, rms or overall scale of zero, or a coupler that never
compresses (then its peak time is undefined too) — makes the relative metric **NaN**,
decided before dividing (no RuntimeWarning), and ``undefined`` names each NaN metric with
its reason (:func:`undefined_reasons`): the relative error of a signal that is not there
is undefined, and NaN cannot be mistaken for a good score. Aggregates are maxima over the
finite items and are left out when there is none. Every score also carries
``reference``, ``wall_time_s`` and ``speedup`` (reference wall time / model wall time).
Checked on shifted and scaled synthetic signals with known errors
(``tests/run/test_scoring.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from numpy.typing import NDArray

from femref.core.catalog import REFERENCES
from femref.results import UNDEFINED, ModelResult

Metrics = dict[str, float]

SCORED_SENSOR_QUANTITIES: tuple[str, ...] = ("acceleration", "vertical_acceleration", "pitch_rate")
"""The sensor histories an impact is scored on: what accelerometers and rate gyroscopes record."""


def score_impact(reference: ModelResult, result: ModelResult) -> Metrics:
    """Coupler-force and acceleration errors of ``result`` against ``reference`` (module docstring); ValueError
    when either result failed, lacks a time axis, or the axes share fewer than two of the result's samples."""
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
    for quantity in SCORED_SENSOR_QUANTITIES:
        for name in sorted(p for p in set(reference.probes) & set(result.probes) if quantity in reference.probes[p] and quantity in result.probes[p]):
            ref = np.interp(tw, t_ref, _series(reference.probes[name], quantity, reference.model, f"probe {name}", t_ref.size))
            mine = _series(result.probes[name], quantity, result.model, f"probe {name}", t.size)[window]
            metrics.update(sensor_errors(name, mine, ref, quantity))
    metrics.update(_aggregates(metrics))
    return metrics


def score_peak_estimates(reference: ModelResult, result: ModelResult) -> Metrics:
    """``coupler_force_peak_error_<c> = |P̂ − max P_ref| / max P_ref`` (NaN when ``max P_ref ≤ 0``) of a result of peak
    estimates ``couplers[c]["peak_force"]`` only, and their maximum; ValueError when either result failed, the
    reference lacks a time axis or a force history, or a peak is not one value."""
    t_ref = _time_axis(reference)
    _check_ok(result)
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


def sensor_errors(name: str, values: NDArray[np.float64], reference: NDArray[np.float64], quantity: str = "acceleration") -> Metrics:
    """Rms and peak-magnitude errors of one probe's ``quantity`` (:data:`SCORED_SENSOR_QUANTITIES`; NaN
    where the reference is zero)."""
    return {
        f"{quantity}_rms_error_{name}": _relative_rms(values, reference),
        f"{quantity}_peak_error_{name}": _peak_error(float(np.max(np.abs(values))), float(np.max(np.abs(reference)))),
    }


def _relative_rms(values: NDArray, reference: NDArray) -> float:
    """``rms(v − r)/rms(r)`` (moduli of complex amplitudes), NaN when ``rms(r) = 0``."""
    scale = float(np.sqrt(np.mean(np.abs(reference) ** 2)))
    if not scale > 0.0:
        return math.nan
    return float(np.sqrt(np.mean(np.abs(values - reference) ** 2))) / scale


IN_RANGE_STATISTIC = "rms_in_range"
"""The statistic of the rms errors over the samples where a run's quasi-rigid cars are inside their range."""


AGGREGATES: dict[str, str] = {
    "coupler_force_peak_error_max": "coupler_force_peak_error_",
    "coupler_force_rms_error_max": "coupler_force_rms_error_",
    "acceleration_rms_error_max": "acceleration_rms_error_",
    "acceleration_max_error_max": "acceleration_max_error_",
    "vertical_acceleration_rms_error_max": "vertical_acceleration_rms_error_",
    "pitch_rate_rms_error_max": "pitch_rate_rms_error_",
    **{f"{q}_{IN_RANGE_STATISTIC}_error_max": f"{q}_{IN_RANGE_STATISTIC}_error_" for q in ("coupler_force", *SCORED_SENSOR_QUANTITIES)},
}
"""Aggregate metric → prefix of the per-item metrics it is the maximum of."""


def _aggregates(metrics: Metrics) -> Metrics:
    found = {name: [v for k, v in metrics.items() if k.startswith(prefix) and math.isfinite(v)] for name, prefix in AGGREGATES.items()}
    return {name: max(values) for name, values in found.items() if values}


def _check_ok(result: ModelResult) -> None:
    if not result.ok:
        raise ValueError(f"cannot score model {result.model!r}: its status is {result.status!r} ({result.message})")


def _time_axis(result: ModelResult) -> NDArray[np.float64]:
    _check_ok(result)
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


def score_results(kind: str, results: list[ModelResult]) -> dict[str, dict[str, Any]]:
    """Scores of every ok result of a scene of ``kind`` against its reference (``femref.core.catalog.REFERENCES``),
    with wall time and speed-up (:func:`_with_context`)."""
    ok = {r.model: r for r in results if r.ok}
    reference = next((ok[name] for name in REFERENCES[kind] if name in ok), None)
    if reference is None:
        return {}
    metrics_of = _impact_metrics if kind == "impact" else _single_body_metrics
    return {r.model: _with_context(metrics_of(reference, r), reference, r) for r in ok.values() if r is not reference}


def _single_body_metrics(reference: ModelResult, result: ModelResult) -> Metrics:
    """For ``q`` the acceleration and, on rods, the axial force, over the axis (time or frequency; complex amplitudes
    by modulus)::

        <q>_max_error_<probe> = max|q − q_ref| / max_probes max|q_ref|   (normalised by the reference's
                                                                          peak over all probes: a free
                                                                          end's force is zero)
        <q>_rms_error_<probe> = rms(q − q_ref) / rms(q_ref)

    and their aggregates."""
    metrics: Metrics = {}
    for quantity in ("acceleration", "axial_force"):
        scale = max((float(np.max(np.abs(out[quantity]))) for out in reference.probes.values() if quantity in out), default=0.0)
        for probe, outputs in reference.probes.items():
            if quantity in outputs and quantity in result.probes.get(probe, {}):
                ref, mine = outputs[quantity], result.probes[probe][quantity]
                worst = float(np.max(np.abs(mine - ref)))
                metrics[f"{quantity}_max_error_{probe}"] = worst / scale if scale > 0.0 else math.nan
                metrics[f"{quantity}_rms_error_{probe}"] = _relative_rms(mine, ref)
    return {**metrics, **_aggregates(metrics)}


def _measured_view(result: ModelResult) -> ModelResult:
    """The measured records of a result as a result of their own (time axis, probe accelerations, vertical ones
    on cars that bend)."""
    probes = {p: {"acceleration": a, **result.measured_bending.get(p, {})} for p, a in result.measured.items() if p != "time"}
    return ModelResult(result.model, axes={"time": result.measured["time"]}, probes=probes)


def _impact_metrics(reference: ModelResult, result: ModelResult) -> dict[str, Any]:
    """:func:`score_impact` and :func:`in_range_errors`; with a measurement chain also on the measured records
    (``measured_…``: the band the records keep, where the cheaper models are compared)."""
    metrics: dict[str, Any] = {**score_impact(reference, result), **in_range_errors(reference, result)}
    if reference.measured and result.measured:
        measured = score_impact(_measured_view(reference), _measured_view(result))
        metrics.update({f"measured_{name}": value for name, value in measured.items()})
    return metrics


IN_RANGE_DEGENERATE = "in_range_degenerate"
"""The score that says, in words, why a run's in-range part is degenerate (absent when it holds the impact)."""

IN_RANGE_CONTACT_LEVEL = 0.01
"""The reference is in contact where a coupler's compression exceeds this share of its peak (``P_ref > 0.01 max P_ref``)."""

IN_RANGE_MIN_CONTACT = 0.25
"""The least share of the reference's contact samples the in-range part must hold for its scores to speak of the impact:
a quarter of the pulse holds its rise or its fall, the part of the impact a car model is judged on."""

IN_RANGE_MIN_SAMPLES = 10
"""The least number of in-range samples inside the contact: an rms over fewer is one oscillation at best."""


def in_range_errors(reference: ModelResult, result: ModelResult) -> dict[str, Any]:
    """``<q>_rms_in_range_error_<item> = rms_I(q − q_ref) / rms_I(q_ref)``, ``I`` the result's samples outside every
    interval of ``settings["quasi_rigid_range"]["outside"]`` (:mod:`femref.run.validity`), for the coupler forces and
    every scored sensor quantity, their maxima, and ``outside_range_fraction``. When ``I`` does not hold the impact
    (:func:`in_range_degeneracy`) ``in_range_degenerate`` says why and every in-range score is **NaN**: over a
    post-separation tail the reference force is ≈ 0 and the error measures the cars' free ringing, not the model on
    the impact. Empty when nothing is marked."""
    marked = result.settings.get("quasi_rigid_range") or {}
    if not marked.get("outside") or "time" not in result.axes:
        return {}
    t = np.asarray(result.axes["time"], dtype=float)
    outside = np.zeros(t.size, dtype=bool)
    for start, end in marked["outside"]:
        outside |= (t >= start) & (t <= end)
    inside = ~outside
    metrics: dict[str, Any] = {"outside_range_fraction": float(np.mean(outside))}
    _, reason = in_range_degeneracy(reference, t, inside)
    if reason:
        metrics[IN_RANGE_DEGENERATE] = reason
    if np.count_nonzero(inside) < 2:
        return metrics
    view = ModelResult(result.model, axes={"time": t[inside]})
    view.couplers = {c: {"force": np.asarray(out["force"])[inside]} for c, out in result.couplers.items() if "force" in out}
    view.probes = {p: {q: np.asarray(out[q])[inside] for q in SCORED_SENSOR_QUANTITIES if q in out} for p, out in result.probes.items()}
    whole = score_impact(reference, view)
    in_range: Metrics = {
        name.replace("_rms_error_", f"_{IN_RANGE_STATISTIC}_error_", 1): math.nan if reason else value
        for name, value in whole.items() if "_rms_error_" in name and not name.endswith("_error_max")
    }
    metrics.update(in_range)
    metrics.update(_aggregates(in_range))
    return metrics


def in_range_degeneracy(reference: ModelResult, time: NDArray[np.float64], inside: NDArray[np.bool_]) -> tuple[float, str]:
    """``(c, reason)``: the share ``c`` of the reference's contact samples that are in range, and why the in-range part
    is degenerate ("" when it is not).

    On the result's samples ``time`` inside the reference's time axis, the reference is in contact where some
    coupler's compression ``P_ref(t) > IN_RANGE_CONTACT_LEVEL · max P_ref`` (``np.interp`` of each coupler's force).
    With ``C`` those samples and ``I`` the in-range ones (``inside``), ``c = |C ∩ I| / |C|``. Degenerate when
    ``c < IN_RANGE_MIN_CONTACT`` or ``|C ∩ I| < IN_RANGE_MIN_SAMPLES`` — *after separation* when most in-range samples
    lie after the reference's last contact sample (its force below 1 % of the peak there), else *too short*. The
    reason is one sentence without ``"; "`` (the separator of the scores' ``undefined`` list). A
    reference that never compresses has no contact (``c`` NaN): then only fewer than ``IN_RANGE_MIN_SAMPLES``
    in-range samples make the part degenerate (too short)."""
    t_ref = np.asarray(reference.axes["time"], dtype=float)
    window = (time >= t_ref[0]) & (time <= t_ref[-1])
    contact = np.zeros(time.size, dtype=bool)
    for outputs in reference.couplers.values():
        if "force" not in outputs:
            continue
        force = np.asarray(outputs["force"], dtype=float)
        peak = float(np.max(force))
        if peak > 0.0:
            contact |= window & (np.interp(time, t_ref, force) > IN_RANGE_CONTACT_LEVEL * peak)
    samples = int(np.count_nonzero(inside & window))
    if not contact.any():
        if samples < IN_RANGE_MIN_SAMPLES:
            return math.nan, f"too short: {samples} in-range samples (fewer than {IN_RANGE_MIN_SAMPLES})"
        return math.nan, ""
    held = int(np.count_nonzero(contact & inside))
    share = held / int(np.count_nonzero(contact))
    if share >= IN_RANGE_MIN_CONTACT and held >= IN_RANGE_MIN_SAMPLES:
        return share, ""
    separation = float(time[np.flatnonzero(contact)[-1]])
    after = int(np.count_nonzero(inside & window & (time > separation)))
    holds = f"it holds {share:.0%} of the contact, {held} samples ({IN_RANGE_MIN_CONTACT:.0%} and {IN_RANGE_MIN_SAMPLES} needed)"
    if samples and after > samples / 2:
        return share, (f"after separation: {after / samples:.0%} of the in-range samples lie after {separation:.3g} s, where the "
                       f"reference coupler force is below {IN_RANGE_CONTACT_LEVEL:.0%} of its peak, and {holds}")
    return share, f"too short: {holds}"


def _with_context(metrics: Metrics, reference: ModelResult, result: ModelResult) -> dict[str, Any]:
    """``reference``, ``wall_time_s``, ``speedup``, the metrics (with their aggregates), and ``undefined``:
    why each NaN metric is undefined (absent when none is)."""
    scores: dict[str, Any] = {"reference": reference.model, "wall_time_s": result.wall_time_s}
    if result.wall_time_s > 0.0:
        scores["speedup"] = reference.wall_time_s / result.wall_time_s
    scores.update(metrics)
    reasons = undefined_reasons(scores)
    if reasons:
        scores[UNDEFINED] = "; ".join(f"{name}: {reason}" for name, reason in reasons.items())
    return scores


#: The observed order ``p`` of a three-level self-check inside which the reference is taken to be in its asymptotic
#: range (second-order integrators: p = 2), so that Richardson extrapolation holds.
ASYMPTOTIC_ORDERS: tuple[float, float] = (1.5, 2.5)


@dataclass(frozen=True)
class PeakError:
    """One item's self-check: the signed relative error of the reference's peak (``estimate``), the observed order
    (NaN with two levels), and whether the estimate is only a lower bound (the reference is outside the asymptotic
    range); ``basis`` says how it was made."""

    estimate: float
    order: float = math.nan
    lower_bound: bool = False
    basis: str = ""


def peak_error(peaks: Sequence[float], order: float = 2.0, orders: tuple[float, float] = ASYMPTOTIC_ORDERS) -> PeakError:
    """``e = (R₀ − R*)/R*``, the relative error of the peak ``R₀`` of a run at step ``h`` from the peaks ``R₁, R₂`` of
    the same run at ``h/2`` (and ``h/4``), by Richardson extrapolation with the formal ``order`` ``p₀``:

    * two levels: ``R* = R₁ + (R₁ − R₀)/(2^p₀ − 1)``;
    * three levels: the observed order ``p = log₂(|R₀ − R₁| / |R₁ − R₂|)``. When ``p`` lies in ``orders`` and the
      differences have one sign (monotone convergence), the run is in its asymptotic range and
      ``R* = R₂ + (R₂ − R₁)/(2^p₀ − 1)`` (from the finest pair). Otherwise it is not, Richardson does not hold,
      and the estimate is the **lower bound** ``e = (R₀ − R₂)/R₂``, the change the refinement has shown so far
      (the remaining error of ``R₂`` is unknown), marked ``lower_bound``.

    NaN when a peak or ``R*`` is not positive (nothing to be relative to)."""
    values = [float(v) for v in peaks]
    if len(values) not in (2, 3):
        raise ValueError(f"a peak error needs the peaks of two or three levels, got {len(values)}")
    if not all(v > 0.0 and math.isfinite(v) for v in values):
        return PeakError(math.nan, basis="a peak is not positive")
    if len(values) == 2:
        coarse, fine = values
        extrapolated = fine + (fine - coarse) / (2.0**order - 1.0)
        estimate = (coarse - extrapolated) / extrapolated if extrapolated > 0.0 else math.nan
        return PeakError(estimate, basis=f"Richardson, order {order:g}, on h and h/2")
    r0, r1, r2 = values
    d1, d2 = r0 - r1, r1 - r2
    observed = math.log2(abs(d1) / abs(d2)) if d1 != 0.0 and d2 != 0.0 else math.nan
    if orders[0] <= observed <= orders[1] and d1 * d2 > 0.0:
        extrapolated = r2 + (r2 - r1) / (2.0**order - 1.0)
        if extrapolated > 0.0:
            return PeakError((r0 - extrapolated) / extrapolated, observed, basis=f"Richardson, order {order:g}, on h/2 and h/4 (observed order {observed:.2f})")
    why = "oscillating" if d1 * d2 < 0.0 else f"observed order {observed:.2f} outside {orders[0]:g}–{orders[1]:g}"
    return PeakError((r0 - r2) / r2, observed, lower_bound=True, basis=f"lower bound (R(h) − R(h/4))/R(h/4): {why}, outside the asymptotic range")


def reference_peaks(result: ModelResult) -> dict[str, float]:
    """The peaks a reference's self-check follows: each coupler's peak compression ``max P`` (an impact run), else each
    probe's peak magnitude ``max |a|`` of the acceleration (a single-body run: what its scores are computed on)."""
    if result.couplers:
        return {name: float(np.max(out["force"])) for name, out in result.couplers.items() if "force" in out}
    return {name: float(np.max(np.abs(out["acceleration"]))) for name, out in result.probes.items() if "acceleration" in out}


def reference_error_estimate(reference: ModelResult, *finer: ModelResult, order: float = 2.0) -> dict[str, PeakError]:
    """:func:`peak_error` of ``(P_h, P_h/2[, P_h/4])`` per item of :func:`reference_peaks`: the reference's own relative
    peak error from one or two finer runs of it (each halving the step, and/or doubling the elements; ``order`` 2 for
    generalized-α and Newmark). Checked against runs at a hundredth of the step (tests/run/test_budget.py,
    tests/run/test_self_check.py)."""
    levels = [reference_peaks(reference), *(reference_peaks(run) for run in finer)]
    names = sorted(set.intersection(*(set(level) for level in levels)))
    return {name: peak_error([level[name] for level in levels], order) for name in names}


#: Why a relative metric is undefined, by the part of its name that says what it divides by.
UNDEFINED_BECAUSE: tuple[tuple[str, str], ...] = (
    ("_peak_time_error_", "the reference never compresses (its peak is not positive)"),
    ("coupler_force_peak_error_", "the reference never compresses (its peak is not positive)"),
    ("_peak_error_", "the reference's peak magnitude is zero"),
    ("_rms_error_", "the reference's rms is zero"),
    ("_max_error_", "the reference is zero at every probe"),
)


def undefined_reasons(metrics: dict[str, Any]) -> dict[str, str]:
    """The NaN metrics among ``metrics`` and why each is undefined (its reference scale vanishes, or — an in-range
    score — the in-range part is degenerate: ``in_range_degenerate``)."""
    reasons = {}
    degenerate = metrics.get(IN_RANGE_DEGENERATE)
    for name, value in metrics.items():
        if isinstance(value, float) and math.isnan(value):
            if degenerate and f"_{IN_RANGE_STATISTIC}_error_" in name:
                reasons[name] = f"the in-range part is degenerate ({degenerate})"
            else:
                reasons[name] = next((why for part, why in UNDEFINED_BECAUSE if part in name), "undefined")
    return reasons


__all__ = ["AGGREGATES", "IN_RANGE_CONTACT_LEVEL", "IN_RANGE_DEGENERATE", "IN_RANGE_MIN_CONTACT", "IN_RANGE_MIN_SAMPLES", "IN_RANGE_STATISTIC", "SCORED_SENSOR_QUANTITIES", "coupler_force_errors", "in_range_degeneracy", "in_range_errors", "ASYMPTOTIC_ORDERS", "PeakError", "peak_error", "reference_error_estimate", "reference_peaks", "score_impact", "score_peak_estimates", "score_results",
           "sensor_errors", "undefined_reasons"]
