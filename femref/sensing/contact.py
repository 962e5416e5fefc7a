"""The instant two cars touch, from a record of the impact's rise (docs/formulas.md §K2: the why and the checks).

A network reads records that start at contact; a recorder's clock knows only when the records rose above a
trigger. The rise, the contact's force through a linear chain (a recorder's filter, a smoother's blur), is fitted
with that chain's responses ``g``, ``r`` to a unit step and a unit ramp starting at lag 0 (given on a lag grid,
cubic between its points; a non-causal chain has responses before lag 0)::

    d(t) ≈ J g(t − t0) + s r(t − t0)          (J, s linear; t0 scanned at a tenth of the step, refined at 1/200)

over the flank from :data:`QUIET_SAMPLES` before the record's last crossing of ``RISE[0]`` of its peak to
:data:`AFTER_HALF` samples past its first crossing of ``RISE[1]`` (at most to the peak).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

#: The flank fitted: from ``QUIET_SAMPLES`` before the last crossing of ``RISE[0]`` of the peak to the first of ``RISE[1]``.
RISE = (0.05, 0.5)
QUIET_SAMPLES = 30
#: Samples past the ``RISE[1]`` crossing also fitted (up to the peak): a jump leaves no flank of its own.
AFTER_HALF = 5


@dataclass(frozen=True)
class ContactEstimate:
    """``time`` (s, the record's clock) of the onset, the fitted jump ``jump`` and slope ``slope`` (record
    units, per s) and the fit's RMS residual over the record's peak ``residual``."""

    time: float
    jump: float
    slope: float
    residual: float


def onset_time(time: ArrayLike, record: ArrayLike, lags: ArrayLike, step_response: ArrayLike, ramp_response: ArrayLike) -> ContactEstimate:
    """When the rise in ``record`` (on the uniform ``time``, positive) began (module docstring).

    ``step_response`` and ``ramp_response`` are the chain's responses to ``1(t > 0)`` and ``t·1(t > 0)``
    on the increasing ``lags`` (s); outside them the responses are taken constant (their end values).
    Raises ValueError when the record has no positive rise with a quiet stretch before it.
    """
    t = np.asarray(time, dtype=float)
    d = np.asarray(record, dtype=float)
    lag = np.asarray(lags, dtype=float)
    shapes = [np.asarray(step_response, dtype=float), np.asarray(ramp_response, dtype=float)]
    if t.ndim != 1 or t.shape != d.shape or t.size < 2 * QUIET_SAMPLES:
        raise ValueError(f"time and record must be 1-D of one length, at least {2 * QUIET_SAMPLES} samples")
    if lag.ndim != 1 or any(shape.shape != lag.shape for shape in shapes) or np.any(np.diff(lag) <= 0.0):
        raise ValueError("lags must increase and the responses be given on them")
    dt = float(t[1] - t[0])
    peak = int(np.argmax(d))
    d_max = float(d[peak])
    if d_max <= 0.0:
        raise ValueError("the record has no positive rise")
    below_half = np.flatnonzero(d[:peak] < RISE[1] * d_max)
    if below_half.size == 0:
        raise ValueError("the record starts above half its peak: it must start before the impact")
    high = min(peak, int(below_half[-1]) + 1 + AFTER_HALF)
    below_start = np.flatnonzero(d[:high] < RISE[0] * d_max)
    if below_start.size == 0 or below_start[-1] < QUIET_SAMPLES:
        raise ValueError(f"fewer than {QUIET_SAMPLES} quiet samples before the record rises")
    low = int(below_start[-1]) - QUIET_SAMPLES
    ts, ds = t[low : high + 1], d[low : high + 1]
    from scipy.interpolate import CubicSpline  # scipy.interpolate costs ~0.3 s to import: only a contact fit needs it

    splines = [CubicSpline(lag, shape) for shape in shapes]
    _, start = _best_start(ts, ds, lag, splines, np.arange(ts[0], ts[-1], 0.1 * dt))
    rss, start = _best_start(ts, ds, lag, splines, np.arange(start - 0.1 * dt, start + 0.1 * dt, 0.005 * dt))
    basis = _basis(ts, lag, splines, np.array([start]))[0]
    (jump, slope), *_ = np.linalg.lstsq(basis, ds, rcond=None)
    return ContactEstimate(float(start), float(jump), float(slope), float(np.sqrt(rss / ts.size)) / d_max)


def _basis(ts: NDArray[np.float64], lag: NDArray[np.float64], splines: Sequence[CubicSpline], starts: NDArray[np.float64]) -> NDArray[np.float64]:
    """(starts, samples, 2): each response (a cubic spline on its lags, constant beyond them) shifted to
    each candidate start."""
    shift = np.clip(ts[None, :] - starts[:, None], lag[0], lag[-1])
    return np.stack([spline(shift) for spline in splines], axis=-1)


def _best_start(ts: NDArray[np.float64], ds: NDArray[np.float64], lag: NDArray[np.float64], splines: Sequence[CubicSpline],
                starts: NDArray[np.float64]) -> tuple[float, float]:
    """Least residual sum of ``d ≈ J g(t − t0) + s r(t − t0)`` over the candidate ``starts``, and its start."""
    basis = _basis(ts, lag, splines, starts)
    gram = np.einsum("snp,snq->spq", basis, basis)
    gram = gram + (1e-12 * np.trace(gram, axis1=1, axis2=2) + 1e-300)[:, None, None] * np.eye(len(splines))
    rhs = np.einsum("snp,n->sp", basis, ds)
    coef = np.linalg.solve(gram, rhs[..., None])[..., 0]
    rss = float(ds @ ds) - np.einsum("sp,sp->s", coef, rhs)
    i = int(np.argmin(rss))
    return float(rss[i]), float(starts[i])


__all__ = ["ContactEstimate", "onset_time"]
