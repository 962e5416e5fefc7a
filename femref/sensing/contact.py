"""The instant two cars touch, from their filtered acceleration records.

A network estimator reads records that start at contact, as the fem records it was trained
on do; a recorder's clock knows only when the records rose above a trigger, and its
anti-alias filter delays every rise (a 4th-order Butterworth at ``f_c`` by about
``0.42/f_c``: 4 ms at 100 Hz). :func:`contact_time` finds the contact from the rising
flank, where the record stands well above its noise, by fitting the filtered response of
the two-mass pulse's start::

    d(t) = (H ∗ u)(t),   u(t) = [A sin ω(t − t0) + B (1 − cos ω(t − t0))]·1(t > t0)

``d`` the relative acceleration of the two cars (compression positive), ``H`` the
recorder's filter (causal Butterworth of ``order`` at ``corner`` Hz, simulated at 50× the
record's rate; none when the recorder declares none). ``A``, ``B`` are linear; ``ω`` and
``t0`` are scanned on grids, then ``t0`` is refined. The fit runs over the flank from 30
samples before the record's last crossing of 5 % of its peak to its first crossing of 50 %.

A sensor away from the coupler feels the contact a wave travel later (distance over the
bar wave speed): the caller removes that from ``t0`` (:mod:`femref.run.measured`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import butter, sosfilt

#: The filter is simulated at this multiple of the record's sampling rate (an analogue filter, sampled).
OVERSAMPLING = 50
#: The flank fitted: from the last crossing of ``RISE[0]`` of the peak before the ``RISE[1]`` crossing.
RISE = (0.05, 0.5)
#: Samples before the ``RISE[0]`` crossing that also enter the fit (quiet, they pin the start).
QUIET_SAMPLES = 30
#: Pulse frequencies ω/2π scanned (Hz): freight-car couplings last 10–250 ms.
FREQUENCIES = np.geomspace(2.0, 50.0, 40)


@dataclass(frozen=True)
class ContactEstimate:
    """``time`` (s, the records' clock) of the contact seen at the sensors, the fitted pulse frequency
    ``frequency`` (Hz) and the fit's RMS residual over the record's peak ``residual``."""

    time: float
    frequency: float
    residual: float


def contact_time(time: ArrayLike, relative: ArrayLike, corner: float | None, order: int = 4) -> ContactEstimate:
    """When the pulse in ``relative`` (m/s², compression positive, on the uniform ``time``) began (module docstring).

    ``corner`` (Hz) and ``order`` are the recorder's anti-alias Butterworth; None: an unfiltered record.
    Raises ValueError when the record has no positive pulse with a quiet stretch before it.
    """
    t = np.asarray(time, dtype=float)
    d = np.asarray(relative, dtype=float)
    if t.ndim != 1 or t.shape != d.shape or t.size < 2 * QUIET_SAMPLES:
        raise ValueError(f"time and relative must be 1-D of one length, at least {2 * QUIET_SAMPLES} samples")
    dt = float(t[1] - t[0])
    peak = int(np.argmax(d))
    d_max = float(d[peak])
    if d_max <= 0.0:
        raise ValueError("the relative acceleration has no compressive pulse")
    below_half = np.flatnonzero(d[:peak] < RISE[1] * d_max)
    if below_half.size == 0:
        raise ValueError("the record starts above half its peak: it must start before the impact")
    high = int(below_half[-1]) + 1
    below_start = np.flatnonzero(d[:high] < RISE[0] * d_max)
    if below_start.size == 0 or below_start[-1] < QUIET_SAMPLES:
        raise ValueError(f"fewer than {QUIET_SAMPLES} quiet samples before the pulse rises")
    low = int(below_start[-1]) - QUIET_SAMPLES
    ts, ds = t[low : high + 1], d[low : high + 1]
    fine = OVERSAMPLING / dt
    tau = np.arange(0.0, ts[-1] - ts[0] + dt, 1.0 / fine)
    sos = butter(order, corner, fs=fine, output="sos") if corner is not None else None
    starts = np.arange(ts[0], ts[-1], 0.1 * dt)
    best = (np.inf, 0.0, 0.0)
    for frequency in FREQUENCIES:
        responses = _responses(tau, 2.0 * np.pi * frequency, sos)
        rss, start = _best_start(ts, ds, tau, responses, starts)
        if rss < best[0]:
            best = (rss, start, frequency)
    _, start, frequency = best
    responses = _responses(tau, 2.0 * np.pi * frequency, sos)
    rss, start = _best_start(ts, ds, tau, responses, np.arange(start - 0.1 * dt, start + 0.1 * dt, 0.005 * dt))
    return ContactEstimate(float(start), float(frequency), float(np.sqrt(rss / ts.size)) / d_max)


def _responses(tau: NDArray[np.float64], omega: float, sos: NDArray[np.float64] | None) -> list[NDArray[np.float64]]:
    """The recorder's response to ``sin ωτ`` and ``1 − cos ωτ`` starting at τ = 0."""
    shapes = [np.sin(omega * tau), 1.0 - np.cos(omega * tau)]
    return shapes if sos is None else [sosfilt(sos, shape) for shape in shapes]


def _best_start(ts: NDArray[np.float64], ds: NDArray[np.float64], tau: NDArray[np.float64], responses: list[NDArray[np.float64]],
                starts: NDArray[np.float64]) -> tuple[float, float]:
    """Least residual sum of ``d ≈ A r1(t − t0) + B r2(t − t0)`` over the candidate ``starts``, and its start."""
    lag = ts[None, :] - starts[:, None]
    basis = np.stack([np.where(lag > 0.0, np.interp(lag, tau, r), 0.0) for r in responses], axis=-1)
    gram = np.einsum("snp,snq->spq", basis, basis)
    gram = gram + (1e-12 * np.trace(gram, axis1=1, axis2=2) + 1e-30)[:, None, None] * np.eye(2)
    rhs = np.einsum("snp,n->sp", basis, ds)
    coef = np.linalg.solve(gram, rhs[..., None])[..., 0]
    rss = float(ds @ ds) - np.einsum("sp,sp->s", coef, rhs)
    i = int(np.argmin(rss))
    return float(rss[i]), float(starts[i])


__all__ = ["ContactEstimate", "contact_time"]
