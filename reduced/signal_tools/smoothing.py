"""Smoothing and differentiation of uniformly sampled records, and their double integral.

* :class:`SavitzkyGolay` (``scipy.signal.savgol_filter``), :class:`SpectralLowPass`
  (FFT with a raised-cosine roll-off) and :class:`GaussianKernel`
  (``scipy.ndimage.gaussian_filter1d``) smooth; the first two also differentiate
  (registry :data:`SMOOTHERS`); :class:`Smoother` is their common protocol.
* :func:`integrate_twice` — exact double integral of the piecewise-linear record.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import gaussian_filter1d
from scipy.signal import savgol_filter

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


__all__ = ["SMOOTHERS", "GaussianKernel", "SavitzkyGolay", "Smoother", "SpectralLowPass", "integrate_twice"]
