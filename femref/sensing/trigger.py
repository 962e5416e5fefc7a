"""Impact events in a continuous stream of records, and each event's records on one time grid.

**The trigger** (:class:`EventTrigger`), as a recorder's trigger with hysteresis works, on the
envelope ``e(t) = max over channels |a(t)|`` (m/s²; a channel with no sample at ``t``, or NaN,
does not count):

* *armed*, an event opens at the first sample with ``e > level`` (the trigger) that *holds*: within
  ``hold`` s from it (:data:`HOLD`) two or more channels exceed the level, or one channel exceeds it at
  each of its samples there (two or more). A spike that does not hold — a glitch of one to three samples
  on one channel at 1 kHz — is no event: it is ignored and counted (:attr:`EventTrigger.glitches`, named
  in the run's warnings). Its trigger probe is the channel with the largest ``|a|`` there;
* while it is open, every sample with ``e > rearm`` (the re-arm level, below the trigger: the
  hysteresis) is the cars still ringing; the trigger *re-arms* at the first sample ``quiet``
  seconds after the last such one, so a ring that dips under the trigger and rises over it
  again is never a new event;
* the event's window is ``[t_trigger − pre, t_last + post]``, ``t_last`` the last sample above
  ``rearm`` before the re-arm: ``post`` is the least record kept after the ringing stops. It is
  capped at ``max_window`` s from its start (the event is flagged ``capped``; the trigger stays
  disarmed until the ring does go quiet, so its tail is never an event of its own; if it does not go quiet
  within another ``max_window`` after the cap, the event is flagged ``never re-armed``: an impact after the cap
  was not looked for, as happens when ``rearm`` lies below the sensor noise; a capped window is returned when the
  ring goes quiet, or then), and cut at
  ``t_next − pre`` (not before ``t_last``) when the next event triggers at ``t_next`` before the
  window ends (flagged ``cut short``): an impact more than ``quiet`` after the previous one's ringing
  fell below ``rearm`` is an event of its own, a sooner one is part of the previous event.

The trigger takes the stream in chunks ``(time, {channel: values})`` in time order (NaN: no sample) and returns
each window as soon as no later sample can change it: the same windows for any cutting of the stream into chunks.
Each chunk is searched with numpy for the few samples where the state changes; Python loops only over triggers
that do not hold.

:mod:`femref.sensing.stream` feeds it the recorders' merged stream, each channel less its baseline
(:mod:`femref.sensing.baseline`: a bias never opens an event), and makes each window an :class:`Event`: clipped to
the span every channel covers (flagged ``truncated``), every gap or saturated stretch of a channel that overlaps it
named in its flags (``"saturated: hammer/front 1.2031–1.2050 s"``: the estimates of such an event are not to be
trusted silently), and, with the trigger within :data:`NOISE_MARGIN` σ of a channel's noise in the quiet stretches,
flagged (:func:`trigger_in_noise`).

:func:`event_grid`: the uniform grid an event's records are interpolated onto (the estimators need one grid for all
cars); :func:`window` cuts them from records held whole.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
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
HOLD = 0.003
"""The default hold time (s): a single channel opens an event only if its samples stay above the trigger this long
(module docstring). A third of the shortest plausible contact, ``π √(m*/k) ≈ 10`` ms for 20 t cars (``m* = 10`` t) on the
stiffest plausible gear (``k = 1e9`` N/m): a half-sine contact of 10 ms stays above the trigger for 3 ms when its peak
is 12 % over it; at 1 kHz four samples, so a spike of up to three samples on one channel is no event."""
NOISE_MARGIN = 5.0
"""A trigger below this many noise σ of a channel lies in the noise (:func:`trigger_in_noise`): Gaussian noise exceeds
5 σ at ``5.7e-7`` of its samples, ten times an hour at 1 kHz on five channels."""
GLITCHES_NAMED = 5
"""Ignored spikes named in the search's notes (all are counted)."""


