"""A measured case, event by event: impact type, closing speed, ε, every estimator's force with its band,
the gear's closure, wear and alarm.

:func:`run_measured` reads the scene's record files (:mod:`femref.sensing.recordings`),
cuts the stream into events (:func:`femref.sensing.events.search_events`) and for each event,
on one common time grid (:func:`femref.sensing.events.window`):

* removes each channel's offset (the median over the ``pre`` window before the trigger: the
  cars are at rest or rolling freely there, their acceleration zero) and measures its noise
  there (1.4826 × the median absolute deviation, with its effective sample count:
  :func:`femref.sensing.noise_gate.quiet_noise`);
* classifies it from the zero-harmonic ratio of the relative acceleration of the first
  coupler's cars (:func:`femref.sensing.impact_type.classify_records`);
* runs every estimator: ``inverse_rigid`` and ``inverse_quasi_rigid``
  (:mod:`femref.models.inverse`; with the case's calibration file a calibrated band inside the
  calibrated ranges, otherwise ``bound = none``) and ``kalman``
  (:func:`kalman_estimate`, bands from the smoothed covariance widened by the declared cars'
  tolerances, ``bound = covariance``; the recorders' declared anti-alias filters in its model),
  then the saved networks (:func:`network_estimate`: a peak from the records started at the
  contact found in the kalman force);
* takes the **primary** estimate — the first estimator of the case's list with a force
  history, a number and a bound, else the first with a history and a number — for the closing
  speed, ε, the gear's closure, the wear and the alarm:

  - closing speed with an interval (:func:`femref.sensing.closing_speed.from_force`): the mean over
    the contact of the relative velocity the force gives the cars, ``(1/T) ∫ ∫ P/m* dt dt``, raised
    by at most the stroke left at separation; or the speed the case gives for the event
    (``events.closing_speed``), which replaces it;
  - ``ε = T_wave / T_load``, ``T_wave = l/c`` the longest wave travel time of the cars and
    ``T_load = π √(∫P² / ∫Ṗ²)`` the pulse's time scale (NaN when a car has no body);
  - closure: :func:`reduced.signal_tools.detect_closure_force` on the primary force and the coupler's stroke
    made of it with the closing speed and the car masses (:func:`_coupler_stroke`);
  - wear: ``worn`` if the gear closed below ``(1 − tolerance) ×`` its rated closure force,
    ``ok`` if at or above it, ``unknown`` if it did not close or no rating was given;
  - alarm: ``certain`` if the peak band's lower end reaches the limit, ``possible`` if only
    its upper end (or, without a bound, the peak itself) does, or if a channel saturated during the
    event, else ``none``.

* before the primary is chosen for the closing speed, every estimate whose peak exceeds the force the
  speed's upper end allows (:mod:`femref.sensing.peak_bound`) is made ``implausible``, without a number.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid

from femref.events import ClosureResult, EventResult, ForceEstimate, without_histories
from femref.fem.build import FemSettings
from femref.models import Progress, ProgressFor
from femref.models.inverse import ESTIMATORS as INVERSE_ESTIMATORS
from femref.models.modal import modal_car
from femref.run.event_budget import check_events
from femref.scene.impact import Car
from femref.scene.measured import MeasuredCoupler, MeasuredScene
from femref.sensing import closing_speed as speeds
from femref.sensing import events as event_finder
from femref.sensing.closing_speed import ClosingSpeed
from femref.sensing.contact import ContactEstimate, onset_time
from femref.sensing.impact_type import classify_records
from femref.sensing.network import ImpactTypeNetworks, NetworkEstimator
from femref.sensing.noise_gate import QuietNoise, quiet_noise
from femref.sensing.peak_bound import implausible, line_reduced_mass
from femref.sensing.recordings import Recordings, read_records
from reduced import kalman
from reduced.signal_tools import detect_closure_force

KALMAN_FEM = FemSettings(elements=64, order=2)
"""The mesh whose free-free modes make the kalman estimator's car model."""
KALMAN_NIS_RANGE = (0.25, 1.0e4)
"""Accepted noise scale λ̂ of the kalman filter (innovation variance over the sensor noise variance): below,
the records are smoother than their own quiet stretch; above 1e4 (innovations a hundred times the sensor
noise) the records are not of the declared cars at all (swapped channels, a wrong unit), and no number is
given. Measured on simulated yard impacts: λ̂ up to 54 with the declared cars exact (four modes and no
anti-alias filter in the model, against 64-element fem cars), up to 860 with cars off by their tolerances
(mass ±5 %, mode frequencies ±15 %, viscosity × 0.6–1.6, lading spread) while the peak stayed within 5 %."""
MIN_QUIET_SAMPLES = 10
"""Samples before the trigger needed to measure a channel's offset and noise."""


