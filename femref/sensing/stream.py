"""The recorders' streams merged, searched for events and each event cut, in memory bounded by the chunk, not the stream.

:class:`EventStream` pulls each recorder's chunks (:class:`femref.sensing.recordings.RecorderReader`, or a recorder
held whole, :class:`HeldRecorder`) and merges them onto the union of their sample times (``(t, {probe: a})``, NaN
where a channel has no sample; a recorder whose clock is estimated mapped onto the reference's first,
:mod:`femref.sensing.clock`), up to the earliest last time any recorder still running has given. The merged chunks go
through each channel's baseline (:class:`femref.sensing.baseline.RunningBaseline`), the noise meter and the trigger
(:class:`femref.sensing.trigger.EventTrigger`), state machines that give the same answers for any cutting of the
stream. Each window the trigger decides becomes an event at once:

* clipped to the span every recorder covers (flagged ``truncated``; a window wholly outside it is no event), flagged
  with the quality stretches of each channel that overlap it (:mod:`femref.sensing.quality`) and, when the trigger
  lies within the noise measured so far, ``trigger in the noise``;
* its lag measured and each estimated clock's fit updated (:mod:`femref.sensing.clock`);
* its records interpolated onto one grid at the highest rate from a buffer of each recorder's last samples — from
  ``pre`` before the earliest window the trigger may still return (:meth:`EventTrigger.earliest_start`) less
  :data:`BUFFER_MARGIN`: an event across a chunk or file boundary is cut whole, exactly as from the records held whole.

What stays in memory is a chunk per recorder, the buffers (the baseline's delay, a chunk and a window), the quality
stretches there and each event's summary: not the stream.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from femref.sensing.baseline import NoiseMeter, RunningBaseline
from femref.events import ClockCorrection
from femref.sensing.clock import INITIAL_SEARCH, ClockTrack, lag_signal, measure_lag
from femref.sensing.quality import QualityInterval
from femref.sensing.record_files import CHUNK_SAMPLES
from femref.sensing.recordings import Channel, Recordings
from femref.sensing.trigger import Event, EventSearch, EventWindow, EventTrigger, TriggerSettings, event_grid, trigger_in_noise

BUFFER_MARGIN = 1.0 + INITIAL_SEARCH
"""Seconds kept before the earliest window the trigger may still return: a sample on each side of a window for the
interpolation, and an estimated clock's search."""

Chunk = tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]


class Quality(Protocol):
    def intervals(self, channel: int) -> list[QualityInterval]: ...

    def prune(self, before: float) -> None: ...


class Recorder(Protocol):
    """A recorder's stream as :class:`EventStream` reads it (:class:`~femref.sensing.recordings.RecorderReader`)."""

    rate: float | None
    first_time: float
    last_time: float
    samples: int
    bytes: int
    files: int
    restarts: list[QualityInterval]
    quality: Quality

    @property
    def probes(self) -> list[str]: ...

    def chunks(self) -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]: ...


@dataclass
class _HeldQuality:
    channels: list[Channel]

    def intervals(self, channel: int) -> list[QualityInterval]:
        return list(self.channels[channel].quality)

    def prune(self, before: float) -> None:
        pass


class HeldRecorder:
    """The channels of a :class:`~femref.sensing.recordings.Recordings` that share one time axis (a recorder), given
    in chunks of ``samples``."""

    def __init__(self, channels: list[Channel], samples: int = CHUNK_SAMPLES) -> None:
        self.channels, self.size = channels, samples
        self.time = channels[0].time
        self.rate: float | None = max(c.rate for c in channels)
        self.first_time, self.last_time = float(self.time[0]), float(self.time[-1])
        self.samples, self.bytes, self.files = self.time.size, 0, 0
        self.restarts: list[QualityInterval] = []
        self.quality = _HeldQuality(channels)

    @property
    def probes(self) -> list[str]:
        return [c.probe for c in self.channels]

    def chunks(self) -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        values = np.array([c.acceleration for c in self.channels])
        for first in range(0, self.time.size, self.size):
            yield self.time[first:first + self.size], values[:, first:first + self.size]


