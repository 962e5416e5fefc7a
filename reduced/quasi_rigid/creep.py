"""Creep kernels and O(1)-per-step recursive hereditary integrals.

Strain law (docs/formulas.md §D), with γ(x) = EA(x)/cA(x) (rod) or EI/cI (beam):

    e(t) = (F(t) − ∫₀ᵗ K(γ (t − t₁)) F'(t₁) dt₁) / EA.

With a Prony series ``K(s) = Σᵢ kᵢ exp(−rᵢ s)`` and the identity
``∫₀ᵗ e^{−(t−t₁)/τ} F'(t₁) dt₁ = F(t) − L_τ[F](t)`` (both sides solve ``τ ḣ + h = τ F'``
from rest), the hereditary integral becomes a weighted sum of first-order low-pass
filters ``L_τ`` (``τ ẏ + y = F``):

    EA e = k₀ F + Σᵢ kᵢ L_{τᵢ}[F],   k₀ = 1 − Σᵢ kᵢ,   τᵢ = 1/(rᵢ γ) = cA/(rᵢ EA).

The Voigt body is ``K = e^{−s}`` (one term, k₀ = 0): ``EA e + cA ė = F``. Nothing here
divides by the viscosity: τ = 0 is the identity (elastic) and τ = ∞ holds the output
(rigid), both exactly. Time-harmonic (``e^{−iωt}``): ``L_τ → 1/(1 − iωτ)``.

Each filter is advanced by the exact exponential update for an input that is linear
between samples (:func:`update_coefficients`), so a record of Nt samples costs O(Nt)
(:func:`filter_piecewise_linear`, one ``scipy.signal.lfilter`` call), never O(Nt²).

Verified: tests/reduced/quasi_rigid/test_time.py (against adaptive quadrature of the hereditary
integral), tests/reduced/quasi_rigid/test_frequency.py (a Zener kernel's closed form).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class CreepKernel:
    """Creep kernel ``K(s) = Σᵢ weights[i] · exp(−rates[i] · s)`` of the dimensionless time ``s = γ t``.

    ``weights`` ≥ 0 with ``Σ weights ≤ 1`` (the rest, ``1 − Σ weights``, is the
    instantaneous elastic part); ``rates`` > 0. The default is the Voigt kernel
    ``K(s) = e^{−s}`` (strain follows ``EA e + cA ė = F``). A standard-linear
    (Zener) body with instantaneous compliance ``f/EA`` and long-term ``1/EA`` is
    ``CreepKernel((1 − f,), (1/(1 − f),))``, with ``cA`` then its creep viscosity
    times ``(1 − f)``; any tabulated kernel can be brought to this form by
    :meth:`fit`.
    """

    weights: tuple[float, ...] = (1.0,)
    rates: tuple[float, ...] = (1.0,)

    def __post_init__(self) -> None:
        w = np.asarray(self.weights, dtype=float)
        r = np.asarray(self.rates, dtype=float)
        if w.ndim != 1 or w.shape != r.shape or w.size == 0:
            raise ValueError("a creep kernel needs one rate per weight (at least one term)")
        if not (np.all(np.isfinite(w)) and np.all(w >= 0.0)):
            raise ValueError(f"creep kernel weights must be finite and ≥ 0, got {self.weights}")
        if not (np.all(np.isfinite(r)) and np.all(r > 0.0)):
            raise ValueError(f"creep kernel rates must be finite and > 0, got {self.rates}")
        if w.sum() > 1.0 + 1e-12:
            raise ValueError(f"creep kernel weights must sum to at most 1 (K(0) ≤ 1), got {w.sum()}")
        object.__setattr__(self, "weights", tuple(float(v) for v in w))
        object.__setattr__(self, "rates", tuple(float(v) for v in r))

    @classmethod
    def voigt(cls) -> "CreepKernel":
        """``K(s) = e^{−s}``: the Kelvin–Voigt body ``EA e + cA ė = F``."""
        return cls((1.0,), (1.0,))

    @classmethod
    def fit(cls, kernel: Callable[[NDArray[np.float64]], ArrayLike], s_max: float, n_terms: int = 12) -> "CreepKernel":
        """Non-negative Prony fit of a kernel ``K(s)`` (``K(0) ≤ 1``) on ``0 ≤ s ≤ s_max``.

        Rates are log-spaced over ``[0.3/s_max, 30]`` and the weights solve a
        non-negative least-squares problem on 400 log-spaced samples, so the
        result is a valid kernel (a completely monotone fit). Check the fit with
        ``max|fit(s) − K(s)|`` before use.
        """
        from scipy.optimize import nnls  # scipy.optimize costs ~0.3 s to import: only a kernel fit needs it

        if not s_max > 0.0:
            raise ValueError("s_max must be > 0")
        s = np.concatenate([[0.0], np.geomspace(1e-3 * s_max, s_max, 399)])
        target = np.broadcast_to(np.asarray(kernel(s), dtype=float), s.shape)
        rates = np.geomspace(0.3 / s_max, 30.0, n_terms)
        design = np.exp(-np.outer(s, rates))
        weights, _ = nnls(design, target)
        total = weights.sum()
        if total > 1.0:
            weights = weights / total
        keep = weights > 1e-14
        if not np.any(keep):
            raise ValueError("the kernel fit has no positive term (is K ≥ 0?)")
        return cls(tuple(weights[keep]), tuple(rates[keep]))

    @property
    def instantaneous(self) -> float:
        """``k₀ = 1 − Σ kᵢ``, the fraction of the strain that follows the force at once."""
        return max(0.0, 1.0 - math.fsum(self.weights))

    def __call__(self, s: ArrayLike) -> NDArray[np.float64]:
        s = np.asarray(s, dtype=float)
        return np.sum(np.asarray(self.weights) * np.exp(-np.multiply.outer(s, np.asarray(self.rates))), axis=-1)

    def time_constants(self, viscous_time: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Filter weights and time constants at points of viscous time ``τ = c/k`` (s).

        Returns ``(weights, taus)`` of shape ``(..., n_terms + 1)``: term 0 is the
        instantaneous part (τ = 0), term i the Prony term with ``τ/rᵢ`` (∞ stays ∞).
        """
        tau = np.asarray(viscous_time, dtype=float)
        taus = np.empty((*tau.shape, len(self.rates) + 1))
        taus[..., 0] = 0.0
        np.divide(tau[..., None], self.rates, out=taus[..., 1:])
        weights = np.empty_like(taus)
        weights[...] = (self.instantaneous, *self.weights)
        return weights, taus


