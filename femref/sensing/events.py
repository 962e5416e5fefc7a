"""Impact events in a continuous stream of records, and each event's records on one time grid.

**The trigger** (:class:`EventTrigger`), as a recorder's trigger with hysteresis works, on the
envelope ``e(t) = max over channels |a(t)|`` (m/s²; a channel with no sample at ``t``, or NaN,
does not count):

* *armed*, an event opens at the first sample with ``e > level`` (the trigger); its trigger
  probe is the channel with the largest ``|a|`` there;
* while it is open, every sample with ``e > rearm`` (the re-arm level, below the trigger: the
  hysteresis) is the cars still ringing; the trigger *re-arms* at the first sample ``quiet``
  seconds after the last such one, so a ring that dips under the trigger and rises over it
  again is never a new event;
* the event's window is ``[t_trigger − pre, t_last + post]``, ``t_last`` the last sample above
  ``rearm`` before the re-arm: ``post`` is the least record kept after the ringing stops. It is
  capped at ``max_window`` s from its start (the event is flagged ``capped``; the trigger stays
  disarmed until the ring does go quiet, so its tail is never an event of its own; if it never does
  while the stream runs on for more than another ``max_window``, the event is flagged ``never re-armed``:
  an impact after the cap was not looked for, as happens when ``rearm`` lies below the sensor noise), and cut at
  ``t_next − pre`` (not before ``t_last``) when the next event triggers at ``t_next`` before the
  window ends (flagged ``cut short``): an impact more than ``quiet`` after the previous one's ringing
  fell below ``rearm`` is an event of its own, a sooner one is part of the previous event.

The trigger takes the stream in chunks ``(time, {channel: values})`` in time order (channels
without a sample at a time hold NaN there) and keeps its state between them: it returns each
window as soon as no later sample can change it, and the same windows for any cutting of the
same stream into chunks. Each chunk is searched with numpy for the few samples where the state
changes (the first trigger, the first gap of ``quiet`` between ringing samples); there is no
Python loop over samples.

:func:`find_events`: every channel of a :class:`Recordings` merged onto the union of their
sample times (:func:`stream_chunks`) and fed to the trigger. Each window is clipped to the span
every channel covers (then the event is flagged ``truncated``), and every gap or saturated
stretch of any channel that overlaps it is named in its flags (``"saturated: hammer/front
1.2031–1.2050 s"``): the estimates of such an event are not to be trusted silently.

:func:`window`: the event's records resampled by linear interpolation onto one uniform grid
``t_k = start + k / rate`` over the window (absolute times, s), ``rate`` the highest rate of
the channels by default — the estimators need one grid for all cars.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.sensing.recordings import Recordings

REARM_FRACTION = 0.5
"""The default re-arm level, as a fraction of the trigger level."""
QUIET = 0.5
"""The default quiet time (s): the records stay below the re-arm level this long before the trigger re-arms. Coupled
cars surging through their gear's slack fall quiet for up to 0.44 s between bursts (the lulls of 12 coupled fem
impacts, tests/measured/test_event_trigger.py), and a burst after a lull of 0.18 s still rose above the trigger."""
MAX_WINDOW = 5.0
"""The default longest event window (s), from its start ``t_trigger − pre`` to its end."""
CHUNK_SAMPLES = 1 << 18
"""Samples of the merged stream per chunk fed to the trigger by :func:`find_events`."""


@dataclass(frozen=True)
class TriggerSettings:
    """How events are cut from a stream: the trigger ``level`` and the re-arm level ``rearm`` (m/s², None:
    ``REARM_FRACTION × level``), the window ``pre`` the trigger and ``post`` the last ringing sample (s),
    the ``quiet`` time before re-arming (s) and the longest window ``max_window`` (s) (module docstring).
    ValueError names the setting and its rule."""

    level: float
    pre: float
    post: float
    rearm: float | None = None
    quiet: float = QUIET
    max_window: float = MAX_WINDOW

    def __post_init__(self) -> None:
        if not (math.isfinite(self.level) and self.level > 0.0):
            raise ValueError(f"trigger must be a positive level (m/s²), got {self.level!r}")
        if not (math.isfinite(self.pre) and self.pre >= 0.0 and math.isfinite(self.post) and self.post > 0.0):
            raise ValueError(f"pre must be >= 0 and post > 0 (s), got {self.pre!r}, {self.post!r}")
        if not (math.isfinite(self.rearm_level) and 0.0 < self.rearm_level <= self.level):
            raise ValueError(f"rearm must be a level in (0, trigger = {self.level:g}] (m/s²), got {self.rearm_level!r}")
        if not (math.isfinite(self.quiet) and self.quiet > 0.0):
            raise ValueError(f"quiet must be a positive time (s), got {self.quiet!r}")
        if not (math.isfinite(self.max_window) and self.max_window >= self.pre + self.post):
            raise ValueError(f"max_window must be >= pre + post = {self.pre + self.post:g} s, got {self.max_window!r}")

    @property
    def rearm_level(self) -> float:
        """The re-arm level (m/s²): ``rearm``, or ``REARM_FRACTION × level``."""
        return REARM_FRACTION * self.level if self.rearm is None else self.rearm


@dataclass(frozen=True)
class EventWindow:
    """A window the trigger decided: ``start``–``end`` (s), its trigger sample's time and probe, and its
    flags (``capped``, ``cut short``)."""

    start: float
    end: float
    trigger_time: float
    trigger_probe: str
    flags: tuple[str, ...] = ()


@dataclass
class _Ringing:
    """The open event: its trigger, the last sample above the re-arm level, and whether its capped window
    was already returned."""

    trigger_time: float
    trigger_probe: str
    last_loud: float
    returned: bool = False


@dataclass
class EventTrigger:
    """The trigger as a state machine over chunks of a stream (module docstring): :meth:`feed` each chunk in
    time order, then :meth:`finish` at the stream's end; each returns the windows decided."""

    settings: TriggerSettings
    _last_time: float = field(default=-math.inf, init=False)
    _ringing: _Ringing | None = field(default=None, init=False)
    _pending: tuple[EventWindow, float] | None = field(default=None, init=False)  # re-armed: its window, t_last
    never_rearmed_after: float | None = field(default=None, init=False)
    """Set by :meth:`finish` when a capped window's ringing never went quiet to the end of the stream, more than
    another ``max_window`` after the cap: that window's trigger time (s). The trigger never re-armed after it, so an
    impact after its cap was not looked for."""

    def feed(self, time: ArrayLike, channels: Mapping[str, ArrayLike]) -> list[EventWindow]:
        """The windows decided by the chunk ``time`` (s, increasing, after the previous chunk's) with each
        channel's samples there (m/s², NaN: no sample)."""
        t = np.asarray(time, dtype=float)
        if t.ndim != 1 or t.size == 0:
            raise ValueError(f"a chunk's time must be a non-empty 1-D array, got shape {t.shape}")
        if not (t[0] > self._last_time and np.all(np.diff(t) > 0.0)):
            raise ValueError(f"a chunk's times must increase, after the previous chunk's last time {self._last_time:.9g} s")
        names = list(channels)
        values = [np.asarray(channels[name], dtype=float) for name in names]
        if not names or any(v.shape != t.shape for v in values):
            raise ValueError(f"a chunk needs one or more channels, each with one value per time ({t.size})")
        magnitude = np.abs(np.array(values))
        envelope = np.fmax.reduce(magnitude, axis=0)
        decided: list[EventWindow] = []
        k = 0
        while k < t.size:
            if self._ringing is None:
                k = self._armed(t, envelope, magnitude, names, k, decided)
            else:
                k = self._ring(t, envelope, k)
        self._settle(float(t[-1]), decided)
        self._last_time = float(t[-1])
        return decided

    def finish(self) -> list[EventWindow]:
        """The windows still open at the stream's end (their ends may lie beyond it). When a capped window's
        ringing never went quiet to the end of a stream that ran on for more than another ``max_window`` after
        the cap, :attr:`never_rearmed_after` names it."""
        decided: list[EventWindow] = []
        if self._pending is not None:
            decided.append(self._pending[0])
        ringing = self._ringing
        if ringing is not None and not ringing.returned:
            decided.append(self._closed(ringing))
        if ringing is not None and self._last_time - self._cap(ringing) > self.settings.max_window:
            self.never_rearmed_after = ringing.trigger_time
        self._pending, self._ringing = None, None
        return decided

    def _armed(self, t: NDArray[np.float64], envelope: NDArray[np.float64], magnitude: NDArray[np.float64],
               names: list[str], k: int, decided: list[EventWindow]) -> int:
        """From sample ``k`` while armed: the next trigger opens an event (deciding the pending window); the
        index to go on from."""
        above = np.flatnonzero(envelope[k:] > self.settings.level)
        if self._pending is not None and above.size:
            pending, last_loud = self._pending
            trigger_time = float(t[k + above[0]])
            if trigger_time < pending.end:
                end = min(max(trigger_time - self.settings.pre, last_loud), pending.end)
                pending = replace(pending, end=end, flags=(*pending.flags, f"cut short: the next event triggers at {trigger_time:.6g} s"))
            decided.append(pending)
            self._pending = None
        if not above.size:
            return t.size
        j = k + int(above[0])
        probe = names[int(np.nanargmax(magnitude[:, j]))]
        self._ringing = _Ringing(float(t[j]), probe, float(t[j]))
        return j + 1

    def _ring(self, t: NDArray[np.float64], envelope: NDArray[np.float64], k: int) -> int:
        """From sample ``k`` while an event is open: its ringing samples up to the re-arm, if this chunk
        holds it; the index to go on from."""
        ringing = self._ringing
        assert ringing is not None
        loud = np.concatenate([[ringing.last_loud], t[k + np.flatnonzero(envelope[k:] > self.settings.rearm_level)]])
        following = np.append(loud[1:], t[-1])  # the next ringing sample, or the chunk's last sample
        silent = np.flatnonzero(following >= loud + self.settings.quiet)
        if not silent.size:
            ringing.last_loud = float(loud[-1])
            return t.size
        ringing.last_loud = float(loud[silent[0]])
        rearmed = max(k, int(np.searchsorted(t, ringing.last_loud + self.settings.quiet, side="left")))
        if not ringing.returned:
            self._pending = (self._closed(ringing), ringing.last_loud)
        self._ringing = None
        return rearmed

    def _cap(self, ringing: _Ringing) -> float:
        """The latest end of the open event's window (s): ``max_window`` after its start."""
        return ringing.trigger_time - self.settings.pre + self.settings.max_window

    def _closed(self, ringing: _Ringing) -> EventWindow:
        """The open event's window: to ``post`` after its last ringing sample, at most ``max_window`` long."""
        start, cap = ringing.trigger_time - self.settings.pre, self._cap(ringing)
        end = ringing.last_loud + self.settings.post
        if end <= cap:
            return EventWindow(start, end, ringing.trigger_time, ringing.trigger_probe)
        flag = f"capped: max_window = {self.settings.max_window:g} s reached while the cars rang above {self.settings.rearm_level:g} m/s²"
        return EventWindow(start, cap, ringing.trigger_time, ringing.trigger_probe, (flag,))

    def _settle(self, now: float, decided: list[EventWindow]) -> None:
        """Return the windows the stream up to ``now`` (s) has decided: a pending window ended, a capped one reached."""
        if self._pending is not None and now >= self._pending[0].end:
            decided.append(self._pending[0])
            self._pending = None
        ringing = self._ringing
        if ringing is not None and not ringing.returned and ringing.last_loud + self.settings.post > self._cap(ringing) <= now:
            decided.append(self._closed(ringing))
            ringing.returned = True