def held_recorders(recordings: Recordings, samples: int = CHUNK_SAMPLES) -> list[HeldRecorder]:
    """The recorders of ``recordings``: its channels grouped by their time axis, in the order declared."""
    groups: dict[int, list[Channel]] = {}
    for channel in recordings.channels.values():
        groups.setdefault(id(channel.time), []).append(channel)
    return [HeldRecorder(channels, samples) for channels in groups.values()]


@dataclass
class _Lane:
    """One recorder in the merge: its chunks, its baseline and noise meter, the samples less their baseline not yet
    merged (``ready``, on the stream's clock), and the buffer of its last samples as recorded (its own clock, the
    stream's, values)."""

    recorder: Recorder
    name: str
    chunks: Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]
    track: ClockTrack | None
    baseline: RunningBaseline | None = None
    meter: NoiseMeter | None = None
    ready: tuple[NDArray[np.float64], NDArray[np.float64]] = field(default_factory=lambda: (np.empty(0), np.empty((0, 0))))
    finished: bool = False  # every sample is in ``ready`` or merged
    own: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    mapped: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    values: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 0)))
    ahead: tuple[NDArray[np.float64], NDArray[np.float64], list[QualityInterval]] | None = None  # the next chunk, read
    exhausted: bool = False  # no chunk beyond those pulled
    first: float = math.nan  # on the stream's clock
    last: float = math.nan


@dataclass(frozen=True)
class CutEvent:
    """An event as the stream decided it, its records on one grid (``time`` s, ``records`` m/s², as recorded) and
    each non-reference recorder's clock there."""

    event: Event
    time: NDArray[np.float64]
    records: dict[str, NDArray[np.float64]]
    clocks: tuple[ClockCorrection, ...] = ()


@dataclass(frozen=True)
class StreamStatistics:
    """What a stream read: samples (per channel, summed over recorders), bytes and files, and the gaps of its time axes."""

    samples: int
    bytes: int
    files: int
    gaps: int


