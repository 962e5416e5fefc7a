"""Smoothing and differentiation of uniformly sampled records, and their double integral.

* :class:`SavitzkyGolay` (``scipy.signal.savgol_filter``), :class:`SpectralLowPass`
  (FFT with a raised-cosine roll-off), :class:`GaussianKernel`
  (``scipy.ndimage.gaussian_filter1d``) and :class:`AdaptiveBandwidth` (local
  polynomial fits whose Gaussian bandwidth is chosen per sample by the ICI rule,
  with :func:`robust_noise_std`) smooth; the first two also differentiate
  (registry :data:`SMOOTHERS`); :class:`Smoother` is their common protocol.
* :func:`integrate_twice` — exact double integral of the piecewise-linear record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks


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
        from scipy.signal import savgol_filter  # scipy.signal costs ~0.5 s to import: only where a smoother runs

        y, _ = self._check(signal, dt)
        return savgol_filter(y, self.window_length, self.polyorder, mode="interp")

    def derivative(self, signal: ArrayLike, dt: float, order: int = 1) -> NDArray[np.float64]:
        """``d^k y/dt^k`` (units of y per s^k), k = ``order`` ≤ polyorder."""
        y, dt = self._check(signal, dt)
        if order < 0 or order > self.polyorder:
            raise ValueError(f"order must be in [0, polyorder={self.polyorder}], got {order!r}")
        from scipy.signal import savgol_filter

        return savgol_filter(y, self.window_length, self.polyorder, deriv=order, delta=dt, mode="interp")


def _odd_extension_spectrum(
    y: NDArray[np.float64], dt: float, end_window: int
) -> tuple[NDArray[np.complex128], NDArray[np.float64], float, float]:
    """Spectrum of the odd periodic extension (period ``2(N−1)dt``) of ``y`` minus a straight line through its
    ends, each end level from a least-squares line over ``end_window`` samples (:class:`SpectralLowPass`)."""
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

    Ends: a straight line through the two end levels (each a least-squares line over half a cutoff period, so
    one noisy end sample does not set it) is taken out, the residual oddly extended (continuous value and
    slope) and the line's derivative added back: no ringing or leaking at ends of different levels. Exact for
    straight lines; strong content above the cutoff *at the ends* biases the end levels and rings back.
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
        from scipy.ndimage import gaussian_filter1d

        y = _checks.record("signal", signal)
        dt = _checks.sample_step("dt", dt)
        return gaussian_filter1d(y, self.sigma / dt, mode="nearest", truncate=4.0)


_KERNEL_REACH = 4.0
"""The Gaussian weights of :class:`AdaptiveBandwidth` are cut at ``|t − t_i| > 4h`` (as in
:class:`GaussianKernel`): the dropped weight is below 3.4e-4 of the peak weight."""


def robust_noise_std(signal: ArrayLike) -> float:
    """``σ̂ = 1.4826 · median|Δ²y − median Δ²y| / √6``, ``Δ²y_k = y_{k+1} − 2y_k + y_{k−1}`` (units of y).

    White noise of standard deviation σ gives second differences of variance 6σ²; the
    median absolute deviation (scaled by 1.4826, exact for Gaussian noise) ignores the
    few large second differences at kinks and steps, and a record sampled fast enough
    for its smooth part to change little between samples adds almost nothing to it.
    Zero for a straight line or a parabola sampled without noise.
    """
    y = _checks.record("signal", signal, min_length=3)
    second = y[2:] - 2.0 * y[1:-1] + y[:-2]
    return float(1.482602218505602 * np.median(np.abs(second - np.median(second))) / math.sqrt(6.0))


@dataclass(frozen=True)
class AdaptiveFit:
    """Result of :meth:`AdaptiveBandwidth.fit`: the smoothed record, the bandwidths (s) chosen at each sample
    by the symmetric, left and right fits, the noise σ used and the ``ladder`` of bandwidths tried (s)."""

    smoothed: NDArray[np.float64]
    bandwidth: NDArray[np.float64]
    left_bandwidth: NDArray[np.float64]
    right_bandwidth: NDArray[np.float64]
    noise_std: float
    ladder: NDArray[np.float64]


_SIDES = (0, -1, 1)
"""Kernel supports of :class:`AdaptiveBandwidth`: symmetric, left (t_k ≤ t_i), right (t_k ≥ t_i)."""


@dataclass(frozen=True)
class AdaptiveBandwidth:
    """Local polynomial fits with Gaussian kernels whose bandwidths are chosen per sample (LPA-ICI).

    At each sample time ``t_i``, for a kernel support s (symmetric, left: t_k ≤ t_i,
    right: t_k ≥ t_i) and a bandwidth h, the local fit of degree p (1 or 2)::

        min_β Σ_k K_s((t_k − t_i)/h) (y_k − Σ_{r≤p} β_r ((t_k − t_i)/h)^r)²,   K(u) = e^{−u²/2} (|u| ≤ 4)
        ŷ_{s,h}(t_i) = β₀ = Σ_k ℓ_ik y_k,      std ŷ_{s,h}(t_i) = σ g_{s,h}(t_i),   g² = Σ_k ℓ_ik²

    over the ladder ``h_j = h_min ρ^j`` (j = 0…J−1). Intersection of confidence
    intervals (ICI, Lepski's rule), for each support and sample: with
    ``D_j = [ŷ_j − Γσ g_j, ŷ_j + Γσ g_j]``, the chosen ``h_s`` is the largest h_j for
    which ``D_0 ∩ … ∩ D_j`` is not empty. The three estimates are then fused by
    their inverse variances::

        ŷ(t_i) = Σ_s ŷ_{s,h_s} / g²_{s,h_s}  /  Σ_s 1/g²_{s,h_s}

    Why: while the bias is small against the noise, the estimates of growing h stay inside each other's
    intervals (which shrink like h^{−1/2}); at a kink the intersection empties and a small h is kept, while the
    one-sided fit looking away from it may grow and the fusion weights it up. σ is ``noise_std`` or, if None,
    :func:`robust_noise_std` of the record; ``min_bandwidth`` None is one sample interval.

    The kernel sums are FFT correlations (one batch per bandwidth), the normal equations solved in closed
    form. At the record ends the fit is one-sided and its larger g widens its interval (fewer than p + 2
    samples: no weight). A polynomial of degree ≤ p is reproduced exactly by every fit. Measured against the
    best fixed Gaussian: tests/reduced/test_adaptive_smoother.py.
    """

    degree: int = 2
    threshold: float = 2.0
    min_bandwidth: float | None = None
    bandwidth_ratio: float = 1.5
    bandwidth_count: int = 12
    noise_std: float | None = None

    def __post_init__(self) -> None:
        if self.degree not in (1, 2):
            raise ValueError(f"degree must be 1 or 2, got {self.degree!r}")
        _checks.positive("threshold", self.threshold)
        if self.min_bandwidth is not None:
            _checks.positive("min_bandwidth", self.min_bandwidth)
        ratio = _checks.finite("bandwidth_ratio", self.bandwidth_ratio)
        if ratio <= 1.0:
            raise ValueError(f"bandwidth_ratio must be > 1, got {ratio!r}")
        if int(self.bandwidth_count) != self.bandwidth_count or self.bandwidth_count < 1:
            raise ValueError(f"bandwidth_count must be an integer >= 1, got {self.bandwidth_count!r}")
        if self.noise_std is not None:
            _checks.non_negative("noise_std", self.noise_std)

    def ladder(self, dt: float) -> NDArray[np.float64]:
        """The bandwidths ``h_j = h_min ρ^j`` (s)."""
        dt = _checks.sample_step("dt", dt)
        h_min = dt if self.min_bandwidth is None else float(self.min_bandwidth)
        if h_min < dt * (1.0 - 1e-12):
            raise ValueError(f"min_bandwidth must be at least the sample interval dt = {dt!r} s, got {h_min!r}")
        return h_min * float(self.bandwidth_ratio) ** np.arange(int(self.bandwidth_count))

    def smooth(self, signal: ArrayLike, dt: float) -> NDArray[np.float64]:
        return self.fit(signal, dt).smoothed

    def fit(self, signal: ArrayLike, dt: float) -> AdaptiveFit:
        """The smoothed record with the bandwidths chosen at each sample."""
        from scipy.fft import next_fast_len

        y = _checks.record("signal", signal, min_length=2 * self.degree + 3)
        ladder = self.ladder(dt)
        dt = float(dt)
        sigma = robust_noise_std(y) if self.noise_std is None else float(self.noise_std)
        n_side, n_h = len(_SIDES), ladder.size
        estimates = np.empty((n_side, n_h, y.size))
        gains = np.empty((n_side, n_h, y.size))
        n_fft = next_fast_len(y.size + 2 * int(math.floor(_KERNEL_REACH * ladder[-1] / dt)) + 1, real=True)
        y_spectrum = np.fft.rfft(y, n_fft)
        for j, h in enumerate(ladder):
            estimates[:, j], gains[:, j] = _local_polynomials(y_spectrum, y.size, n_fft, h / dt, self.degree)
        # ICI per support; a fit without enough samples (gain inf) constrains nothing
        finite = np.isfinite(gains)
        half_width = np.where(finite, self.threshold * sigma * np.where(finite, gains, 0.0), np.inf)
        lower = np.maximum.accumulate(np.where(finite, estimates - half_width, -np.inf), axis=1)
        upper = np.minimum.accumulate(np.where(finite, estimates + half_width, np.inf), axis=1)
        chosen = np.maximum(np.sum(lower <= upper, axis=1) - 1, 0)  # (side, sample)
        est = np.take_along_axis(estimates, chosen[:, None, :], axis=1)[:, 0]
        gain = np.take_along_axis(gains, chosen[:, None, :], axis=1)[:, 0]
        weight = np.where(np.isfinite(gain), 1.0 / np.where(np.isfinite(gain), gain, 1.0) ** 2, 0.0)
        smoothed = np.sum(weight * np.where(weight > 0.0, est, 0.0), axis=0) / np.sum(weight, axis=0)
        h = ladder[chosen]
        return AdaptiveFit(smoothed, h[0], h[1], h[2], sigma, ladder)


def _local_polynomials(
    y_spectrum: NDArray[np.complex128], n: int, n_fft: int, bandwidth_samples: float, degree: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Local polynomial estimates ``ŷ_i = Σ_k ℓ_ik y_k`` and noise gains ``(Σ_k ℓ_ik²)^{1/2}`` at
    every sample for the symmetric, left and right Gaussian kernels of ``bandwidth_samples``
    (in sample intervals); shape (3, n). ``y_spectrum`` is ``rfft(y, n_fft)`` with
    ``n_fft ≥ n + 2·reach``. Gain inf where a support holds fewer than degree + 2 samples."""
    reach = int(math.floor(_KERNEL_REACH * bandwidth_samples))
    offset = np.arange(-reach, reach + 1)
    u = offset / bandwidth_samples
    kernel = np.exp(-0.5 * u * u)
    m = 2 * degree + 1
    powers = u[None, :] ** np.arange(m)[:, None]
    k_side = np.stack([kernel * (side * offset >= 0) for side in _SIDES])  # (3, 2 reach + 1)
    # Σ over the offsets d with t_{i+d} inside the record, from cumulative sums of the weights
    i = np.arange(n)
    before, after = np.minimum(reach, i), np.minimum(reach, n - 1 - i)
    first, last = reach - before, reach + after  # index range of d in the weight arrays

    def window_sums(g: NDArray[np.float64]) -> NDArray[np.float64]:
        c = np.concatenate([np.zeros(g.shape[:-1] + (1,)), np.cumsum(g, axis=-1)], axis=-1)
        return c[..., last + 1] - c[..., first]

    s = window_sums(k_side[:, None, :] * powers[None])  # Σ K u^r        (3, m, n)
    q = window_sums((k_side * k_side)[:, None, :] * powers[None])  # Σ K² u^r   (3, m, n)
    # Σ_d K u^r y_{i+d}: correlation = convolution with the reversed weights (zero outside the record)
    rows = (k_side[:, None, :] * powers[None, : degree + 1])[..., ::-1].reshape(-1, 2 * reach + 1)
    conv = np.fft.irfft(np.fft.rfft(rows, n_fft, axis=-1) * y_spectrum[None, :], n_fft, axis=-1)
    data = conv[:, reach : reach + n].reshape(3, degree + 1, n)
    # first column of the inverse of the Hankel normal matrix [s_{a+b}], in closed form
    if degree == 1:
        a = np.stack([s[:, 2], -s[:, 1]])
        det = s[:, 0] * s[:, 2] - s[:, 1] ** 2
    else:
        a = np.stack([s[:, 2] * s[:, 4] - s[:, 3] ** 2, s[:, 2] * s[:, 3] - s[:, 1] * s[:, 4], s[:, 1] * s[:, 3] - s[:, 2] ** 2])
        det = s[:, 0] * a[0] + s[:, 1] * a[1] + s[:, 2] * a[2]
    count = np.stack([before + after + 1, before + 1, after + 1])
    ok = count >= degree + 2
    a = a / np.where(ok, det, 1.0)  # (p+1, side, n)
    estimate = np.einsum("rjn,jrn->jn", a, data)
    r = np.arange(degree + 1)
    gain2 = np.einsum("rjn,jrsn,sjn->jn", a, q[:, r[:, None] + r[None, :]], a)
    return np.where(ok, estimate, 0.0), np.where(ok, np.sqrt(np.maximum(gain2, 0.0)), np.inf)


SMOOTHERS: dict[str, type] = {
    "savgol": SavitzkyGolay,
    "spectral": SpectralLowPass,
    "gaussian": GaussianKernel,
    "adaptive": AdaptiveBandwidth,
}
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


__all__ = [
    "SMOOTHERS",
    "AdaptiveBandwidth",
    "AdaptiveFit",
    "GaussianKernel",
    "SavitzkyGolay",
    "Smoother",
    "SpectralLowPass",
    "integrate_twice",
    "robust_noise_std",
]