@dataclass
class MeasuredOutcome:
    """The scene, the records as read and every event's result."""

    scene: MeasuredScene
    recordings: Recordings
    events: list[EventResult]
    search: event_finder.EventSearch
    """How the events were found: spikes ignored, triggers outside the recorders' common span
    (:class:`femref.sensing.events.EventSearch`; its notes are the run's warnings)."""
    streamed: bool = False
    """True when a sink took each event as it finished: ``events`` are then summaries without their histories
    (:func:`femref.events.without_histories`)."""


#: The progress label while the record files are read.
READ_LABEL = "read records"


def run_measured(scene: MeasuredScene, progress_for: ProgressFor | None = None, sink: Callable[[EventResult], None] | None = None,
                 source: str = "<case>") -> MeasuredOutcome:
    """Every event of the scene's records (module docstring).

    ``progress_for(label)``, if given, is called when a stage starts — :data:`READ_LABEL` while the
    record files are read, then ``event <k>/<n> at <t> s`` for each event (:func:`event_label`) — and
    the callback it may return gets ``(done, total)`` after each step of that stage: the records read;
    the event's classification, each estimator (kalman's filters, the inverse estimators) and each
    saved network.

    ``sink(event)``, if given, takes each event's full result as soon as it is done (``femref run`` writes it:
    :class:`femref.events.EventWriter`) and the outcome keeps only its summary, so memory does not grow with the
    events' histories. Once the trigger has found the events, before the first event's estimators run, their total
    cost is checked against the work budget (:func:`femref.run.event_budget.check_events`: a
    :class:`~femref.case.CaseError` at ``source``).
    """
    step = progress_for(READ_LABEL) if progress_for else None
    recordings = read_records(scene.records)
    if step is not None:
        step(1, 1)
    search = event_finder.search_events(recordings, _trigger_settings(scene))
    found = search.events
    check_events(scene, recordings, found, source)
    events = []
    for number, event in enumerate(found, start=1):
        step = progress_for(event_label(number, len(found), event.trigger_time)) if progress_for else None
        result = _event(scene, recordings, event, step)
        if sink is not None:
            sink(result)
            result = without_histories(result)
        events.append(result)
    return MeasuredOutcome(scene, recordings, events, search, streamed=sink is not None)


def _trigger_settings(scene: MeasuredScene) -> event_finder.TriggerSettings:
    """The scene's ``events`` settings as the trigger takes them."""
    return event_finder.TriggerSettings(scene.trigger, scene.pre, scene.post, scene.rearm, scene.quiet, scene.max_window)


def event_label(number: int, count: int, trigger_time: float) -> str:
    """How progress names an event: ``event 2/7 at 3.603 s`` (its trigger time on the records' clock)."""
    return f"event {number}/{count} at {trigger_time:.3f} s"


def _event(scene: MeasuredScene, recordings: Recordings, event: event_finder.Event, progress: Progress | None = None) -> EventResult:
    """One event's result (module docstring); ``progress(done, total)`` after its classification, each
    estimator and each network."""
    total = 1 + len(scene.estimators) + len(scene.networks)
    done = 0

    def stepped() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    t, raw = event_finder.window(recordings, event)
    records, noise_std, quiet = _quiet_corrected(t, raw, event)
    result = EventResult(
        index=event.index, start=event.start, end=event.end, trigger_time=event.trigger_time,
        trigger_probe=event.trigger_probe, flags=tuple(event.flags), time=t, records=records,
    )
    _classify(scene, result)
    stepped()
    for name in scene.estimators:
        result.estimates.extend(_estimates(scene, name, t, records, noise_std))
        stepped()
    contacts: dict[str, ContactEstimate | ValueError] = {}  # per coupler: its kalman force's onset, found once
    for network in scene.networks:
        result.estimates.append(network_estimate(scene, network, t, records, noise_std, result.estimates, contacts, result.impact_type))
        stepped()
    speed, first = _checked_closing_speed(scene, event, result, quiet)
    result.closing_speed, result.closing_speed_lower, result.closing_speed_upper = speed.value, speed.lower, speed.upper
    result.closing_speed_source, result.closing_speed_basis = speed.source, speed.basis
    if first is not None:
        result.epsilon = _epsilon(scene, first)
    if scene.calibration is not None:
        _calibrated(scene, result, quiet)
    primary = _primary(scene, result)
    for coupler in scene.couplers:
        estimate = primary.get(coupler.name)
        if estimate is not None:
            result.closures.append(_closure(scene, coupler, primary, result.closing_speed))
    saturated = [flag for flag in event.flags if flag.startswith("saturated")]
    result.alarm, result.alarm_basis = _alarm(scene, list(primary.values()), saturated, [e for e in result.estimates if e.status == "implausible"])
    result.wear, result.wear_basis = _wear(scene, result.closures)
    return result