VOIGT = CreepKernel.voigt()


def harmonic_factor(omega: ArrayLike, tau: ArrayLike) -> NDArray[np.complex128]:
    """``1/(1 − iωτ)``, the low-pass filter ``τ ẏ + y = F`` at ``e^{−iωt}``; exact at τ = 0 and τ = ∞.

    Broadcasts ``omega`` against ``tau``. At τ = ∞ the factor is 0 for ω ≠ 0 and 1 at ω = 0.
    """
    omega = np.asarray(omega, dtype=float)
    tau = np.asarray(tau, dtype=float)
    omega, tau = np.broadcast_arrays(omega, tau)
    out = np.ones(omega.shape, dtype=complex)
    finite = np.isfinite(tau) & (tau > 0.0)
    out[finite] = 1.0 / (1.0 - 1j * omega[finite] * tau[finite])
    out[np.isinf(tau) & (omega != 0.0)] = 0.0
    return out


def harmonic_factor_at(omega: float, tau: float) -> complex:
    """:func:`harmonic_factor` at one frequency and time constant, in plain complex arithmetic (no array set-up):
    ``1/(1 − iωτ)``, 1 at τ = 0, at τ = ∞ 0 for ω ≠ 0 and 1 at ω = 0."""
    if tau == 0.0 or (omega == 0.0 and math.isinf(tau)):
        return 1.0 + 0.0j
    if math.isinf(tau):
        return 0.0j
    return 1.0 / complex(1.0, -omega * tau)