class EventStream:
    """Iterate over the events of ``recorders``' streams as they are decided (module docstring); :attr:`search` and
    :attr:`statistics` once the iteration ends. ``names``: the recorders' names (clock reports); ``labels``: how the
    search's notes name their files; ``estimated``: which recorders' clocks are estimated against the first's; ``cut``:
    False to find the events without cutting them; ``on_chunk()`` is called after each chunk read."""

    def __init__(self, recorders: list[Recorder], settings: TriggerSettings, *, names: list[str] | None = None, labels: list[str] | None = None,
                 estimated: list[bool] | None = None, remove_baseline: bool = True, cut: bool = True, on_chunk: Callable[[], None] | None = None) -> None:
        self.on_chunk = on_chunk
        names = names or [f"recorder {k}" for k in range(len(recorders))]
        self.labels = labels or names
        estimated = estimated or [False] * len(recorders)
        self.lanes = [_Lane(r, name, r.chunks(), ClockTrack(name) if flag else None) for r, name, flag in zip(recorders, names, estimated)]
        self.settings, self.remove_baseline, self.cut = settings, remove_baseline, cut
        self.trigger = EventTrigger(settings)
        self.loudest: dict[str, float] = {}
        self.events: list[Event] = []
        self.outside: list[float] = []
        self.search: EventSearch | None = None
        self.statistics: StreamStatistics | None = None
        self._gaps = 0

    @property
    def rate(self) -> float:
        """The events' grid rate (Hz): the highest of the recorders'."""
        return max(lane.recorder.rate or 0.0 for lane in self.lanes)

    def noise(self) -> dict[str, float]:
        """Each channel's noise (m/s², :class:`~femref.sensing.baseline.NoiseMeter`) in the stream so far."""
        return {probe: sigma for lane in self.lanes if lane.meter is not None for probe, sigma in lane.meter.noise().items()}

    def __iter__(self) -> Iterator[CutEvent]:
        for t, values in self._merged():
            if t.size:
                yield from self._decided(self.trigger.feed(t, values))
                self._prune(self.trigger.earliest_start() - BUFFER_MARGIN)
        yield from self._decided(self.trigger.finish())
        first, last = self._span()
        noise = self.noise()
        self.search = EventSearch(self.settings, self.events, noise, max(self.loudest.items(), key=lambda item: item[1], default=("", 0.0)),
                                  self.trigger.glitches, tuple(self.trigger.first_glitches), tuple(self.outside), (first, last),
                                  {label: (lane.first, lane.last) for label, lane in zip(self.labels, self.lanes)})
        recorders = [lane.recorder for lane in self.lanes]
        self.statistics = StreamStatistics(sum(r.samples * len(r.probes) for r in recorders), sum(r.bytes for r in recorders),
                                           sum(r.files for r in recorders), self._gaps)

    def _merged(self) -> Iterator[Chunk]:
        """Each recorder's samples less their baseline (each recorder's own :class:`RunningBaseline` and
        :class:`NoiseMeter`, on blocks from the stream's first time: the medians of a channel's own samples, as on the
        merged stream) merged onto the union of their times, up to the earliest last time of a running one."""
        lanes = self.lanes
        for lane in lanes:
            self._read_ahead(lane)
        origin = min((lane.ahead[0][0] for lane in lanes if lane.ahead is not None and lane.ahead[0].size), default=0.0)
        for lane in lanes:
            lane.baseline = RunningBaseline(origin=origin) if self.remove_baseline else None
            lane.meter = NoiseMeter(origin=origin)
        while True:
            for lane in lanes:
                while not lane.finished and lane.ready[0].size == 0:
                    self._advance(lane)
            running = [lane.ready[0][-1] for lane in lanes if not lane.finished]
            cutoff = min(running) if running else math.inf
            parts = []
            for lane in lanes:
                t, a = lane.ready
                n = int(np.searchsorted(t, cutoff, side="right"))
                parts.append((t[:n], a[:, :n]))
                lane.ready = (t[n:], a[:, n:])
            if all(t.size == 0 for t, _ in parts):
                if all(lane.finished for lane in lanes):
                    return
                continue
            yield _union(parts, [lane.recorder.probes for lane in lanes])

    def _advance(self, lane: _Lane) -> None:
        """The lane's next chunk pulled, less its baseline into ``ready`` (the rest of it too once its last chunk is in)."""
        t, a = self._pull(lane) if not lane.exhausted else (np.empty(0), np.empty((len(lane.recorder.probes), 0)))
        pieces = []
        if lane.baseline is None:
            pieces.append((t, a))
        else:
            probes = lane.recorder.probes
            if t.size:
                pieces.append(lane.baseline.feed(t, {probe: a[k] for k, probe in enumerate(probes)}))
            if lane.exhausted:
                pieces.append(lane.baseline.finish())
            pieces = [(t, np.array([v[probe] for probe in probes]).reshape(len(probes), t.size)) for t, v in pieces if t.size]
        lane.finished = lane.exhausted
        for t, a in pieces:
            if not t.size:
                continue
            values = {probe: a[k] for k, probe in enumerate(lane.recorder.probes)}
            for probe, v in values.items():
                finite = np.abs(v[np.isfinite(v)])
                self.loudest[probe] = max(self.loudest.get(probe, 0.0), float(finite.max()) if finite.size else 0.0)
            assert lane.meter is not None
            lane.meter.feed(t, values)
            lane.ready = (t, a) if lane.ready[0].size == 0 else (np.concatenate([lane.ready[0], t]), np.concatenate([lane.ready[1], a], axis=1))

    def _read_ahead(self, lane: _Lane) -> None:
        """Read ``lane``'s next chunk (and the restarts found in it) ahead, so a lane knows its last chunk."""
        chunk = next(lane.chunks, None)
        lane.ahead = None if chunk is None else (*chunk, list(lane.recorder.restarts))
        lane.recorder.restarts.clear()
        lane.exhausted = chunk is None

    def _pull(self, lane: _Lane) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The chunk read ahead of ``lane``'s recorder on the stream's clock, into its buffer (restarts noted)."""
        assert lane.ahead is not None
        t, a, restarts = lane.ahead
        self._read_ahead(lane)
        for gap in restarts:
            self._gaps += 1
            for other in self.lanes:
                if other.track is not None and (other is lane or lane is self.lanes[0]):
                    other.track.restart(gap.end - (0.0 if other is lane else other.track.predict(gap.end)))
        mapped = t if lane.track is None else t + lane.track.stream_map(t)
        if math.isnan(lane.first):
            lane.first = float(mapped[0])
        lane.last = float(mapped[-1])
        if self.cut:
            lane.own = np.concatenate([lane.own, t])
            lane.mapped = np.concatenate([lane.mapped, mapped])
            lane.values = a if lane.values.size == 0 else np.concatenate([lane.values, a], axis=1)
        if self.on_chunk is not None:
            self.on_chunk()
        return mapped, a

    def _span(self) -> tuple[float, float]:
        """The span every recorder covers so far (s, stream clock): every window decided before the stream's end ends
        before every running recorder's last sample."""
        return max(lane.first for lane in self.lanes), min(lane.last for lane in self.lanes)

    def _decided(self, windows: list[EventWindow]) -> Iterator[CutEvent]:
        if not windows:
            return
        first, last = self._span()
        in_noise = trigger_in_noise(self.settings.level, self.noise())  # the noise so far: the same for the windows of one chunk
        for found in windows:
            start, end = max(found.start, first), min(found.end, last)
            if end <= start:
                self.outside.append(found.trigger_time)
                continue
            flags = (["truncated"] if start > found.start or end < found.end else []) + list(found.flags) + self._quality_flags(start, end)
            if in_noise is not None:
                flags.append(in_noise)
            event = Event(len(self.events), start, end, found.trigger_time, found.trigger_probe, tuple(flags))
            self.events.append(event)
            if self.cut:
                yield self._cut(event)

    def _quality_flags(self, start: float, end: float) -> list[str]:
        flags = []
        for lane in self.lanes:
            for k, probe in enumerate(lane.recorder.probes):
                for quality in lane.recorder.quality.intervals(k):
                    lo, hi = quality.start, quality.end
                    if lane.track is not None:
                        lo, hi = lo + lane.track.predict(lo), hi + lane.track.predict(hi)
                    if hi >= start and lo <= end:
                        flags.append(f"{quality.reason}: {probe} {lo:.6g}–{hi:.6g} s")
        return flags

    def _cut(self, event: Event) -> CutEvent:
        """The event's records on its grid (each estimated clock's lag measured and taken first)."""
        rate = self.rate
        t = event_grid(event.start, event.end, rate)
        clocks = [self._clock(lane, event, t, rate) for lane in self.lanes if lane.track is not None]
        corrections = {clock.recorder: clock.correction for clock in clocks}
        records: dict[str, NDArray[np.float64]] = {}
        for lane in self.lanes:
            grid = t if lane.track is None else t - corrections[lane.name]
            for k, probe in enumerate(lane.recorder.probes):
                records[probe] = np.interp(grid, lane.own, lane.values[k])
        return CutEvent(event, t, records, tuple(clocks))

    def _clock(self, lane: _Lane, event: Event, t: NDArray[np.float64], rate: float) -> ClockCorrection:
        """The lane's clock at the event: its lag measured against the reference recorder's, taken into its fit."""
        track = lane.track
        assert track is not None
        reference = self.lanes[0]
        at = event.trigger_time - track.predict(event.trigger_time)  # on the recorder's clock
        predicted, half = track.predict(at), track.search(at)
        k = int(math.ceil(half * rate))
        ref = lag_signal(t, np.array([np.interp(t, reference.own, reference.values[i]) for i in _first_car(reference.recorder.probes)]), rate)
        grid = t[0] - predicted - k / rate + np.arange(t.size + 2 * k) / rate
        other = lag_signal(grid, np.array([np.interp(grid, lane.own, lane.values[i]) for i in _first_car(lane.recorder.probes)]), rate)
        same_car = _car(reference.recorder.probes[0]) == _car(lane.recorder.probes[0])
        lag, rho = measure_lag(ref, other, rate, predicted, 1.0 if same_car else -1.0)
        taken = math.isfinite(lag) and track.take(at, lag)
        correction = track.predict(at)
        if not math.isfinite(lag):
            basis = f"no lag: the correlation peaks at ρ = {rho:.2f} (within ±{half:.3g} s of the prediction); the fit's prediction applied"
        elif not taken:
            basis = f"lag {lag:.6f} s (ρ = {rho:.2f}) lies off the fit: not taken; the fit's prediction applied"
        else:
            basis = f"cross-correlation of the cars' low-passed mean accelerations (ρ = {rho:.2f}); the fit of segment {track.segment_number(at)} (from the stream's start or a restart)"
        return ClockCorrection(lane.name, correction, track.drift_at(at), lag, lag - correction, basis)

    def _prune(self, before: float) -> None:
        """Drop the buffered samples and the quality stretches before ``before`` (s, stream clock), a sample kept."""
        for lane in self.lanes:
            lane.recorder.quality.prune(before if lane.track is None else before - lane.track.predict(before))
            if not self.cut or lane.mapped.size == 0:
                continue
            n = max(int(np.searchsorted(lane.mapped, before, side="left")) - 1, 0)
            if n > 0:
                lane.own, lane.mapped, lane.values = lane.own[n:], lane.mapped[n:], lane.values[:, n:]


