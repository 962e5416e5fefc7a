"""The quality of a recorder's channels, followed chunk by chunk: gaps, saturated and implausible stretches.

Per channel (:class:`QualityTracker`, fed the recorder's chunks in time order):

* a **gap** is a run of NaN samples, from the sample before it to the sample after it (the stream's first or last
  sample at its ends), or a time step longer than :data:`GAP_STEP` median steps (the file's first chunk's median;
  the step from one file to the next, a logger restart, too);
* **saturated** is a run of :data:`SATURATED_RUN` or more samples at the channel's extreme ``max |a| > 0``: the
  tracker keeps the running extreme and the runs at it, dropping them when a larger value comes, so once a stream
  has been fed whole it gives the runs at the stream's extreme (a file read in one chunk: its own);
* **implausible** is a run of samples with ``|a| >`` :data:`PLAUSIBLE_ACCELERATION`.

A run that reaches a chunk's end stays open and is continued by the next chunk: any cutting of the stream gives the
same stretches. Stretches that ended before a time no event can reach any more are dropped (:meth:`QualityTracker.prune`):
memory follows the stretches of the last seconds, not the stream's length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

GAP_STEP = 1.5
"""A time step longer than this many median steps is a gap."""
SATURATED_RUN = 3
"""Samples in a row at a channel's extreme that make it saturated."""
PLAUSIBLE_ACCELERATION = 1000.0 * 9.80665
"""Largest |a| (m/s², 1000 g) a car-body accelerometer records of a coupling impact. The hardest yard impact (~4.5 MN,
the gear solid) decelerates even an empty 20 t car by 4.5e6 / 2e4 = 225 m/s² (23 g) as a rigid body; ringing near the
coupler multiplies that locally by a few, and shock loggers' ranges end at ±200–500 g. A sample beyond is a glitch, a
wrong unit or a sensor knocked loose: flagged ``implausible``, never taken silently."""


@dataclass(frozen=True)
class QualityInterval:
    """A stretch of a channel not to be trusted: ``reason`` ``gap``, ``saturated`` or ``implausible``, from ``start``
    to ``end`` (s)."""

    start: float
    end: float
    reason: str


@dataclass
class _Run:
    """A run open at the end of the samples fed so far: its first sample's time, its length and its last time."""

    start: float
    count: int
    last: float


@dataclass
class _ChannelState:
    intervals: list[QualityInterval] = field(default_factory=list)  # closed gaps and implausible stretches
    saturated: list[QualityInterval] = field(default_factory=list)  # closed runs at the extreme
    extreme: float = 0.0
    nan_from: float | None = None  # an open NaN run: the time of the sample before it (or its first)
    at_extreme: _Run | None = None
    beyond: _Run | None = None


