"""Gear families for the closure-force tests, their laws written here, not in the library.

Each record is two rigid cars (m₁ ẍ₁ = −P, m₂ ẍ₂ = P, stroke δ = x₁ − x₂, so δ̈ = −P (1/m₁ + 1/m₂)) through:

* the standard-linear gear of the source study (:meth:`reduced.couplers.StandardLinearDraftGear.m901e_like`,
  run by :func:`reduced.nonlinear.simulate_impact`; the truth is the force at its ``gear_closed`` event);
* a friction gear with hysteresis: loading ``L(x) = k₁x + k₃x³`` or ``a (e^{x/b} − 1)``, unloading ``u L(x)``
  (u = 0.3–0.5) switched by the stroke rate, ``P = uL + (1 − u) L clip(ẋ/v_s, 0, 1)``, and a solid stop
  ``k_s (x − x_s)₊`` (k_s = 20–50 × L'(x_s), x_s = 60–90 mm) in parallel; the truth is ``L(x_s)``;
* a polymer-like gear, rate-dependent with little hysteresis: ``P = F_s (x/x_s)ⁿ (1 + ẋ/v_r)`` and the same
  stop; the truth is the law at the closure instant, ``F_s (1 + ẋ_c/v_r)``.

Integrated here by ``solve_ivp`` (DOP853, rtol 1e-10) with an event at ``x = x_s``, sampled from before
contact. The friction gears' speeds come from the energy balance (rate-independent loading):
``½ m* v₀² = ∫₀^{x_m} (L + k_s (x − x_s)₊) dx`` with ``L(x_m) + k_s (x_m − x_s) = F_c/r`` for a chosen
closure ratio r; the polymer's from the energy integrated back from the largest stroke with its rate term
(the achieved r is asserted within 40–90 % by the tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid, quad, solve_ivp
from scipy.optimize import brentq

from reduced.couplers import Coupling, StandardLinearDraftGear
from reduced.nonlinear import simulate_impact
from reduced.rigid import ImpactPair

DT = 1e-3  # s
LEAD = 20  # samples of zero force before contact
MASSES = (80e3, 70e3)  # kg


@dataclass(frozen=True)
class GearRecord:
    """A coupler-force record, the exact stroke, the cars' masses, the closing speed and the exact closure force
    (None: the gear stays open)."""

    name: str
    time: np.ndarray
    force: np.ndarray
    stroke: np.ndarray
    masses: tuple[float, float]
    closing_speed: float
    truth: float | None

    @property
    def ratio(self) -> float:
        return (self.truth or math.nan) / float(self.force.max())

    def rigid_stroke(self, closing_speed: float, force: np.ndarray | None = None) -> np.ndarray:
        """``δ = v₀ t − (1/m₁ + 1/m₂) ∫∫ P`` from the first sample: the stroke a user makes from the force."""
        p = self.force if force is None else force
        rate = cumulative_trapezoid(p, self.time, initial=0.0) * (1.0 / self.masses[0] + 1.0 / self.masses[1])
        return closing_speed * self.time - cumulative_trapezoid(rate, self.time, initial=0.0)


@dataclass(frozen=True)
class FrictionGear:
    """Loading ``k1 x + k3 x³`` (or ``a (e^{x/b} − 1)`` with ``exponential = (a, b)``), unloading ``unloading × L``,
    switch speed ``v_s``, stop at ``x_s`` of ``stop_ratio × L'(x_s)`` (SI)."""

    k1: float
    k3: float
    x_s: float
    stop_ratio: float
    unloading: float
    exponential: tuple[float, float] | None = None
    v_s: float = 0.01

    def loading(self, x: float) -> float:
        if self.exponential is not None:
            a, b = self.exponential
            return a * math.expm1(x / b)
        return self.k1 * x + self.k3 * x**3

    def loading_slope(self, x: float) -> float:
        if self.exponential is not None:
            a, b = self.exponential
            return a / b * math.exp(x / b)
        return self.k1 + 3.0 * self.k3 * x**2

    @property
    def stop_stiffness(self) -> float:
        return self.stop_ratio * self.loading_slope(self.x_s)

    def force(self, x: float, rate: float) -> float:
        if x <= 0.0:
            return 0.0
        curve = self.loading(x)
        switch = min(max(rate / self.v_s, 0.0), 1.0)
        return self.unloading * curve + (1.0 - self.unloading) * curve * switch + self.stop_stiffness * max(x - self.x_s, 0.0)

    def truth(self, x: float, rate: float) -> float:
        return self.loading(self.x_s)

    def speed_for(self, ratio: float, reduced_mass: float) -> float:
        """``v₀`` for a closure at ``ratio`` of the peak, from the energy balance of the loading curve and stop."""
        peak = self.loading(self.x_s) / ratio
        x_m = brentq(lambda x: self.loading(x) + self.stop_stiffness * (x - self.x_s) - peak, self.x_s, 2.0 * self.x_s)
        work = quad(self.loading, 0.0, x_m)[0] + 0.5 * self.stop_stiffness * (x_m - self.x_s) ** 2
        return math.sqrt(2.0 * work / reduced_mass)