def _quiet_corrected(t: NDArray[np.float64], raw: dict[str, NDArray[np.float64]], event: event_finder.Event
                     ) -> tuple[dict[str, NDArray[np.float64]], dict[str, float], dict[str, QuietNoise]]:
    """Each channel less its median before the trigger (its offset), its noise std there (m/s²) as the
    estimators weigh it, and that noise with its effective sample count for the calibration's noise gate
    (:func:`femref.sensing.noise_gate.quiet_noise`: ``1.4826 ×`` the median absolute deviation, robust to the
    impact's first rise, which a channel near the coupler records before the trigger fires on it — a plain
    standard deviation read 0.37 m/s² there for 0.05 m/s² of noise). With fewer than :data:`MIN_QUIET_SAMPLES`
    quiet samples no offset is removed, the noise is not measured and the estimators take it equal on every
    channel (the kalman estimator estimates its scale)."""
    quiet = t < event.trigger_time
    if np.count_nonzero(quiet) < MIN_QUIET_SAMPLES:
        return dict(raw), {probe: 1.0 for probe in raw}, {probe: QuietNoise(math.nan, 0, 0.0) for probe in raw}
    records = {probe: a - float(np.median(a[quiet])) for probe, a in raw.items()}
    measured = {probe: quiet_noise(a[quiet]) for probe, a in records.items()}
    floor = max(max(found.std for found in measured.values()), 1e-12) * 1e-3
    return records, {probe: max(found.std, floor) for probe, found in measured.items()}, measured


def _classify(scene: MeasuredScene, result: EventResult) -> None:
    try:
        found = classify_records(scene.cars, scene.couplers[0], result.time, result.records)
    except ValueError as error:
        result.impact_type = "unknown"
        result.flags = (*result.flags, f"not classified: {error}")
        return
    result.impact_type = found.kind
    result.zero_harmonic_ratio = found.zero_frequency_ratio
    result.classification_confidence = found.confidence


def _estimates(scene: MeasuredScene, name: str, t: NDArray[np.float64], records: dict[str, NDArray[np.float64]], noise_std: dict[str, float]) -> list[ForceEstimate]:
    started = _time.perf_counter()
    try:
        if name == "kalman":
            estimates = [kalman_estimate(scene, t, records, noise_std)]
        else:
            forces = INVERSE_ESTIMATORS[name](scene, t, records)  # type: ignore[arg-type]
            nan = np.full(t.size, np.nan)
            estimates = [ForceEstimate(name, coupler, t, force, nan, nan.copy(), bound="none",
                                       message="no calibration of this estimator's error: no band")
                         for coupler, force in forces.items()]
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
        nan = np.full(t.size, np.nan)
        return [ForceEstimate(name, c.name, t, nan, nan, nan, status="failed", message=f"{type(error).__name__}: {error}") for c in scene.couplers]
    elapsed = _time.perf_counter() - started
    for estimate in estimates:
        estimate.wall_time_s = elapsed / len(estimates)
        _fail_if_not_finite(estimate)
    return estimates


def _fail_if_not_finite(estimate: ForceEstimate) -> None:
    """An ok estimate whose force history holds NaN or infinity is failed, with no number (``ForceEstimate``)."""
    bad = np.flatnonzero(~np.isfinite(estimate.force))
    if estimate.ok and bad.size:
        estimate.status = "failed"
        estimate.message = f"the {estimate.estimator} force is not finite (NaN or infinity) at {bad.size} of {estimate.force.size} samples, from t = {estimate.time[bad[0]]:g} s"
        estimate.force = np.full(estimate.force.shape, np.nan)
        estimate.lower, estimate.upper = estimate.force.copy(), estimate.force.copy()


