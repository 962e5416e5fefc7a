"""The work budget of a measured scene: events × estimators × the event grid (docs/design.md §3.5).

A measured run reads its records, finds the events in them, and runs every estimator on each event's window,
resampled onto one grid at the fastest channel's rate (:func:`femref.sensing.trigger.window`). Its cost is

    work   = Σ over events of the event's grid samples × the per-sample cost of every estimator (:func:`event_cost`)
    memory = the records held + the largest event (events are written as they finish and not kept)

The number of events is unknown before the trigger runs, so the budget is checked twice (docs/design.md §3.5,
"Measured scenes"): **before any work**, one event at its largest, a window of ``events.max_window`` on the fastest
record's grid (:func:`measured_costs`); **once the trigger has run**, before the first event's estimators, the events
found, each on its own window (:func:`check_events`: counted exactly, where a bound from the stream's length over
the shortest event spacing would refuse every long stream for events it does not hold). Both refuse as
:func:`femref.run.costs.check_costs` does.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

from femref.case.errors import CaseError, Problem
from femref.run.costs import Cost, check_costs
from femref.sensing.recordings import RecordError, RecordFile, Recordings, read_record_file

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
    """A record file as the budget sees it: its samples, its rate (Hz), its channels, and the key that sets the rate
    (``records.<i>.time.rate`` when the case declares it, ``records.<i>.file`` when the file's times do)."""

    samples: int
    rate: float
    channels: int
    key: str


def record_size(record: RecordFile, index: int) -> RecordSize:
    """The size of ``record``: its samples and its fastest channel's rate (Hz), from what validation read of it
    (``record.kept``), or — a record built without validation — from reading it with the record reader
    (:func:`femref.sensing.recordings.read_record_file`, with its limits). RecordError for a file that cannot be read
    as declared."""
    key = f"records.{index}.time.rate" if record.time.rate is not None else f"records.{index}.file"
    channels = (record.kept if record.kept is not None else read_record_file(record)).channels
    return RecordSize(max(c.acceleration.size for c in channels), max(c.rate for c in channels), len(record.channels), key)


def kalman_states(scene: MeasuredScene) -> int:
    """The kalman filter's state size: ``2 × modes`` (each elastic mode's displacement and rate) for each car of the
    first coupler, the force, and the anti-alias filter's ``order`` states of each of their recorded channels that
    declares one (:mod:`reduced.kalman`)."""
    filters = sum(f.order for probe, f in _kalman_filters(scene).items() if f is not None)
    return 2 * 2 * scene.kalman.modes + 1 + filters


def _kalman_filters(scene: MeasuredScene) -> dict:
    """The anti-alias filter (or None) of each recorded channel of the first coupler's two cars."""
    coupler = scene.couplers[0]
    cars = {scene.cars[coupler.rear].name, scene.cars[coupler.front].name}
    return {probe: f for probe, f in scene.anti_alias.items() if probe.split("/")[0] in cars}


def event_cost(scene: MeasuredScene, samples: int, channels: int, rate: float, what: str = "") -> Cost:
    """One event on a grid of ``samples`` times × ``channels`` (``rate`` Hz): its work and the memory it holds.
    Per sample (work units, measured on the reference machine and rounded up; kalman on 1075 – 17 185 samples with
    29 – 85 states, checked against a run in tests/measured/test_measured_scale.py)::

        every event     1e-6 s per channel + 2e-5 s (window, offsets, classification, closing speed, closure)
        inverse_rigid   1e-6 s;  inverse_quasi_rigid 2e-6 s (+ 0.05 s set-up)
        kalman          1e-4 s + 5e-8 s × n² + (1 + corners) × 2e-5 s   (n states, kalman_states; the likelihood
                        search over 15 force rates side by side, then the smoother of the nominal cars and of each
                        tolerance corner: frequency × (1 ± tolerance) × each damping factor)
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
    largest event grid (:func:`event_cost`) with the records it reads (:func:`record_size`)."""
    sizes = []
    for i, record in enumerate(scene.records):
        try:
            sizes.append(record_size(record, i))
        except RecordError as error:  # a record built without validation, unreadable as declared
            raise CaseError(Problem(("records", i), str(error))) from None
    fastest = max(sizes, key=lambda s: s.rate)
    samples = int(scene.max_window * fastest.rate) + 1
    cost = event_cost(scene, samples, sum(s.channels for s in sizes), fastest.rate,
                      what=f"one event (a window of events.max_window = {scene.max_window:g} s at the records' {fastest.rate:.4g} Hz)")
    cost.memory += sum(_BYTES * s.samples * (s.channels + 1) for s in sizes)  # the records as read: times and channels
    cost.factors[fastest.key] = (fastest.rate / _TYPICAL_RATE, f"{fastest.rate:.4g} Hz")
    return [cost]


def check_events(scene: MeasuredScene, recordings: Recordings, events: list[Event], source: str = "<case>") -> Cost:
    """Refuse the events the trigger found when their total exceeds the budget (module docstring): raises
    :class:`CaseError` naming ``records`` or, when one event alone is over, the key driving it; returns the total."""
    fastest = max(recordings.channels.values(), key=lambda c: c.rate)
    rate, channels = fastest.rate, len(recordings.channels)
    index = next((i for i, record in enumerate(scene.records) if record.path.name == fastest.file), 0)
    rate_key = f"records.{index}.time.rate" if scene.records[index].time.rate is not None else f"records.{index}.file"
    times = {id(c.time): c.time.size for c in recordings.channels.values()}  # one time axis per recorder, shared by its channels
    held = _BYTES * (sum(times.values()) + sum(c.acceleration.size for c in recordings.channels.values()))
    costs = [event_cost(scene, int((e.end - e.start) * rate) + 1, channels, rate, what=f"event {e.index} ({e.end - e.start:.3g} s)") for e in events]
    if not costs:
        return Cost("events", 0.0, held, "no event")
    largest = max(costs, key=lambda c: c.memory)
    first, last = recordings.span
    total = Cost("events", sum(c.work for c in costs), largest.memory + held,
                 f"{len(events)} events in {last - first:.4g} s of records, the largest {largest.size}",
                 {"records": (len(events) / _TYPICAL_EVENTS, f"{len(events)} events")}, what=f"the run of the {len(events)} events found")
    for cost in (max(costs, key=lambda c: c.work), largest):  # one event alone over: its own keys
        cost.factors[rate_key] = (rate / _TYPICAL_RATE, f"{rate:.4g} Hz")
        check_costs([dataclasses.replace(cost, memory=cost.memory + held)], source, cost.title)
    check_costs([total], source, "the events")
    return total


__all__ = ["RecordSize", "check_events", "event_cost", "kalman_states", "measured_costs", "record_size"]