@dataclass(frozen=True)
class Event:
    """Event ``index`` (0-based, in time order): its window ``start``–``end`` (s), the trigger sample's time
    and probe, and its flags (``truncated``, ``capped``, ``cut short``, quality problems in the window)."""

    index: int
    start: float
    end: float
    trigger_time: float
    trigger_probe: str
    flags: tuple[str, ...]


def stream_chunks(recordings: Recordings, samples: int = CHUNK_SAMPLES) -> Iterator[tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]]:
    """The records as one stream, in chunks of ``samples`` times: ``(t, {probe: a})`` on the union of the
    channels' sample times (s), each channel's samples at its own times and NaN at the others' (m/s²)."""
    axes = list({id(channel.time): channel.time for channel in recordings.channels.values()}.values())  # one per recorder
    time = axes[0] if len(axes) == 1 else np.unique(np.concatenate(axes))
    for first in range(0, time.size, samples):
        t = time[first:first + samples]
        values = {}
        for probe, channel in recordings.channels.items():
            lo, hi = np.searchsorted(channel.time, t[0], side="left"), np.searchsorted(channel.time, t[-1], side="right")
            if hi - lo == t.size:  # sampled at every time of the chunk
                values[probe] = channel.acceleration[lo:hi]
                continue
            a = np.full(t.size, np.nan)
            a[np.searchsorted(t, channel.time[lo:hi])] = channel.acceleration[lo:hi]
            values[probe] = a
        yield t, values


