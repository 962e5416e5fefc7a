"""A recorder's clock mapped onto the reference recorder's (the first declared), estimated from the impacts both saw.

Each recorder with ``clock_drift: estimate`` gets a :class:`ClockTrack`. Its *correction* ``c(t)`` (s) is added to the
recorder's times (its declared ``clock_offset`` already in) to reach the reference clock; within a *segment* (from
the stream's start or a logger restart, a gap of either recorder) it is a line

    c(t) = c₀ + ċ · (t − t_s)          drift = −ċ · 1e6 ppm  (a clock that gains has a falling correction)

fitted by least squares to the lags measured at the segment's events. The lag at an event (:func:`measure_lag`):
each recorder's first car's mean acceleration (its channels less their medians), low-passed at :data:`LAG_CORNER`
(zero phase) to what is left of the rigid-body pulse, the two cross-correlated over the event's window; the lag is
the peak of ``s ρ``, ``ρ`` the normalised correlation, within ``±w`` of the fit's prediction, refined by a parabola
through its three samples. A coupling impact moves the two cars at once, equal and opposite: two recorders on
different cars see its pulse at the same instant with ``ρ`` near −1 (``s = −1``), two on the same car with ``ρ``
near +1 (``s = +1``). A transient one car alone feels does not correlate, and one both cars feel at other times — a
track joint under each car's axles in turn, the same sign on both — correlates with the sign an impact does not give:
with ``s ρ <`` :data:`MIN_CORRELATION` there is no lag and the prediction is kept. (Read by ``|ρ|``, a joint 1.4 s
after the restart of a synthetic day's logger was taken as the lag and every later impact of the day was cut apart.)
The search half-width ``w`` follows what the fit does not know: :data:`INITIAL_SEARCH` with no lag in the segment,
:data:`MIN_SEARCH` plus :data:`MAX_DRIFT` times the time since the one lag there is, :data:`MIN_SEARCH` plus
:data:`FIT_DRIFT` times the time since the last lag once the drift is fitted; a lag further than
:data:`OUTLIER` from a fit of three or more is not taken. A new segment starts from the previous one's line (its
drift kept until two lags of its own) with the initial search.

The stream itself (the trigger's view) maps the recorder's chunks by :meth:`ClockTrack.stream_map`: the fit's
correction, joined continuously to what the previous chunk used over :data:`JOIN_TIME`, so times keep increasing
when the fit moves. Each event is cut with the fit at its trigger time once its own lag is in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


LAG_CORNER = 10.0
"""Corner (Hz) of the zero-phase low-pass (2nd-order Butterworth, forward and back) the lag is measured through: the
cars' rigid-body pulse (a contact of 50–1200 ms) passes, their axial modes (15–30 Hz and up) and the noise are damped,
so what is left of the two cars is one pulse shape, scaled by their masses."""
MIN_CORRELATION = 0.8
"""Least normalised correlation ``s ρ`` of the two recorders' signals for an event's lag to count. A coupling impact's
rigid-body pulse gives ``s ρ`` 0.99–1.00 (a synthetic day's 202 fem impacts); a track joint's ring, slid half a period
over its twin, gave 0.50 and misplaced a day's clock after a restart when 0.5 counted."""
AMBIGUITY = 0.8
"""A lag counts only if no other peak of ``s ρ`` in the search, outside the main one's lobe (down to half its height),
reaches this fraction of it: a pulse has one peak, a ring a row of nearly equal ones a period apart."""
INITIAL_SEARCH = 1.0
"""Search half-width (s) with no lag in the segment: the declared clock offset's own uncertainty, or a restart's jump."""
MIN_SEARCH = 0.05
"""Least search half-width (s)."""
MAX_DRIFT = 200e-6
"""Largest drift (200 ppm) a recorder's clock is searched for before the fit knows it: quartz clocks drift 20–100 ppm
over their temperature range."""
FIT_DRIFT = 5e-6
"""How far (5 ppm) a fitted drift is allowed to be off when predicting the next lag."""
OUTLIER = 0.005
"""A lag further than this (s) from a fit of three or more lags is not taken."""
JOIN_TIME = 10.0
"""Time (s) over which the stream's correction is joined to a moved fit."""


@dataclass
class _Segment:
    """The lags taken since a restart: running sums of ``x = t − t_s`` and ``y = lag`` for the least-squares line."""

    start: float
    offset: float  # the line carried from before: c(t_s)
    slope: float
    n: int = 0
    sx: float = 0.0
    sy: float = 0.0
    sxx: float = 0.0
    sxy: float = 0.0
    syy: float = 0.0
    last: float = math.nan  # the time of the last lag taken

    def line(self) -> tuple[float, float]:
        """``(c(t_s), ċ)`` of the fit: the carried line moved to the lags (one lag: its offset, the carried slope)."""
        if self.n == 0:
            return self.offset, self.slope
        if self.n == 1:
            return self.sy - self.slope * self.sx, self.slope
        d = self.n * self.sxx - self.sx**2
        slope = (self.n * self.sxy - self.sx * self.sy) / d if d > 0.0 else self.slope
        return (self.sy - slope * self.sx) / self.n, slope

    def rms(self) -> float:
        """The fit's RMS residual (s; 0 for fewer than three lags)."""
        if self.n < 3:
            return 0.0
        c0, slope = self.line()
        sse = self.syy - 2 * c0 * self.sy - 2 * slope * self.sxy + self.n * c0**2 + 2 * c0 * slope * self.sx + slope**2 * self.sxx
        return math.sqrt(max(sse, 0.0) / (self.n - 2))


@dataclass
class ClockTrack:
    """One recorder's clock mapped onto the reference's (module docstring). The segment before the last restart is
    kept for the events that began before it (their lags belong to the clock as it ran then)."""

    recorder: str
    segment: _Segment = field(default_factory=lambda: _Segment(-math.inf, 0.0, 0.0))
    previous: _Segment | None = None
    segments: int = 1
    _joined: tuple[float, float] | None = None  # the stream's last (time, correction)

    def _at(self, t: float) -> _Segment:
        """The segment the time ``t`` (s, the recorder's clock) lies in."""
        return self.previous if self.previous is not None and t < self.segment.start else self.segment

    def predict(self, t: float) -> float:
        """The fit's correction at ``t`` (s, on the recorder's clock)."""
        seg = self._at(t)
        c0, slope = seg.line()
        return c0 + slope * (t - seg.start if math.isfinite(seg.start) else t)

    def drift_at(self, t: float) -> float:
        """The fit's drift (ppm) at ``t``."""
        return -self._at(t).line()[1] * 1e6

    def segment_number(self, t: float) -> int:
        """The number (from 1) of the segment ``t`` lies in."""
        return self.segments - 1 if self._at(t) is not self.segment else self.segments

    def search(self, t: float) -> float:
        """The search half-width (s) for a lag at ``t`` (module docstring)."""
        seg = self._at(t)
        if seg.n == 0:
            return INITIAL_SEARCH
        return min(INITIAL_SEARCH, MIN_SEARCH + (MAX_DRIFT if seg.n == 1 else FIT_DRIFT) * abs(t - seg.last))

    def restart(self, t: float) -> None:
        """A logger restart at ``t`` (s): a new segment from the present line, searched afresh."""
        c0, slope = self.segment.line()
        start = self.segment.start if math.isfinite(self.segment.start) else 0.0
        self.previous, self.segment = self.segment, _Segment(t, c0 + slope * (t - start), slope)
        self.segments += 1

    def take(self, t: float, lag: float) -> bool:
        """Take the lag measured at ``t`` into the fit, unless it is an outlier of a fit of three or more; whether taken."""
        seg = self._at(t)
        if seg.n >= 3 and abs(lag - self.predict(t)) > max(OUTLIER, 5.0 * seg.rms()):
            return False
        x = t - seg.start if math.isfinite(seg.start) else t
        seg.n += 1
        seg.sx, seg.sy, seg.sxx, seg.sxy, seg.syy = seg.sx + x, seg.sy + lag, seg.sxx + x * x, seg.sxy + x * lag, seg.syy + lag * lag
        seg.last = t
        return True

    def stream_map(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """The corrections (s) of a chunk of the recorder's times ``t`` for the stream: the fit's, joined continuously
        to the previous chunk's last over :data:`JOIN_TIME` (or twice the jump, so times keep increasing)."""
        c0, slope = self.segment.line()
        start = self.segment.start if math.isfinite(self.segment.start) else 0.0
        fit = c0 + slope * (t - start)
        if self._joined is not None:
            t_last, c_last = self._joined
            jump = c_last - (c0 + slope * (t_last - start))
            span = max(JOIN_TIME, 2.0 * abs(jump))
            fit = fit + jump * np.clip(1.0 - (t - t_last) / span, 0.0, 1.0)
        if t.size:
            self._joined = (float(t[-1]), float(fit[-1]))
        return fit


def lag_signal(t: NDArray[np.float64], records: NDArray[np.float64], rate: float) -> NDArray[np.float64]:
    """``lowpass(mean over channels of (a − median a))``: a car's rigid-body acceleration, low-passed (``records``: the
    car's channels × samples on the grid ``t`` at ``rate`` Hz; NaN read as 0): the signal whose lag is measured."""
    from scipy.signal import butter, sosfiltfilt  # scipy.signal costs ~0.5 s to import: only a clock track needs it

    a = np.nan_to_num(records - np.nanmedian(records, axis=1, keepdims=True)).mean(axis=0)
    corner = min(LAG_CORNER, 0.4 * rate)
    return sosfiltfilt(butter(2, corner, fs=rate, output="sos"), a) if a.size > 15 else a


def measure_lag(reference: NDArray[np.float64], other: NDArray[np.float64], rate: float, predicted: float, sign: float = -1.0
                ) -> tuple[float, float]:
    """``(lag, ρ)``: the correction (s) at which the ``other`` recorder's signal best matches the ``reference``'s
    (module docstring), ``ρ`` the normalised correlation there, of the ``sign`` a coupling impact gives (−1: the two
    signals are of different cars, which it moves opposite ways; +1: of the same car). ``reference`` is on a grid ``t_j`` (``rate`` Hz); ``other`` on the recorder's clock at
    ``t_j − predicted − K/rate + m/rate``, ``2K`` samples longer (``K`` samples each side: the search), so shift ``k``
    is the correction ``predicted + (K − k)/rate``. NaN lag when the peak of ``sign · ρ`` is at the search's edge,
    below :data:`MIN_CORRELATION` or not alone (:data:`AMBIGUITY`)."""
    from scipy.signal import correlate

    k_max = other.size - reference.size
    energy = float(np.dot(reference, reference))
    if k_max < 2 or energy <= 0.0:
        return math.nan, 0.0
    r = correlate(other, reference, mode="valid", method="fft")
    squares = np.concatenate([[0.0], np.cumsum(other * other)])
    window = squares[reference.size:] - squares[: k_max + 1]
    rho = r / np.sqrt(energy * np.maximum(window, 1e-300))
    score = sign * rho
    k = int(np.argmax(score))
    best = float(rho[k])
    if k == 0 or k == k_max or score[k] < MIN_CORRELATION or _ambiguous(score, k):
        return math.nan, best
    left, centre, right = sign * rho[k - 1 : k + 2]
    curvature = left - 2.0 * centre + right
    shift = 0.5 * (left - right) / curvature if curvature < 0.0 else 0.0
    return predicted + (0.5 * k_max - k - shift) / rate, best


def _ambiguous(score: NDArray[np.float64], k: int) -> bool:
    """Whether ``score`` peaks a second time outside the lobe of its peak ``k`` (down to half its height) at
    :data:`AMBIGUITY` of it or more."""
    half = score < 0.5 * score[k]
    left = int(np.flatnonzero(half[:k])[-1]) if half[:k].any() else 0
    right = k + int(np.argmax(half[k:])) if half[k:].any() else score.size
    rest = np.concatenate([score[:left], score[right:]])
    return bool(rest.size and rest.max() >= AMBIGUITY * score[k])


__all__ = ["AMBIGUITY", "FIT_DRIFT", "INITIAL_SEARCH", "JOIN_TIME", "LAG_CORNER", "MAX_DRIFT", "MIN_CORRELATION", "MIN_SEARCH", "OUTLIER",
           "ClockTrack", "lag_signal", "measure_lag"]