@dataclass(frozen=True)
class PolymerGear:
    """``P = F_s (x/x_s)ⁿ (1 + ẋ/v_r) + k_s (x − x_s)₊``, ``k_s = stop_ratio × n F_s/x_s`` (SI)."""

    f_s: float
    n: float
    x_s: float
    stop_ratio: float
    v_r: float

    def static(self, x: float) -> float:
        return self.f_s * (max(x, 0.0) / self.x_s) ** self.n

    def force(self, x: float, rate: float) -> float:
        if x <= 0.0:
            return 0.0
        return self.static(x) * (1.0 + rate / self.v_r) + self.stop_ratio * self.n * self.f_s / self.x_s * max(x - self.x_s, 0.0)

    def truth(self, x: float, rate: float) -> float:
        return self.f_s * (1.0 + rate / self.v_r)

    def speed_for(self, ratio: float, reduced_mass: float) -> float:
        """``v₀`` for a closure at about ``ratio`` of the peak: the peak taken at the largest stroke ``x_m``
        (``P(x_m, 0) = F_s/ratio``), the energy ``E = ½ m* ẋ²`` integrated back from ``E(x_m) = 0`` with
        ``dE/dx = −P(x, ẋ)`` (the rate term's dissipation included)."""
        k_s = self.stop_ratio * self.n * self.f_s / self.x_s
        x_m = brentq(lambda x: self.static(x) + k_s * (x - self.x_s) - self.f_s / ratio, self.x_s, 2.0 * self.x_s)

        def rate(x: float, energy: np.ndarray) -> list[float]:
            return [-self.force(x, math.sqrt(2.0 * max(energy[0], 0.0) / reduced_mass))]

        back = solve_ivp(rate, (x_m, 0.0), [0.0], rtol=1e-10, atol=1e-6)
        return math.sqrt(2.0 * float(back.y[0, -1]) / reduced_mass)


Law = FrictionGear | PolymerGear


