"""What an event tells: its impact type and, from its force estimates, the primary estimate, the closing speed, ε,
the gear's closure, wear and alarm — on the line's cars and couplers, never the whole scene.

The **impact type** (:func:`classify_records`, docs/formulas.md §B): a free-to-roll impact changes the cars'
relative velocity for good, so the relative acceleration ``a_front − a_rear`` of a coupler's two cars has a
zero-frequency component; a coupled impact (cars coupled before and after) returns it, and the zero harmonic
vanishes. :func:`reduced.signal_tools.classify_impact` decides on the ratio ``ρ = |A(0)|/max_f |A(f)|``; each car's
acceleration is read at its sensor nearest the centre (the rigid-body motion: a node of its first axial mode). Before
that, :func:`momentum_records`: a coupler force is internal to the line, ``Σ m_k a_k ≈ 0`` below the cars' first elastic
mode, and the coupler closes; a transient pushed from outside (a track joint, brakes, a knock on one car, a noise burst)
is ``not_an_impact`` (:func:`reduced.signal_tools.classification.momentum_evidence`).

**The closing speed** (:func:`from_force`; docs/formulas.md §K3: the derivation, the assumption's numbers, the
checks) from an estimated coupler force ``P`` (N, compression positive) and ``m* = m_rear m_front/(m_rear + m_front)``:

    V(t) = ∫_{t_c}^{t} P(s) / m* ds,    v₀ = v̂ + x_s / T,    v̂ = (1/T) ∫_{t_c}^{t_s} V(t) dt      (m/s)

with ``0 ≤ x_s ≤ β v₀ T`` (β = :data:`RESIDUAL_STROKE`), hence ``v₀ ∈ [v̂, v̂/(1 − β)]``; ``t_c``, ``t_s`` the force's
crossings of each of :data:`EDGE_FRACTIONS` of its peak (the interval the envelope over them), widened by ``2 sd(v̂)``,
``sd(v̂) = σ_rel √(dt T/3)`` for white noise ``σ_rel`` on the relative acceleration; the speed is its middle. A
**coupled** event's interval reaches down to ``V(t_p)`` at the force peak (the stroke at the start is not known).
A speed the user has (:class:`StatedSpeed`) replaces the estimate.

**The largest coupler force a closing speed allows** (:func:`peak_force_bound`, docs/design.md §3.7): cars of reduced
mass ``m*`` meeting at ``v`` carry ``½ m* v²``, and a coupler ``P = f(x) + g(ẋ)`` with ``0 ≤ f′ ≤ k_max`` and
``0 ≤ g(ẋ) ≤ c_max ẋ`` stores at least ``f²/(2 k_max)`` and closes no faster than ``v``, so

    P_max ≤ v (√(k_max m*) + c_max)                (N)

with equality for a linear spring of stiffness ``k_max`` and no damping (elastic cars lower the force). ``k_max`` =
:data:`STIFFEST_COUPLER` and ``c_max`` = :data:`MOST_DAMPED_COUPLER`, the top of the plausible ranges of
:mod:`femref.case.plausibility`: 8.4 MN per m/s on the yard's two cars (``m* = 54.5`` t). Checked in
tests/measured/test_phantom_impacts.py. An estimate whose peak exceeds the bound at the upper end of the event's
closing-speed interval is ``implausible`` (:func:`implausible`): a bias, a glitch or a wrong unit made it, not the cars.

From the **primary** estimates (:func:`primary`): the closing speed (:func:`checked_closing_speed`), ε
(:func:`epsilon`), the gear's closure on each coupler (:func:`closure`), wear (:func:`wear`) and alarm (:func:`alarm`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.events import ClosureResult, ForceEstimate
from femref.sensing.noise_gate import QuietNoise
from reduced.signal_tools import NOT_AN_IMPACT, ImpactClassification, MomentumEvidence, classify_impact, detect_closure_force, momentum_evidence

Cars = Sequence[Any]
"""The line's cars in order (``name``, ``mass``, ``body`` or None, ``sensors``)."""
Couplers = Sequence[Any]
"""The line's couplers (``name``, ``rear``, ``front``: the car indices)."""