def _car(probe: str) -> str:
    """The car of probe ``<car>/<sensor>``."""
    return probe.split("/")[0]


def _first_car(probes: list[str]) -> list[int]:
    """The indices of the probes (``<car>/<sensor>``) on the first car a recorder records."""
    return [i for i, probe in enumerate(probes) if _car(probe) == _car(probes[0])]


def _union(parts: list[tuple[NDArray[np.float64], NDArray[np.float64]]], probes: list[list[str]]) -> Chunk:
    """The recorders' samples ``parts`` on the union of their times, each channel NaN at the others' times (each part's
    times increase: one stable sort merges the runs in linear time)."""
    if len(parts) == 1:
        t, a = parts[0]
        return t, {probe: a[k] for k, probe in enumerate(probes[0])}
    joined = np.concatenate([t for t, _ in parts])
    order = np.argsort(joined, kind="stable")
    ordered = joined[order]
    new = np.empty(ordered.size, dtype=bool)
    new[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=new[1:])
    time = ordered[new]
    place = np.empty(ordered.size, dtype=np.int64)
    place[order] = np.cumsum(new) - 1  # each sample's index in ``time``
    values: dict[str, NDArray[np.float64]] = {}
    first = 0
    for (t, a), names in zip(parts, probes):
        at = place[first:first + t.size]
        first += t.size
        if t.size == time.size:
            values.update((probe, a[k]) for k, probe in enumerate(names))
            continue
        for k, probe in enumerate(names):
            column = np.full(time.size, np.nan)
            column[at] = a[k]
            values[probe] = column
    return time, values


