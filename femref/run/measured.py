"""A measured case, event by event: impact type, closing speed, ε, every estimator's force with its band,
the gear's closure, wear and alarm.

:func:`run_measured` streams the scene's recorders (:mod:`femref.sensing.recordings`) and takes each event as the
stream decides it (:class:`femref.sensing.stream.EventStream`: its records on one common time grid, each estimated
clock's correction), checks its cost against the work budget (:class:`femref.run.event_budget.EventBudget`) and:

* removes each channel's offset before the trigger and measures its noise there
  (:func:`femref.sensing.noise_gate.quiet_corrected`), and checks what the records say about themselves — each car's
  end sensors against each other, each channel's offset and drift (:func:`femref.sensing.diagnostics.diagnose`; its
  findings are the event's flags);
* classifies it from the zero-harmonic ratio of the relative acceleration of the first coupler's cars
  (:func:`femref.sensing.findings.classify_event`), or as ``not_an_impact`` when the cars' forces are not internal
  to the line or the coupler did not close (:func:`femref.sensing.findings.momentum_records`; not when a channel
  saturated): such an event keeps its records, window and flags and runs nothing further;
* runs the scene's estimators, plug-ins of one protocol (:func:`femref.estimators.plug_ins`: the inverse ones,
  ``kalman``, then the saved networks, each reading the records from the contact in the kalman force), each
  through :func:`femref.estimators.capture`, on the records and the noise;
* reads what the estimates tell (:mod:`femref.sensing.findings`): the closing speed (estimates beyond the force it
  allows made ``implausible``), ε, the calibrated bands (:meth:`femref.sensing.calibration.Calibration.band`), the
  gear's closure on each coupler, wear and alarm.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from femref.estimators import Estimator, Recorded, capture, plug_ins
from femref.events import EventResult
from femref.models import Progress, ProgressFor
from femref.run.event_budget import EventBudget
from femref.run.runner import load_one_off_imports
from femref.scene.measured import MeasuredScene
from femref.sensing import trigger
from femref.sensing import findings
from femref.sensing.diagnostics import diagnose
from femref.sensing.findings import stated_speed
from femref.sensing.noise_gate import quiet_corrected
from femref.sensing.recordings import RecorderReader
from femref.sensing.stream import CutEvent, EventStream, StreamStatistics
from reduced.signal_tools import NOT_AN_IMPACT


@dataclass
class MeasuredOutcome:
    """The scene, every event's result, how they were found and what the stream read."""

    scene: MeasuredScene
    events: list[EventResult]
    search: trigger.EventSearch
    """How the events were found (its notes are the run's warnings)."""
    streamed: bool = False
    """True when a sink took each event as it finished: ``events`` are then what it returned."""
    stream: StreamStatistics | None = None
    """What the stream read: samples, bytes, files, gaps."""


#: The progress label while the record files are read (``(bytes read, bytes in all)``).
READ_LABEL = "read records"


def run_measured(scene: MeasuredScene, progress_for: ProgressFor | None = None, sink: Callable[[EventResult], EventResult] | None = None,
                 source: str = "<case>") -> MeasuredOutcome:
    """Every event of the scene's records (module docstring), each as soon as the stream decides it.

    ``progress_for(label)``, if given, is called when a stage starts — :data:`READ_LABEL` (its callback gets the bytes
    read and the bytes of all files as the stream goes), then :func:`event_label` for each event — and the callback it
    may return gets ``(done, total)`` after each step of that stage. ``sink(event)``, if given, takes each event's full
    result as soon as it is done and returns what the outcome keeps (``femref run``'s
    :class:`femref.events.EventWriter`: its summary, so memory does not grow with the events). Over the work budget: a
    :class:`~femref.case.CaseError` at ``source``; a record broken further in than validation looked: a RecordError.
    """
    settings = trigger.TriggerSettings(scene.trigger, scene.pre, scene.post, scene.rearm, scene.quiet, scene.max_window)
    estimators = plug_ins(scene)
    load_one_off_imports(scene.kind, scene.estimators)
    readers = [RecorderReader(record) for record in scene.records]
    total = sum(path.stat().st_size for record in scene.records for path in record.paths if path.exists())
    read = progress_for(READ_LABEL) if progress_for else None
    stream = EventStream(readers, settings, names=[r.name for r in scene.records], labels=[r.label for r in scene.records],
                         estimated=[r.estimated_clock for r in scene.records],
                         on_chunk=None if read is None else lambda: read(sum(r.bytes for r in readers), total))
    budget: EventBudget | None = None
    events = []
    for number, cut in enumerate(stream, start=1):
        if budget is None:
            fastest = max(range(len(readers)), key=lambda i: readers[i].rate or 0.0)
            record = scene.records[fastest]
            key = f"records.{fastest}.time.rate" if record.time.rate is not None else f"records.{fastest}.{'files' if record.files else 'file'}"
            budget = EventBudget(scene, stream.rate, sum(len(r.channels) for r in scene.records), key, source)
        budget.check(cut.event)
        step = progress_for(event_label(number, None, cut.event.trigger_time)) if progress_for else None
        result = event_result(scene, estimators, cut, step)
        events.append(result if sink is None else sink(result))
    if read is not None:
        read(total, total)
    assert stream.search is not None
    return MeasuredOutcome(scene, events, stream.search, streamed=sink is not None, stream=stream.statistics)