RESIDUAL_STROKE = 0.15
"""β: the stroke left at separation is at most ``β v₀ T`` (module docstring)."""
EDGE_FRACTIONS = (0.01, 0.05)
"""The fractions of the peak force whose crossings give the contact's start and end."""
RIGID_CORNER = 8.0
"""Hz: the low-pass of the momentum evidence on a car without a body, half of 16 Hz, the lowest first axial mode taken
for a loaded car (its lading on the underframe)."""


@dataclass(frozen=True)
class ClosingSpeed:
    """The closing speed ``value`` (m/s) with its interval ``[lower, upper]`` (m/s), where it came from
    (``records``: estimated from the force; ``given``: the user's; ``none``: no number) and how it was found."""

    value: float
    lower: float
    upper: float
    source: str
    basis: str


@dataclass(frozen=True)
class StatedSpeed:
    """A closing speed the user has (radar, a wayside detector): ``value ± uncertainty`` (m/s), for the event
    whose window holds ``time`` (s, on the records' clock; None: every event)."""

    value: float
    uncertainty: float
    time: float | None = None

    def covers(self, start: float, end: float) -> bool:
        """Whether it is the speed of the event with window ``[start, end]`` (s)."""
        return self.time is None or start <= self.time <= end

    def speed(self) -> ClosingSpeed:
        """As the event's closing speed: it replaces the estimate (``source = given``)."""
        at = "" if self.time is None else f" at {self.time:g} s"
        return ClosingSpeed(self.value, self.value - self.uncertainty, self.value + self.uncertainty, "given",
                            f"given in the case{at}: {self.value:.3g} ± {self.uncertainty:.2g} m/s")


def unknown(why: str) -> ClosingSpeed:
    """No closing speed, and why."""
    return ClosingSpeed(math.nan, math.nan, math.nan, "none", why)


def stated_speed(stated: Sequence[StatedSpeed], start: float, end: float) -> ClosingSpeed | None:
    """The closing speed ``stated`` gives for the event with window ``[start, end]`` (s), if any (the first that covers it)."""
    found = next((speed for speed in stated if speed.covers(start, end)), None)
    return None if found is None else found.speed()


def from_force(time: NDArray[np.float64], force: NDArray[np.float64], reduced_mass: float, relative_noise: float = 0.0,
               impact_type: str = "free_to_roll") -> ClosingSpeed:
    """The closing speed from a force history ``force`` (N, compression positive) on the uniform ``time`` (s),
    the cars' reduced mass ``m*`` (kg) and the relative acceleration's noise std (m/s²), as the module
    docstring derives it. No number (``source = none``) when the force has no compression peak or does not
    fall back below the crossing levels on both sides of it within the history."""
    t = np.asarray(time, dtype=float)
    P = np.nan_to_num(np.asarray(force, dtype=float))
    peak = int(np.argmax(P))
    if P[peak] <= 0.0:
        return unknown("the force has no compression peak")
    velocity = _cumulative(P / reduced_mass, t)
    stroke_integral = _cumulative(velocity, t)
    estimates, durations, starts = [], [], []
    for fraction in EDGE_FRACTIONS:
        edges = _edges(t, P, peak, fraction * P[peak])
        if edges is None:
            return unknown(f"the force does not fall below {fraction:.0%} of its peak on both sides of it within the event's window")
        start, end = edges
        v_start = float(np.interp(start, t, velocity))
        w_start, w_end = np.interp([start, end], t, stroke_integral)
        estimates.append(float((w_end - w_start) / (end - start) - v_start))
        durations.append(end - start)
        starts.append(start)
    dt = float(t[1] - t[0])
    noise = 2.0 * relative_noise * math.sqrt(dt * max(durations) / 3.0)
    lower, upper = min(estimates) - noise, max(estimates) / (1.0 - RESIDUAL_STROKE) + noise
    value = 0.5 * (lower + upper)
    crossings = " and ".join(f"{f:.0%}" for f in EDGE_FRACTIONS)
    basis = (f"mean relative velocity over the contact {min(estimates):.3g}–{max(estimates):.3g} m/s (between the force's crossings "
             f"of {crossings} of its peak), stroke left at separation 0–{RESIDUAL_STROKE:.0%} of v₀T")
    if impact_type == "coupled":
        at_peak = float(velocity[peak] - np.interp(min(starts), t, velocity))
        lower = min(lower, at_peak)
        basis += f"; coupled before the impact (the stroke at the start is not known): down to the relative velocity at the force peak, {at_peak:.3g} m/s"
    return ClosingSpeed(value, lower, upper, "records", basis)


