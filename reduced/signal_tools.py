"""Signal tools for acceleration and force records: smoothing, differentiation,
integration, impact-type classification, closure-force detection, resampling and
normalisation of network features.

All records are uniformly sampled 1-D arrays with sampling interval ``dt`` (s);
every setting is an explicit argument or a field of a small frozen class:

* :class:`SavitzkyGolay` (``scipy.signal.savgol_filter``), :class:`SpectralLowPass`
  (FFT with a raised-cosine roll-off) and :class:`GaussianKernel`
  (``scipy.ndimage.gaussian_filter1d``) smooth; the first two also differentiate
  (registry :data:`SMOOTHERS`).
* :func:`integrate_twice` — exact double integral of the piecewise-linear record.
* :func:`classify_impact` — free to roll vs coupled from the zero-frequency content
  of the relative acceleration spectrum (SOURCE-NOTES B).
* :func:`detect_closure_force` — draft-gear closure force by the sine fit through
  the force peak (SOURCE-NOTES A5).
* :func:`resample_record`, :func:`peak_normalise`, :class:`FeatureScaler` — fixed
  length network inputs and their scaling (saved as plain arrays).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import gaussian_filter1d
from scipy.optimize import brentq, least_squares
from scipy.signal import savgol_filter

from reduced import _checks

# ----------------------------------------------------------- smoothing, derivatives


class Smoother(Protocol):
    """A smoothing filter for uniformly sampled records."""

    def smooth(self, signal: ArrayLike, dt: float) -> NDArray[np.float64]: ...


@dataclass(frozen=True)
class SavitzkyGolay:
    """Local least-squares polynomial of degree ``polyorder`` over ``window_length`` samples.

    ``derivative(y, dt, k)`` is ``savgol_filter(y, window_length, polyorder, deriv=k,
    delta=dt, mode='interp')``: exact for polynomials of degree ≤ polyorder (edges
    included, by the ``interp`` end fit); the noise gain of the k-th derivative grows
    like ``1/(window·dt)^k``. Defaults suit 1 kHz records of 0.1–0.3 s pulses.
    """

    window_length: int = 31
    polyorder: int = 4

    def __post_init__(self) -> None:
        w, p = int(self.window_length), int(self.polyorder)
        if w != self.window_length or w < 3 or w % 2 == 0:
            raise ValueError(f"window_length must be an odd integer >= 3, got {self.window_length!r}")
        if p != self.polyorder or not 0 <= p < w:
            raise ValueError(f"polyorder must be an integer in [0, window_length), got {self.polyorder!r}")

    def _check(self, signal: ArrayLike, dt: float) -> tuple[NDArray[np.float64], float]:
        y = _checks.record("signal", signal, min_length=self.window_length)
        return y, _checks.sample_step("dt", dt)

    def smooth(self, signal: ArrayLike, dt: float) -> NDArray[np.float64]:
        y, _ = self._check(signal, dt)
        return savgol_filter(y, self.window_length, self.polyorder, mode="interp")

    def derivative(self, signal: ArrayLike, dt: float, order: int = 1) -> NDArray[np.float64]:
        """``d^k y/dt^k`` (units of y per s^k), k = ``order`` ≤ polyorder."""
        y, dt = self._check(signal, dt)
        if order < 0 or order > self.polyorder:
            raise ValueError(f"order must be in [0, polyorder={self.polyorder}], got {order!r}")
        return savgol_filter(y, self.window_length, self.polyorder, deriv=order, delta=dt, mode="interp")


def _odd_extension_spectrum(
    y: NDArray[np.float64], dt: float, end_window: int
) -> tuple[NDArray[np.complex128], NDArray[np.float64], float, float]:
    """Spectrum of the odd periodic extension of ``y`` minus a straight line through its ends.

    The line joins the end values of least-squares lines fitted to the first and the
    last ``end_window`` samples (so one noisy end sample is not spread over the whole
    record as a trend); the residual nearly vanishes at both ends, and its odd
    extension of period ``2(N−1)dt`` is continuous with a continuous slope up to that
    small misfit: no Gibbs ringing at the record ends.
    """
    n = y.size
    t_end = (n - 1) * dt
    w = int(min(max(end_window, 2), n // 2))
    k = np.arange(w) * dt
    y0 = float(np.polyval(np.polyfit(k, y[:w], 1), 0.0))
    y1 = float(np.polyval(np.polyfit(k, y[-w:][::-1], 1), 0.0))
    slope = (y1 - y0) / t_end
    r = y - (y0 + slope * dt * np.arange(n))
    ext = np.concatenate([r, -r[-2:0:-1]])
    freq = np.fft.rfftfreq(ext.size, dt)
    return np.fft.rfft(ext), freq, y0, slope


@dataclass(frozen=True)
class SpectralLowPass:
    """Zero-phase spectral low-pass: gain 1 below ``(1 − transition)·cutoff_hz``, a
    raised-cosine roll-off to 0 at ``cutoff_hz``; derivatives by ``(i2πf)^k`` on the
    same spectrum.

    Ends: a straight line through the two end levels (each from a least-squares line
    over half a cutoff period of samples, so that one noisy end sample does not set
    it) is taken out and the residual oddly extended (continuous value and slope), so
    records that do not start and end at the same level neither ring nor leak; the
    line's own derivative is added back. Exact for straight lines; a smooth record
    below the roll-off passes to ≈ 1e-3 (5 Hz sine on a ramp, 50 Hz cutoff). Strong
    content above the cutoff *at the ends* biases the end levels and rings back into
    the record (a 200 Hz sine of amplitude 0.5 running to the ends leaves ≈ 0.02);
    records that start and end quiet (pre-trigger, post-impact) are not affected.
    """

    cutoff_hz: float
    transition: float = 0.2

    def __post_init__(self) -> None:
        _checks.positive("cutoff_hz", self.cutoff_hz)
        tr = _checks.finite("transition", self.transition)
        if not 0.0 < tr <= 1.0:
            raise ValueError(f"transition must be in (0, 1], got {tr!r}")

    def gain(self, frequency: NDArray[np.float64]) -> NDArray[np.float64]:
        """``H(f)``: 1, raised-cosine roll-off, 0."""
        f0 = (1.0 - self.transition) * self.cutoff_hz
        x = np.clip((np.abs(frequency) - f0) / (self.cutoff_hz - f0), 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * x))

    def _check(self, signal: ArrayLike, dt: float) -> tuple[NDArray[np.float64], float]:
        y = _checks.record("signal", signal, min_length=4)
        dt = _checks.sample_step("dt", dt)
        if self.cutoff_hz * (1.0 - self.transition) >= 0.5 / dt:
            raise ValueError(
                f"cutoff_hz={self.cutoff_hz!r} leaves no roll-off below the Nyquist frequency {0.5 / dt:.6g} Hz"
            )
        return y, dt

    def smooth(self, signal: ArrayLike, dt: float) -> NDArray[np.float64]:
        return self.derivative(signal, dt, 0)

    def derivative(self, signal: ArrayLike, dt: float, order: int = 1) -> NDArray[np.float64]:
        """``d^k y/dt^k`` of the low-passed record (units of y per s^k)."""
        y, dt = self._check(signal, dt)
        if order < 0:
            raise ValueError(f"order must be >= 0, got {order!r}")
        spec, freq, y0, slope = _odd_extension_spectrum(y, dt, int(round(0.5 / (self.cutoff_hz * dt))))
        spec = spec * self.gain(freq) * (2j * np.pi * freq) ** order
        out = np.fft.irfft(spec, n=2 * (y.size - 1))[: y.size]
        if order == 0:
            out += y0 + slope * dt * np.arange(y.size)
        elif order == 1:
            out += slope
        return out


@dataclass(frozen=True)
class GaussianKernel:
    """Gaussian-kernel smoothing, standard deviation ``sigma`` (s); ends by ``nearest``
    reflection (``scipy.ndimage.gaussian_filter1d``, truncated at 4σ)."""

    sigma: float

    def __post_init__(self) -> None:
        _checks.positive("sigma", self.sigma)

    def smooth(self, signal: ArrayLike, dt: float) -> NDArray[np.float64]:
        y = _checks.record("signal", signal)
        dt = _checks.sample_step("dt", dt)
        return gaussian_filter1d(y, self.sigma / dt, mode="nearest", truncate=4.0)


SMOOTHERS: dict[str, type] = {"savgol": SavitzkyGolay, "spectral": SpectralLowPass, "gaussian": GaussianKernel}
"""Name → smoother class (the first two also differentiate)."""


def integrate_twice(values: ArrayLike, dt: float) -> NDArray[np.float64]:
    """``u(t) = ∫₀ᵗ ∫₀^{t₁} a dt₂ dt₁`` with ``u(0) = u'(0) = 0``, exact for piecewise-linear ``a``::

        v_{k+1} = v_k + dt (a_k + a_{k+1})/2
        u_{k+1} = u_k + dt v_k + dt² (2 a_k + a_{k+1})/6
    """
    a = _checks.record("values", values)
    dt = _checks.sample_step("dt", dt)
    v = np.concatenate([[0.0], np.cumsum(0.5 * dt * (a[:-1] + a[1:]))])
    du = dt * v[:-1] + dt * dt * (2.0 * a[:-1] + a[1:]) / 6.0
    return np.concatenate([[0.0], np.cumsum(du)])


# ------------------------------------------------------------------ classification

IMPACT_KINDS: tuple[str, ...] = ("free_to_roll", "coupled")


@dataclass(frozen=True)
class ImpactClassification:
    """``kind`` (``free_to_roll`` or ``coupled``), ``confidence`` in [0, 1] (0 at the
    threshold, 1 at ρ = 1 or ρ = 0), the zero-frequency ratio ρ and the threshold."""

    kind: str
    confidence: float
    zero_frequency_ratio: float
    threshold: float


def zero_frequency_ratio(relative_acceleration: ArrayLike, dt: float, *, pad_factor: int = 8, baseline_samples: int = 0) -> float:
    """``ρ = |A(0)| / max_f |A(f)|`` of the relative acceleration spectrum ``A``.

    ``A(f) = Σ a_k e^{−i2πf k dt} dt`` (``rfft`` zero-padded to ``pad_factor·N`` so
    that resonance peaks are resolved); ``A(0) = ∫ a dt`` is the change of the
    relative velocity over the record. Since ``|A(f)| ≤ ∫|a| dt`` with equality at
    f = 0 iff ``a`` keeps one sign, ``ρ = 1`` for a free-to-roll (compression-only)
    impact, where the coupler only pushes; for coupled cars the relative
    acceleration oscillates and ``ρ ≈ 1/max|H|``, ``H(iω) = (ω0² + 2iζω0ω)/(ω0² − ω² +
    2iζω0ω)``: about 0.1 at ζ = 0.05, 0.5 at ζ = 0.3, 0.7 at ζ = 0.5 — so the method
    separates the kinds for coupler damping ratios below ≈ 0.6. Noise spreads over
    all frequencies and barely moves ρ. ``baseline_samples`` > 0 subtracts the mean
    of the first samples (sensor offset; a record should then start before impact).
    """
    a = _checks.record("relative_acceleration", relative_acceleration, min_length=4)
    _checks.sample_step("dt", dt)
    if int(pad_factor) != pad_factor or pad_factor < 1:
        raise ValueError(f"pad_factor must be an integer >= 1, got {pad_factor!r}")
    if baseline_samples < 0 or baseline_samples > a.size:
        raise ValueError(f"baseline_samples must be in [0, {a.size}], got {baseline_samples!r}")
    if baseline_samples:
        a = a - a[:baseline_samples].mean()
    spectrum = np.abs(np.fft.rfft(a, n=int(pad_factor) * a.size))
    peak = spectrum.max()
    if peak == 0.0:
        raise ValueError("relative_acceleration is identically zero: nothing to classify")
    return float(spectrum[0] / peak)


def classify_impact(
    relative_acceleration: ArrayLike,
    dt: float,
    *,
    threshold: float = 0.9,
    pad_factor: int = 8,
    baseline_samples: int = 0,
) -> ImpactClassification:
    """Free to roll if ``ρ ≥ threshold``, else coupled (SOURCE-NOTES B; ρ in
    :func:`zero_frequency_ratio`). Confidence ``(ρ − t)/(1 − t)`` above the threshold
    ``t``, ``(t − ρ)/t`` below. The relative acceleration is ``a2 − a1`` (either sign).
    On 40 noisy rigid-model records (ζ ≤ 0.4, 2 % noise) and 4 coupled cars hit by a
    third car it is right 44/44, confidence ≥ 0.32 (``tests/test_reduced_signals.py``).
    """
    t = _checks.finite("threshold", threshold)
    if not 0.0 < t < 1.0:
        raise ValueError(f"threshold must be in (0, 1), got {t!r}")
    rho = zero_frequency_ratio(relative_acceleration, dt, pad_factor=pad_factor, baseline_samples=baseline_samples)
    if rho >= t:
        return ImpactClassification("free_to_roll", min(1.0, (rho - t) / (1.0 - t)), rho, t)
    return ImpactClassification("coupled", (t - rho) / t, rho, t)


# --------------------------------------------------------------- closure force (A5)


@dataclass(frozen=True)
class ClosureForceEstimate:
    """Result of :func:`detect_closure_force` (s, N, rad/s). ``closure_time`` and
    ``closure_force`` are None when the record never departs from the fitted sine
    (no closure: a single-stiffness pulse)."""

    closure_time: float | None
    closure_force: float | None
    peak_time: float
    peak_force: float
    sine_frequency: float
    smoothed_force: NDArray[np.float64]


def detect_closure_force(
    time: ArrayLike,
    force: ArrayLike,
    *,
    smoother: Smoother | None = None,
    fit_level: float = 0.7,
    departure: float = 0.04,
) -> ClosureForceEstimate:
    """Closure force of a draft gear from a coupler-force record (SOURCE-NOTES A5).

    Near the peak the closed (solid) gear is a stiff linear spring, so the force is a
    sine about zero force; before closure the soft gear makes it rise more slowly, so
    the record lies above that sine. Steps:

    1. Smooth the record (``smoother``; default a Gaussian kernel, σ = 2 samples).
    2. Fit ``y = F_m cos(b (t − t_m))`` — the source's ``a sin(b t + φ)`` with
       ``a = F_m`` and ``b t_m + φ = π/2`` — to the samples around the peak above
       ``fit_level·F_m`` (least squares, ``scipy.optimize.least_squares``; without
       noise this is the source's fit through the peak and one more point).
    3. Going back from that window, the record departs from the sine where
       ``F(t) − y(t)`` first exceeds ``departure·F_m`` at two samples in a row.
    4. A straight line fitted to the soft branch just before the departure (the
       samples whose departure is below 8 thresholds, at least three) is intersected
       with the sine (``brentq``): that time is the closure time, the sine's value
       there the closure force. Both branches are extrapolated to the kink, so the
       smoothing's rounding of the kink does not bias the estimate.

    ``time`` uniform (s), ``force`` compression positive (N). Verified on a synthetic
    gear-closure record from :func:`reduced.nonlinear.simulate_impact` (M-901E-like
    gear at 3.58 m/s, 1 kHz): closure force 3.1 % high without noise, within 5.4 %
    (mean 2.5 %) with 1 % noise over ten seeds (``tests/test_reduced_signals.py``).
    The bias comes from the closed gear's damper, which bends the stiff branch away
    from a sine near closure. A record whose force jumps at contact (a viscous
    coupler) departs from the sine at the start and reads as a (low) closure; a gear
    that closes above ``fit_level·F_m`` cannot be seen.
    """
    t = _checks.time_grid("time", time, uniform=True, min_length=8)
    f = _checks.record("force", force, min_length=8)
    _checks.same_length(time=t, force=f)
    lvl = _checks.finite("fit_level", fit_level)
    if not 0.0 < lvl < 1.0:
        raise ValueError(f"fit_level must be in (0, 1), got {lvl!r}")
    dep = _checks.finite("departure", departure)
    if not 0.0 < dep < 1.0:
        raise ValueError(f"departure must be in (0, 1), got {dep!r}")
    dt = float(t[1] - t[0])
    smoother = GaussianKernel(2.0 * dt) if smoother is None else smoother
    fs = np.asarray(smoother.smooth(f, dt), dtype=float)
    i_m = int(np.argmax(fs))
    if fs[i_m] <= 0.0:
        raise ValueError("the force record has no compressive peak")
    level = lvl * fs[i_m]
    lo = i_m
    while lo > 0 and fs[lo - 1] >= level:
        lo -= 1
    hi = i_m
    while hi < fs.size - 1 and fs[hi + 1] >= level:
        hi += 1
    if lo == 0:
        raise ValueError("the force record starts above fit_level·peak: it must start before the load rises")
    if hi - lo + 1 < 3:
        raise ValueError("fewer than 3 samples above fit_level·peak: sample faster or lower fit_level")
    tw, fw = t[lo : hi + 1], fs[lo : hi + 1]
    quad_coef = np.polyfit(tw - t[i_m], fw, 2)
    curvature = -quad_coef[0]
    b0 = math.sqrt(2.0 * curvature / fs[i_m]) if curvature > 0.0 else math.acos(lvl) / max(t[i_m] - tw[0], dt)
    fit = least_squares(
        lambda p: p[0] * np.cos(p[1] * (tw - p[2])) - fw,
        x0=[fs[i_m], b0, t[i_m]],
        x_scale=[fs[i_m], b0, 1.0 / b0],
    )
    f_m, b, t_m = (float(v) for v in fit.x)
    b = abs(b)

    def sine(x: NDArray[np.float64] | float) -> NDArray[np.float64] | float:
        return f_m * np.cos(b * (x - t_m))

    start = t_m - 0.5 * math.pi / b
    d = fs - sine(t)
    thr = dep * f_m
    k = lo
    k_dep = None
    while k >= 1 and t[k - 1] >= start:
        if d[k] > thr and d[k - 1] > thr:  # two samples in a row: not a noise spike
            k_dep = k
            break
        k -= 1
    if k_dep is None:
        return ClosureForceEstimate(None, None, t_m, f_m, b, fs)
    soft = [k_dep]
    while soft[-1] > 0 and d[soft[-1] - 1] <= 8.0 * thr:
        soft.append(soft[-1] - 1)
    while len(soft) < 3 and soft[-1] > 0:
        soft.append(soft[-1] - 1)
    idx = np.array(sorted(soft))
    slope, intercept = np.polyfit(t[idx], fs[idx], 1)

    def gap(x: float) -> float:
        return float(sine(x)) - (slope * x + intercept)

    a, c = float(t[k_dep]), float(t[lo])
    if gap(a) < 0.0 < gap(c):
        t_c = brentq(gap, a, c, xtol=1e-12 * max(1.0, abs(c)))
    else:
        t_c = a
    return ClosureForceEstimate(float(t_c), float(sine(t_c)), t_m, f_m, b, fs)


# ------------------------------------------------------ resampling, normalisation


def resample_record(
    time: ArrayLike,
    values: ArrayLike,
    n_samples: int,
    *,
    start: float | None = None,
    stop: float | None = None,
    antialias: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The record on ``n_samples`` equally spaced times from ``start`` to ``stop``.

    Linear interpolation; when the new step is longer than the old one and the record
    is uniform, ``antialias`` first low-passes it at 0.8 of the new Nyquist frequency
    (:class:`SpectralLowPass`). Outside the record the end values are held.
    Returns ``(new_time, new_values)``.
    """
    t = _checks.time_grid("time", time)
    y = _checks.record("values", values)
    _checks.same_length(time=t, values=y)
    if int(n_samples) != n_samples or n_samples < 2:
        raise ValueError(f"n_samples must be an integer >= 2, got {n_samples!r}")
    a = float(t[0]) if start is None else _checks.finite("start", start)
    b = float(t[-1]) if stop is None else _checks.finite("stop", stop)
    if not b > a:
        raise ValueError(f"stop must be after start (start={a!r}, stop={b!r})")
    new_t = np.linspace(a, b, int(n_samples))
    new_dt = (b - a) / (n_samples - 1)
    steps = np.diff(t)
    uniform = np.allclose(steps, steps[0], rtol=1e-6, atol=0.0)
    if antialias and uniform and new_dt > steps[0] and y.size >= 4:
        y = SpectralLowPass(cutoff_hz=0.8 * 0.5 / new_dt).smooth(y, float(steps[0]))
    return new_t, np.interp(new_t, t, y)


def peak_normalise(records: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each record (row) divided by its peak magnitude ``max|a|``; returns ``(normalised, peaks)``.

    The source study's "normalised acceleration input"; keep ``peaks`` to restore units.
    """
    x = np.asarray(records, dtype=float)
    if x.ndim not in (1, 2) or x.size == 0:
        raise ValueError(f"records must be a non-empty 1-D or 2-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("records contain non-finite values (NaN or inf)")
    x2 = np.atleast_2d(x)
    peaks = np.max(np.abs(x2), axis=1)
    if np.any(peaks == 0.0):
        raise ValueError(f"records {np.flatnonzero(peaks == 0.0).tolist()} are identically zero")
    out = x2 / peaks[:, None]
    return (out[0], peaks) if x.ndim == 1 else (out, peaks)


SCALER_KINDS: tuple[str, ...] = ("standard", "minmax")


@dataclass(frozen=True, eq=False)
class FeatureScaler:
    """Per-feature affine scaling ``z = (x − offset)/scale`` fitted on training data.

    ``standard``: offset = mean, scale = standard deviation; ``minmax``: offset = min,
    scale = max − min (to [0, 1]). A constant feature gets scale 1. Saved with a
    network as plain arrays (:meth:`to_arrays` / :meth:`from_arrays`), never pickled.
    """

    kind: str
    offset: NDArray[np.float64]
    scale: NDArray[np.float64]

    def __post_init__(self) -> None:
        _checks.choice("kind", self.kind, SCALER_KINDS)
        if self.offset.shape != self.scale.shape or self.offset.ndim != 1:
            raise ValueError("offset and scale must be 1-D arrays of the same length")
        if not (np.all(np.isfinite(self.offset)) and np.all(np.isfinite(self.scale)) and np.all(self.scale > 0.0)):
            raise ValueError("offset must be finite and scale finite and > 0")

    @classmethod
    def fit(cls, features: ArrayLike, kind: str = "standard") -> FeatureScaler:
        """Fit on ``features`` of shape (n_samples, n_features)."""
        _checks.choice("kind", kind, SCALER_KINDS)
        x = np.asarray(features, dtype=float)
        if x.ndim != 2 or x.shape[0] < 1:
            raise ValueError(f"features must have shape (n_samples, n_features), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("features contain non-finite values (NaN or inf)")
        if kind == "standard":
            offset, scale = x.mean(axis=0), x.std(axis=0)
        else:
            offset, scale = x.min(axis=0), x.max(axis=0) - x.min(axis=0)
        scale = np.where(scale > 0.0, scale, 1.0)
        return cls(kind, offset, scale)

    def _check(self, features: ArrayLike) -> NDArray[np.float64]:
        x = np.asarray(features, dtype=float)
        if x.shape[-1] != self.offset.size:
            raise ValueError(f"features have {x.shape[-1]} columns, the scaler was fitted on {self.offset.size}")
        return x

    def transform(self, features: ArrayLike) -> NDArray[np.float64]:
        return (self._check(features) - self.offset) / self.scale

    def inverse_transform(self, scaled: ArrayLike) -> NDArray[np.float64]:
        return self._check(scaled) * self.scale + self.offset

    def to_arrays(self) -> dict[str, NDArray]:
        """Plain arrays for HDF5/npz: ``kind`` (as a 0-d string array), ``offset``, ``scale``."""
        return {"kind": np.array(self.kind), "offset": self.offset.copy(), "scale": self.scale.copy()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, NDArray]) -> FeatureScaler:
        return cls(str(arrays["kind"]), np.asarray(arrays["offset"], dtype=float), np.asarray(arrays["scale"], dtype=float))


__all__ = [
    "IMPACT_KINDS",
    "SCALER_KINDS",
    "SMOOTHERS",
    "ClosureForceEstimate",
    "FeatureScaler",
    "GaussianKernel",
    "ImpactClassification",
    "SavitzkyGolay",
    "Smoother",
    "SpectralLowPass",
    "classify_impact",
    "detect_closure_force",
    "integrate_twice",
    "peak_normalise",
    "resample_record",
    "zero_frequency_ratio",
]