def event_label(number: int, count: int | None, trigger_time: float) -> str:
    """How progress names an event: ``event 2/7 at 3.603 s`` (its trigger time on the records' clock), ``event 2 at
    3.603 s`` while the count is not known."""
    of = "" if count is None else f"/{count}"
    return f"event {number}{of} at {trigger_time:.3f} s"


def event_result(scene: MeasuredScene, estimators: list[Estimator], cut: CutEvent, progress: Progress | None = None) -> EventResult:
    """One event's result from its records as cut (module docstring): what :func:`run_measured` does with each event the
    stream decides, and what a window cut by hand from the files is run through to check the stream
    (benchmarks/bench_stream.py); ``progress(done, total)`` after its classification and each estimator."""
    cars, couplers, event, t = scene.cars, scene.couplers, cut.event, cut.time
    records, noise_std, quiet = quiet_corrected(t, cut.records, event.trigger_time)
    result = EventResult(index=event.index, start=event.start, end=event.end, trigger_time=event.trigger_time,
                         trigger_probe=event.trigger_probe, flags=tuple(event.flags), time=t, records=records, clock_corrections=cut.clocks)
    diagnosed = diagnose(cars, t, cut.records, records, quiet, event.trigger_time)
    result.diagnostics, result.flags = diagnosed.record(), (*result.flags, *diagnosed.flags)
    saturated = [flag for flag in event.flags if flag.startswith("saturated")]
    tolerances = [scene.kalman.mass_tolerance_of(k)[0] for k in range(len(cars))]
    found = findings.classify_event(cars, couplers[0], t, records, noise_std, tolerances, bool(saturated))
    result.impact_type, result.zero_harmonic_ratio, result.classification_confidence = found.kind, found.zero_frequency_ratio, found.confidence
    result.classification_basis = found.basis
    if found.not_classified:
        result.flags = (*result.flags, f"not classified: {found.not_classified}")
    if found.momentum is not None:
        m = found.momentum
        result.momentum_ratio, result.momentum_threshold, result.velocity_change, result.velocity_change_noise = (
            m.ratio, m.threshold, m.velocity_change, m.velocity_noise)
    if found.kind == NOT_AN_IMPACT:
        return _not_an_impact(result, progress)
    total = len(estimators) + 1
    if progress is not None:
        progress(1, total)
    recorded = Recorded(t, records, cars, couplers, noise_std, result.impact_type, earlier=result.estimates)
    for done, estimator in enumerate(estimators, start=2):
        result.estimates.extend(capture(estimator, recorded))
        if progress is not None:
            progress(done, total)
    stated = stated_speed(scene.closing_speeds, event.start, event.end)
    speed, first = findings.checked_closing_speed(cars, couplers, stated, result.estimates, quiet, result.impact_type)
    result.closing_speed, result.closing_speed_lower, result.closing_speed_upper = speed.value, speed.lower, speed.upper
    result.closing_speed_source, result.closing_speed_basis = speed.source, speed.basis
    if first is not None:
        result.epsilon = findings.epsilon(cars, first)
    if scene.calibration is not None:
        filters = {probe: None if declared is None else declared.corner for probe, declared in scene.anti_alias.items()}
        scene.calibration.band(result.estimates, (speed.lower, speed.upper), {car.name: car.mass for car in cars}, filters, quiet, result.impact_type)
    primary = findings.primary(couplers, result.estimates)
    result.closures = [findings.closure(cars, couplers, coupler, primary, speed.value) for coupler in couplers if coupler.name in primary]
    implausible = [e for e in result.estimates if e.status == "implausible"]
    result.alarm, result.alarm_basis = findings.alarm(scene.checks.alarm, list(primary.values()), saturated, implausible)
    result.wear, result.wear_basis = findings.wear(scene.checks.rated_closure_force, scene.checks.wear_tolerance, result.closures)
    return result


def _not_an_impact(result: EventResult, progress: Progress | None) -> EventResult:
    """``result`` of a transient that is no coupler impact: no estimator run, no closing speed, no closure, alarm none."""
    why = "not an impact (its type's evidence): no estimator run"
    result.closing_speed_basis, result.alarm_basis, result.wear_basis = why, why, why
    if progress is not None:
        progress(1, 1)
    return result


__all__ = ["READ_LABEL", "MeasuredOutcome", "event_label", "event_result", "run_measured"]
