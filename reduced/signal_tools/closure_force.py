"""Closure-force detection: where a draft gear goes solid, found as the force at which the coupler's
compliance (stroke per force) drops, from the loading part of a force–stroke record (docs/formulas.md §A5).

:func:`detect_closure_force` returns a :class:`ClosureForceEstimate`. It assumes no gear law: the
open gear is any smooth curve, the solid gear a straight line of smaller compliance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks

from .smoothing import GaussianKernel

#: Contact is the last sample before the peak at or below ``CONTACT_LEVEL·F_m``; the record must
#: fall below ``END_LEVEL·F_m`` after the peak (so that the peak is one).
CONTACT_LEVEL, END_LEVEL = 0.02, 0.9
#: The regression reads the loading part from the first sample above ``FIT_LEVEL·F_m`` to the peak:
#: below it the estimators' onset and the gear's initial play dominate the stroke (chosen on the
#: tests' records: 0.05 put one of 18 records 6 % off through the measurement chain, 0.1–0.25 kept
#: all within 5 %, 0.15 did best with a closing speed 10 % off).
FIT_LEVEL = 0.15
#: Change points are searched between these fractions of the peak force, on a grid of
#: ``SEARCH_POINTS`` (the best one refined between its neighbours).
SEARCH_LEVELS, SEARCH_POINTS = (0.25, 0.98), 293
#: Degree of the open gear's curve ``δ = p(F)``.
OPEN_DEGREE = 3
#: Samples needed on the closed branch (its line and the change point).
MIN_CLOSED_SAMPLES = 4
#: A closure stiffens the coupler: the open compliance at the change point over the closed one.
#: At least ``CLOSED_STIFFENING`` (with a significant change point) the gear closed; below
#: ``NO_STIFFENING`` it did not; between, the change is ambiguous.
CLOSED_STIFFENING, NO_STIFFENING = 3.0, 1.5
#: Significance of the change point (F test of the two-branch model against the open curve alone).
CLOSED_P_VALUE, NOT_CLOSED_P_VALUE = 1e-3, 0.05
#: The closure force is reported as closed only when its 95 % profile interval is within this
#: relative half-width (a wider interval is ``ambiguous``).
INTERVAL_HALF_WIDTH = 0.10
TWO_BRANCH_PARAMETERS = OPEN_DEGREE + 1 + 2  # p(F), the closed compliance, the change point


@dataclass(frozen=True)
class ClosureForceEstimate:
    """Result of :func:`detect_closure_force` (s, N, m).

    ``status`` is ``closed``, ``not closed`` or ``ambiguous`` (``reason`` says why);
    ``closure_time``, ``closure_force`` and ``closure_stroke`` are None unless a change point
    was found (``ambiguous`` keeps the best one for inspection). ``force_interval`` is the 95 %
    profile interval of the closure force; ``stiffening`` the open over the closed compliance
    at the change point; ``p_value`` the F test of the change point; ``residual`` the fit's RMS
    stroke residual over the stroke travel in the fit; ``window`` the fitted time span (from the
    first sample above 15 % of the peak to the peak).
    """

    status: str
    reason: str
    closure_time: float | None
    closure_force: float | None
    closure_stroke: float | None
    force_interval: tuple[float, float] | None
    peak_time: float
    peak_force: float
    stiffening: float
    p_value: float
    residual: float
    window: tuple[float, float]


@dataclass(frozen=True)
class _Fit:
    """One least-squares fit of the two-branch model at change point ``c`` (of the peak force)."""

    change: float
    rss: float
    coefficients: NDArray[np.float64]
    residuals: NDArray[np.float64]

    @property
    def open_compliance(self) -> float:
        """``p'(c)`` in scaled units."""
        a = self.coefficients[:OPEN_DEGREE + 1]
        return float(sum(k * a[k] * self.change ** (k - 1) for k in range(1, OPEN_DEGREE + 1)))

    @property
    def closed_compliance(self) -> float:
        return float(self.coefficients[OPEN_DEGREE + 1])


