"""The gears' closure-force trend (femref.fleet.wear) against closed forms: a linear decline's slope recovered within
its interval, a noise-free line's crossing exact, a flat gear not flagged, a wearing gear flagged before it crosses."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binom, theilslopes

from femref.fleet.wear import MIN_EVENTS, MIN_SPAN_DAYS, RECENT_EVENTS, gear_trend, gear_trends

from support.fleet_events import RATED, START, WEAR_LIMIT, fleet_events, linear_gear

SEEDS = 200


def _closures(days: np.ndarray, forces: np.ndarray) -> pd.DataFrame:
    times = START + pd.to_timedelta(days, unit="D")
    return pd.DataFrame({"time": times, "closure_force": forces, "event_key": [f"r{k}/0" for k in range(days.size)]})


def _now(day: float) -> pd.Timestamp:
    return START + pd.Timedelta(days=day)


def test_the_slope_interval_covers_a_linear_decline():
    """P(t) = 2 MN − 10 kN/day·t + N(0, 40 kN), 30 closures over 30 days: the 95 % interval of the slope covers −10 kN/day in
    at least 90 % of 200 seeds (at a true 95 %, fewer than 180 covering has probability binom.cdf(179, 200, 0.95) < 2e-3)."""
    assert binom.cdf(179, SEEDS, 0.95) < 2e-3
    rate, sigma = -1.0e4, 4.0e4
    covered = 0
    for seed in range(SEEDS):
        rng = np.random.default_rng(seed)
        days = np.sort(rng.uniform(0.0, 30.0, 30))
        trend = gear_trend("G", _closures(days, RATED + rate * days + sigma * rng.standard_normal(days.size)), WEAR_LIMIT, _now(30.0), 30.0)
        covered += trend.slope_lower <= rate <= trend.slope_upper
    assert covered / SEEDS >= 0.90, covered


def test_a_noise_free_line_crosses_exactly():
    """Closures on P(t) = P0 − r t exactly: slope −r with a zero-width interval, and the line, the lower and the upper band all
    cross the limit at t = (P0 − P_w)/r (to a microsecond)."""
    days = np.linspace(0.0, 20.0, 15)
    start, rate = 2.1e6, 1.3e4
    trend = gear_trend("G", _closures(days, start - rate * days), WEAR_LIMIT, _now(20.0), 30.0)
    exact = START + pd.Timedelta(days=(start - WEAR_LIMIT) / rate)
    assert trend.slope == pytest.approx(-rate, rel=1e-12)
    assert trend.slope_lower == pytest.approx(-rate, rel=1e-12) and trend.slope_upper == pytest.approx(-rate, rel=1e-12)
    for crossing in (trend.crossing, trend.crossing_early, trend.crossing_late):
        assert abs((crossing - exact).total_seconds()) < 1e-6
    line, lower, upper = trend.at(pd.DatetimeIndex([exact]))
    assert line[0] == pytest.approx(WEAR_LIMIT, rel=1e-12) and lower[0] == pytest.approx(WEAR_LIMIT, rel=1e-12)
    assert trend.status == "wearing"  # crossing at day 30.8, 10.8 days ahead of day 20


def test_a_flat_gear_is_not_flagged():
    """A gear at its rating with 2 % scatter, 30 closures over 30 days: over 200 seeds never worn, wearing in at most 1 %
    (a significantly negative slope alone happens in 2.5 %, and a crossing 15 % below within 30 days needs a slope ten
    of its standard deviations steep)."""
    flagged = []
    for seed in range(SEEDS):
        rng = np.random.default_rng(1000 + seed)
        days = np.sort(rng.uniform(0.0, 30.0, 30))
        trend = gear_trend("G", _closures(days, RATED + 0.02 * RATED * rng.standard_normal(days.size)), WEAR_LIMIT, _now(30.0), 30.0)
        flagged.append(trend.status)
    assert "worn" not in flagged
    assert flagged.count("wearing") <= 0.01 * SEEDS
    assert set(flagged) == {"ok"}


@pytest.mark.parametrize("seed", range(4))
def test_a_wearing_gear_is_flagged_before_it_crosses(seed):
    """The done-when: a gear falling through its wear limit at day 28 of 30 (the fleet's 20 cars recorded daily) is
    ``wearing`` at day 20 from the events up to day 20 — while its closures are still above the limit —, and its crossing
    interval holds day 28; every other gear is ``ok`` on every day from 8 to 20 (no false alarm)."""
    events = fleet_events(cars=20, days=30, seed=seed, closure=linear_gear("G0007", RATED, 28.0))
    for day in range(8, 21):
        known = events[events["time"] <= _now(day)]
        trends = gear_trends(known, now=_now(day), horizon_days=30.0)
        assert {t.status for g, t in trends.items() if g != "G0007"} <= {"ok", "insufficient data"}, day
    wearing = trends["G0007"]
    assert wearing.status == "wearing", wearing.basis
    assert wearing.closures["closure_force"].min() > WEAR_LIMIT  # not crossed yet
    assert wearing.crossing_early <= _now(28.0) <= wearing.crossing_late


def test_later_events_do_not_count():
    """Events after ``now`` are ignored: the trend at day 20 of the whole 30 days equals the trend of the first 20."""
    events = fleet_events(cars=4, days=30, seed=5, closure=linear_gear("G0002", RATED, 28.0))
    whole, cut = gear_trends(events, now=_now(20.0)), gear_trends(events[events["time"] <= _now(20.0)], now=_now(20.0))
    assert whole["G0002"].slope == cut["G0002"].slope and whole["G0002"].events == cut["G0002"].events


def test_only_closed_impacts_count():
    """Rows of not-an-impact events, of gears that did not close and without a closure force never enter a trend."""
    events = fleet_events(cars=3, days=10, seed=1)
    trends = gear_trends(events)
    for gear, trend in trends.items():
        rows = events[(events["gear"] == gear) & (events["closure_status"] == "closed") & (events["event_type"] != "not_an_impact")]
        assert trend.events == len(rows) and set(trend.closures["event_key"]) == set(rows["event_key"])


def test_an_outlier_does_not_make_a_trend():
    """One closure 30 % low (a closure found on the wrong knee) among 20 flat ones on a flat gear: the Theil–Sen slope stays
    within a tenth of what least squares makes of it, and the gear stays ok."""
    days = np.arange(20.0)
    forces = RATED + 2.0e4 * (-1.0) ** days
    forces[-2] = 0.7 * RATED
    trend = gear_trend("G", _closures(days, forces), WEAR_LIMIT, _now(19.0), 30.0)
    least_squares = np.polyfit(days, forces, 1)[0]
    assert abs(trend.slope) < 0.1 * abs(least_squares)
    assert trend.status == "ok"


def test_the_fewest_events_rule():
    """MIN_EVENTS is the smallest n whose Sen 95 % interval is narrower than the range of the pairwise slopes (5 points: the
    extremes; 6: not), and fewer closures or a span under MIN_SPAN_DAYS are ``insufficient data``."""
    rng = np.random.default_rng(7)
    for n in (MIN_EVENTS - 1, MIN_EVENTS):
        x, y = np.arange(float(n)), rng.standard_normal(n)
        slopes = [(y[j] - y[i]) / (x[j] - x[i]) for i in range(n) for j in range(i + 1, n)]
        _, _, low, high = theilslopes(y, x, alpha=0.95)
        assert (low == min(slopes) and high == max(slopes)) == (n < MIN_EVENTS)
    falling = lambda days: RATED - 1.0e4 * days  # noqa: E731
    few = np.linspace(0.0, 20.0, MIN_EVENTS - 1)
    short = np.linspace(0.0, 0.9 * MIN_SPAN_DAYS, 12)
    for days in (few, short):
        assert gear_trend("G", _closures(days, falling(days)), WEAR_LIMIT, _now(days[-1]), 30.0).status == "insufficient data"


def test_a_worn_gear():
    """The median of the last three closures below the limit: worn, whatever the trend (here too few points for one)."""
    days = np.array([0.0, 1.0, 2.0])
    trend = gear_trend("G", _closures(days, np.array([1.69e6, 1.75e6, 1.6e6])), WEAR_LIMIT, _now(2.0), 30.0)
    assert RECENT_EVENTS == 3 and trend.recent_closure == 1.69e6 and trend.status == "worn"
    no_limit = gear_trend("G", _closures(days, np.array([1.69e6, 1.75e6, 1.6e6])), math.nan, _now(2.0), 30.0)
    assert no_limit.status == "no wear limit"


def test_bad_horizon():
    with pytest.raises(ValueError, match="horizon_days"):
        gear_trends(fleet_events(cars=2, days=2), horizon_days=0.0)