@dataclass(frozen=True)
class TriggerSettings:
    """How events are cut from a stream (module docstring): levels in m/s² (``rearm`` None: ``REARM_FRACTION × level``),
    times in s. ValueError names the setting and its rule."""

    level: float
    pre: float
    post: float
    rearm: float | None = None
    quiet: float = QUIET
    max_window: float = MAX_WINDOW
    hold: float = HOLD

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
        if not (math.isfinite(self.hold) and self.hold >= 0.0):
            raise ValueError(f"hold must be a time >= 0 (s), got {self.hold!r}")

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
    """The open event: its trigger, the last sample above the re-arm level, whether its window is decided (capped),
    and that capped window while it is held back (module docstring)."""

    trigger_time: float
    trigger_probe: str
    last_loud: float
    returned: bool = False
    held: EventWindow | None = None


@dataclass
class EventTrigger:
    """The trigger as a state machine over chunks of a stream (module docstring): :meth:`feed` each chunk in
    time order, then :meth:`finish` at the stream's end; each returns the windows decided."""

    settings: TriggerSettings
    _last_time: float = field(default=-math.inf, init=False)
    _ringing: _Ringing | None = field(default=None, init=False)
    _pending: tuple[EventWindow, float] | None = field(default=None, init=False)  # re-armed: its window, t_last
    _names: list[str] | None = field(default=None, init=False)
    _carry: tuple[NDArray[np.float64], NDArray[np.float64]] | None = field(default=None, init=False)  # (t, |a|) from a trigger not yet held
    glitches: int = field(default=0, init=False)
    """Spikes above the trigger ignored so far: on one channel, held less than ``hold`` (module docstring)."""
    first_glitches: list[tuple[float, str]] = field(default_factory=list, init=False)
    """The first :data:`GLITCHES_NAMED` of them: ``(time, channel)``."""

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
        if self._names is None:
            self._names = names
        elif names != self._names:
            raise ValueError(f"every chunk needs the channels {self._names}, got {names}")
        magnitude = np.abs(np.array(values))
        self._last_time = float(t[-1])
        if self._carry is not None:
            t, magnitude = np.concatenate([self._carry[0], t]), np.concatenate([self._carry[1], magnitude], axis=1)
        return self._process(t, magnitude, final=False)

    def _process(self, t: NDArray[np.float64], magnitude: NDArray[np.float64], final: bool) -> list[EventWindow]:
        """Run the state machine over the samples ``t`` (with ``|a|`` per channel); a trigger whose hold time runs
        past the last sample is carried to the next chunk (unless ``final``: the stream has ended)."""
        envelope = np.fmax.reduce(magnitude, axis=0)
        decided: list[EventWindow] = []
        self._carry = None
        k = 0
        while k < t.size:
            if self._ringing is None:
                k = self._armed(t, envelope, magnitude, k, decided, final)
            else:
                k = self._ring(t, envelope, k, decided)
        if self._carry is None:
            self._settle(float(t[-1]), decided)
        elif self._carry[0][0] > t[0]:
            self._settle(float(t[t < self._carry[0][0]][-1]), decided)
        return decided

    def finish(self) -> list[EventWindow]:
        """The windows still open at the stream's end (their ends may lie beyond it); a trigger still within its hold
        time is decided on the samples there are."""
        decided: list[EventWindow] = []
        if self._carry is not None:
            decided += self._process(*self._carry, final=True)
        if self._pending is not None:
            decided.append(self._pending[0])
        ringing = self._ringing
        if ringing is not None and not ringing.returned:
            decided.append(self._closed(ringing))
        if ringing is not None and ringing.held is not None:
            never = self._last_time - self._cap(ringing) > self.settings.max_window
            decided.append(self._never_rearmed(ringing.held) if never else ringing.held)
        self._pending, self._ringing = None, None
        return decided

    def earliest_start(self) -> float:
        """The earliest start (s) a window not yet returned can have: an open, held or pending one's, or ``pre``
        before the last sample taken (a later trigger's)."""
        pre = self.settings.pre
        found = [self._last_time - pre]
        if self._carry is not None:
            found.append(float(self._carry[0][0]) - pre)
        if self._pending is not None:
            found.append(self._pending[0].start)
        ringing = self._ringing
        if ringing is not None:
            found.append(ringing.trigger_time - pre)
        return min(found)

    def _never_rearmed(self, window: EventWindow) -> EventWindow:
        note = (f"never re-armed: the records stayed above rearm = {self.settings.rearm_level:g} m/s² with no quiet stretch of "
                f"{self.settings.quiet:g} s for another max_window = {self.settings.max_window:g} s after the cap, so an impact after the cap "
                f"would not be found (is rearm below the sensor noise?)")
        return replace(window, flags=(*window.flags, note))

    def _armed(self, t: NDArray[np.float64], envelope: NDArray[np.float64], magnitude: NDArray[np.float64],
               k: int, decided: list[EventWindow], final: bool) -> int:
        """From sample ``k`` while armed: the next trigger that holds opens an event (deciding the pending window);
        spikes that do not hold are counted; the index to go on from (the chunk's end when a trigger's hold time
        runs past it: then it is carried)."""
        level, hold = self.settings.level, self.settings.hold
        above = k + np.flatnonzero(envelope[k:] > level)
        j, skip = -1, -1
        for candidate in above:
            if candidate < skip:
                continue  # part of the spike just ignored
            if hold > 0.0 and not final and t[-1] <= t[candidate] + hold:  # its hold time goes on in the next chunk
                self._carry = (t[candidate:], magnitude[:, candidate:])
                return t.size
            stop = int(np.searchsorted(t, t[candidate] + hold, side="right"))
            if hold == 0.0 or _holds(magnitude[:, candidate:stop], level):
                j = int(candidate)
                break
            self._ignore(float(t[candidate]), magnitude[:, candidate])
            skip = stop
        if self._pending is not None and j >= 0:
            pending, last_loud = self._pending
            trigger_time = float(t[j])
            if trigger_time < pending.end:
                end = min(max(trigger_time - self.settings.pre, last_loud), pending.end)
                pending = replace(pending, end=end, flags=(*pending.flags, f"cut short: the next event triggers at {trigger_time:.6g} s"))
            decided.append(pending)
            self._pending = None
        if j < 0:
            return t.size
        assert self._names is not None
        probe = self._names[int(np.nanargmax(magnitude[:, j]))]
        self._ringing = _Ringing(float(t[j]), probe, float(t[j]))
        return j + 1

    def _ignore(self, time: float, magnitude: NDArray[np.float64]) -> None:
        """Count a spike that did not hold (and name it, among the first)."""
        assert self._names is not None
        self.glitches += 1
        if len(self.first_glitches) < GLITCHES_NAMED:
            self.first_glitches.append((time, self._names[int(np.nanargmax(magnitude))]))

    def _ring(self, t: NDArray[np.float64], envelope: NDArray[np.float64], k: int, decided: list[EventWindow]) -> int:
        """From sample ``k`` while an event is open: its ringing samples up to the re-arm, if this chunk
        holds it (a capped window held back is then decided); the index to go on from."""
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
        elif ringing.held is not None:
            decided.append(ringing.held)
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
            ringing.held, ringing.returned = self._closed(ringing), True
        if ringing is not None and ringing.held is not None and now - self._cap(ringing) > self.settings.max_window:
            decided.append(self._never_rearmed(ringing.held))
            ringing.held = None