def _cumulative(y: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``∫_{t_0}^{t_k} y dt`` by the trapezoidal rule."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])


def _edges(t: NDArray[np.float64], P: NDArray[np.float64], peak: int, level: float) -> tuple[float, float] | None:
    """The times (s) where ``P`` last rises through ``level`` before ``peak`` and first falls through it after."""
    below_before = np.flatnonzero(P[:peak] <= level)
    below_after = np.flatnonzero(P[peak:] <= level)
    if not below_before.size or not below_after.size:
        return None
    k = int(below_before[-1])
    j = peak + int(below_after[0])
    start = t[k] + (level - P[k]) / (P[k + 1] - P[k]) * (t[k + 1] - t[k])
    end = t[j - 1] + (P[j - 1] - level) / (P[j - 1] - P[j]) * (t[j] - t[j - 1])
    return float(start), float(end)


STIFFEST_COUPLER = 1.0e9
"""``k_max`` (N/m): the largest plausible coupler or draft-gear stiffness."""
MOST_DAMPED_COUPLER = 1.0e6
"""``c_max`` (N·s/m): the largest plausible draft-gear damping."""


def peak_force_bound(closing_speed: float, reduced_mass: float, stiffness: float = STIFFEST_COUPLER,
                     damping: float = MOST_DAMPED_COUPLER) -> float:
    """``P_max = v (√(k_max m*) + c_max)`` (N): the largest coupler force closing speed ``v`` (m/s) allows between
    groups of reduced mass ``m*`` (kg) (module docstring)."""
    return closing_speed * (math.sqrt(stiffness * reduced_mass) + damping)


def line_reduced_mass(masses: Sequence[float], coupler: int) -> float:
    """``m* = M_r M_f/(M_r + M_f)`` (kg): the cars behind coupler ``coupler`` (0-based, between cars ``coupler`` and
    ``coupler + 1``) against those ahead of it, masses in line order (kg)."""
    behind, ahead = sum(masses[: coupler + 1]), sum(masses[coupler + 1 :])
    return behind * ahead / (behind + ahead)


def implausible(peak: float, closing_speed_upper: float, reduced_mass: float) -> str | None:
    """Why a peak force ``peak`` (N) cannot come from cars of reduced mass ``m*`` (kg) closing at no more than
    ``closing_speed_upper`` (m/s), or None when it can (or without a finite speed to check it by)."""
    if not (math.isfinite(peak) and math.isfinite(closing_speed_upper) and closing_speed_upper > 0.0):
        return None
    bound = peak_force_bound(closing_speed_upper, reduced_mass)
    if peak <= bound:
        return None
    return (f"implausible: peak {peak / 1e3:.6g} kN exceeds the {bound / 1e3:.6g} kN that a closing speed of at most "
            f"{closing_speed_upper:.3g} m/s allows between m* = {reduced_mass / 1e3:.4g} t through the stiffest plausible coupler "
            f"(P ≤ v (√(k m*) + c), k = {STIFFEST_COUPLER:.0e} N/m, c = {MOST_DAMPED_COUPLER:.0e} N·s/m)")


def classify_records(cars: Cars, coupler: Any, time: NDArray[np.float64], records: Mapping[str, NDArray[np.float64]]) -> ImpactClassification:
    """The impact type at ``coupler`` from records on the uniform ``time`` (s): the zero harmonic of ``a_front −
    a_rear``, each car at its sensor nearest the centre (:func:`reduced.signal_tools.classify_impact`; ValueError
    when the records cannot be classified)."""
    front, rear = (cars[coupler.front], cars[coupler.rear])
    relative = records[f"{front.name}/{_central_sensor(front)}"] - records[f"{rear.name}/{_central_sensor(rear)}"]
    return classify_impact(np.asarray(relative, dtype=float), float(time[1] - time[0]))


def momentum_records(cars: Cars, coupler: Any, time: NDArray[np.float64], records: Mapping[str, NDArray[np.float64]],
                     noise_std: Mapping[str, float], mass_tolerance: float | Sequence[float]) -> MomentumEvidence:
    """Whether the event's forces are internal to the line and ``coupler`` closed (:func:`momentum_evidence` on each car's
    central sensor, low-passed at half the lowest first axial mode ``1/(2 T_wave)`` of the cars, :data:`RIGID_CORNER`
    when a car has no body); ValueError when the records cannot tell."""
    probes = [f"{car.name}/{_central_sensor(car)}" for car in cars]
    missing = [probe for probe in probes if probe not in records]
    if missing:
        raise ValueError(f"the line's momentum needs every car's central sensor; not recorded: {', '.join(missing)}")
    corner = min((0.25 / car.body.wave_travel_time if car.body is not None else RIGID_CORNER) for car in cars)
    return momentum_evidence([records[p] for p in probes], [car.mass for car in cars], [noise_std[p] for p in probes], float(time[1] - time[0]),
                             corner=corner, mass_tolerance=mass_tolerance, rear=coupler.rear)


@dataclass(frozen=True)
class EventClass:
    """An event's class — ``kind``: an impact type (``free_to_roll``, ``coupled``), ``not_an_impact`` or ``unknown`` —
    with its evidence: the zero-frequency ratio and confidence of the impact type, the line's ``momentum`` evidence
    (None when the records cannot give it), the ``basis`` in words, and why it was ``not_classified`` (unknown)."""

    kind: str
    zero_frequency_ratio: float = math.nan
    confidence: float = math.nan
    momentum: MomentumEvidence | None = None
    basis: str = ""
    not_classified: str = ""


def classify_event(cars: Cars, coupler: Any, time: NDArray[np.float64], records: Mapping[str, NDArray[np.float64]],
                   noise_std: Mapping[str, float], mass_tolerance: float | Sequence[float], saturated: bool) -> EventClass:
    """The event's class at ``coupler``: its impact type (:func:`classify_records`), made ``not_an_impact`` when the
    forces are not internal to the line or the coupler did not close (:func:`momentum_records`) — but not when a
    channel ``saturated``: its clipped peak breaks the balance, so the event stays an impact."""
    try:
        kind = classify_records(cars, coupler, time, records)
    except ValueError as error:
        return EventClass("unknown", not_classified=str(error))
    try:
        momentum = momentum_records(cars, coupler, time, records, noise_std, mass_tolerance)
    except ValueError as error:
        return EventClass(kind.kind, kind.zero_frequency_ratio, kind.confidence, basis=f"no momentum evidence: {error}")
    if momentum.internal or saturated:
        basis = momentum.basis if momentum.internal else f"{momentum.basis}; a channel saturated (its clipped peak breaks the balance): kept an impact"
        return EventClass(kind.kind, kind.zero_frequency_ratio, kind.confidence, momentum, basis)
    return EventClass(NOT_AN_IMPACT, kind.zero_frequency_ratio, math.nan, momentum, momentum.basis)


def _central_sensor(car: Any) -> str:
    if not car.sensors:
        raise ValueError(f"car {car.name} has no sensor")
    return min(car.sensors, key=lambda name: abs(car.sensors[name]))


def primary(couplers: Couplers, estimates: Sequence[ForceEstimate]) -> dict[str, ForceEstimate]:
    """Per coupler, the first force history with a number and a bound, else the first history with a number (a
    network's peak is no history)."""
    found: dict[str, ForceEstimate] = {}
    for coupler in couplers:
        histories = [e for e in estimates if e.coupler == coupler.name and e.ok and e.time.size > 1]
        bounded = [e for e in histories if e.bound != "none"]
        if bounded or histories:
            found[coupler.name] = (bounded or histories)[0]
    return found


def checked_closing_speed(cars: Cars, couplers: Couplers, stated: ClosingSpeed | None, estimates: Sequence[ForceEstimate],
                          quiet: Mapping[str, QuietNoise], impact_type: str) -> tuple[ClosingSpeed, ForceEstimate | None]:
    """The first coupler's closing speed and the primary estimate it came from: ``stated`` (the case's for the
    event) if given, else from the primary force (the noise of the relative acceleration from the quiet stretch of
    the cars' central channels). Every estimate whose peak exceeds the force the speed's upper end allows is made
    ``implausible``, without a number (the cars behind the first coupler against those ahead); an implausible
    primary gives way to the next estimate, and the speed is read again from it."""
    coupler = couplers[0]
    line_mass = line_reduced_mass([car.mass for car in cars], 0)
    rear, front = cars[coupler.rear], cars[coupler.front]
    while True:
        first = primary(couplers, estimates).get(coupler.name)
        if stated is not None:
            speed = stated
        elif first is None:
            speed = unknown("no force history with a number to read it from")
        else:
            channels = [quiet.get(f"{car.name}/{_central_sensor(car)}") for car in (rear, front) if car.sensors]
            noise = math.sqrt(sum(c.std**2 for c in channels if c is not None and c.measured))
            speed = from_force(first.time, first.force, rear.mass * front.mass / (rear.mass + front.mass), noise, impact_type)
        flagged = [estimate for estimate in estimates if estimate.ok and _flag_implausible(estimate, speed.upper, line_mass)]
        if not any(estimate is first for estimate in flagged):
            return speed, first


def _flag_implausible(estimate: ForceEstimate, closing_speed_upper: float, reduced_mass: float) -> bool:
    """Make ``estimate`` ``implausible`` (its peak kept in the message and ``settings``, no number) when its peak
    exceeds :func:`peak_force_bound`; whether it did."""
    peak = estimate.peak[0]
    reason = implausible(peak, closing_speed_upper, reduced_mass)
    if reason is None:
        return False
    estimate.drop_number("implausible", reason)
    estimate.settings["implausible_peak"] = peak
    return True


def epsilon(cars: Cars, estimate: ForceEstimate) -> float:
    """``ε = T_wave / T_load``: ``T_wave = l/c`` the longest wave travel time of the cars, ``T_load = π √(∫P² / ∫Ṗ²)``
    the time scale of the pulse ``estimate`` (NaN when a car has no body)."""
    force = np.nan_to_num(estimate.force)
    rate = np.gradient(force, estimate.time)
    load_time = math.pi * math.sqrt(np.trapezoid(force**2, estimate.time) / max(np.trapezoid(rate**2, estimate.time), 1e-300))
    waves = [car.body.wave_travel_time for car in cars if car.body is not None]
    return max(waves) / load_time if waves and len(waves) == len(cars) else math.nan


def closure(cars: Cars, couplers: Couplers, coupler: Any, primaries: Mapping[str, ForceEstimate], closing_speed: float) -> ClosureResult:
    """The gear's closure on ``coupler`` from its primary force and the stroke :func:`coupler_stroke` makes of it
    (:func:`reduced.signal_tools.detect_closure_force`)."""
    estimate = primaries[coupler.name]
    try:
        stroke = coupler_stroke(cars, couplers, coupler, primaries, closing_speed)
        found = detect_closure_force(estimate.time, np.nan_to_num(estimate.force), stroke)
    except ValueError as error:
        return ClosureResult(estimate.coupler, estimate.estimator, "ambiguous", message=str(error))
    diagnostics = dict(message=found.reason, stiffening=found.stiffening, p_value=found.p_value, residual=found.residual)
    if found.closure_force is None:
        return ClosureResult(estimate.coupler, estimate.estimator, found.status, **diagnostics)
    low, high = found.force_interval
    return ClosureResult(estimate.coupler, estimate.estimator, found.status, float(found.closure_force), float(found.closure_time),
                         force_lower=low, force_upper=high, **diagnostics)


def coupler_stroke(cars: Cars, couplers: Couplers, coupler: Any, primaries: Mapping[str, ForceEstimate], closing_speed: float) -> NDArray[np.float64]:
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
    from scipy.integrate import cumulative_trapezoid  # scipy.integrate costs ~0.3 s to import: only a measured event needs it

    t = primaries[coupler.name].time
    force = {name: np.nan_to_num(e.force) for name, e in primaries.items() if e.time.shape == t.shape and np.array_equal(e.time, t)}
    behind = next((c.name for c in couplers if c.front == coupler.rear), None)
    ahead = next((c.name for c in couplers if c.rear == coupler.front), None)
    zero = np.zeros(t.size)
    own = force[coupler.name]
    rear = (force.get(behind, zero) - own) / cars[coupler.rear].mass
    front = (own - force.get(ahead, zero)) / cars[coupler.front].mass
    rate = cumulative_trapezoid(rear - front, t, initial=0.0)
    if not math.isfinite(closing_speed):
        raise ValueError("no closing speed for the event: no stroke to find the gear's closure in")
    return closing_speed * (t - t[0]) + cumulative_trapezoid(rate, t, initial=0.0)


def alarm(limit: float | None, estimates: Sequence[ForceEstimate], saturated: Sequence[str], implausible: Sequence[ForceEstimate]) -> tuple[str, str]:
    """``certain`` if a primary estimate's peak band reaches the ``limit`` (N; None: no alarm limit) with its lower end,
    ``possible`` if only with its upper end (or, without a bound, the peak itself), else ``none``; and why. A channel ``saturated`` during the event (its quality flags) makes ``none`` ``possible``: the
    records clip, the real peak lies above what they show. With no primary estimate, an ``implausible`` one at the
    limit makes it ``possible``: nothing rules the limit out."""
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


def wear(rated: float | None, tolerance: float, closures: Sequence[ClosureResult]) -> tuple[str, str]:
    """``worn`` if the gear closed below ``(1 − tolerance) × rated`` (N; None: no rating), ``ok`` if at or above it,
    ``unknown`` if it did not close or no rating was given; and why."""
    if rated is None:
        return "unknown", "no rated closure force given"
    closed = [c for c in closures if c.status == "closed"]
    if not closed:
        return "unknown", "the gear did not close (or its closure is ambiguous): no closure force to compare"
    least = min(closed, key=lambda c: c.closure_force)
    threshold = (1.0 - tolerance) * rated
    state = "worn" if least.closure_force < threshold else "ok"
    return state, f"{least.coupler} closed at {least.closure_force:.4g} N against {threshold:.4g} N ({1 - tolerance:.0%} of the rated {rated:.4g} N)"


__all__ = ["EDGE_FRACTIONS", "MOST_DAMPED_COUPLER", "RESIDUAL_STROKE", "RIGID_CORNER", "STIFFEST_COUPLER", "ClosingSpeed", "EventClass",
           "StatedSpeed", "alarm", "checked_closing_speed", "classify_event", "classify_records", "closure", "momentum_records", "coupler_stroke", "epsilon", "from_force", "implausible", "line_reduced_mass",
           "peak_force_bound", "primary", "stated_speed", "unknown", "wear"]