class QualityTracker:
    """Each channel's gaps, saturated and implausible stretches over a stream fed in chunks (module docstring)."""

    def __init__(self, channels: int) -> None:
        self._states = [_ChannelState() for _ in range(channels)]
        self._last_time = -math.inf
        self.steps: list[QualityInterval] = []
        """Gaps of the time axis (long steps), shared by every channel."""

    def feed(self, time: NDArray[np.float64], values: NDArray[np.float64], median_step: float) -> list[QualityInterval]:
        """Take the chunk ``time`` (s) with ``values`` (channels × samples, m/s²); ``median_step``: the file's (s).
        Returns the long steps the chunk holds (from the previous chunk's last sample on)."""
        if time.size == 0:
            return []
        joined = np.concatenate([[self._last_time], time]) if math.isfinite(self._last_time) else time
        steps = np.diff(joined)
        long = np.flatnonzero(steps > GAP_STEP * median_step)
        found = [QualityInterval(float(joined[k]), float(joined[k + 1]), "gap") for k in long]
        self.steps += found
        previous = self._last_time
        for state, a in zip(self._states, values):
            self._nan_runs(state, time, a, previous)
            magnitude = np.abs(a)
            self._saturated(state, time, magnitude)
            state.beyond = _open_runs(time, magnitude > PLAUSIBLE_ACCELERATION, state.beyond, state.intervals, "implausible", 1)
        self._last_time = float(time[-1])
        return found

    def finish(self) -> None:
        """Close the runs still open at the stream's end."""
        for state in self._states:
            if state.nan_from is not None:
                state.intervals.append(QualityInterval(state.nan_from, self._last_time, "gap"))
                state.nan_from = None
            for run, into, reason, least in ((state.beyond, state.intervals, "implausible", 1), (state.at_extreme, state.saturated, "saturated", SATURATED_RUN)):
                if run is not None and run.count >= least:
                    into.append(QualityInterval(run.start, run.last, reason))
            state.beyond = state.at_extreme = None

    def intervals(self, channel: int) -> list[QualityInterval]:
        """Channel ``channel``'s stretches so far (open runs to their last sample), by start."""
        state = self._states[channel]
        found = [*self.steps, *state.intervals, *state.saturated]
        if state.nan_from is not None:
            found.append(QualityInterval(state.nan_from, self._last_time, "gap"))
        if state.at_extreme is not None and state.at_extreme.count >= SATURATED_RUN:
            found.append(QualityInterval(state.at_extreme.start, state.at_extreme.last, "saturated"))
        if state.beyond is not None:
            found.append(QualityInterval(state.beyond.start, state.beyond.last, "implausible"))
        return sorted(found, key=lambda q: q.start)

    def prune(self, before: float) -> None:
        """Drop the closed stretches that end before ``before`` (s)."""
        self.steps = [q for q in self.steps if q.end >= before]
        for state in self._states:
            state.intervals = [q for q in state.intervals if q.end >= before]
            state.saturated = [q for q in state.saturated if q.end >= before]

    @staticmethod
    def _nan_runs(state: _ChannelState, time: NDArray[np.float64], a: NDArray[np.float64], previous: float) -> None:
        missing = ~np.isfinite(a)
        edges = np.diff(np.concatenate([[1 if state.nan_from is not None else 0], missing.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        if state.nan_from is not None:
            starts = np.concatenate([[-1], starts])
        for first, last in zip(starts, ends):
            if last == time.size - 1:  # open at the chunk's end
                if first >= 0:
                    state.nan_from = float(time[first - 1]) if first > 0 else (previous if math.isfinite(previous) else float(time[0]))
                break
            begin = state.nan_from if first < 0 else (float(time[first - 1]) if first > 0 else (previous if math.isfinite(previous) else float(time[0])))
            state.intervals.append(QualityInterval(begin, float(time[last + 1]), "gap"))
            state.nan_from = None

    @staticmethod
    def _saturated(state: _ChannelState, time: NDArray[np.float64], magnitude: NDArray[np.float64]) -> None:
        finite = magnitude[np.isfinite(magnitude)]
        largest = float(finite.max()) if finite.size else 0.0
        if largest > state.extreme:
            state.extreme, state.saturated, state.at_extreme = largest, [], None
        if state.extreme > 0.0:
            state.at_extreme = _open_runs(time, magnitude == state.extreme, state.at_extreme, state.saturated, "saturated", SATURATED_RUN)


def _open_runs(time: NDArray[np.float64], mask: NDArray[np.bool_], open_run: _Run | None, into: list[QualityInterval], reason: str,
               least: int) -> _Run | None:
    """Append to ``into`` every run of ``mask`` of ``least`` or more samples that ends in this chunk (the first one
    continuing ``open_run``, the run open from the previous chunk); return the run still open at the chunk's end."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    runs = [_Run(float(time[first]), int(last - first + 1), float(time[last])) for first, last in zip(starts, ends)]
    if open_run is not None:
        if runs and starts[0] == 0:
            runs[0] = _Run(open_run.start, open_run.count + runs[0].count, runs[0].last)
        else:
            runs.insert(0, open_run)
    still_open = runs.pop() if runs and mask.size and mask[-1] else None
    into += [QualityInterval(run.start, run.last, reason) for run in runs if run.count >= least]
    return still_open


__all__ = ["GAP_STEP", "PLAUSIBLE_ACCELERATION", "SATURATED_RUN", "QualityInterval", "QualityTracker"]
