"""The work budget of a measured scene: events × estimators × the event grid (docs/design.md §3.5).

A measured run streams its records, finds the events in them, and runs every estimator on each event's window,
resampled onto one grid at the fastest channel's rate (:func:`femref.sensing.trigger.event_grid`). Its cost is

    work   = Σ over events of the event's grid samples × the per-sample cost of every estimator (:func:`event_cost`)
    memory = the stream's buffers (:func:`stream_memory`) + the largest event (events are written as they finish)

The number of events is unknown before the stream is read, so the budget is checked in two steps (docs/design.md
§3.5, "Measured scenes"): **before any work**, one event at its largest, a window of ``events.max_window`` on the
fastest record's grid (:func:`measured_costs`); **as the events are found**, each before its estimators run
(:class:`EventBudget`: the event alone, and the events so far together). Both refuse as
:func:`femref.run.costs.check_costs` does.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

from femref.case.errors import CaseError, Problem
from femref.run.costs import Cost, check_costs
from femref.sensing.baseline import BLOCK, half_blocks
from femref.sensing import record_files
from femref.sensing.recordings import RecordError, RecordFile, probe_recorder
from femref.sensing.stream import BUFFER_MARGIN

if TYPE_CHECKING:
    from femref.scene.measured import MeasuredScene
    from femref.sensing.trigger import Event

_BYTES = 8.0  # a float64

#: Typical settings of a measured case: beyond them a key drives the cost (its factor is the ratio).
_TYPICAL_RATE, _TYPICAL_POST, _TYPICAL_WINDOW, _TYPICAL_EVENTS = 1.0e3, 0.5, 5.0, 100
_TYPICAL_KALMAN_STATES = 37  # four modes per car, a 4th-order anti-alias filter on five channels
#: Force rates the kalman filter runs side by side in its likelihood search (reduced.kalman.estimate_force).
_KALMAN_BATCH = 15


@dataclass(frozen=True)
class RecordSize:
    """A recorder as the budget sees it: its rate (Hz), its channels, and the key that sets the rate
    (``records.<i>.time.rate`` when the case declares it, ``records.<i>.file`` when the file's times do)."""

    rate: float
    channels: int
    key: str


def record_size(record: RecordFile, index: int) -> RecordSize:
    """The size of ``record``: its channels and rate (Hz), declared, or as validation probed it, or from its first
    file's first chunk (:func:`femref.sensing.recordings.probe_recorder`). RecordError for a file that cannot be read
    as declared."""
    key = f"records.{index}.time.rate" if record.time.rate is not None else f"records.{index}.{'files' if record.files else 'file'}"
    rate = record.time.rate or record.probed_rate or probe_recorder(record).rate
    return RecordSize(rate, len(record.channels), key)


def stream_memory(rate: float, channels: int, max_window: float) -> float:
    """The bytes a stream holds at most (s, Hz): per channel and its recorder's times, the chunk read ahead, the samples
    merged and not yet through the baseline (a chunk and its delay ``(H + 1.5) B``) and the buffer an event is cut from
    (a chunk, its window, the baseline's delay and :data:`~femref.sensing.stream.BUFFER_MARGIN`)."""
    delay = (half_blocks() + 1.5) * BLOCK
    samples = 3 * record_files.CHUNK_SAMPLES + rate * (2 * delay + max_window + BUFFER_MARGIN)
    return _BYTES * samples * (channels + 1)


def kalman_states(scene: MeasuredScene) -> int:
    """The kalman filter's state size: ``2 × modes`` (each elastic mode's displacement and rate) for each car a
    coupler joins, one force per coupler, and the anti-alias filter's ``order`` states of each of their recorded
    channels that declares one (:mod:`reduced.kalman`)."""
    filters = sum(f.order for probe, f in _kalman_filters(scene).items() if f is not None)
    return 2 * len(_kalman_cars(scene)) * scene.kalman.modes + len(scene.couplers) + filters


def _kalman_cars(scene: MeasuredScene) -> set[str]:
    """The names of the cars the couplers join (the kalman model's cars)."""
    return {scene.cars[i].name for coupler in scene.couplers for i in (coupler.rear, coupler.front)}


def _kalman_filters(scene: MeasuredScene) -> dict:
    """The anti-alias filter (or None) of each recorded channel of the kalman model's cars."""
    cars = _kalman_cars(scene)
    return {probe: f for probe, f in scene.anti_alias.items() if probe.split("/")[0] in cars}


def event_cost(scene: MeasuredScene, samples: int, channels: int, rate: float, what: str = "") -> Cost:
    """One event on a grid of ``samples`` times × ``channels`` (``rate`` Hz): its work and the memory it holds.
    Per sample (work units, measured on the reference machine and rounded up; kalman on 1075 – 17 185 samples with
    29 – 85 states, checked against a run in tests/measured/test_measured_scale.py)::

        every event     1e-6 s per channel + 2e-5 s (window, offsets, classification, closing speed, closure)
        inverse_rigid   1e-6 s;  inverse_quasi_rigid 2e-6 s (+ 0.05 s set-up)
        kalman          1e-4 s + 5e-8 s × n² + (1 + corners) × 2e-5 s   (n states, kalman_states; the likelihood
                        search over 15 force rates side by side, then the smoother of the nominal cars and of each
                        tolerance corner: frequency × (1 ± tolerance) × each damping factor, in a line of N ≥ 3 cars
                        each car's two mass corners and a step and a ramp per coupler for its contact instant)
        network         2e-4 s (the contact instant from a kalman filter at the event's force rate)

    Memory: the window's records three times (read, offset-removed, kept), four histories per estimator and coupler,
    and the kalman search's batch, ``15 × (3n + 4m)`` values a sample (``m`` channels of the filtered cars)."""
    couplers = len(scene.couplers)
    work = samples * (1e-6 * channels + 2e-5)
    memory = _BYTES * samples * (3 * channels + 4 * couplers * (len(scene.estimators) + len(scene.networks)))
    for name in scene.estimators:
        if name == "inverse_rigid":
            work += 1e-6 * samples
        elif name == "inverse_quasi_rigid":
            work += 2e-6 * samples + 0.05
        elif name == "kalman":
            n, m = kalman_states(scene), len(_kalman_filters(scene))
            corners = len({1.0 - scene.kalman.frequency_tolerance, 1.0 + scene.kalman.frequency_tolerance}) * len(set(scene.kalman.damping_factors))
            line = len(_kalman_cars(scene))
            corners += 2 * line + 2 * len(scene.couplers) if line > 2 else 0
            work += samples * (1e-4 + 5e-8 * n**2 + (1 + corners) * 2e-5)
            memory += _BYTES * samples * (_KALMAN_BATCH * (3 * n + 4 * m) + 4 * n)
    if scene.networks:
        n = kalman_states(scene)
        work += len(scene.networks) * 2e-4 * samples
        memory = max(memory, _BYTES * samples * (3 * channels + 8 * n))
    factors: dict[str, tuple[float, object]] = {
        "events.post": (scene.post / _TYPICAL_POST, scene.post),
        "events.max_window": (scene.max_window / _TYPICAL_WINDOW, scene.max_window),
    }
    if "kalman" in scene.estimators:
        factors["kalman.modes"] = ((kalman_states(scene) / _TYPICAL_KALMAN_STATES) ** 2, scene.kalman.modes)
    size = f"{samples:.3g} samples × {channels} channels ({samples / rate:.3g} s at {rate:.4g} Hz) × {len(scene.estimators) + len(scene.networks)} estimators"
    return Cost("event", work, memory, size, factors, what=what or "one event")


def measured_costs(scene: MeasuredScene) -> list[Cost]:
    """What ``femref run`` of a measured ``scene`` costs at most per event, before any work (module docstring): the
    largest event grid (:func:`event_cost`) with the stream's buffers (:func:`stream_memory`)."""
    sizes = []
    for i, record in enumerate(scene.records):
        try:
            sizes.append(record_size(record, i))
        except RecordError as error:  # a record built without validation, unreadable as declared
            raise CaseError(Problem(("records", i), str(error))) from None
    fastest = max(sizes, key=lambda s: s.rate)
    samples = int(scene.max_window * fastest.rate) + 1
    channels = sum(s.channels for s in sizes)
    cost = event_cost(scene, samples, channels, fastest.rate,
                      what=f"one event (a window of events.max_window = {scene.max_window:g} s at the records' {fastest.rate:.4g} Hz)")
    cost.memory += stream_memory(fastest.rate, channels, scene.max_window)
    cost.factors[fastest.key] = (fastest.rate / _TYPICAL_RATE, f"{fastest.rate:.4g} Hz")
    return [cost]


@dataclass
class EventBudget:
    """The budget of the events a stream finds, checked as each is found, before its estimators run (module
    docstring): :meth:`check` raises :class:`CaseError` at ``source`` naming the key driving one event alone over it,
    or ``records`` when the events so far are. ``rate`` (Hz): the events' grid; ``rate_key``: the key that sets it."""

    scene: MeasuredScene
    rate: float
    channels: int
    rate_key: str
    source: str = "<case>"
    count: int = 0
    work: float = 0.0
    largest: Cost | None = None

    def check(self, event: Event) -> Cost:
        """Add ``event`` (refused as the module docstring says); the total so far."""
        scene, rate = self.scene, self.rate
        held = stream_memory(rate, self.channels, scene.max_window)
        cost = event_cost(scene, int((event.end - event.start) * rate) + 1, self.channels, rate, what=f"event {event.index} ({event.end - event.start:.3g} s)")
        cost.factors[self.rate_key] = (rate / _TYPICAL_RATE, f"{rate:.4g} Hz")
        check_costs([dataclasses.replace(cost, memory=cost.memory + held)], self.source, cost.title)
        self.count, self.work = self.count + 1, self.work + cost.work
        if self.largest is None or cost.memory > self.largest.memory:
            self.largest = cost
        largest, n = self.largest, self.count
        total = Cost("events", self.work, largest.memory + held,
                     f"{n} events up to {event.end:.4g} s of records, the largest {largest.size}",
                     {"records": (n / _TYPICAL_EVENTS, f"{n} events")}, what=f"the run of the first {n} events found")
        check_costs([total], self.source, "the events")
        return total


__all__ = ["EventBudget", "RecordSize", "event_cost", "kalman_states", "measured_costs", "record_size", "stream_memory"]