def stream_chunks(recordings: Recordings, samples: int = CHUNK_SAMPLES) -> Iterator[Chunk]:
    """The records as one stream in chunks (at most ``samples`` of each recorder's times a chunk): ``(t, {probe: a})``
    on the union of the channels' sample times (s), each channel's samples at its own times and NaN at the others'."""
    stream = EventStream(held_recorders(recordings, samples), TriggerSettings(1.0, 0.0, 1.0), remove_baseline=False, cut=False)
    yield from stream._merged()


def search_events(recordings: Recordings, settings: TriggerSettings, *, remove_baseline: bool = True, samples: int = CHUNK_SAMPLES) -> EventSearch:
    """The events of records held whole (module docstring; each recorder in chunks of ``samples``), not cut; with
    ``remove_baseline`` false the trigger sees the records as they are."""
    recorders = held_recorders(recordings, samples)
    stream = EventStream(recorders, settings, labels=[r.channels[0].file for r in recorders], remove_baseline=remove_baseline, cut=False)
    for _ in stream:
        pass
    assert stream.search is not None
    return stream.search


__all__ = ["BUFFER_MARGIN", "CutEvent", "EventStream", "HeldRecorder", "Recorder", "StreamStatistics", "held_recorders", "search_events", "stream_chunks"]
