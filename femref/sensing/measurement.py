"""The measurement chain: what an accelerometer record made from a model's sensor accelerations looks like.

Three steps, in the order a data-acquisition system applies them, each optional
(:class:`Measurement`):

1. **anti-alias low-pass** at ``lowpass`` Hz: causal Butterworth of order 4, from rest — the
   records start before the impact (:func:`butterworth_sections`, the sections of
   ``scipy.signal.butter(4, lowpass, fs=1/dt, output='sos')``, run by :func:`causal_filter`,
   ``scipy.signal.sosfilt``'s recursion, without importing ``scipy.signal``), applied at the model's sampling rate
   ``1/dt``. Its magnitude is that of the bilinear-transformed analogue prototype,
   ``|H(f)| = 1/√(1 + (tan(πf dt)/tan(π f_c dt))^8)``, and it delays the signal (group
   delay 2.61/(2π f_c) ≈ 0.42/f_c at low frequencies), as a real anti-alias filter does;
2. **resampling** at ``rate`` Hz: the samples ``t_k = k/rate`` (integer k) that lie in
   ``[time[0], time[-1]]``, linear interpolation of the filtered record;
3. **white noise** of standard deviation ``noise`` (m/s²), Gaussian, from
   ``numpy.random.default_rng(seed)`` (reproducible; one draw per sample and sensor).

A car that bends may also carry rate gyroscopes: its pitch rates go through the same filter and
sampling, with their own noise ``pitch_rate_noise`` (rad/s) from an independent stream
(``stream = 1``: ``default_rng((seed, 1))``), so adding gyroscopes leaves the accelerometers'
records as they were.

``lowpass = None`` and ``rate = None`` skip their steps, ``noise = 0`` skips the noise.
The filter must lie below the model's Nyquist frequency ``1/(2 dt)`` (the case schema
also keeps it below the record's Nyquist ``rate/2``, where it does its anti-alias job).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class Measurement:
    """How the accelerometer records are made from the model's sensor accelerations (module docstring): ``rate`` and
    ``lowpass`` in Hz, ``noise`` in m/s², ``pitch_rate_noise`` in rad/s."""

    rate: float | None = None
    lowpass: float | None = None
    noise: float = 0.0
    seed: int = 0
    pitch_rate_noise: float = 0.0


FILTER_ORDER = 4
"""Order of the anti-alias Butterworth low-pass."""


def measure(time: ArrayLike, acceleration: ArrayLike, measurement: Measurement, stream: int = 0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Records ``(t_meas (Nm,), a_meas (Nm, S))`` from sensor accelerations ``(Nt, S)`` (or one sensor's ``(Nt,)``) on a
    uniform ``time`` (s): low-pass, resample, add noise (module docstring; ``stream = 1``: the gyroscopes'). A copy
    with every step skipped. ValueError for a bad time axis, shapes or values, or settings out of range."""
    t, a, dt = _checked_input(time, acceleration)
    lowpass, rate, noise = _checked_settings(measurement, dt, stream)
    if lowpass is not None:
        a = lowpass_filter(a, dt, lowpass)
    if rate is not None:
        t, a = resample(t, a, rate)
    if noise > 0.0:
        rng = np.random.default_rng((measurement.seed, stream) if stream else measurement.seed)
        a = a + rng.normal(0.0, noise, size=a.shape)
    return t.copy(), a.copy()


def lowpass_filter(acceleration: NDArray[np.float64], dt: float, corner: float) -> NDArray[np.float64]:
    """``|H(f)| = 1/√(1 + (tan(πf dt)/tan(π f_c dt))^8)``: causal order-4 Butterworth low-pass at ``corner`` (Hz) along
    axis 0, from rest (checked on filtered tones in ``tests/sensing/test_measurement.py``)."""
    return causal_filter(butterworth_sections(corner, 1.0 / dt), acceleration)


@functools.lru_cache(maxsize=64)
def butterworth_sections(corner: float, rate: float) -> tuple[tuple[float, ...], ...]:
    """``H(z) = Π_k g_k (1 + z⁻¹)² / (1 − 2 Re(z_k) z⁻¹ + |z_k|² z⁻²)``, ``z_k = (4 + s_k)/(4 − s_k)``,
    ``s_k = −w e^{iπm/8}`` (m = −3, −1, 1, 3), ``w = 4 tan(π corner/rate)``: the order-4 Butterworth low-pass at
    ``corner`` (Hz) for samples at ``rate`` (Hz) by the bilinear transform with pre-warping, as second-order sections
    ``(b0, b1, b2, 1, a1, a2)`` — the poles nearest the unit circle last, the gain ``w⁴ / Π(4 − s)`` in the first — as
    ``scipy.signal.butter(4, corner, fs=rate, output="sos")`` gives them (equal to rounding in
    ``tests/sensing/test_measurement.py``). Designed once per corner and rate: a sweep's samples share them."""
    warped = 4.0 * math.tan(math.pi * corner / rate)
    analog = -np.exp(1j * math.pi * np.arange(-FILTER_ORDER + 1, FILTER_ORDER, 2) / (2 * FILTER_ORDER)) * warped
    digital = (4.0 + analog) / (4.0 - analog)
    upper = digital[digital.imag > 0.0]
    upper = upper[np.argsort(np.abs(upper))]
    sections = np.array([[1.0, 2.0, 1.0, 1.0, -2.0 * z.real, (z * z.conjugate()).real] for z in upper])
    sections[0, :3] *= warped**FILTER_ORDER * np.real(1.0 / np.prod(4.0 - analog))
    return tuple(map(tuple, sections.tolist()))