def _holds(magnitude: NDArray[np.float64], level: float) -> bool:
    """Whether a trigger holds over its hold time (``|a|`` per channel from the trigger sample on): two or more
    channels above ``level``, or one channel above it at each of its two or more samples there."""
    finite, above = np.isfinite(magnitude), magnitude > level
    if np.count_nonzero(above.any(axis=1)) >= 2:
        return True
    return bool(np.any((np.count_nonzero(finite, axis=1) >= 2) & np.all(above | ~finite, axis=1)))


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


@dataclass(frozen=True)
class EventSearch:
    """What :func:`search_events` found: the events, each channel's noise in the quiet stretches (m/s²), the loudest
    channel and its largest ``|a − b|`` (m/s²), the spikes ignored, and the triggers outside the span every recorder
    covers, with that span and each file's (s)."""

    settings: TriggerSettings
    events: list[Event]
    noise: dict[str, float]
    loudest: tuple[str, float]
    glitches: int
    first_glitches: tuple[tuple[float, str], ...]
    outside_span: tuple[float, ...]
    span: tuple[float, float]
    file_spans: dict[str, tuple[float, float]]

    def notes(self) -> list[str]:
        """The search's warnings for the run to print: spikes ignored, triggers outside the recorders' common span."""
        notes = []
        if self.glitches:
            named = ", ".join(f"{probe} at {time:.4f} s" for time, probe in self.first_glitches)
            more = f" and {self.glitches - len(self.first_glitches)} more" if self.glitches > len(self.first_glitches) else ""
            notes.append(f"{self.glitches} spike(s) above the trigger on one channel, held less than hold = {self.settings.hold * 1e3:g} ms, "
                         f"ignored (no event): {named}{more}")
        if self.outside_span:
            times = ", ".join(f"{t:.4g}" for t in self.outside_span[:GLITCHES_NAMED]) + (" …" if len(self.outside_span) > GLITCHES_NAMED else "")
            spans = "; ".join(f"{name} {lo:.6g}–{hi:.6g} s" for name, (lo, hi) in self.file_spans.items())
            notes.append(f"{len(self.outside_span)} trigger(s) (at {times} s) fell outside the span every recorder covers, "
                         f"{self.span[0]:.6g}–{self.span[1]:.6g} s ({self.span[1] - self.span[0]:.3g} s): no event there; the recorders "
                         f"cover {spans} (check their clock_offset)")
        return notes

    def no_event_reason(self) -> str:
        """Why there is no event: triggers only outside the common span, only spikes, or no channel above the trigger."""
        if self.outside_span:
            return f"every trigger fell outside the span every recorder covers ({self.span[0]:.6g}–{self.span[1]:.6g} s): the recorders' spans barely overlap"
        if self.glitches:
            return f"the only samples above the trigger {self.settings.level:g} m/s² were spikes on one channel, held less than {self.settings.hold * 1e3:g} ms"
        probe, largest = self.loudest
        return (f"no channel exceeds the trigger level {self.settings.level:g} m/s² once its baseline is removed "
                f"(largest |a − baseline|: {largest:.3g} m/s² on {probe})")


