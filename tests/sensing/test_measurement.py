"""The measurement chain (femref.sensing.measurement): low-pass, resampling, noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femref.sensing.measurement import butterworth_sections, causal_filter, lowpass_filter, measure
from femref.scene.impact import Measurement

DT = 1.0e-4  # s: a 10 kHz model grid
TIME = np.arange(20001) * DT  # 0 … 2 s


def _butterworth_magnitude(f: float, corner: float, dt: float) -> float:
    """Bilinear-transformed order-4 Butterworth: |H| = 1/√(1 + (tan(πf dt)/tan(πf_c dt))^8)."""
    ratio = math.tan(math.pi * f * dt) / math.tan(math.pi * corner * dt)
    return 1.0 / math.sqrt(1.0 + ratio**8)


def _tone_amplitude(t: np.ndarray, y: np.ndarray, f: float) -> float:
    """Least-squares amplitude of the tone at f (Hz) in y (steady state)."""
    basis = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return float(np.hypot(*coef))


def test_no_op_chain_returns_the_input() -> None:
    """Measurement() skips every step: the same arrays come back (copies), 1-D stays 1-D."""
    a = np.column_stack([np.sin(3 * TIME), TIME**2])
    t, out = measure(TIME, a, Measurement())
    np.testing.assert_array_equal(t, TIME)
    np.testing.assert_array_equal(out, a)
    assert out is not a and t is not TIME
    t1, out1 = measure(TIME, a[:, 0], Measurement(noise=0.0, seed=5))
    assert out1.shape == (TIME.size,)
    np.testing.assert_array_equal(out1, a[:, 0])


@pytest.mark.parametrize(("frequency", "kind"), [(10.0, "pass"), (50.0, "pass"), (200.0, "stop"), (400.0, "stop")])
def test_lowpass_amplitude_follows_butterworth_magnitude(frequency: float, kind: str) -> None:
    """Tones through a 100 Hz corner: after the start-up transient (the last 1.5 s of 2 s) the
    amplitude ratio equals |H(f)| of the order-4 Butterworth (bilinear form) to 1e-4 relative;
    10 Hz passes (|H| > 0.9999), 400 Hz is attenuated below 0.004."""
    corner = 100.0
    a = np.column_stack([np.sin(2 * np.pi * frequency * TIME), 2.0 * np.cos(2 * np.pi * frequency * TIME)])
    t, out = measure(TIME, a, Measurement(lowpass=corner))
    steady = TIME >= 0.5
    expected = _butterworth_magnitude(frequency, corner, DT)
    for column, amplitude in [(0, 1.0), (1, 2.0)]:
        ratio = _tone_amplitude(t[steady], out[steady, column], frequency) / amplitude
        assert ratio == pytest.approx(expected, rel=1e-4)
    if kind == "pass":
        assert expected > 0.9999 if frequency == 10.0 else expected > 0.99
    else:
        assert expected < 0.07 if frequency == 200.0 else expected < 0.004


def test_lowpass_is_causal() -> None:
    """A record that is zero up to t = 0.3 s stays exactly zero there after filtering (causal,
    started from rest)."""
    a = np.where(TIME > 0.3, np.sin(2 * np.pi * 20 * (TIME - 0.3)), 0.0)
    _, out = measure(TIME, a, Measurement(lowpass=100.0))
    assert np.all(out[TIME <= 0.3] == 0.0)
    assert np.max(np.abs(out[TIME > 0.35])) > 0.5


def test_resampling_hits_the_rate_and_linear_values() -> None:
    """A linear signal a = 3 + 2t (exact under linear interpolation) on a grid starting at
    t = 0.00037 s: resampled at 1 kHz the instants are k/1000 for k = 1 … 2000 (the first one
    after the start, the last one at the end) and the values 3 + 2t_k to 1e-12."""
    t_model = 0.00037 + np.arange(20000) * DT  # ends at 2.00027 s
    a = np.column_stack([3.0 + 2.0 * t_model, -t_model])
    t, out = measure(t_model, a, Measurement(rate=1000.0))
    np.testing.assert_allclose(t, np.arange(1, 2001) / 1000.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=1e-9)
    np.testing.assert_allclose(out[:, 0], 3.0 + 2.0 * t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[:, 1], -t, rtol=0, atol=1e-12)


def test_resampling_keeps_the_record_ends() -> None:
    """On 0 … 2 s at 10 kHz, resampling at 250 Hz gives 501 samples, the first at 0 and the
    last at exactly 2 s (k/rate rounding does not drop the end)."""
    t, out = measure(TIME, TIME, Measurement(rate=250.0))
    assert t.size == 501 and t[0] == 0.0 and t[-1] == pytest.approx(2.0, abs=1e-15)
    np.testing.assert_allclose(out, t, atol=1e-12)


def test_filter_then_resample_order() -> None:
    """The filter runs at the model rate before resampling: the chain equals filtering the whole
    record and interpolating it at k/rate."""
    a = np.sin(2 * np.pi * 30 * TIME) + 0.3 * np.sin(2 * np.pi * 700 * TIME)
    _, filtered = measure(TIME, a, Measurement(lowpass=200.0))
    t, out = measure(TIME, a, Measurement(lowpass=200.0, rate=1000.0))
    np.testing.assert_allclose(out, np.interp(t, TIME, filtered), rtol=0, atol=1e-13)


def test_noise_is_reproducible_and_has_the_requested_std() -> None:
    """Noise of std 0.05 m/s² on 20001 × 3 samples: the same seed gives identical records, another
    seed different ones; the added noise has mean 0 (± 4 standard errors, 4·0.05/√60003) and a
    standard deviation 0.05 within 2 % (4 standard errors of a std estimate, 1/√(2N) ≈ 0.3 %,
    are 1.2 %)."""
    a = np.column_stack([np.sin(TIME), np.cos(TIME), TIME])
    m = Measurement(noise=0.05, seed=11)
    _, one = measure(TIME, a, m)
    _, two = measure(TIME, a, m)
    _, other = measure(TIME, a, Measurement(noise=0.05, seed=12))
    np.testing.assert_array_equal(one, two)
    assert not np.allclose(one, other)
    added = (one - a).ravel()
    assert abs(added.mean()) <= 4 * 0.05 / math.sqrt(added.size)
    assert added.std() == pytest.approx(0.05, rel=0.02)


def test_full_chain_shapes() -> None:
    """Low-pass 100 Hz, 500 Hz records, noise 0.01: (1001, 2) records on k/500 instants."""
    a = np.column_stack([np.sin(2 * np.pi * 5 * TIME), np.zeros_like(TIME)])
    t, out = measure(TIME, a, Measurement(rate=500.0, lowpass=100.0, noise=0.01, seed=3))
    assert t.shape == (1001,) and out.shape == (1001, 2)
    assert np.std(out[:, 1]) == pytest.approx(0.01, rel=0.15)


@pytest.mark.parametrize(
    ("time", "acceleration", "measurement", "match"),
    [
        (np.array([0.0, 0.1, 0.25, 0.3]), np.zeros(4), Measurement(), "uniformly sampled"),
        (np.array([0.0, 0.1, 0.1, 0.2]), np.zeros(4), Measurement(), "increase strictly"),
        (TIME, np.zeros((TIME.size + 1, 2)), Measurement(), "acceleration must have shape"),
        (TIME[:, None], np.zeros(TIME.size), Measurement(), "time must be a 1-D array"),
        (TIME, np.full(TIME.size, np.nan), Measurement(), "must be finite"),
        (TIME, np.zeros(TIME.size), Measurement(lowpass=5000.0), "below the model's Nyquist frequency"),
        (TIME, np.zeros(TIME.size), Measurement(lowpass=8000.0), "below the model's Nyquist frequency"),
        (TIME, np.zeros(TIME.size), Measurement(lowpass=0.0), "lowpass must be finite and > 0"),
        (TIME, np.zeros(TIME.size), Measurement(rate=-1.0), "rate must be finite and > 0"),
        (TIME, np.zeros(TIME.size), Measurement(noise=-0.1), "noise must be finite and >= 0"),
        (TIME, np.zeros(TIME.size), Measurement(noise=0.1, seed=1.5), "seed must be an integer"),
        (TIME, np.zeros(TIME.size), Measurement(rate=0.2), "fewer than 2 samples"),
    ],
)
def test_bad_input(time, acceleration, measurement: Measurement, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        measure(time, acceleration, measurement)


@pytest.mark.parametrize("corner, rate", [(100.0, 3448.0), (100.0, 1000.0), (400.0, 1000.0), (499.0, 1000.0), (30.0, 1.0e4), (1.0, 1.0e5)])
def test_butterworth_sections_and_causal_filter_are_scipys(corner: float, rate: float) -> None:
    """Against scipy.signal (a second implementation): the sections are ``butter(4, corner, fs=rate, output="sos")`` to
    rounding, and ``causal_filter`` is ``sosfilt`` along axis 0 — 1-D and one column per sensor, zero before the first
    nonzero input exactly (the record from rest), 1e-11 of the output's peak at the poles nearest the unit circle."""
    from scipy.signal import butter, sosfilt

    expected = butter(4, corner, btype="low", fs=rate, output="sos")
    np.testing.assert_allclose(butterworth_sections(corner, rate), expected, rtol=1e-14, atol=0.0)
    x = np.random.default_rng(7).normal(size=(3000, 3))
    x[:400] = 0.0
    for values in (x, x[:, 1]):
        filtered = causal_filter(expected, values)
        reference = sosfilt(expected, values, axis=0)
        assert filtered.shape == values.shape
        assert np.max(np.abs(filtered - reference)) <= 1e-11 * np.max(np.abs(reference))
        assert not np.any(filtered[:400])
    dt = 1.0 / rate
    np.testing.assert_array_equal(lowpass_filter(x, dt, corner), causal_filter(butterworth_sections(corner, 1.0 / dt), x))
