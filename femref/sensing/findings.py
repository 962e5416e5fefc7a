"""What an event's force estimates tell: the primary estimate, the closing speed, ε, the gear's closure, wear and
alarm — on the line's cars and couplers, never the whole scene.

The **primary** estimate of a coupler is the first of the case's list with a force history, a number and a bound,
else the first with a history and a number (:func:`primary`). From the first coupler's:

* closing speed with an interval (:func:`checked_closing_speed`, :func:`femref.sensing.closing_speed.from_force`):
  the mean over the contact of the relative velocity the force gives the cars, ``(1/T) ∫ ∫ P/m* dt dt``, raised
  by at most the stroke left at separation; or the speed the case gives for the event, which replaces it. Before
  the primary is taken for it, every estimate whose peak exceeds the force the speed's upper end allows
  (:func:`femref.sensing.closing_speed.implausible`) is made ``implausible``, without a number;
* ``ε = T_wave / T_load`` (:func:`epsilon`), ``T_wave = l/c`` the longest wave travel time of the cars and
  ``T_load = π √(∫P² / ∫Ṗ²)`` the pulse's time scale (NaN when a car has no body).

Per coupler, the closure (:func:`closure`): :func:`reduced.signal_tools.detect_closure_force` on the primary force
and the stroke made of it (:func:`coupler_stroke`); then wear (:func:`wear`): ``worn`` if the gear closed below
``(1 − tolerance) ×`` its rated closure force, ``ok`` if at or above it, ``unknown`` if it did not close or no rating
was given; and alarm (:func:`alarm`): ``certain`` if the peak band's lower end reaches the limit, ``possible`` if
only its upper end (or, without a bound, the peak itself) does, or if a channel saturated during the event, else
``none``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid

from femref.events import ClosureResult, ForceEstimate
from femref.sensing import closing_speed as speeds
from femref.sensing.closing_speed import ClosingSpeed
from femref.sensing.noise_gate import QuietNoise
from reduced.signal_tools import detect_closure_force

Cars = Sequence[Any]
"""The line's cars in order (``name``, ``mass``, ``body`` or None, ``sensors``)."""
Couplers = Sequence[Any]
"""The line's couplers (``name``, ``rear``, ``front``: the car indices)."""


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
    line_mass = speeds.line_reduced_mass([car.mass for car in cars], 0)
    rear, front = cars[coupler.rear], cars[coupler.front]
    while True:
        first = primary(couplers, estimates).get(coupler.name)
        if stated is not None:
            speed = stated
        elif first is None:
            speed = speeds.unknown("no force history with a number to read it from")
        else:
            channels = [quiet.get(f"{car.name}/{min(car.sensors, key=lambda name: abs(car.sensors[name]))}") for car in (rear, front)]
            noise = math.sqrt(sum(c.std**2 for c in channels if c is not None and c.measured))
            speed = speeds.from_force(first.time, first.force, rear.mass * front.mass / (rear.mass + front.mass), noise, impact_type)
        flagged = [estimate for estimate in estimates if estimate.ok and _flag_implausible(estimate, speed.upper, line_mass)]
        if not any(estimate is first for estimate in flagged):
            return speed, first


def _flag_implausible(estimate: ForceEstimate, closing_speed_upper: float, reduced_mass: float) -> bool:
    """Make ``estimate`` ``implausible`` (its peak kept in the message and ``settings``, no number) when its peak
    exceeds :func:`femref.sensing.closing_speed.peak_force_bound`; whether it did."""
    peak = estimate.peak[0]
    reason = speeds.implausible(peak, closing_speed_upper, reduced_mass)
    if reason is None:
        return False
    estimate.status, estimate.message = "implausible", reason
    estimate.settings["implausible_peak"] = peak
    estimate.force = np.full(estimate.force.shape, np.nan)
    estimate.lower, estimate.upper = estimate.force.copy(), estimate.force.copy()
    return True


def epsilon(cars: Cars, estimate: ForceEstimate) -> float:
    """``ε = T_wave / T_load`` of the pulse ``estimate`` (module docstring)."""
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
    """``certain``, ``possible`` or ``none`` from the primary ``estimates`` against the ``limit`` (N; None: no alarm
    limit), and why. A channel ``saturated`` during the event (its quality flags) makes ``none`` ``possible``: the
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
    """``worn``, ``ok`` or ``unknown`` from the least closure force against ``(1 − tolerance) × rated`` (N; None: no
    rating), and why."""
    if rated is None:
        return "unknown", "no rated closure force given"
    closed = [c for c in closures if c.status == "closed"]
    if not closed:
        return "unknown", "the gear did not close (or its closure is ambiguous): no closure force to compare"
    least = min(closed, key=lambda c: c.closure_force)
    threshold = (1.0 - tolerance) * rated
    state = "worn" if least.closure_force < threshold else "ok"
    return state, f"{least.coupler} closed at {least.closure_force:.4g} N against {threshold:.4g} N ({1 - tolerance:.0%} of the rated {rated:.4g} N)"


__all__ = ["alarm", "checked_closing_speed", "closure", "coupler_stroke", "epsilon", "primary", "wear"]