def find_events(recordings: Recordings, trigger: float, pre: float, post: float, *, rearm: float | None = None,
                quiet: float = QUIET, max_window: float = MAX_WINDOW) -> list[Event]:
    """The events of the stream (module docstring); ValueError for settings out of their range
    (:class:`TriggerSettings`)."""
    machine = EventTrigger(TriggerSettings(trigger, pre, post, rearm, quiet, max_window))
    windows = [window for t, values in stream_chunks(recordings) for window in machine.feed(t, values)] + machine.finish()
    if machine.never_rearmed_after is not None:
        k = next(i for i, w in enumerate(windows) if w.trigger_time == machine.never_rearmed_after)
        note = (f"never re-armed: the records stayed above rearm = {machine.settings.rearm_level:g} m/s² with no quiet stretch of "
                f"{machine.settings.quiet:g} s to the end of the stream, so an impact after the cap would not be found "
                f"(is rearm below the sensor noise?)")
        windows[k] = replace(windows[k], flags=(*windows[k].flags, note))
    first, last = recordings.span
    events: list[Event] = []
    for found in windows:
        start, end = max(found.start, first), min(found.end, last)
        if end <= start:
            continue
        flags = (["truncated"] if start > found.start or end < found.end else []) + list(found.flags) + _quality_flags(recordings, start, end)
        events.append(Event(len(events), start, end, found.trigger_time, found.trigger_probe, tuple(flags)))
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


__all__ = ["CHUNK_SAMPLES", "MAX_WINDOW", "QUIET", "REARM_FRACTION", "Event", "EventTrigger", "EventWindow", "TriggerSettings",
           "find_events", "stream_chunks", "window"]
