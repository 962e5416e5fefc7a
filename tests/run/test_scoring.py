"""Scores (femref.run.scoring) on synthetic results whose errors are known exactly: impact and single body."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from femref.run.scoring import score_impact, score_results, undefined_reasons
from femref.results import ModelResult

DT = 1.0e-4
T_PULSE = 0.2  # s
T_START = 0.05  # s


def pulse(t: np.ndarray, amplitude: float = 1.5e6, start: float = T_START) -> np.ndarray:
    """sin² compression pulse of length 0.2 s, peak ``amplitude`` at ``start + 0.1`` s."""
    on = (t >= start) & (t <= start + T_PULSE)
    return amplitude * np.where(on, np.sin(np.pi * (t - start) / T_PULSE) ** 2, 0.0)


def result(model: str, t: np.ndarray, couplers: dict | None = None, probes: dict | None = None) -> ModelResult:
    r = ModelResult(model)
    r.axes = {"time": t}
    r.couplers = {name: {"force": f} for name, f in (couplers or {}).items()}
    r.probes = {name: {"acceleration": a} for name, a in (probes or {}).items()}
    return r


def test_scaled_pulse_gives_the_scale_error() -> None:
    """P = (1 + 0.07) P_ref and a = (1 − 0.03) a_ref on the same axis: peak and rms errors are
    exactly 0.07 and 0.03, the peak time error 0 (to 1e-12)."""
    t = np.arange(4001) * DT
    ref = result("fem", t, {"c1": pulse(t)}, {"anvil/center": pulse(t) / 1e5})
    mine = result("rigid", t, {"c1": 1.07 * pulse(t)}, {"anvil/center": 0.97 * pulse(t) / 1e5})
    scores = score_impact(ref, mine)
    assert scores["coupler_force_peak_error_c1"] == pytest.approx(0.07, rel=1e-12)
    assert scores["coupler_force_rms_error_c1"] == pytest.approx(0.07, rel=1e-12)
    assert scores["coupler_force_peak_time_error_c1"] == 0.0
    assert scores["acceleration_rms_error_anvil/center"] == pytest.approx(0.03, rel=1e-12)
    assert scores["acceleration_peak_error_anvil/center"] == pytest.approx(0.03, rel=1e-12)
    assert scores["coupler_force_peak_error_max"] == scores["coupler_force_peak_error_c1"]
    assert scores["coupler_force_rms_error_max"] == scores["coupler_force_rms_error_c1"]
    assert scores["acceleration_rms_error_max"] == scores["acceleration_rms_error_anvil/center"]
    assert set(scores) == {
        "coupler_force_peak_error_c1",
        "coupler_force_peak_time_error_c1",
        "coupler_force_rms_error_c1",
        "acceleration_rms_error_anvil/center",
        "acceleration_peak_error_anvil/center",
        "coupler_force_peak_error_max",
        "coupler_force_rms_error_max",
        "acceleration_rms_error_max",
    }


def test_shifted_signals_give_the_shift() -> None:
    """P(t) = P_ref(t − s), s = 12.3 ms (123 samples): peak time error +s exactly (and −s for a
    pulse that comes early), peak error 0. A tone a = sin(ω(t − s)) against sin(ωt) over whole
    periods (samples at k·dt, end excluded): rms error 2|sin(ωs/2)| exactly (discrete sums of
    sin² over whole periods are exact), peak error 0 (to 1e-12)."""
    t = np.arange(5000) * DT  # 0 … 0.4999 s: 20 periods of a 40 Hz tone
    s = 123 * DT
    w = 2 * np.pi * 40.0
    ref = result("fem", t, {"late": pulse(t), "early": pulse(t)}, {"car/x": np.sin(w * t)})
    mine = result("model", t, {"late": pulse(t, start=T_START + s), "early": pulse(t, start=T_START - s)}, {"car/x": np.sin(w * (t - s))})
    scores = score_impact(ref, mine)
    assert scores["coupler_force_peak_time_error_late"] == pytest.approx(s, abs=1e-12)
    assert scores["coupler_force_peak_time_error_early"] == pytest.approx(-s, abs=1e-12)
    assert scores["coupler_force_peak_error_late"] == pytest.approx(0.0, abs=1e-12)
    assert scores["acceleration_rms_error_car/x"] == pytest.approx(2 * abs(math.sin(w * s / 2)), rel=1e-12)
    assert scores["acceleration_peak_error_car/x"] == pytest.approx(0.0, abs=1e-6)


def test_different_time_axes_use_the_common_interval() -> None:
    """Reference at 10 kHz on 0 … 0.5 s; result at 1 kHz on −0.1 … 0.7 s, equal to 1.05 × the
    reference inside the common interval and 1e9 outside (which must be ignored). The 1 kHz
    instants are reference samples, so the interpolation adds nothing: errors 0.05 (1e-9)."""
    t_ref = np.arange(5001) * DT
    t = -0.1 + np.arange(801) * 1e-3
    inside = (t >= 0.0) & (t <= 0.5 + 1e-12)
    force = np.where(inside, 1.05 * pulse(t), 1e9)
    accel = np.where(inside, 1.05 * np.sin(30 * t), 1e9)
    ref = result("fem", t_ref, {"c1": pulse(t_ref)}, {"a/b": np.sin(30 * t_ref)})
    scores = score_impact(ref, result("inverse_rigid", t, {"c1": force}, {"a/b": accel}))
    assert scores["coupler_force_peak_error_c1"] == pytest.approx(0.05, rel=1e-9)
    assert scores["coupler_force_rms_error_c1"] == pytest.approx(0.05, rel=1e-9)
    assert scores["coupler_force_peak_time_error_c1"] == pytest.approx(0.0, abs=1e-12)
    assert scores["acceleration_rms_error_a/b"] == pytest.approx(0.05, rel=1e-9)


def test_zero_reference_gives_nan_without_warnings() -> None:
    """A reference coupler that never compresses (identically zero, or in tension only) and a
    zero reference acceleration give NaN relative metrics (documented choice), with no
    RuntimeWarning; the aggregates take the finite values only and are left out when none."""
    t = np.arange(1001) * DT
    ref = result("fem", t, {"zero": np.zeros_like(t), "pull": -pulse(t), "ok": pulse(t)}, {"p/q": np.zeros_like(t)})
    mine = result("model", t, {"zero": pulse(t), "pull": pulse(t), "ok": 1.1 * pulse(t)}, {"p/q": np.ones_like(t)})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scores = score_impact(ref, mine)
    for key in [
        "coupler_force_peak_error_zero",
        "coupler_force_peak_time_error_zero",
        "coupler_force_rms_error_zero",
        "coupler_force_peak_error_pull",
        "coupler_force_peak_time_error_pull",
        "acceleration_rms_error_p/q",
        "acceleration_peak_error_p/q",
    ]:
        assert math.isnan(scores[key]), key
    assert scores["coupler_force_rms_error_pull"] == pytest.approx(2.0, rel=1e-12)  # rms(2 P)/rms(P)
    assert scores["coupler_force_peak_error_max"] == pytest.approx(0.1, rel=1e-12)
    assert scores["coupler_force_rms_error_max"] == pytest.approx(2.0, rel=1e-12)
    assert "acceleration_rms_error_max" not in scores


def test_only_common_items_are_scored_and_empty_results_have_no_aggregates() -> None:
    """Couplers and probes missing on either side (or without an acceleration history) are
    skipped; an estimator result with coupler forces only has no acceleration metrics; with
    nothing in common the score is empty."""
    t = np.arange(1001) * DT
    ref = result("fem", t, {"c1": pulse(t), "c2": pulse(t)}, {"a/x": np.sin(t), "a/y": np.cos(t)})
    ref.probes["a/z"] = {"displacement": t}
    mine = result("inverse_rigid", t, {"c1": pulse(t), "c9": pulse(t)})
    mine.probes["a/z"] = {"displacement": t}
    scores = score_impact(ref, mine)
    assert set(scores) == {
        "coupler_force_peak_error_c1",
        "coupler_force_peak_time_error_c1",
        "coupler_force_rms_error_c1",
        "coupler_force_peak_error_max",
        "coupler_force_rms_error_max",
    }
    assert score_impact(ref, result("other", t)) == {}


def test_aggregate_is_the_worst_item() -> None:
    """Three couplers scaled by 1.02, 0.9, 1.05: the peak and rms aggregates are 0.1 (1e-12)."""
    t = np.arange(3001) * DT
    ref = result("fem", t, {f"c{k}": pulse(t) for k in range(3)})
    mine = result("m", t, {f"c{k}": f * pulse(t) for k, f in enumerate([1.02, 0.9, 1.05])})
    scores = score_impact(ref, mine)
    assert scores["coupler_force_peak_error_max"] == pytest.approx(0.1, rel=1e-12)
    assert scores["coupler_force_rms_error_max"] == pytest.approx(0.1, rel=1e-12)


def test_bad_input() -> None:
    t = np.arange(101) * DT
    ref = result("fem", t, {"c1": pulse(t)})
    with pytest.raises(ValueError, match="status is 'failed'"):
        score_impact(ref, ModelResult.failed("rigid", "diverged"))
    no_axis = ModelResult("harmonic")
    no_axis.axes = {"omega": np.ones(3)}
    with pytest.raises(ValueError, match="has no time axis"):
        score_impact(ref, no_axis)
    with pytest.raises(ValueError, match="overlap in fewer than two"):
        score_impact(ref, result("late", t + 1.0, {"c1": pulse(t)}))
    with pytest.raises(ValueError, match="expected \\(101,\\)"):
        score_impact(ref, result("short", t, {"c1": np.zeros(50)}))
    with pytest.raises(ValueError, match="strictly increasing"):
        score_impact(ref, result("backwards", t[::-1], {"c1": pulse(t)}))


def single_body(model: str, t: np.ndarray, acceleration: dict, axial_force: dict) -> ModelResult:
    r = ModelResult(model)
    r.axes = {"time": t}
    r.probes = {p: {"acceleration": acceleration[p], "axial_force": axial_force[p]} for p in acceleration}
    return r


def test_single_body_scores_on_known_errors_and_nan_for_a_zero_reference() -> None:
    """A rod loaded at +l, free at −l: the reference's axial force at ``left`` is exactly zero.

    With a = 1.1 a_ref everywhere: ``acceleration_max_error_<p>`` = 0.1 max|a_ref(p)| / max over
    probes, ``acceleration_rms_error_<p>`` = 0.1. The force at the free end scores NaN with the
    reason (never a huge number from a floored denominator), and the aggregates take the finite
    items only.
    """
    t = np.linspace(0.0, 0.5, 501)
    shape = pulse(t) / 1.5e6
    ref_a = {"left": 2.0 * shape, "right": 4.0 * shape}
    ref_f = {"left": np.zeros_like(t), "right": 1.0e6 * shape}
    mine_f = {"left": 1.0e3 * shape, "right": 0.9e6 * shape}
    reference = single_body("exact", t, ref_a, ref_f)
    model = single_body("rigid", t, {p: 1.1 * a for p, a in ref_a.items()}, mine_f)
    reference.wall_time_s, model.wall_time_s = 2.0, 0.5
    scores = score_results("transient", [reference, model])["rigid"]
    assert scores["reference"] == "exact" and scores["speedup"] == pytest.approx(4.0)
    assert scores["acceleration_max_error_left"] == pytest.approx(0.1 * 2.0 / 4.0, rel=1e-12)
    assert scores["acceleration_max_error_right"] == pytest.approx(0.1, rel=1e-12)
    assert scores["acceleration_rms_error_left"] == pytest.approx(0.1, rel=1e-12)
    assert scores["acceleration_max_error_max"] == pytest.approx(0.1, rel=1e-12)
    assert scores["axial_force_rms_error_right"] == pytest.approx(0.1, rel=1e-12)
    assert math.isnan(scores["axial_force_rms_error_left"])
    assert scores["axial_force_max_error_left"] == pytest.approx(1.0e3 / 1.0e6, rel=1e-12)  # scale: the peak over probes
    assert undefined_reasons(scores) == {"axial_force_rms_error_left": "the reference's rms is zero"}
    assert scores["undefined"] == "axial_force_rms_error_left: the reference's rms is zero"


def test_undefined_names_every_nan_impact_metric() -> None:
    """A coupler that never compresses: its peak, peak-time and rms errors are NaN, each with its reason."""
    t = np.arange(2001) * DT
    reference = result("fem", t, {"c1": np.zeros_like(t), "c2": pulse(t)})
    model = result("rigid", t, {"c1": pulse(t), "c2": pulse(t)})
    scores = score_results("impact", [reference, model])["rigid"]
    reasons = undefined_reasons(scores)
    never = "the reference never compresses (its peak is not positive)"
    assert reasons == {
        "coupler_force_peak_error_c1": never,
        "coupler_force_peak_time_error_c1": never,
        "coupler_force_rms_error_c1": "the reference's rms is zero",
    }
    assert scores["coupler_force_peak_error_max"] == 0.0