def causal_filter(sections: ArrayLike, values: ArrayLike) -> NDArray[np.float64]:
    """``y[n] = b0 x[n] + b1 x[n−1] + b2 x[n−2] − a1 y[n−1] − a2 y[n−2]`` for each section in turn, along axis 0, from
    rest (``x`` and ``y`` zero before the first sample): ``scipy.signal.sosfilt(sections, values, axis=0)``. Each
    section's recursion is the forward substitution of the banded lower-triangular system ``A y = B x`` (LAPACK
    ``dtbtrs``): every column in one call, O(samples) and no Python loop over them."""
    from scipy.linalg.lapack import dtbtrs  # scipy.linalg, which the models load anyway; not scipy.signal (~0.5 s)

    x = np.asarray(values, dtype=float)
    y = x.reshape(x.shape[0], -1)
    for b0, b1, b2, _, a1, a2 in sections:
        forced = b0 * y
        forced[1:] += b1 * y[:-1]
        forced[2:] += b2 * y[:-2]
        band = np.empty((3, y.shape[0]))
        band[0], band[1], band[2] = 1.0, a1, a2
        y, info = dtbtrs(band, forced, uplo="L", diag="U")
        assert info == 0, info
    return y.reshape(x.shape)


def resample(time: NDArray[np.float64], values: NDArray[np.float64], rate: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Samples at ``t_k = k/rate`` within ``[time[0], time[-1]]`` (within 1e-9 of a period outside: clipped to its
    ends) by linear interpolation along axis 0; at least two."""
    first = math.ceil(time[0] * rate - 1e-9)
    last = math.floor(time[-1] * rate + 1e-9)
    if last - first + 1 < 2:
        raise ValueError(f"rate {rate!r} Hz gives fewer than 2 samples within the record [{time[0]!r}, {time[-1]!r}] s")
    t_new = np.clip(np.arange(first, last + 1) / rate, time[0], time[-1])
    if values.ndim == 1:
        return t_new, np.interp(t_new, time, values)
    return t_new, np.column_stack([np.interp(t_new, time, column) for column in values.T])


def _checked_input(time: ArrayLike, acceleration: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """The time axis (uniform, increasing), the accelerations and the step ``dt`` (s)."""
    t = np.asarray(time, dtype=float)
    a = np.asarray(acceleration, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"time must be a 1-D array of at least 2 samples, got shape {t.shape}")
    if a.ndim not in (1, 2) or a.shape[0] != t.size:
        raise ValueError(f"acceleration must have shape (Nt,) or (Nt, S) with Nt = {t.size} samples, got {a.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise ValueError("time and acceleration must be finite (no NaN or inf)")
    steps = np.diff(t)
    if np.any(steps <= 0.0):
        raise ValueError("time must increase strictly")
    dt = float(steps.mean())
    if np.max(np.abs(steps - dt)) > 1e-6 * dt:
        raise ValueError(f"time must be uniformly sampled for the measurement chain (steps between {steps.min():.6g} and {steps.max():.6g} s)")
    return t, a, dt


def _checked_settings(measurement: Measurement, dt: float, stream: int = 0) -> tuple[float | None, float | None, float]:
    """``(lowpass, rate, noise)`` checked against the model's step ``dt``; the noise of the stream's sensors."""
    lowpass = None if measurement.lowpass is None else _positive("lowpass", measurement.lowpass, "Hz")
    rate = None if measurement.rate is None else _positive("rate", measurement.rate, "Hz")
    name, unit, given = ("pitch_rate_noise", "rad/s", measurement.pitch_rate_noise) if stream else ("noise", "m/s^2", measurement.noise)
    noise = float(given)
    if not (math.isfinite(noise) and noise >= 0.0):
        raise ValueError(f"measurement {name} must be finite and >= 0 ({unit}), got {given!r}")
    if noise > 0.0 and (isinstance(measurement.seed, bool) or int(measurement.seed) != measurement.seed):
        raise ValueError(f"measurement seed must be an integer, got {measurement.seed!r}")
    nyquist = 0.5 / dt
    if lowpass is not None and lowpass >= nyquist:
        raise ValueError(f"measurement lowpass {lowpass:g} Hz must be below the model's Nyquist frequency 1/(2 dt) = {nyquist:g} Hz "
                         "(the filter runs at the model's sampling rate): lower it or refine the time step")
    return lowpass, rate, noise


def _positive(name: str, value: float, unit: str) -> float:
    x = float(value)
    if not (math.isfinite(x) and x > 0.0):
        raise ValueError(f"measurement {name} must be finite and > 0 ({unit}); use None to skip the step, got {value!r}")
    return x


__all__ = ["FILTER_ORDER", "butterworth_sections", "causal_filter", "lowpass_filter", "measure", "resample"]