def rigid_impact(name: str, gear: Law, speed: float, masses: tuple[float, float] = MASSES, end: float = 0.25, dt: float = DT,
                 lead: int = LEAD) -> GearRecord:
    """Two rigid cars closing at ``speed`` through ``gear``: ``δ̈ = −P(δ, δ̇) (1/m₁ + 1/m₂)`` from contact until
    the cars part (then P = 0 and δ̇ constant), sampled every ``dt`` with ``lead`` samples before contact."""
    inverse_mass = 1.0 / masses[0] + 1.0 / masses[1]

    def rhs(_: float, y: np.ndarray) -> list[float]:
        return [y[1], -gear.force(y[0], y[1]) * inverse_mass]

    def closed(_: float, y: np.ndarray) -> float:
        return y[0] - gear.x_s

    def parted(t: float, y: np.ndarray) -> float:
        return y[0] if t > 1e-3 else 1.0

    closed.direction, parted.direction, parted.terminal = 1, -1, True  # type: ignore[attr-defined]
    run = solve_ivp(rhs, (0.0, end), [0.0, speed], method="DOP853", rtol=1e-10, atol=[1e-12, 1e-10], max_step=2e-4,
                    dense_output=True, events=[closed, parted])
    assert run.status >= 0, run.message
    t = dt * np.arange(round(end / dt))
    t_end = float(run.t[-1])
    inside = run.sol(np.minimum(t, t_end))
    x = np.where(t <= t_end, inside[0], inside[0] + (t - t_end) * run.y[1, -1])
    v = np.where(t <= t_end, inside[1], run.y[1, -1])
    force = np.array([gear.force(a, b) for a, b in zip(x, v)])
    truth = gear.truth(*run.y_events[0][0]) if run.t_events[0].size else None
    force = np.concatenate([np.zeros(lead), force])
    stroke = np.concatenate([speed * dt * np.arange(-lead, 0), x])
    return GearRecord(name, dt * np.arange(force.size), force, stroke, masses, speed, truth)


def standard_linear(speed: float, gear_damping: float, dt: float = DT, lead: int = LEAD) -> GearRecord:
    """The source study's pair (119 t into 100 t) through the M-901E-like gear; truth at the ODE's ``gear_closed`` event."""
    pair = ImpactPair.source_study(speed)
    run = simulate_impact(pair, Coupling(StandardLinearDraftGear.m901e_like(gear_damping=gear_damping), "compression_only"), np.arange(0.0, 0.25, dt))
    assert run.status == "ok", run.message
    closures = [e.coupler_force for e in run.events if e.kind == "gear_closed"]
    force = np.concatenate([np.zeros(lead), run.coupler_force])
    stroke = np.concatenate([speed * dt * np.arange(-lead, 0), -run.relative_displacement])
    return GearRecord(f"standard-linear {speed} m/s μ {gear_damping:g}", dt * np.arange(force.size), force, stroke,
                      (pair.hammer_mass, pair.anvil_mass), speed, closures[0] if closures else None)


M_STAR = MASSES[0] * MASSES[1] / (MASSES[0] + MASSES[1])
#: six gears of each family closing at 40–90 % of the peak: (gear, closure ratio aimed at)
FRICTION = [
    (FrictionGear(1.0e7, 3.0e9, 0.075, 30.0, 0.4), 0.45),
    (FrictionGear(1.5e7, 2.0e9, 0.090, 20.0, 0.3), 0.6),
    (FrictionGear(1.2e7, 1.0e9, 0.080, 20.0, 0.5), 0.85),
    (FrictionGear(0.0, 0.0, 0.070, 25.0, 0.35, exponential=(2.0e5, 0.03)), 0.5),
    (FrictionGear(0.0, 0.0, 0.085, 40.0, 0.45, exponential=(4.0e5, 0.04)), 0.7),
    (FrictionGear(0.0, 0.0, 0.065, 20.0, 0.5, exponential=(3.0e5, 0.04)), 0.8),
]
POLYMER = [
    (PolymerGear(1.5e6, 2.0, 0.080, 30.0, 8.0), 0.45),
    (PolymerGear(2.0e6, 1.5, 0.070, 20.0, 6.0), 0.6),
    (PolymerGear(1.2e6, 2.5, 0.090, 40.0, 10.0), 0.75),
    (PolymerGear(1.8e6, 1.5, 0.080, 20.0, 5.0), 0.8),
    (PolymerGear(2.5e6, 3.0, 0.085, 25.0, 8.0), 0.5),
    (PolymerGear(1.0e6, 1.8, 0.075, 35.0, 12.0), 0.65),
]
STANDARD_LINEAR = [(2.6, 2e5), (3.0, 2e5), (3.58, 2e5), (4.0, 2e5), (3.58, 5e5), (4.0, 5e5)]


