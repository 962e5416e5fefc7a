"""Numerical inverse Laplace transform by the method of de Hoog, Knight and Stokes (1982).

For ``f(t) = (1/2πi) ∫ F(s) e^{st} ds`` on ``Re s = σ``, the trapezoidal rule with step
``π/T`` gives the Fourier series (valid on ``0 ≤ t < 2T``)::

    f(t) ≈ (e^{σt}/T) Re[ F(σ)/2 + Σ_{k≥1} F(σ + ikπ/T) z^k ],     z = e^{iπt/T}

whose discretisation (aliasing) error is ``≈ e^{−2σT} f(2T + t)``; ``σ = α − ln(ε)/(2T)``
makes it ``ε`` relative to functions growing no faster than ``e^{αt}``. de Hoog et al.
sum the power series in ``z`` through its continued fraction (a Padé approximant), built
from ``2M + 1`` coefficients by the quotient-difference (QD) algorithm, with their
estimate of the fraction's remainder. This converges far faster than the series, also
for kinks and ``√t`` fronts, but a record holding more sharp features than ``≈ M``
(e.g. many undamped wave fronts) is not resolved: Gibbs-like ringing.

Numerical choices (measured on the Voigt rod against modal superposition,
tests/exact/test_transient.py):

* The QD table runs in extended precision (``np.clongdouble``, 80-bit on x86-64) and the
  fraction is evaluated backwards (from its tail): the forward three-term recurrence and
  a double-precision QD table lose up to 8 digits where the Padé table is nearly
  degenerate, e.g. at the centre of a homogeneous rod, whose wave arrivals are equally
  spaced.
* The times are split into geometric windows ``[0, t₁], (t₁, 2t₁], …`` (``t₁`` the
  smallest positive time), each with ``T`` = its last time, so behaviour near ``t = 0``
  is resolved on its own scale.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Relative size of the aliasing error, ``e^{−2σT}``.
ALIASING_TOLERANCE = 1e-10
#: Ratio of consecutive window ends.
WINDOW_GROWTH = 2.0
#: The first window ends at the smallest positive time, but not before this fraction of the last.
MIN_FIRST_WINDOW = 1e-6

Transform = Callable[[NDArray[np.complex128]], NDArray[np.complex128]]


def invert_laplace(
    transform: Transform,
    t: ArrayLike,
    *,
    terms: int | Callable[[float], int] = 32,
    alpha: float = 0.0,
) -> NDArray[np.float64]:
    """``f(t)`` from its Laplace transform: ``transform(s)`` maps ``(Ns,)`` complex ``s`` to ``(Ns, …)``.

    ``t`` (s) is ``(Nt,)`` with values ``≥ 0``; the result is ``(Nt, …)`` real. ``terms`` is
    de Hoog's ``M`` (``2M + 1`` transform values per window), or a function of the window's
    last time returning it. ``alpha`` bounds the exponential growth rate of ``f`` (1/s; 0
    for bounded or polynomially growing ``f``).
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(t < 0.0):
        raise ValueError("times t must be a 1-D array of finite values >= 0 s")
    order = terms if callable(terms) else (lambda _end, m=int(terms): m)
    out: NDArray | None = None
    for lo, hi in _windows(t):
        select = (t > lo) & (t <= hi) if lo > 0.0 else (t <= hi)
        if not np.any(select):
            continue
        M = int(order(hi))
        if M < 2:
            raise ValueError(f"the number of terms must be >= 2, got {M}")
        sigma = alpha - np.log(ALIASING_TOLERANCE) / (2.0 * hi)
        s = sigma + 1j * np.pi * np.arange(2 * M + 1) / hi
        values = np.asarray(transform(s), dtype=complex)
        f = _de_hoog(values, t[select], hi, sigma)
        if out is None:
            out = np.zeros((t.size, *f.shape[1:]))
        out[select] = f
    return out if out is not None else np.zeros(t.shape)


def _windows(t: NDArray) -> list[tuple[float, float]]:
    """Window bounds ``[(0, t₁), (t₁, 2t₁), …, (…, t_max)]`` covering ``t``."""
    t_max = float(np.max(t)) if t.size else 0.0
    if t_max == 0.0:
        return [(0.0, 1.0)]  # only t = 0: any window gives f(0)
    first = max(float(np.min(t[t > 0.0])), t_max * MIN_FIRST_WINDOW)
    bounds = [0.0, first]
    while bounds[-1] < t_max:
        bounds.append(bounds[-1] * WINDOW_GROWTH)
    bounds[-1] = t_max
    return list(zip(bounds[:-1], bounds[1:]))


def _de_hoog(values: NDArray, t: NDArray, T: float, sigma: float) -> NDArray:
    """de Hoog et al.'s accelerated continued fraction; ``values[k] = F(σ + ikπ/T)``, k = 0 … 2M."""
    a = values.astype(np.clongdouble)
    a[0] = 0.5 * a[0]
    M = (a.shape[0] - 1) // 2
    z = np.exp(1j * np.pi * t / T).reshape((-1,) + (1,) * (a.ndim - 1))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        d = [c.astype(complex) for c in _qd_coefficients(a, M)]
        # remainder estimate (de Hoog et al., eq. 20) in place of the last partial numerator
        h = 0.5 * (1.0 + (d[2 * M - 1] - d[2 * M]) * z)
        R = -h * (1.0 - np.sqrt(1.0 + d[2 * M] * z / (h * h)))
        # backward evaluation of d0/(1 + d1 z/(1 + … d_{2M−1} z/(1 + R)))
        v = 1.0 + R
        for n in range(2 * M - 1, 0, -1):
            v = 1.0 + d[n] * z / v
        series = d[0] / v
        bad = ~np.isfinite(series)
        if np.any(bad):  # degenerate QD table (e.g. F ≡ 0): the plain Fourier sum
            plain = np.polynomial.polynomial.polyval(z, a.astype(complex), tensor=False)
            series = np.where(bad, plain, series)
    return np.exp(sigma * t).reshape(z.shape) / T * np.real(series)


def _qd_coefficients(a: NDArray, M: int) -> list[NDArray]:
    """Continued-fraction coefficients ``d_0 … d_2M`` of ``Σ a_k z^k`` by the QD algorithm."""
    e = np.zeros_like(a)  # e_0^{(i)} = 0
    q = a[1:] / a[:-1]  # q_1^{(i)}, i = 0 … 2M−1
    d = [a[0]]
    for r in range(1, M + 1):
        # e_r^{(i)} = q_r^{(i+1)} − q_r^{(i)} + e_{r−1}^{(i+1)},   i = 0 … 2M − 2r
        e = q[1:] - q[:-1] + e[1 : q.shape[0]]
        d.append(-q[0])
        d.append(-e[0])
        if r < M:
            # q_{r+1}^{(i)} = q_r^{(i+1)} e_r^{(i+1)} / e_r^{(i)},   i = 0 … 2M − 2r − 1
            q = q[1:-1] * e[1:] / e[:-1]
    return d