def kalman_estimate(scene: MeasuredScene, t: NDArray[np.float64], records: dict[str, NDArray[np.float64]], noise_std: dict[str, float]) -> ForceEstimate:
    """The joint input-state estimate of the one coupler's force (:func:`reduced.kalman.estimate_force`) with a
    band that carries the sensor noise and the declared cars' tolerances.

    Each car is its rigid mode and ``scene.kalman.modes`` elastic free-free modes of its fem mesh
    (:data:`KALMAN_FEM`, no static correction), observed at its recorded sensors; the sensor noise
    ``noise_std`` (m/s², per probe) sets the channels' relative weights and the noise scale is estimated
    (model error shows as noise, not as force). A likelihood optimum at the edge of the force-rate range,
    or innovations outside :data:`KALMAN_NIS_RANGE` times the sensor noise variance, give a status and no
    number. The band is the envelope of the 95 % bands of the nominal cars and of the four corners
    frequencies × (1 ± frequency_tolerance), viscosity × each damping factor (``K → f² K``, ``C → d C``,
    each estimated at the nominal force-rate level), widened for the masses: scaling every mass by
    ``s`` scales the force the accelerations imply by exactly ``s`` (``reduced.kalman``), so
    ``[lower, upper] → [lower (1 − m), upper (1 + m)]``.
    """
    coupler = scene.couplers[0]
    model = scene.kalman
    cars, probes = kalman_cars(scene, records)
    dynamics, filters = [cars.rear, cars.front], cars.channel_filters
    y = np.column_stack([records[probe] for probe in probes])
    noise = [noise_std[probe] for probe in probes]
    found = kalman.estimate_force(cars, t, y, noise, noise_scale="estimated", nis_range=KALMAN_NIS_RANGE)
    settings = {"modes": model.modes, "force_rate": found.force_rate, "noise_scale": found.noise_scale, "probes": probes,
                "declared_force_rate": found.force_rate / found.noise_scale**2,
                "anti_alias": [None if f is None else [f.corner, f.order] for f in filters],
                "mass_tolerance": model.mass_tolerance, "frequency_tolerance": model.frequency_tolerance,
                "damping_factors": list(model.damping_factors)}
    if found.status != "ok":
        nan = np.full(t.size, np.nan)
        return ForceEstimate("kalman", coupler.name, t, nan, nan, nan.copy(), bound="covariance", status="untrusted",
                             message=found.status, settings=settings)
    lower, upper = found.lower.copy(), found.upper.copy()
    rate = settings["declared_force_rate"]  # q_P per unit of the declared noise variance
    for frequency in {1.0 - model.frequency_tolerance, 1.0 + model.frequency_tolerance}:
        for damping in set(model.damping_factors):
            changed = [kalman.CarDynamics(c.mass, damping * c.damping, frequency**2 * c.stiffness, c.load_map, c.sensor_map, c.coupler_load) for c in dynamics]
            variant = kalman.estimate_force(kalman.CoupledCars(*changed, filters), t, y, noise, force_rate=rate, noise_scale="estimated", nis_range=KALMAN_NIS_RANGE)
            lower, upper = np.minimum(lower, variant.lower), np.maximum(upper, variant.upper)
    m = model.mass_tolerance
    lower, upper = np.minimum(lower * (1.0 - m), lower * (1.0 + m)), np.maximum(upper * (1.0 - m), upper * (1.0 + m))
    return ForceEstimate("kalman", coupler.name, t, found.force, lower, upper, bound="covariance", settings=settings)


def kalman_cars(scene: MeasuredScene, records: dict[str, NDArray[np.float64]]) -> tuple[kalman.CoupledCars, list[str]]:
    """The kalman estimator's model of the first coupler's two cars — rigid mode and ``scene.kalman.modes``
    elastic modes of each car's :data:`KALMAN_FEM` mesh, observed at its recorded sensors through their
    recorders' declared anti-alias filters — and the probes in channel order."""
    coupler = scene.couplers[0]
    dynamics, probes = [], []
    for index, coupler_load in ((coupler.rear, (0.0, -1.0)), (coupler.front, (-1.0, 0.0))):
        car = _impact_car(scene, index, records)
        system = modal_car(car, KALMAN_FEM, scene.kalman.modes, static_correction=False)
        dynamics.append(kalman.CarDynamics(system.mass, system.damping, system.stiffness, system.load_matrix, system.sensor_outputs, coupler_load))
        probes += [f"{car.name}/{sensor}" for sensor in car.sensors]
    return kalman.CoupledCars(*dynamics, _sensor_filters(scene, probes)), probes