def update_coefficients(dt: float, tau: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Exact one-step update of ``τ ẏ + y = F`` for F linear on the step.

    ``y₁ = d·y₀ + a·F₀ + b·F₁`` with ``h = dt/τ``, ``d = e^{−h}``, ``φ = 1 − e^{−h}``,
    ``b = 1 − φ/h``, ``a = φ − b``. Derivation: ``y = F − sτ + (y₀ − F₀ + sτ) e^{−(t−t₀)/τ}``
    with slope ``s = (F₁ − F₀)/dt``. ``b`` is summed as its Taylor series for h < 1e-2
    (no cancellation); τ = 0 gives ``(0, 0, 1)`` (y = F), τ = ∞ gives ``(1, 0, 0)`` (y held).
    Returns ``(d, a, b)`` with the shape of ``tau``.
    """
    tau = np.asarray(tau, dtype=float)
    h = np.divide(dt, tau, out=np.full(tau.shape, np.inf), where=tau > 0.0)  # τ = ∞: h = 0
    decay = np.exp(-h)
    phi = -np.expm1(-h)
    small = h < 1e-2
    if not np.any(small):
        b = 1.0 - phi / h  # h = ∞: 1
    else:
        hs = np.where(small, h, 0.0)
        series = hs * (1 / 2 - hs * (1 / 6 - hs * (1 / 24 - hs * (1 / 120 - hs * (1 / 720 - hs / 5040)))))
        b = np.where(small, series, 1.0 - phi / np.where(small, 1.0, h))
    return decay, phi - b, b


def filter_piecewise_linear(samples: ArrayLike, dt: float, tau: float, initial_output: ArrayLike = 0.0) -> NDArray[np.float64]:
    """``y = L_τ[F]`` on a uniform grid for F linear between samples, O(1) per step.

    ``samples`` has time on its last axis. The input before ``t₀`` is taken as
    ``F(t₀)`` held with the output at ``initial_output`` (rest: 0 for 0); the output
    at sample n is exact for the piecewise-linear input (up to rounding).
    Implemented as the two-tap recursion of :func:`update_coefficients` through
    ``scipy.signal.lfilter``.
    """
    x = np.asarray(samples, dtype=float)
    decay, a, b = (float(v) for v in update_coefficients(dt, tau))
    y0 = np.broadcast_to(np.asarray(initial_output, dtype=float), x.shape[:-1])
    if b == 1.0 and decay == 0.0:  # τ = 0: the identity, exactly
        return x.copy()
    from scipy.signal import lfilter  # scipy.signal costs ~0.5 s to import: only a transient response filters

    zi = (y0 - b * x[..., 0])[..., None]
    y, _ = lfilter([b, a], [1.0, -decay], x, axis=-1, zi=zi)
    return y


def hereditary_integral_direct(samples: ArrayLike, dt: float, tau: float) -> NDArray[np.float64]:
    """Reference O(Nt²) quadrature of ``∫₀ᵗ e^{−(t−t₁)/τ} F(t₁) dt₁ / τ`` (input zero before t₀).

    Adaptive quadrature (``scipy.integrate.quad`` with a break at every sample) of the
    exponential against the piecewise-linear interpolant, for each output time anew, with
    no recursion: for tests of :func:`filter_piecewise_linear` on short records only.
    """
    from scipy.integrate import quad

    f = np.asarray(samples, dtype=float)
    times = np.arange(f.size) * dt
    out = np.zeros(f.size)
    for k in range(1, f.size):
        t = times[k]

        def integrand(s: float) -> float:
            return math.exp(-(t - s) / tau) * float(np.interp(s, times, f)) / tau

        out[k] = quad(integrand, 0.0, t, points=times[1:k], limit=4 * k + 50, epsabs=0.0, epsrel=1e-13)[0]
    return out
