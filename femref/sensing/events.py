"""Impact events in a continuous stream of records, and each event's records on one time grid.

:func:`find_events`: an event starts at the first sample, on any channel, with
``|a| > trigger`` after the previous event's window; its window is
``[t_trigger − pre, t_trigger + post]``, and exceedances inside it belong to it. The window
is clipped to the span every channel covers (then the event is flagged ``truncated``), and
every gap or saturated stretch of any channel that overlaps it is named in its flags
(``"saturated: hammer/front 1.2031–1.2050 s"``): the estimates of such an event are not to
be trusted silently.

:func:`window`: the event's records resampled by linear interpolation onto one uniform grid
``t_k = start + k / rate`` over the window (absolute times, s), ``rate`` the highest rate of
the channels by default — the estimators need one grid for all cars.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from femref.sensing.recordings import Recordings


@dataclass(frozen=True)
class Event:
    """Event ``index`` (0-based, in time order): its window ``start``–``end`` (s), the trigger sample's time
    and probe, and its flags (quality problems in the window, ``truncated``)."""

    index: int
    start: float
    end: float
    trigger_time: float
    trigger_probe: str
    flags: tuple[str, ...]


def find_events(recordings: Recordings, trigger: float, pre: float, post: float) -> list[Event]:
    """The events of the stream (module docstring)."""
    if not (math.isfinite(trigger) and trigger > 0.0):
        raise ValueError(f"trigger must be a positive level (m/s²), got {trigger!r}")
    if not (math.isfinite(pre) and pre >= 0.0 and math.isfinite(post) and post > 0.0):
        raise ValueError(f"pre must be >= 0 and post > 0 (s), got {pre!r}, {post!r}")
    crossings = sorted(
        (float(channel.time[k]), probe)
        for probe, channel in recordings.channels.items()
        for k in np.flatnonzero(np.abs(np.nan_to_num(channel.acceleration)) > trigger)
    )
    first, last = recordings.span
    events: list[Event] = []
    window_end = -math.inf
    for time, probe in crossings:
        if time <= window_end:
            continue
        window_end = time + post
        start, end = max(time - pre, first), min(window_end, last)
        if end <= start:
            continue
        flags = (["truncated"] if start > time - pre or end < window_end else []) + _quality_flags(recordings, start, end)
        events.append(Event(len(events), start, end, time, probe, tuple(flags)))
    return events


def window(recordings: Recordings, event: Event, rate: float | None = None) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    """``(t, {probe: a})``: the event's records linearly interpolated onto ``t_k = start + k / rate`` (s, m/s²)."""
    rate = max(channel.rate for channel in recordings.channels.values()) if rate is None else rate
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be positive (Hz), got {rate!r}")
    samples = int(math.floor((event.end - event.start) * rate + 1e-9)) + 1
    t = event.start + np.arange(samples) / rate
    return t, {probe: np.interp(t, channel.time, channel.acceleration) for probe, channel in recordings.channels.items()}


def _quality_flags(recordings: Recordings, start: float, end: float) -> list[str]:
    return [
        f"{quality.reason}: {probe} {quality.start:.6g}–{quality.end:.6g} s"
        for probe, channel in recordings.channels.items()
        for quality in channel.quality
        if quality.end >= start and quality.start <= end
    ]


__all__ = ["Event", "find_events", "window"]
