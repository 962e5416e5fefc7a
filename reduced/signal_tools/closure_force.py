"""Closure-force detection: draft-gear closure force by the sine fit through the force
peak (docs/formulas.md §A5).

:func:`detect_closure_force` returns a :class:`ClosureForceEstimate`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq, least_squares

from reduced import _checks

from .smoothing import GaussianKernel, Smoother


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
    """Closure force of a draft gear from a coupler-force record (docs/formulas.md §A5).

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
    (mean 2.5 %) with 1 % noise over ten seeds (``tests/reduced/test_signal_tools.py``).
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


__all__ = ["ClosureForceEstimate", "detect_closure_force"]