def trigger_in_noise(level: float, noise: Mapping[str, float]) -> str | None:
    """The flag of the events of a stream whose trigger ``level`` (m/s²) lies below :data:`NOISE_MARGIN` σ of a channel's
    noise (``noise``: channel → σ, m/s², in the stream's quiet stretches), or None."""
    noisy = {probe: sigma for probe, sigma in noise.items() if math.isfinite(sigma) and level < NOISE_MARGIN * sigma}
    if not noisy:
        return None
    named = ", ".join(f"{probe} σ = {sigma:.3g} m/s²" for probe, sigma in noisy.items())
    return (f"trigger in the noise: trigger = {level:g} m/s² is below {NOISE_MARGIN:g} σ of the noise in the quiet stretches "
            f"({named}); noise alone crosses it, the event may be noise")


def event_grid(start: float, end: float, rate: float) -> NDArray[np.float64]:
    """The event's grid ``t_k = start + k / rate`` (s) up to ``end``."""
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"rate must be positive (Hz), got {rate!r}")
    return start + np.arange(int(math.floor((end - start) * rate + 1e-9)) + 1) / rate


def window(recordings: Recordings, event: Event, rate: float | None = None) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    """``(t, {probe: a})``: the event's records held whole linearly interpolated onto its grid (:func:`event_grid`;
    ``rate`` None: the highest channel rate), as :class:`femref.sensing.stream.EventStream` cuts them from its buffers."""
    rate = max(channel.rate for channel in recordings.channels.values()) if rate is None else rate
    t = event_grid(event.start, event.end, rate)
    return t, {probe: np.interp(t, channel.time, channel.acceleration) for probe, channel in recordings.channels.items()}


__all__ = ["HOLD", "MAX_WINDOW", "NOISE_MARGIN", "QUIET", "REARM_FRACTION", "Event", "EventSearch", "EventTrigger", "EventWindow",
           "TriggerSettings", "event_grid", "trigger_in_noise", "window"]