def detect_closure_force(time: ArrayLike, force: ArrayLike, stroke: ArrayLike) -> ClosureForceEstimate:
    """Closure force of a draft gear from its coupler force and stroke (docs/formulas.md §A5).

    Over the loading part — from the first sample above 15 % of the peak ``F_m`` to the peak —
    regress the stroke on the force (``F`` in units of ``F_m``, δ in units of its travel there)::

        δ = p(min(F, F_c)) + D (F − F_c)₊,    p a cubic

    continuous at ``F_c``: any smooth open-gear curve below the change point, a straight line
    of compliance ``D`` (the solid gear in series with the coupler and car bodies) above it. No
    gear law is assumed: the open curve may stiffen, be rate-dependent or hysteretic (only its
    loading part is read). For each ``F_c`` on a grid from 25 to 98 % of the peak (at least 4
    samples above it) the coefficients are linear; among the ``F_c`` where the compliance drops
    (``p'(F_c) > D``) the least residual sum wins and is refined between its grid neighbours
    (bounded Brent). The closure force is ``F_c``, the closure time the force's first crossing
    of it, the closure stroke ``p(F_c)``.

    Evidence, each from the record: the stiffening ``p'(F_c)/D`` (open over closed compliance:
    about one where nothing closes, the solid gear's stiffness over the open gear's where it
    does; ∞ for a closed line with ``D ≤ 0``); the F test of the two-branch model against the
    cubic alone (two more parameters, ``D`` and ``F_c``); the 95 % profile interval of ``F_c``
    (the grid points where the compliance drops whose residual sum is within ``χ²₁(0.95) σ̂²`` of
    the best). Residuals of an estimated force are correlated, so ``σ̂²`` (the best fit's
    residual variance) is inflated by ``(1 + ρ₁)/(1 − ρ₁)``, ``ρ₁`` the residuals' lag-one
    autocorrelation, and the F test has as many times fewer effective samples. The interval
    carries the noise, not the open curve's misfit. Status:

    - ``not closed``: the stiffening below 1.5, or p ≥ 0.05 with a stiffening below 3;
    - ``closed``: p < 1e-3, the stiffening at least 3 and the interval within ±10 %;
    - ``ambiguous`` otherwise (the estimate and interval are kept for inspection).

    ``time`` uniform (s); ``force`` compression positive (N); ``stroke`` the coupler's closure
    (m, compression positive, any offset) on the same samples. The record must start before
    the force rises and run until it falls below 90 % of the peak; the solid stretch must span
    about 5 samples. Checked on three gear families written in the tests, exact, noisy and
    through the measurement chain (``tests/reduced/test_closure_stiffness.py``,
    ``tests/measured/test_closure_families.py``).
    """
    t = _checks.time_grid("time", time, uniform=True, min_length=16)
    f = _checks.record("force", force, min_length=16)
    d = _checks.record("stroke", stroke, min_length=16)
    _checks.same_length(time=t, force=f, stroke=d)
    dt = float(t[1] - t[0])
    smooth = np.asarray(GaussianKernel(2.0 * dt).smooth(f, dt), dtype=float)
    i_m = int(np.argmax(smooth))
    f_m = float(smooth[i_m])
    if f_m <= 0.0:
        raise ValueError("the force record has no compressive peak")
    below = np.flatnonzero(smooth[: i_m + 1] <= CONTACT_LEVEL * f_m)
    if below.size == 0 or min(smooth[0], f[0]) > CONTACT_LEVEL * f_m:
        raise ValueError("the force record starts loaded: it must start before the force rises")
    if not np.any(smooth[i_m:] < END_LEVEL * f_m):
        raise ValueError("the force record ends near its peak: it must run until the force falls")
    start = int(below[-1]) + int(np.argmax(smooth[below[-1] : i_m + 1] > FIT_LEVEL * f_m))
    x = f[start : i_m + 1] / f_m
    n = x.size
    if n < TWO_BRANCH_PARAMETERS + 8:
        raise ValueError(f"only {n} samples from {FIT_LEVEL:.0%} of the peak to the peak: sample faster")
    travel = float(np.ptp(d[start : i_m + 1]))
    if travel <= 0.0:
        raise ValueError("the stroke does not move while the force rises")
    y = (d[start : i_m + 1] - d[start]) / travel
    peak_time, window = float(t[i_m]), (float(t[start]), float(t[i_m]))

    null = _two_branch_fit(x, y, float(np.max(x)) + 1.0)  # the open curve alone
    ordered = np.sort(x)
    grid = np.linspace(*SEARCH_LEVELS, SEARCH_POINTS)
    grid = grid[(grid < float(ordered[-MIN_CLOSED_SAMPLES])) & (grid > float(ordered[OPEN_DEGREE + 2]))]
    if grid.size < 3:
        return _not_closed("the force rises too fast to place a change point between 25 and 98 % of the peak",
                           peak_time, f_m, null, window)
    search = _search(x, y, grid)
    if search is None:
        return _not_closed("the coupler never stiffens: no change point where the compliance drops", peak_time, f_m, null, window)
    rss, stiffer, best = search.rss, search.stiffer, search.best
    ratio = _stiffening(best)
    dof = n - TWO_BRANCH_PARAMETERS
    inflation = _correlation_inflation(best.residuals)
    sigma2 = inflation * best.rss / dof
    effective_dof = max(dof / inflation, 1.0)
    statistic = max(null.rss - best.rss, 0.0) / 2.0 / max(sigma2, np.finfo(float).tiny)
    from scipy.stats import chi2, f as f_distribution  # scipy.stats costs ~0.5 s to import: only where a closure is sought

    p_value = float(f_distribution.sf(statistic, 2, effective_dof))
    near = stiffer[rss[stiffer] <= best.rss + chi2.ppf(0.95, 1) * sigma2]
    low = min(float(grid[near].min()), best.change) if near.size else best.change
    high = max(float(grid[near].max()), best.change) if near.size else best.change
    f_c = best.change * f_m
    rising = np.flatnonzero(f[start : i_m + 1] >= f_c)
    j = start + int(rising[0]) if rising.size else i_m
    closure_time = float(np.interp(f_c, [f[j - 1], f[j]], [t[j - 1], t[j]])) if j > start and f[j] > f[j - 1] else float(t[j])
    closure_stroke = float(d[start] + travel * _open_curve(best.coefficients, best.change))
    args = (closure_time, f_c, closure_stroke, (low * f_m, high * f_m), peak_time, f_m, ratio, p_value,
            math.sqrt(best.rss / n), window)
    if ratio < NO_STIFFENING or (p_value >= NOT_CLOSED_P_VALUE and ratio < CLOSED_STIFFENING):
        reason = (f"the compliance barely drops (open over closed {ratio:.2f} < {NO_STIFFENING})" if ratio < NO_STIFFENING
                  else f"no significant change point (p = {p_value:.2g}) and the compliance drops only {ratio:.2f}×")
        return ClosureForceEstimate("not closed", reason, None, None, None, None, peak_time, f_m, ratio, p_value, *args[-2:])
    if p_value >= CLOSED_P_VALUE:
        return ClosureForceEstimate("ambiguous", f"weak change point (p = {p_value:.2g})", *args)
    if ratio < CLOSED_STIFFENING:
        return ClosureForceEstimate("ambiguous", f"the compliance drops only {ratio:.2f}× at the change point", *args)
    half_width = max(high - best.change, best.change - low) / best.change
    if half_width > INTERVAL_HALF_WIDTH:
        return ClosureForceEstimate("ambiguous", f"the closure force is uncertain by ±{half_width:.0%} (95 % profile interval)", *args)
    return ClosureForceEstimate("closed", f"change point significant (p = {p_value:.2g}), compliance ÷{ratio:.1f}", *args)