def closing_records(dt: float = DT, lead: int = LEAD) -> list[GearRecord]:
    """The 18 records: six of each family."""
    records = [standard_linear(v, mu, dt, lead) for v, mu in STANDARD_LINEAR]
    for family, gears in (("friction", FRICTION), ("polymer", POLYMER)):
        for k, (gear, ratio) in enumerate(gears):
            records.append(rigid_impact(f"{family} {k}", gear, gear.speed_for(ratio, M_STAR), dt=dt, lead=lead))
    return records


#: The shortest solid stretch the random gears may have: the closed branch from closure to the peak lasts
#: ``arccos(r)/ω_s`` (``ω_s = √(k_s/m*)``, ``r`` the closure ratio); at 1 kHz fewer than 5 samples cannot
#: show a line.
SHORTEST_SOLID = 5e-3  # s


def solid_time(stop_stiffness: float, ratio: float, reduced_mass: float = M_STAR) -> float:
    """``arccos(r)/√(k_s/m*)`` (s): how long a stop of ``stop_stiffness`` (N/m) carries the rise from the closure at
    ``ratio`` of the peak to the peak, the open force held at the closure force (two rigid cars)."""
    return math.acos(ratio) / math.sqrt(stop_stiffness / reduced_mass)


def random_records(rng: np.random.Generator, per_family: int, dt: float = DT, lead: int = LEAD) -> list[GearRecord]:
    """``per_family`` gears of each family drawn at random: standard-linear at 2.6–4.0 m/s with a dashpot of
    2e5–5e5 N·s/m; friction (cubic or exponential loading, stop at 60–90 mm, 20–50 × stiffer, unloading
    0.3–0.5) and polymer (n = 1.5–3, v_r = 5–12 m/s, the same stops) aimed at closures at 45–85 % of the
    peak, a draw whose solid stretch is shorter than :data:`SHORTEST_SOLID` drawn again."""
    records = []
    while len(records) < per_family:
        speed, damping = rng.uniform(2.6, 4.0), rng.uniform(2e5, 5e5)
        record = standard_linear(round(speed, 3), round(damping, -3), dt, lead)
        if record.truth is not None and 0.4 <= record.ratio <= 0.9:
            records.append(record)
    for family in ("friction", "polymer"):
        drawn = 0
        while drawn < per_family:
            ratio, x_s, stop = rng.uniform(0.45, 0.85), rng.uniform(0.06, 0.09), rng.uniform(20.0, 50.0)
            if family == "friction":
                closure_force = rng.uniform(1.2e6, 2.5e6)
                if rng.uniform() < 0.5:
                    k1 = rng.uniform(0.1, 0.5) * closure_force / x_s
                    gear: Law = FrictionGear(k1, (closure_force - k1 * x_s) / x_s**3, x_s, stop, rng.uniform(0.3, 0.5))
                else:
                    b = rng.uniform(0.25, 0.6) * x_s
                    gear = FrictionGear(0.0, 0.0, x_s, stop, rng.uniform(0.3, 0.5), exponential=(closure_force / math.expm1(x_s / b), b))
                stiffness = gear.stop_stiffness
            else:
                n = rng.uniform(1.5, 3.0)
                gear = PolymerGear(rng.uniform(1.0e6, 2.5e6), n, x_s, stop, rng.uniform(5.0, 12.0))
                stiffness = stop * n * gear.f_s / x_s
            if solid_time(stiffness, ratio) < SHORTEST_SOLID:
                continue
            record = rigid_impact(f"{family} random {drawn}", gear, gear.speed_for(ratio, M_STAR), dt=dt, lead=lead)
            if record.truth is not None and 0.4 <= record.ratio <= 0.9:
                records.append(record)
                drawn += 1
    return records
