"""Numerical inverse Laplace transform by the method of de Hoog, Knight and Stokes (1982).

For ``f(t) = (1/2πi) ∫ F(s) e^{st} ds`` on ``Re s = σ``, the trapezoidal rule with step
``π/T`` gives the Fourier series (valid on ``0 ≤ t < 2T``)::

    f(t) ≈ (e^{σt}/T) Re[ F(σ)/2 + Σ_{k≥1} F(σ + ikπ/T) z^k ],     z = e^{iπt/T}

whose discretisation error is ``≈ e^{−2σT} f(2T + t)`` (so ``σ = α − ln(ε)/(2T)`` makes it
``ε``-small relative to ``e^{α(2T+t)}``-growing functions). de Hoog et al. sum the power
series in ``z`` through its continued-fraction (Padé) form, built from the ``2M + 1``
coefficients by the quotient-difference algorithm, with their estimate of the remainder
of the fraction. This converges far faster than the series itself, also for functions
with kinks or ``√t`` fronts, but it cannot resolve jumps finer than ``≈ T/M``
(Gibbs-like ringing, e.g. the wave-front jumps of an elastic rod's acceleration).

The times are split into windows ``[0, t₁], (t₁, t₂], …`` with ``t_{j+1} = 2 t_j``
(geometric) after the first, each inverted with its own ``T = T_RATIO · t_max`` of
the window, so early times are not resolved on the scale of the last one.
All times of a window share the ``2M + 1`` transform values; the QD table is built once
per window and the fraction evaluated for all its times at once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Half-period of the Fourier series as a multiple of the window's last time.
T_RATIO = 1.0
#: Relative size of the discretisation (aliasing) error, ``e^{−2σT}``.
ALIASING_TOLERANCE = 1e-10


def invert_laplace(
    transform: Callable[[NDArray[np.complex128]], NDArray[np.complex128]],
    t: ArrayLike,
    *,
    terms: int = 24,
    window_growth: float = 2.0,
    first_window: float | None = None,
    alpha: float = 0.0,
) -> NDArray[np.float64]:
    """``f(t)`` from ``F(s)``: ``transform(s)`` maps ``(Ns,)`` complex ``s`` to ``(Ns, …)``.

    ``t`` (s) is ``(Nt,)``, ``≥ 0``; the result is ``(Nt, …)`` real. ``terms`` is ``M``
    (``2M + 1`` transform values per window); windows grow geometrically by
    ``window_growth`` from ``first_window`` (default: the whole range in one window
    when ``window_growth`` is ``inf``; else ``t_max / window_growth**n`` with the
    first window holding at least a tenth of the range). ``alpha`` bounds the
    exponential growth rate of ``f`` (0 for bounded or polynomially growing ``f``).
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(t < 0.0):
        raise ValueError("times t must be a 1-D array of finite values >= 0 s")
    if terms < 2:
        raise ValueError(f"terms must be >= 2, got {terms}")
    out = None
    for lo, hi in _windows(t, window_growth, first_window):
        select = (t > lo) & (t <= hi) if lo > 0.0 else (t <= hi)
        if not np.any(select):
            continue
        half_period = T_RATIO * hi
        sigma = alpha - np.log(ALIASING_TOLERANCE) / (2.0 * half_period)
        s = sigma + 1j * np.pi * np.arange(2 * terms + 1) / half_period
        values = np.asarray(transform(s), dtype=complex)
        f = _de_hoog(values, t[select], half_period, sigma)
        if out is None:
            out = np.zeros((t.size, *f.shape[1:]))
        out[select] = f
    if out is None:  # all t == 0 handled above; only reached for empty t
        out = np.zeros((t.size,))
    return out


def _windows(t: NDArray, growth: float, first: float | None) -> list[tuple[float, float]]:
    t_max = float(np.max(t)) if t.size else 0.0
    if t_max == 0.0:
        return [(0.0, 1.0)]
    if not np.isfinite(growth):
        return [(0.0, t_max)]
    if first is None:
        first = t_max
        while first / growth >= 0.1 * t_max:
            first /= growth
    bounds = [0.0, first]
    while bounds[-1] < t_max:
        bounds.append(bounds[-1] * growth)
    bounds[-1] = t_max
    return list(zip(bounds[:-1], bounds[1:]))


def _de_hoog(values: NDArray, t: NDArray, T: float, sigma: float) -> NDArray:
    """de Hoog et al.'s accelerated continued fraction; ``values`` are ``F(σ + ikπ/T)``, k = 0…2M."""
    a = values.copy()
    a[0] = 0.5 * a[0]
    n_coef = a.shape[0]
    M = (n_coef - 1) // 2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = _qd_coefficients(a, M)
        z = np.exp(1j * np.pi * t / T).reshape((-1,) + (1,) * (a.ndim - 1))
        # three-term recurrence for the 2M-th convergent A/B
        A_prev, A = np.zeros_like(a[0]), d[0] * np.ones_like(z)
        B_prev, B = np.ones_like(z), np.ones_like(z)
        for n in range(1, 2 * M):
            A, A_prev = A + d[n] * z * A_prev, A
            B, B_prev = B + d[n] * z * B_prev, B
        # remainder estimate replaces the last partial numerator (de Hoog et al. eq. 20)
        h = 0.5 * (1.0 + (d[2 * M - 1] - d[2 * M]) * z)
        R = -h * (1.0 - np.sqrt(1.0 + d[2 * M] * z / (h * h)))
        A = A + R * A_prev
        B = B + R * B_prev
        f = np.exp(sigma * t).reshape(z.shape) / T * np.real(A / B)
        bad = ~np.isfinite(f)
        if np.any(bad):  # degenerate QD table (e.g. F ≡ 0): fall back to the plain Fourier sum
            plain = np.exp(sigma * t).reshape(z.shape) / T * np.real(np.polynomial.polynomial.polyval(z, a, tensor=False))
            f = np.where(bad, plain, f)
    return f


def _qd_coefficients(a: NDArray, M: int) -> list[NDArray]:
    """Continued-fraction coefficients ``d_0 … d_2M`` of ``Σ a_k z^k`` by the QD algorithm."""
    n = 2 * M + 1
    e = np.zeros_like(a)  # e_{r-1}^{(i)}, i = 0 … n-1
    q = a[1:] / a[:-1]  # q_1^{(i)}, i = 0 … 2M-1
    d = [a[0]]
    for r in range(1, M + 1):
        # e_r^{(i)} = q_r^{(i+1)} − q_r^{(i)} + e_{r−1}^{(i+1)}, i = 0 … 2M − 2r
        e = q[1:] - q[:-1] + e[1 : q.shape[0]]
        d.append(-q[0])
        d.append(-e[0])
        if r < M:
            # q_{r+1}^{(i)} = q_r^{(i+1)} e_r^{(i+1)} / e_r^{(i)}, i = 0 … 2M − 2r − 1
            q = q[1:-1] * e[1:] / e[:-1]
    del n
    return d