def _open_curve(coefficients: NDArray[np.float64], x: float) -> float:
    return float(sum(coefficients[k] * x**k for k in range(OPEN_DEGREE + 1)))


def _two_branch_fit(x: NDArray[np.float64], y: NDArray[np.float64], change: float) -> _Fit:
    """Least squares of ``y = p(min(x, c)) + D (x − c)₊``: columns 1, m, m², m³ (``m = min(x, c)``) and (x − c)₊."""
    m = np.minimum(x, change)
    basis = np.column_stack([m**k for k in range(OPEN_DEGREE + 1)] + [np.maximum(x - change, 0.0)])
    coefficients, *_ = np.linalg.lstsq(basis, y, rcond=None)
    residuals = y - basis @ coefficients
    return _Fit(change, float(residuals @ residuals), coefficients, residuals)


@dataclass(frozen=True)
class _Search:
    """The two-branch fits over the grid of change points: residual sums, the grid points where the coupler
    stiffens and the best of them refined."""

    rss: NDArray[np.float64]
    stiffer: NDArray[np.intp]
    best: _Fit


def _search(x: NDArray[np.float64], y: NDArray[np.float64], grid: NDArray[np.float64]) -> _Search | None:
    """The least residual sum over the change points of ``grid`` where the compliance drops, refined
    between its grid neighbours (bounded Brent); None if the compliance drops nowhere."""
    fits = [_two_branch_fit(x, y, float(c)) for c in grid]
    rss = np.array([g.rss for g in fits])
    stiffer = np.flatnonzero(np.array([_stiffening(g) for g in fits]) > 1.0)
    if stiffer.size == 0:
        return None
    k = int(stiffer[np.argmin(rss[stiffer])])
    bounds = (float(grid[max(k - 1, 0)]), float(grid[min(k + 1, grid.size - 1)]))
    from scipy.optimize import minimize_scalar

    refined = minimize_scalar(lambda c: _two_branch_fit(x, y, c).rss, bounds=bounds, method="bounded", options={"xatol": 1e-5})
    best = _two_branch_fit(x, y, float(refined.x)) if refined.fun < rss[k] else fits[k]
    return _Search(rss, stiffer, best)


def _stiffening(fit: _Fit) -> float:
    """Open compliance ``p'(c)`` over closed compliance ``D``: ∞ for a closed line that does not
    yield, 0 where the open curve does not rise."""
    open_compliance, closed = fit.open_compliance, fit.closed_compliance
    if open_compliance <= 0.0:
        return 0.0
    return open_compliance / closed if closed > 0.0 else math.inf


def _correlation_inflation(residuals: NDArray[np.float64]) -> float:
    """``(1 + ρ₁)/(1 − ρ₁)`` for the residuals' lag-one autocorrelation ``ρ₁`` clipped to [0, 0.95]:
    the variance of a mean of AR(1) residuals over that of independent ones."""
    r = residuals - residuals.mean()
    denominator = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / denominator if denominator > 0.0 else 0.0
    rho = min(max(rho, 0.0), 0.95)
    return (1.0 + rho) / (1.0 - rho)


def _not_closed(reason: str, peak_time: float, peak_force: float, null: _Fit,
                window: tuple[float, float]) -> ClosureForceEstimate:
    return ClosureForceEstimate("not closed", reason, None, None, None, None, peak_time, peak_force, 1.0, 1.0,
                                math.sqrt(null.rss / null.residuals.size), window)


__all__ = ["ClosureForceEstimate", "detect_closure_force"]
