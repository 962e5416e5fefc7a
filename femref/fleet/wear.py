"""The closure-force trend of each draft gear, and the date it is forecast to cross its wear limit.

Per gear, the closure forces ``P_i`` (N) of the impacts where it closed (event store rows, an impact type,
``closure_status == "closed"``), against their times ``t_i`` (days), follow the Theil–Sen line

    m = median_{i<j} (P_j − P_i)/(t_j − t_i)   (N/day),     P(t) = c + m (t − t_c),    c = median_i (P_i − m (t_i − t_c))

pivoted at ``t_c = median(t_i)``. The slope's confidence interval ``[m_lo, m_hi]`` is Sen's: the order statistics of
the pairwise slopes at ranks ``(N_p ∓ z √Var S)/2``, ``Var S = n(n−1)(2n+5)/18`` (Kendall's S,
:func:`scipy.stats.theilslopes`); the level's, ``[c_lo, c_hi]``, the order statistics of the residuals that cover
their median with the same confidence (a sign test: ``P(Bin(n, ½) ≤ k − 1) ≤ α/2``). The band at ``t`` is

    lower(t) = c_lo + min(m_lo Δ, m_hi Δ),    upper(t) = c_hi + max(m_lo Δ, m_hi Δ),    Δ = t − t_c

and the forecast crossing of the wear limit ``P_w = (1 − wear_tolerance) × rated_closure_force`` (the store's
``wear_limit``) is where the line falls through ``P_w``; its interval, where ``lower`` and ``upper`` do (the lower
band first). Noise-free points on a line give ``m_lo = m = m_hi`` and ``c_lo = c = c_hi``: the crossing exact.

Why Theil–Sen and not weighted least squares: a gear's closure force scatters with temperature, speed and which
estimator read it, and a closure found on the wrong knee of a force–stroke curve is an outlier tens of % off. The
median of pairwise slopes ignores up to 29 % of such points (its breakdown point) and loses only ~9 % efficiency
against least squares on Gaussian scatter; its interval is distribution-free (it needs only exchangeable errors), where
WLS would need weights the closure intervals do not give (they hold the estimator's noise, not the gear's day-to-day
scatter). Checked in tests/fleet/test_wear.py: the slope's 95 % interval covers the true slope of a linear decline
with Gaussian scatter in ≥ 90 % of seeds, a noise-free line's crossing is exact, a flat gear is rarely flagged.

Status of a gear (:func:`gear_trends`), in this order:

* ``worn``: the median of its last :data:`RECENT_EVENTS` closure forces is below the wear limit;
* ``no wear limit``: no rated closure force, nothing to compare;
* ``insufficient data``: fewer than :data:`MIN_EVENTS` closures or a span under :data:`MIN_SPAN_DAYS` days;
* ``wearing``: the slope is significantly negative (``m_hi < 0``), and the upper band crosses no later than ``now +
  horizon`` (the gear will have crossed by then at the interval's confidence) or the line crosses no later than ``now +
  min(horizon, span)``: a line is not extrapolated farther than the span of the closures it was fitted on. The line's
  crossing within the horizon alone flagged a flat gear whose ten closures over a week happened to fall (extrapolated four
  times their span); with this rule a gear falling through its limit at day 28 of a 20-car, 30-day fleet was flagged on
  days 9–18 in 20 fleets and no flat gear on any of 7980 gear-days (tests/fleet/test_wear.py holds a sample of it);
* ``ok`` otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.stats import binom, theilslopes

CONFIDENCE = 0.95
"""Of the slope's and level's intervals, and so of the crossing's."""
MIN_EVENTS = 6
"""The fewest closures a trend is judged on: with 5 or fewer, Sen's 95 % interval is the whole range of the pairwise
slopes (its ranks ``(N_p ± 1.96 √Var S)/2`` reach the first and last), so the data could not tell a decline from scatter (tests/fleet/test_wear.py)."""
MIN_SPAN_DAYS = 7.0
"""The shortest span of closures (days) a trend is judged on: a week holds a yard's weekly traffic cycle and the
day–night swing of a friction gear's temperature, which would otherwise read as a slope."""
RECENT_EVENTS = 3
"""A gear is ``worn`` when the median of its last this many closures is below the limit: one low closure is that
event's ``worn`` (the store's ``wear``), a gear's state needs it to persist."""
SECONDS_PER_DAY = 86400.0
FORECAST_DAYS = 36525.0
"""A crossing farther than a century from the pivot is no forecast (NaT): a nearly flat trend."""
IMPACT_TYPES = ("free_to_roll", "coupled")
"""The event types whose closure forces enter a trend (``not_an_impact`` and ``unknown`` rows never close a gear)."""


