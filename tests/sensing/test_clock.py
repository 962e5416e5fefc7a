"""A recorder's clock against the reference's (femref.sensing.clock): the lag of a pulse shifted by a known fraction of
a sample, no lag where only one recorder saw something, and the fit of a clock that drifts and restarts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femref.sensing.clock import INITIAL_SEARCH, MIN_SEARCH, ClockTrack, lag_signal, measure_lag

RATE = 1000.0


def pulse(t: np.ndarray, contact: float) -> np.ndarray:
    """A 80 ms half-sine (12.5 m/s²) from ``contact`` and an 18 Hz ring after it."""
    s = t - contact
    inside = (s > 0) & (s < 0.08)
    return np.where(inside, 12.5 * np.sin(np.pi * np.clip(s, 0, 0.08) / 0.08), 0.0) + np.where(s > 0, 0.6 * np.exp(-s / 0.3) * np.sin(2 * np.pi * 18 * s), 0.0)


@pytest.mark.parametrize("correction", [0.00337, -0.0412, 0.25])
def test_the_lag_of_a_shifted_pulse_is_the_shift(correction):
    """The other recorder's clock reads ``t − correction`` for the reference's ``t`` (its pulse, opposite in sign, seen
    at ``contact − correction`` on its clock), with noise on both: the lag found is the correction within 0.1 ms,
    searched ±0.3 s around a prediction 0.2 s off it (±1 s for the largest)."""
    rng = np.random.default_rng(3)
    t = 10.0 + np.arange(1500) / RATE
    reference = lag_signal(t, (pulse(t, 10.2) + rng.normal(0, 0.05, t.size))[None, :], RATE)
    predicted = correction - 0.2 if abs(correction) < 0.2 else 0.0
    k = int(0.3 * RATE) if abs(correction) < 0.2 else int(INITIAL_SEARCH * RATE)
    grid = t[0] - predicted - k / RATE + np.arange(t.size + 2 * k) / RATE
    other = lag_signal(grid, (-pulse(grid + correction, 10.2) + rng.normal(0, 0.05, grid.size))[None, :], RATE)
    lag, rho = measure_lag(reference, other, RATE, predicted)
    assert rho < -0.9 and abs(lag - correction) < 1e-4, (lag, rho)  # the cars moved opposite ways


def test_a_transient_one_recorder_alone_saw_gives_no_lag():
    """A pulse on the reference's car, only noise on the other's: the correlation stays below the threshold, no lag."""
    rng = np.random.default_rng(4)
    t = np.arange(1500) / RATE
    reference = lag_signal(t, (pulse(t, 0.2) + rng.normal(0, 0.05, t.size))[None, :], RATE)
    other = lag_signal(np.arange(2100) / RATE, rng.normal(0, 0.05, (1, 2100)), RATE)
    lag, rho = measure_lag(reference, other, RATE, 0.0)
    assert math.isnan(lag) and abs(rho) < 0.5


def test_a_track_joint_under_both_cars_gives_no_lag():
    """A track joint jolts both cars the same way, the second 0.4 s after the first (its axles reach the joint later):
    the two signals correlate near +1 at that delay, the sign no coupling impact gives between two cars, so there is no
    lag; two recorders on the same car, where an impact does correlate near +1, read the same signals as a lag."""
    rng = np.random.default_rng(5)
    t = 10.0 + np.arange(1500) / RATE
    reference = lag_signal(t, (pulse(t, 10.2) + rng.normal(0, 0.05, t.size))[None, :], RATE)
    k = int(INITIAL_SEARCH * RATE)
    grid = t[0] - k / RATE + np.arange(t.size + 2 * k) / RATE
    other = lag_signal(grid, (pulse(grid, 10.6) + rng.normal(0, 0.05, grid.size))[None, :], RATE)
    lag, rho = measure_lag(reference, other, RATE, 0.0)
    assert math.isnan(lag), (lag, rho)
    lag, rho = measure_lag(reference, other, RATE, 0.0, sign=1.0)
    assert rho > 0.9 and abs(lag - (-0.4)) < 1e-4, (lag, rho)


def test_a_ring_on_both_cars_gives_no_lag():
    """Both cars ringing at 8 Hz (a track joint's bounce, under the lag signal's 10 Hz low-pass), in opposite phase:
    ``−ρ`` peaks near 1 at every period within the search, so no one lag stands out and none is taken."""
    rng = np.random.default_rng(6)
    t = 10.0 + np.arange(1500) / RATE

    def ring(x, start):
        s = x - start
        return np.where(s > 0, 8.0 * np.exp(-s / 1.5) * np.sin(2 * np.pi * 8.0 * s), 0.0)

    reference = lag_signal(t, (ring(t, 10.2) + rng.normal(0, 0.05, t.size))[None, :], RATE)
    k = int(INITIAL_SEARCH * RATE)
    grid = t[0] - k / RATE + np.arange(t.size + 2 * k) / RATE
    other = lag_signal(grid, (-ring(grid, 10.3) + rng.normal(0, 0.05, grid.size))[None, :], RATE)
    lag, rho = measure_lag(reference, other, RATE, 0.0)
    assert math.isnan(lag) and rho < -0.8, (lag, rho)


def test_the_fit_follows_a_drifting_clock_across_a_restart():
    """Lags on the line ``c = 0.01 − 50e-6 t`` (a clock 50 ppm fast): the drift read 50 ppm and the line predicted
    exactly; the search narrows from 1 s to 50 ms plus 200 ppm, then 5 ppm, of the time since the last lag. A restart
    at 1000 s whose clock comes back 0.3 s off: a new segment searched afresh from the old line, its drift kept until
    two lags of its own; an event before the restart still reads (and feeds) the old segment."""
    track = ClockTrack("r2")
    assert track.search(100.0) == INITIAL_SEARCH
    line = lambda t: 0.01 - 50e-6 * t  # noqa: E731
    assert track.take(100.0, line(100.0))
    assert track.search(400.0) == pytest.approx(MIN_SEARCH + 200e-6 * 300.0)
    for t in (400.0, 700.0, 900.0):
        assert track.take(t, line(t))
    assert track.drift_at(900.0) == pytest.approx(50.0, rel=1e-9) and track.predict(950.0) == pytest.approx(line(950.0), abs=1e-12)
    assert track.search(950.0) == pytest.approx(MIN_SEARCH + 5e-6 * 50.0)
    assert not track.take(950.0, line(950.0) + 0.02)  # an outlier of a fit of four
    track.restart(1000.0)
    assert track.search(1100.0) == INITIAL_SEARCH and track.predict(1100.0) == pytest.approx(line(1100.0), abs=1e-12)
    assert track.take(990.0, line(990.0)) and track.segment_number(990.0) == 1 and track.segment.n == 0
    after = lambda t: line(t) - 0.3  # noqa: E731
    assert track.take(1100.0, after(1100.0))
    assert track.drift_at(1200.0) == pytest.approx(50.0, rel=1e-9) and track.predict(1200.0) == pytest.approx(after(1200.0), abs=1e-12)
    assert track.segment_number(1200.0) == 2 and track.predict(500.0) == pytest.approx(line(500.0), abs=1e-12)