def _sensor_filters(scene: MeasuredScene, probes: list[str]) -> tuple[kalman.SensorFilter | None, ...]:
    """Each probe's recorder anti-alias filter as the kalman model takes it (None: not declared)."""
    declared = scene.anti_alias
    return tuple(None if declared.get(probe) is None else kalman.SensorFilter(declared[probe].corner, declared[probe].order) for probe in probes)


def kalman_contact(scene: MeasuredScene, t: NDArray[np.float64], records: dict[str, NDArray[np.float64]], noise_std: dict[str, float],
                   estimate: ForceEstimate) -> ContactEstimate:
    """The contact instant in the kalman force ``estimate`` (:func:`femref.sensing.contact.onset_time`).

    The smoother spreads a sharp start of the force over a few samples both ways, so the chain the
    rise is fitted through is the smoother itself: its responses to a unit step and a unit ramp of
    the force, starting mid-record, are the model's forced response
    (:func:`reduced.kalman.forced_response`) estimated back at the event's force-rate level (the
    smoothed mean is linear in the records, and time-invariant away from the ends).
    """
    cars, probes = kalman_cars(scene, records)
    noise = [noise_std[p] for p in probes]
    rate = float(estimate.settings["declared_force_rate"])
    middle = t[t.size // 2]
    lags = t - middle
    scale = float(np.nanmax(estimate.force))
    responses = []
    for unit in (np.where(lags > 0.0, 1.0, 0.0), np.maximum(lags, 0.0) / (t[-1] - t[0])):
        accelerations = kalman.forced_response(cars, t, scale * unit)
        smoothed = kalman.estimate_force(cars, t, accelerations, noise, force_rate=rate, nis_range=(1e-300, math.inf)).force / scale
        responses.append(smoothed)
    return onset_time(t, np.nan_to_num(estimate.force), lags, responses[0], responses[1] * (t[-1] - t[0]))


def network_estimate(scene: MeasuredScene, estimator: NetworkEstimator, t: NDArray[np.float64], records: dict[str, NDArray[np.float64]],
                     noise_std: dict[str, float], estimates: list[ForceEstimate],
                     contacts: dict[str, ContactEstimate | ValueError] | None = None, impact_type: str = "unknown") -> ForceEstimate:
    """A saved network's peak force on the event, its records started at contact as its training records were.

    An estimator with one network per impact type (:class:`ImpactTypeNetworks`) reads the event with the
    network of its ``impact_type`` (the event's classification); an unclassified event, or one of a type
    the estimator has no network for, gets no estimate, with the reason.

    The contact instant ``t_c`` is where the kalman force of the network's coupler began
    (:func:`kalman_contact`). The records from ``t_c`` on, on ``t − t_c``, go through the network
    (:meth:`femref.sensing.network.AnnEstimator.peak_force`) with the declared car masses. A peak,
    not a history: ``time`` and ``force`` hold the one value at ``t_c``. Bound ``none``: the error
    a network file reports is measured on its own training source, not on these records (a
    calibration file that covers the network gives it a calibrated band). ``contacts`` (per coupler) keeps
    the contact found for one network for the next networks of the event.
    """
    started = _time.perf_counter()
    nan = np.full(1, np.nan)
    settings = dict(estimator.settings)

    def failed(at: float, why: str) -> ForceEstimate:
        return ForceEstimate(estimator.name, estimator.coupler, np.full(1, at), nan, nan, nan.copy(), status="failed", message=why, settings=settings)

    if isinstance(estimator, ImpactTypeNetworks):
        try:
            network = estimator.network_for(impact_type)
        except ValueError as error:
            return failed(t[0], str(error))
        settings = dict(network.settings, impact_type=impact_type)
    else:
        network = estimator

    source = next((e for e in estimates if e.estimator == "kalman" and e.coupler == network.coupler), None)
    if source is None or not source.ok:
        return failed(t[0], "no kalman force to find the contact in" if source is None else f"the kalman force has no number ({source.message})")
    contacts = {} if contacts is None else contacts
    if network.coupler not in contacts:
        try:
            contacts[network.coupler] = kalman_contact(scene, t, records, noise_std, source)
        except ValueError as error:
            contacts[network.coupler] = error
    contact = contacts[network.coupler]
    try:
        if isinstance(contact, ValueError):
            raise contact
        after = t >= contact.time
        histories = {probe: records[probe][after] for probe in network.contract.probes}
        peak = network.peak_force(t[after] - contact.time, histories, {car.name: car.mass for car in scene.cars})
    except ValueError as error:
        return failed(t[0], f"{type(error).__name__}: {error}")
    settings.update(contact_time=contact.time, contact_fit_residual=contact.residual)
    if not math.isfinite(peak):
        return failed(contact.time, "the network gave a non-finite force")
    training = network.contract.training.get("validation_mean_error")
    note = f" (its file reports {training:.1%} mean error on its own training source: not a bound here)" if isinstance(training, (int, float)) else ""
    estimate = ForceEstimate(estimator.name, network.coupler, np.full(1, contact.time), np.full(1, peak), nan, nan.copy(), bound="none",
                             message="peak only, records from the contact in the kalman force; no calibration of this network: no band" + note,
                             settings=settings)
    estimate.wall_time_s = _time.perf_counter() - started
    return estimate


def _calibrated(scene: MeasuredScene, result: EventResult, quiet: dict[str, QuietNoise]) -> None:
    """Calibrated bands on the inverse estimates of the calibrated coupler (:mod:`femref.sensing.calibration`):
    ``P ∈ [P̂/(1 + e_hi), P̂/(1 + e_lo)]`` inside the calibrated closing speeds (the event's interval not wholly
    outside them; one that straddles an edge is said in the message), car masses, anti-alias filter, sensor
    noise (the gate of :mod:`femref.sensing.noise_gate`) and impact type; outside, no band, ``in_calibrated_range``
    false and the reason."""
    calibration = scene.calibration
    assert calibration is not None
    filters = {probe: None if declared is None else declared.corner for probe, declared in scene.anti_alias.items()}
    speed = (result.closing_speed_lower, result.closing_speed_upper)
    outside = calibration.outside(speed, {car.name: car.mass for car in scene.cars}, filters, quiet, result.impact_type)
    notes = "".join(f"; {note}" for note in calibration.edge_notes(speed))
    for estimate in result.estimates:
        if estimate.estimator not in calibration.errors or estimate.coupler != calibration.coupler or not estimate.ok:
            continue
        estimate.in_calibrated_range = not outside
        if outside:
            estimate.message = "outside the calibrated range: " + "; ".join(outside) + ": no band"
            continue
        e_lo, e_hi = calibration.error_band(estimate.estimator)
        low, high = estimate.force / (1.0 + e_hi), estimate.force / (1.0 + e_lo)
        estimate.lower, estimate.upper = np.minimum(low, high), np.maximum(low, high)
        estimate.bound = "calibrated"
        estimate.message = f"calibrated peak error 95 % band [{e_lo:+.1%}, {e_hi:+.1%}]" + notes


def _primary(scene: MeasuredScene, result: EventResult) -> dict[str, ForceEstimate]:
    """Per coupler, the first force history of the case's list with a number and a bound, else the first history
    with a number (a network's peak is no history)."""
    primary: dict[str, ForceEstimate] = {}
    for coupler in scene.couplers:
        estimates = [e for e in result.estimates if e.coupler == coupler.name and e.ok and e.time.size > 1]
        bounded = [e for e in estimates if e.bound != "none"]
        if bounded or estimates:
            primary[coupler.name] = (bounded or estimates)[0]
    return primary


def _closure(scene: MeasuredScene, coupler: MeasuredCoupler, primary: dict[str, ForceEstimate], closing_speed: float) -> ClosureResult:
    """The gear's closure on ``coupler`` from its primary force and the stroke :func:`_coupler_stroke` makes of it
    (:func:`reduced.signal_tools.detect_closure_force`)."""
    estimate = primary[coupler.name]
    try:
        stroke = _coupler_stroke(scene, coupler, primary, closing_speed)
        found = detect_closure_force(estimate.time, np.nan_to_num(estimate.force), stroke)
    except ValueError as error:
        return ClosureResult(estimate.coupler, estimate.estimator, "ambiguous", message=str(error))
    diagnostics = dict(message=found.reason, stiffening=found.stiffening, p_value=found.p_value, residual=found.residual)
    if found.closure_force is None:
        return ClosureResult(estimate.coupler, estimate.estimator, found.status, **diagnostics)
    low, high = found.force_interval
    return ClosureResult(estimate.coupler, estimate.estimator, found.status, float(found.closure_force), float(found.closure_time),
                         force_lower=low, force_upper=high, **diagnostics)


def _coupler_stroke(scene: MeasuredScene, coupler: MeasuredCoupler, primary: dict[str, ForceEstimate], closing_speed: float) -> NDArray[np.float64]:
    """The coupler's stroke (m, compression positive) from the rigid motion of its two cars::

        δ(t) = v₀ (t − t₀) + ∫_{t₀}^{t} ∫_{t₀}^{s} (a_rear − a_front) dr ds,    m_k a_k = P_{k−1} − P_k

    ``v₀`` the closing speed, ``t₀`` the window's start (the cars are apart and unloaded there), ``P`` the
    primary forces of this coupler and of its neighbours (none for a two-car line; a neighbour without a
    force history is taken as unloaded). No closing speed, no stroke: ValueError. Made from the force itself, the stroke carries the estimator's own smoothing and
    delay, so the force–stroke line of the solid gear stays straight. An error ``Δv₀`` of the closing
    speed adds ``Δv₀ (t − t₀)``, a common error of the masses scales δ and adds such a term: with the
    closing speed 10 % off the closure force moved by up to 3.5 % on the tests' gears (docs/formulas.md
    §A5). A centre-of-mass stroke: on elastic cars it also holds the bodies' compression, in series with
    the gear on both branches."""
    estimate = primary[coupler.name]
    t = estimate.time
    force = {name: np.nan_to_num(e.force) for name, e in primary.items() if e.time.shape == t.shape and np.array_equal(e.time, t)}
    behind = next((c.name for c in scene.couplers if c.front == coupler.rear), None)
    ahead = next((c.name for c in scene.couplers if c.rear == coupler.front), None)
    zero = np.zeros(t.size)
    own = force[coupler.name]
    rear = (force.get(behind, zero) - own) / scene.cars[coupler.rear].mass
    front = (own - force.get(ahead, zero)) / scene.cars[coupler.front].mass
    rate = cumulative_trapezoid(rear - front, t, initial=0.0)
    if not math.isfinite(closing_speed):
        raise ValueError("no closing speed for the event: no stroke to find the gear's closure in")
    return closing_speed * (t - t[0]) + cumulative_trapezoid(rate, t, initial=0.0)


def _closing_speed(scene: MeasuredScene, event: event_finder.Event, estimate: ForceEstimate | None, quiet: dict[str, QuietNoise],
                   impact_type: str) -> ClosingSpeed:
    """The first coupler's closing speed: the case's for this event if it gives one, else from the primary
    force ``estimate`` (:func:`femref.sensing.closing_speed.from_force`; the noise of the relative acceleration
    from the quiet stretch of the cars' central channels)."""
    stated = scene.closing_speed_for(event.start, event.end)
    if stated is not None:
        return stated
    if estimate is None:
        return speeds.unknown("no force history with a number to read it from")
    coupler = scene.couplers[0]
    rear, front = scene.cars[coupler.rear], scene.cars[coupler.front]
    channels = [quiet.get(f"{car.name}/{min(car.sensors, key=lambda name: abs(car.sensors[name]))}") for car in (rear, front)]
    noise = math.sqrt(sum(c.std**2 for c in channels if c is not None and c.measured))
    reduced_mass = rear.mass * front.mass / (rear.mass + front.mass)
    return speeds.from_force(estimate.time, estimate.force, reduced_mass, noise, impact_type)


def _checked_closing_speed(scene: MeasuredScene, event: event_finder.Event, result: EventResult, quiet: dict[str, QuietNoise]
                           ) -> tuple[ClosingSpeed, ForceEstimate | None]:
    """The first coupler's closing speed (:func:`_closing_speed`) and the primary estimate it came from, every estimate
    whose peak exceeds the force the speed's upper end allows made ``implausible``, without a number
    (:func:`femref.sensing.peak_bound.implausible`, the cars behind the first coupler against those ahead); an
    implausible primary gives way to the next estimate, and the speed is read again from it."""
    reduced_mass = line_reduced_mass([car.mass for car in scene.cars], 0)
    while True:
        first = _primary(scene, result).get(scene.couplers[0].name)
        speed = _closing_speed(scene, event, first, quiet, result.impact_type)
        flagged = [estimate for estimate in result.estimates if estimate.ok and _flag_implausible(estimate, speed.upper, reduced_mass)]
        if not any(estimate is first for estimate in flagged):
            return speed, first


def _flag_implausible(estimate: ForceEstimate, closing_speed_upper: float, reduced_mass: float) -> bool:
    """Make ``estimate`` ``implausible`` (its peak kept in the message and ``settings``, no number) when its peak
    exceeds :func:`femref.sensing.peak_bound.peak_force_bound`; whether it did."""
    peak = estimate.peak[0]
    reason = implausible(peak, closing_speed_upper, reduced_mass)
    if reason is None:
        return False
    estimate.status, estimate.message = "implausible", reason
    estimate.settings["implausible_peak"] = peak
    estimate.force = np.full(estimate.force.shape, np.nan)
    estimate.lower, estimate.upper = estimate.force.copy(), estimate.force.copy()
    return True


def _epsilon(scene: MeasuredScene, estimate: ForceEstimate) -> float:
    force = np.nan_to_num(estimate.force)
    rate = np.gradient(force, estimate.time)
    load_time = math.pi * math.sqrt(np.trapezoid(force**2, estimate.time) / max(np.trapezoid(rate**2, estimate.time), 1e-300))
    waves = [car.body.wave_travel_time for car in scene.cars if car.body is not None]
    return max(waves) / load_time if waves and len(waves) == len(scene.cars) else math.nan


def _alarm(scene: MeasuredScene, estimates: list[ForceEstimate], saturated: list[str], implausible: list[ForceEstimate]) -> tuple[str, str]:
    """``certain``, ``possible`` or ``none`` from the primary ``estimates`` against the limit (module docstring), and
    why. A channel ``saturated`` during the event (its quality flags) makes ``none`` ``possible``: the records clip,
    the real peak lies above what they show. With no primary estimate, an ``implausible`` one at the limit makes it
    ``possible``: nothing rules the limit out."""
    limit = scene.checks.alarm
    if limit is None:
        return "none", "no alarm limit given"
    level = "none"
    basis = []
    for estimate in estimates:
        peak, lower, upper = estimate.peak
        if estimate.bound != "none" and math.isfinite(lower):
            found = "certain" if lower >= limit else "possible" if upper >= limit else "none"
            basis.append(f"{estimate.coupler}: {estimate.estimator} peak {peak:.4g} N, 95 % band [{lower:.4g}, {upper:.4g}] N against {limit:.4g} N")
        else:
            found = "possible" if peak >= limit else "none"
            basis.append(f"{estimate.coupler}: {estimate.estimator} peak {peak:.4g} N without a bound against {limit:.4g} N")
        level = max(level, found, key=("none", "possible", "certain").index)
    if not estimates:
        reaches = any(e.settings["implausible_peak"] >= limit for e in implausible)
        level = "possible" if reaches else level
        basis.append(f"no estimate with a number{'; an implausible one reaches the limit' if reaches else ''}")
    if saturated and level == "none":
        level = "possible"
        basis.append(f"a channel saturated during the event ({'; '.join(saturated)}): the records clip, the real peak is higher than they show")
    return level, "; ".join(basis)


def _wear(scene: MeasuredScene, closures: list[ClosureResult]) -> tuple[str, str]:
    rated = scene.checks.rated_closure_force
    if rated is None:
        return "unknown", "no rated closure force given"
    closed = [c for c in closures if c.status == "closed"]
    if not closed:
        return "unknown", "the gear did not close (or its closure is ambiguous): no closure force to compare"
    least = min(closed, key=lambda c: c.closure_force)
    threshold = (1.0 - scene.checks.wear_tolerance) * rated
    state = "worn" if least.closure_force < threshold else "ok"
    return state, f"{least.coupler} closed at {least.closure_force:.4g} N against {threshold:.4g} N ({1 - scene.checks.wear_tolerance:.0%} of the rated {rated:.4g} N)"


def _impact_car(scene: MeasuredScene, index: int, records: dict[str, NDArray[np.float64]]) -> Car:
    """The recorded car as an impact car with its recorded sensors (at rest: a modal reduction needs no velocity)."""
    car = scene.cars[index]
    assert car.body is not None  # the case requires bodies for kalman
    return Car(car.name, car.body, 0.0, {name: x for name, x in car.sensors.items() if f"{car.name}/{name}" in records})


__all__ = ["KALMAN_FEM", "READ_LABEL", "MeasuredOutcome", "event_label", "kalman_cars", "kalman_contact", "kalman_estimate", "network_estimate", "run_measured"]