@dataclass(frozen=True)
class GearTrend:
    """The closure-force trend of gear ``gear`` (module docstring): its ``closures`` (``time``, ``closure_force`` N,
    oldest first), the Theil–Sen ``slope`` with its interval (N/day), the ``level`` at ``pivot`` with its interval (N),
    the ``wear_limit`` (N, NaN none), the forecast ``crossing`` with ``crossing_early``/``crossing_late`` (NaT: never on
    this evidence), the ``status`` and its ``basis`` in words. Slope and level are NaN with fewer than two times."""

    gear: str
    status: str
    basis: str
    closures: pd.DataFrame
    wear_limit: float
    recent_closure: float
    slope: float
    slope_lower: float
    slope_upper: float
    level: float
    level_lower: float
    level_upper: float
    pivot: pd.Timestamp
    crossing: pd.Timestamp
    crossing_early: pd.Timestamp
    crossing_late: pd.Timestamp

    @property
    def events(self) -> int:
        return len(self.closures)

    @property
    def span_days(self) -> float:
        times = self.closures["time"]
        return (times.iloc[-1] - times.iloc[0]).total_seconds() / SECONDS_PER_DAY if len(times) else 0.0

    def at(self, times: pd.Series | pd.DatetimeIndex) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The trend line and its band (N) at ``times``."""
        delta = np.asarray((pd.DatetimeIndex(times) - self.pivot).total_seconds(), dtype=float) / SECONDS_PER_DAY
        line = self.level + self.slope * delta
        lower = self.level_lower + np.minimum(self.slope_lower * delta, self.slope_upper * delta)
        upper = self.level_upper + np.maximum(self.slope_lower * delta, self.slope_upper * delta)
        return line, lower, upper


def closures(events: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``events`` whose gear closed in an impact, with a finite closure force."""
    rows = events[events["event_type"].isin(IMPACT_TYPES) & (events["closure_status"] == "closed") & np.isfinite(events["closure_force"])]
    return rows.sort_values(["time", "event_key"], kind="stable")


def gear_trends(events: pd.DataFrame, now: pd.Timestamp | None = None, horizon_days: float = 30.0,
                confidence: float = CONFIDENCE) -> dict[str, GearTrend]:
    """Every gear of ``events`` (DataFrame) with its trend as of ``now`` (UTC; default the latest event):
    only events up to ``now`` count, ``wearing`` looks ``horizon_days`` ahead of it (module docstring)."""
    if horizon_days <= 0.0 or not math.isfinite(horizon_days):
        raise ValueError(f"horizon_days {horizon_days}: must be a positive number of days")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence {confidence}: must lie strictly between 0 and 1")
    now = as_utc(now) if now is not None else (events["time"].max() if len(events) else pd.Timestamp.now(tz="UTC"))
    known = events[events["time"] <= now]
    closed = closures(known)
    limits = known.sort_values("time", kind="stable").groupby("gear")["wear_limit"].agg(lambda s: s.dropna().iloc[-1] if s.notna().any() else math.nan)
    gears = sorted(g for g in known["gear"].unique() if g)
    return {gear: gear_trend(gear, closed[closed["gear"] == gear][["time", "closure_force", "event_key"]].reset_index(drop=True),
                             float(limits.get(gear, math.nan)), now, horizon_days, confidence) for gear in gears}


def as_utc(time: pd.Timestamp | str) -> pd.Timestamp:
    """A time as a UTC timestamp (a naive one is taken as UTC)."""
    stamp = pd.Timestamp(time)
    return stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")


def gear_trend(gear: str, closed: pd.DataFrame, wear_limit: float, now: pd.Timestamp, horizon_days: float,
               confidence: float = CONFIDENCE) -> GearTrend:
    """The trend of one gear from its ``closed`` rows (``time``, ``closure_force``; oldest first) as of ``now``."""
    forces = closed["closure_force"].to_numpy(dtype=float)
    n = forces.size
    recent = float(np.median(forces[-RECENT_EVENTS:])) if n else math.nan
    times = closed["time"]
    fit = _fit(times, forces, confidence)
    trend = GearTrend(gear, "", "", closed, wear_limit, recent, *fit, *_crossings(wear_limit, *fit))
    status, basis = _status(trend, now, horizon_days, confidence)
    return replace(trend, status=status, basis=basis)


_NO_FIT = (math.nan,) * 6


def _fit(times: pd.Series, forces: NDArray[np.float64], confidence: float) -> tuple:
    """``(m, m_lo, m_hi, c, c_lo, c_hi, t_c)`` (module docstring); NaN numbers (pivot NaT) without two distinct times."""
    if len(times) == 0:
        return (*_NO_FIT, pd.NaT)
    start = times.iloc[0]
    days = np.asarray((times - start).dt.total_seconds(), dtype=float) / SECONDS_PER_DAY
    pivot_days = float(np.median(days))
    pivot = start + pd.Timedelta(days=pivot_days)
    if np.ptp(days) == 0.0:
        return (*_NO_FIT, pivot)
    slope, _, slope_lower, slope_upper = theilslopes(forces, days, alpha=confidence)
    residuals = np.sort(forces - slope * (days - pivot_days))
    level = float(np.median(residuals))
    k = _median_rank(residuals.size, 1.0 - confidence)
    return float(slope), float(slope_lower), float(slope_upper), level, float(residuals[k - 1]), float(residuals[-k]), pivot


def _median_rank(n: int, alpha: float) -> int:
    """The largest ``k ≥ 1`` with ``P(Bin(n, ½) ≤ k − 1) ≤ α/2``: ``[x_(k), x_(n−k+1)]`` covers the median with at least
    ``1 − α`` (``k = 1``, the whole range, when ``n`` is too small for that)."""
    below = binom.cdf(np.arange(n), n, 0.5) <= alpha / 2.0
    return max(1, int(np.count_nonzero(below)))


def _crossings(limit: float, slope: float, slope_lower: float, slope_upper: float, level: float, level_lower: float, level_upper: float,
               pivot: pd.Timestamp) -> tuple[pd.Timestamp, pd.Timestamp, pd.Timestamp]:
    """Where the line, the lower band and the upper band fall through ``limit`` (N)."""
    if not math.isfinite(limit) or not math.isfinite(slope):
        return pd.NaT, pd.NaT, pd.NaT
    return (_falls_through(limit, level, slope, slope, pivot), _falls_through(limit, level_lower, slope_upper, slope_lower, pivot),
            _falls_through(limit, level_upper, slope_lower, slope_upper, pivot))


def _falls_through(limit: float, level: float, before: float, after: float, pivot: pd.Timestamp) -> pd.Timestamp:
    """Where ``level + before·Δ`` (Δ ≤ 0) or ``level + after·Δ`` (Δ ≥ 0) falls through ``limit``: NaT when it never does
    ahead of the pivot (not falling) or only beyond :data:`FORECAST_DAYS`; the pivot when it lies below the limit there and
    has not risen to it before."""
    if level >= limit:
        days = (limit - level) / after if after < 0.0 else math.inf
    else:
        days = (limit - level) / before if before < 0.0 else 0.0
    return pivot + pd.Timedelta(days=days) if abs(days) <= FORECAST_DAYS else pd.NaT


def _status(trend: GearTrend, now: pd.Timestamp, horizon_days: float, confidence: float) -> tuple[str, str]:
    limit = trend.wear_limit
    kN = 1e-3
    if not math.isfinite(limit):
        return "no wear limit", "no rated closure force: no wear limit to compare the closures with"
    if trend.events and trend.recent_closure < limit:
        return "worn", (f"the median of the last {min(RECENT_EVENTS, trend.events)} closures, {trend.recent_closure * kN:.4g} kN, is below "
                        f"the wear limit {limit * kN:.4g} kN")
    if trend.events < MIN_EVENTS or trend.span_days < MIN_SPAN_DAYS:
        return "insufficient data", (f"{trend.events} closures over {trend.span_days:.3g} days: a trend needs at least {MIN_EVENTS} "
                                     f"over {MIN_SPAN_DAYS:g} days")
    rate = (f"slope {trend.slope * kN:.3g} kN/day, {confidence:.0%} interval [{trend.slope_lower * kN:.3g}, {trend.slope_upper * kN:.3g}] "
            f"kN/day, from {trend.events} closures over {trend.span_days:.3g} days")
    if pd.isna(trend.crossing):
        return "ok", f"{rate}: not falling toward the wear limit {limit * kN:.4g} kN"
    ahead = (trend.crossing - now).total_seconds() / SECONDS_PER_DAY
    latest = (trend.crossing_late - now).total_seconds() / SECONDS_PER_DAY if not pd.isna(trend.crossing_late) else math.inf
    reach = min(horizon_days, trend.span_days)
    when = (f"forecast to cross the wear limit {limit * kN:.4g} kN on {trend.crossing:%Y-%m-%d} ({ahead:+.1f} days from now), at the latest "
            + (f"on {trend.crossing_late:%Y-%m-%d} ({latest:+.1f} days)" if math.isfinite(latest) else "never on this evidence"))
    if trend.slope_upper < 0.0 and (latest <= horizon_days or ahead <= reach):
        within = "the latest crossing" if latest <= horizon_days else f"the forecast within {reach:.3g} days (the horizon or the closures' span)"
        return "wearing", f"{rate}; {when}: {within}"
    why = ("the slope is not significantly negative" if trend.slope_upper >= 0.0
           else f"neither the latest crossing within {horizon_days:g} days nor the forecast within {reach:.3g}")
    return "ok", f"{rate}; {when}: {why}"


__all__ = ["CONFIDENCE", "IMPACT_TYPES", "MIN_EVENTS", "MIN_SPAN_DAYS", "RECENT_EVENTS", "GearTrend", "as_utc", "closures",
           "gear_trend", "gear_trends"]
