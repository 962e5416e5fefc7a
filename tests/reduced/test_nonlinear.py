"""Nonlinear couplers through the event-driven ODE (reduced.nonlinear, reduced.couplers) and the power-law
peak series against it (reduced.power_law_peak)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from reduced.couplers import (
    COUPLER_LAWS,
    Coupling,
    KelvinVoigt,
    PowerLawGear,
    StandardLinearDraftGear,
    coupling_from_name,
)
from reduced.nonlinear import IntegratorSettings, simulate_impact
from reduced.power_law_peak import power_law_peak_estimate, power_law_peak_series
from reduced.rigid import ImpactPair, kelvin_voigt_impact

PAIR = ImpactPair.source_study()  # 119 t at 2.2 m/s against 100 t
STIFFNESS = 4.0e7
GEAR = StandardLinearDraftGear.m901e_like()  # M-901E class: 34 MN/m, 82.5 mm stroke
FAST = ImpactPair.source_study(hammer_speed=3.58)  # 8 mph: the gear closes


def _mu(zeta: float) -> float:
    return 2.0 * zeta * math.sqrt(STIFFNESS * PAIR.reduced_mass)


@pytest.mark.parametrize("zeta", [0.3, 1.5])
@pytest.mark.parametrize("contact", ["bilateral", "compression_only"])
def test_linear_power_law_reproduces_closed_form(zeta: float, contact: str) -> None:
    """N = c xⁿ + N0 with n = 1, N0 = 0, γ = μ is the Kelvin-Voigt coupler.

    Exact answer: reduced.rigid.kelvin_voigt_impact (itself checked against DOP853).
    The ODE solution matches x, a1, a2, P to 1e-8 of their peaks and the separation
    time to 1e-9 s (measured 3e-11 and 3e-13 s).
    """
    mu = _mu(zeta)
    t = np.linspace(0.0, 0.4, 401)
    closed = kelvin_voigt_impact(PAIR, STIFFNESS, mu, t, contact=contact)
    ode = simulate_impact(PAIR, Coupling(PowerLawGear(STIFFNESS, 1.0, 0.0, (mu,)), contact), t)
    assert ode.status == "ok", ode.message
    for mine, ref in [
        (ode.relative_displacement, closed.relative_displacement),
        (ode.coupler_force, closed.coupler_force),
        (ode.hammer_acceleration, closed.hammer_acceleration),
        (ode.anvil_acceleration, closed.anvil_acceleration),
    ]:
        assert np.max(np.abs(mine - ref)) <= 1e-8 * np.max(np.abs(ref))
    if contact == "compression_only":
        assert ode.separation_time == pytest.approx(closed.separation_time, abs=1e-9)


@pytest.mark.parametrize(
    ("name", "pair", "coupling", "external"),
    [
        ("kelvin_voigt free to roll", PAIR, Coupling(KelvinVoigt(STIFFNESS, _mu(0.2)), "compression_only"), None),
        ("draft gear closing, free to roll", FAST, Coupling(GEAR, "compression_only"), None),
        (
            "preloaded power law, bilateral with slack",
            PAIR,
            Coupling(PowerLawGear(4.6e8, 2.0, 2.0e5, (2.0e5, 1.0e6)), "bilateral", slack=0.01, tension_slack=0.005),
            None,
        ),
        ("draft gear, coupled, pushed", PAIR, Coupling(GEAR, "bilateral"), lambda t: (1.0e5 * (t < 0.3), 0.0)),
    ],
)
def test_energy_balance(name: str, pair: ImpactPair, coupling: Coupling, external) -> None:
    """KE + stored + dissipated − external work stays at its initial value m1 v²/2.

    Exact answer: zero residual (the dissipation is integrated as a separate state, so
    this checks the integration and the event bookkeeping). Asserted ≤ 1e-8 of the
    initial kinetic energy (measured ≤ 5e-10).
    """
    t = np.linspace(0.0, 0.6, 601)
    run = simulate_impact(pair, coupling, t, external_force=external)
    assert run.status == "ok", run.message
    assert np.max(np.abs(run.energy_residual)) <= 1e-8 * pair.kinetic_energy, name
    assert np.all(np.diff(run.dissipated_energy) >= -1e-9 * pair.kinetic_energy)


def test_compression_only_never_pulls_and_recontacts() -> None:
    """A locomotive pushes the hammer with 200 kN and the anvil brakes with 200 kN: after each
    separation the cars meet again.

    Exact answers: coupler force ≥ 0 at every sample (no tension in a free-to-roll
    contact); contacts and separations alternate, at least two of each in 3 s; at a
    separation the force is zero.
    """
    t = np.linspace(0.0, 3.0, 3001)
    coupling = Coupling(KelvinVoigt(STIFFNESS, _mu(0.1)), "compression_only", slack=0.005)
    run = simulate_impact(PAIR, coupling, t, external_force=lambda _t: (2.0e5, -2.0e5))
    assert run.status == "ok", run.message
    assert np.min(run.coupler_force) >= 0.0
    kinds = [e.kind for e in run.events]
    assert kinds.count("contact") >= 2 and kinds.count("separation") >= 2
    assert all(a != b for a, b in zip(kinds, kinds[1:]))
    assert all(e.coupler_force == 0.0 for e in run.events if e.kind == "separation")
    assert np.max(np.abs(run.energy_residual)) <= 1e-8 * PAIR.kinetic_energy


def _brute_force_gear(pair: ImpactPair, gear: StandardLinearDraftGear, t: np.ndarray):
    """Independent reference: raw state (x1, v1, x2, v2, x_g), branch chosen by sign at every
    call (no events, no frozen pieces), LSODA rtol 1e-12 with max_step 2e-5 s."""
    d = gear.series_compliance
    c, cs, s, mu = gear.gear_stiffness, gear.solid_stiffness, gear.stroke, gear.gear_damping

    def spring(xg: float) -> float:
        return c * xg if abs(xg) <= s else cs * xg + (c - cs) * s * math.copysign(1.0, xg)

    def force(y: np.ndarray) -> float:
        return max(0.0, (y[0] - y[2] - y[4]) / d)

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        p = force(y)
        return [y[1], -p / pair.hammer_mass, y[3], p / pair.anvil_mass, (p - spring(y[4])) / mu]

    sol = solve_ivp(
        rhs, (0.0, t[-1]), [0.0, pair.hammer_speed, 0.0, 0.0, 0.0], method="LSODA",
        rtol=1e-12, atol=1e-14, max_step=2e-5, dense_output=True,
    )
    y = sol.sol(t)
    p = np.array([force(y[:, k]) for k in range(t.size)])
    return sol, p


def test_gear_closure_event_found_and_matches_brute_force() -> None:
    """M-901E-class standard-linear gear at 3.58 m/s (8 mph) closes; at 1.79 m/s (4 mph) it does not.

    Exact answers: at the reported closure the gear compression equals the stroke (to
    1e-12 m); the closure time and the whole force history agree with an independent
    brute-force integration (kinked right-hand side, tiny steps) to 1e-7 s and 1e-6 of
    the peak force (measured 3e-13 s, 3e-10).
    """
    t = np.linspace(0.0, 0.2, 401)
    run = simulate_impact(FAST, Coupling(GEAR, "compression_only"), t)
    assert run.status == "ok", run.message
    closure = [e for e in run.events if e.kind == "gear_closed"]
    assert len(closure) == 1
    assert closure[0].coupler_state[0] == pytest.approx(GEAR.stroke, abs=1e-12)
    assert [e.kind for e in run.events] == ["contact", "gear_closed", "gear_reopened", "separation"]
    sol, p_ref = _brute_force_gear(FAST, GEAR, t)
    t_ref = brentq(lambda x: sol.sol(x)[4] - GEAR.stroke, 0.0, 0.06, xtol=1e-14)
    assert run.closure_time == pytest.approx(t_ref, abs=1e-7)
    assert np.max(np.abs(run.coupler_force - p_ref)) <= 1e-6 * np.max(p_ref)
    slow = simulate_impact(ImpactPair.source_study(1.79), Coupling(GEAR, "compression_only"), t)
    assert slow.closure_time is None and slow.separation_time is not None
    assert np.max(slow.coupler_state) < GEAR.stroke


def test_chattering_cap_reports_failure_instead_of_looping() -> None:
    """More events than settings.max_segments → status 'failed' with a message; unreached samples NaN."""
    t = np.linspace(0.0, 0.2, 201)
    run = simulate_impact(FAST, Coupling(GEAR, "compression_only"), t, settings=IntegratorSettings(max_segments=2))
    assert run.status == "failed"
    assert "more than 2" in run.message
    assert np.isnan(run.coupler_force[-1])


@pytest.mark.parametrize(
    ("law", "closure", "rate", "state", "branch"),
    [
        (KelvinVoigt(4e7, 3e5), 0.02, 1.3, np.zeros(0), None),
        (PowerLawGear(4.6e8, 2.0, 1e5, (2e5, 3e6, 1e7)), 0.03, -0.7, np.zeros(0), None),
        (PowerLawGear(4.6e8, 1.5, 1e5, (2e5, 3e6)), -0.02, 0.4, np.zeros(0), None),
        (GEAR, 0.05, 1.0, np.array([0.04]), None),
        (GEAR, 0.11, 1.0, np.array([0.09]), None),
        (GEAR, -0.11, 1.0, np.array([-0.09]), None),
    ],
)
def test_tangents_match_finite_differences(law, closure: float, rate: float, state: np.ndarray, branch) -> None:
    """Consistency: the analytic tangent (what a Newton iteration on the coupler force uses)
    equals central differences of force(δ, δ̇, s) and state_rate(δ, δ̇, s, P) to 1e-6 relative."""
    p = law.force(closure, rate, state, branch)
    tan = law.tangent(closure, rate, state, p, branch)
    hd, hr = 1e-7, 1e-6

    def close(a: float, b: float) -> bool:
        return abs(a - b) <= 1e-6 * max(abs(a), abs(b), 1.0)

    assert close(tan.force_closure, (law.force(closure + hd, rate, state, branch) - law.force(closure - hd, rate, state, branch)) / (2 * hd))
    assert close(tan.force_rate, (law.force(closure, rate + hr, state, branch) - law.force(closure, rate - hr, state, branch)) / (2 * hr))
    for k in range(law.state_size):
        e = np.zeros(law.state_size)
        e[k] = hd
        dp = (law.force(closure, rate, state + e, branch) - law.force(closure, rate, state - e, branch)) / (2 * hd)
        assert close(tan.force_state[k], dp)
        dq = (law.state_rate(closure, rate, state + e, p, branch) - law.state_rate(closure, rate, state - e, p, branch)) / (2 * hd)
        assert np.allclose(tan.rate_state[:, k], dq, rtol=1e-6)
        hp = 1.0
        dqp = (law.state_rate(closure, rate, state, p + hp, branch) - law.state_rate(closure, rate, state, p - hp, branch)) / (2 * hp)
        assert np.allclose(tan.rate_force, dqp, rtol=1e-6)


def test_coupling_modes_with_slack() -> None:
    """Contact modes: compression-only with a 10 mm gap transmits nothing before closing the gap
    and never in tension; bilateral with slack transmits tension beyond the tension slack;
    bilateral without slack is the bare law. Exact values: P = c (δ − slack) + μ δ̇ etc."""
    law = KelvinVoigt(4e7, 3e5)
    free = Coupling(law, "compression_only", slack=0.01)
    assert free.evaluate(0.005, 1.0).force == 0.0 and free.evaluate(0.005, 1.0).mode == 0
    r = free.evaluate(0.02, 1.0)
    assert r.mode == 1 and r.force == pytest.approx(4e7 * 0.01 + 3e5)
    assert r.tangent.force_closure == 4e7 and free.evaluate(0.0, 1.0).tangent.force_closure == 0.0
    assert free.evaluate(0.011, -10.0).force == 0.0  # the dashpot would pull: separated
    coupled = Coupling(law, "bilateral", slack=0.01, tension_slack=0.02)
    r = coupled.evaluate(-0.03, -1.0)
    assert r.mode == -1 and r.force == pytest.approx(4e7 * -0.01 - 3e5)
    assert coupled.evaluate(-0.015, -1.0).force == 0.0
    bare = Coupling(law, "bilateral")
    assert bare.always_engaged and bare.evaluate(-0.01, 0.5).force == pytest.approx(-4e5 + 1.5e5)
    built = coupling_from_name("kelvin_voigt", {"stiffness": 4e7, "damping": 3e5}, contact="bilateral")
    assert built.law == law and set(COUPLER_LAWS) == {"kelvin_voigt", "power_law", "standard_linear", "draft_gear", "table"}


def test_power_law_peak_estimate_is_first_order_in_damping() -> None:
    """Energy-form perturbation (A3) of the peak closure for N = c δ² (M-901E-like), γ = γ0:
    its error against the ODE falls like γ0² — the ratio for γ0 = 4e5 → 2e5 → 1e5 N·s/m is
    ≈ 4 (asserted 3.2–4.8), and with γ0 = 0 it is exact (1e-9)."""
    t = np.linspace(0.0, 0.3, 3001)
    errors = []
    for g in [0.0, 4.0e5, 2.0e5, 1.0e5]:
        law = PowerLawGear(2.52e6 / 0.074**2, 2.0, 0.0, (g,))
        run = simulate_impact(PAIR, Coupling(law, "compression_only"), t)
        est, _ = power_law_peak_estimate(PAIR, law)
        # the peak closure is where δ̇ = 0: refine on the sampled record by a parabola
        k = int(np.argmin(run.relative_displacement))
        y = -run.relative_displacement[k - 1 : k + 2]
        peak = y[1] + 0.125 * (y[0] - y[2]) ** 2 / (2 * y[1] - y[0] - y[2])
        errors.append(abs(est - peak) / peak)
    assert errors[0] <= 1e-9
    ratios = [errors[1] / errors[2], errors[2] / errors[3]]
    assert all(3.2 <= r <= 4.8 for r in ratios), ratios


def _ode_peak_closure(law: PowerLawGear) -> float:
    """Peak closure (m) of the free impact through ``law`` by simulate_impact (LSODA, rtol 1e-10):
    a coarse run locates the peak sample, a second one samples ±1 ms around it every 5 µs and
    a parabola through the three highest samples gives the vertex (sampling error ≈ 1e-16 m)."""
    t = np.linspace(0.0, 0.3, 601)
    run = simulate_impact(PAIR, Coupling(law, "compression_only"), t)
    k = int(np.argmax(-run.relative_displacement))
    fine = np.linspace(t[k - 1], t[k + 1], 401)
    run = simulate_impact(PAIR, Coupling(law, "compression_only"), fine)
    closure = -run.relative_displacement
    k = int(np.argmax(closure))
    y = closure[k - 1 : k + 2]
    return float(y[1] + 0.125 * (y[0] - y[2]) ** 2 / (2 * y[1] - y[0] - y[2]))


def test_power_law_peak_series_is_the_kelvin_voigt_taylor_series() -> None:
    """n = 1, N0 = 0, γ = μ: the Kelvin-Voigt coupler, whose peak closure is known in closed form.

    Exact answer: δ_p = (w/β) e^{α t_p} sin β t_p with β t_p = atan2(β, −α), α = −μ/(2m*),
    β = √(c/m* − α²); in ε = μ/√(c m*) (= γ w/N(δ₀) here) its Taylor series is
    δ_p/δ₀ = 1 − (π/4) ε + (π²/32 + 1/4) ε² + O(ε³). The series coefficients match to 1e-13,
    T₀ = (π/2)√(m*/c) to 1e-13 relative; the errors of orders 1 and 2 against the closed form
    fall like ε² and ε³ (polyfit slopes in [1.95, 2.05] and [2.95, 3.05] over ε = 0.2 … 0.0125,
    measured 2.007 and 3.008) and stay below 0.6 ε^{k+1} (measured ≤ 0.55 ε² and ≤ 0.37 ε³)."""
    m, w = PAIR.reduced_mass, PAIR.closing_speed
    undamped = power_law_peak_series(PAIR, PowerLawGear(STIFFNESS, 1.0, 0.0, (0.0,)))
    eps_levels = 0.2 / 2.0 ** np.arange(5)
    errors = {1: [], 2: []}
    for eps in eps_levels:
        mu = eps * math.sqrt(STIFFNESS * m)
        law = PowerLawGear(STIFFNESS, 1.0, 0.0, (mu,))
        alpha = -mu / (2.0 * m)
        beta = math.sqrt(STIFFNESS / m - alpha**2)
        t_peak = math.atan2(beta, -alpha) / beta
        exact = w / beta * math.exp(alpha * t_peak) * math.sin(beta * t_peak)
        for order in (1, 2):
            peak = power_law_peak_series(PAIR, law, order)
            assert peak.damping_parameter == pytest.approx(eps, rel=1e-13)
            errors[order].append(abs(peak.closure - exact) / undamped.closure)
    peak = power_law_peak_series(PAIR, PowerLawGear(STIFFNESS, 1.0, 0.0, (3.0e5,)))
    assert peak.closure_coefficients == pytest.approx((1.0, -math.pi / 4, math.pi**2 / 32 + 0.25), abs=1e-13)
    assert peak.undamped_time_to_peak == pytest.approx(0.5 * math.pi * math.sqrt(m / STIFFNESS), rel=1e-13)
    for order, window in [(1, (1.95, 2.05)), (2, (2.95, 3.05))]:
        slope = np.polyfit(np.log(eps_levels), np.log(errors[order]), 1)[0]
        assert window[0] <= slope <= window[1], (order, slope)
        assert np.all(np.array(errors[order]) <= 0.6 * eps_levels ** (order + 1)), (order, errors[order])


@pytest.mark.parametrize(
    ("name", "stiffness", "exponent", "preload", "damping_shape"),
    [
        ("linear", STIFFNESS, 1.0, 0.0, (1.0,)),
        ("n = 1.5", 1.5e8, 1.5, 0.0, (1.0,)),
        ("n = 3 with preload", 3.0e10, 3.0, 5.0e5, (1.0,)),
        ("n = 2, gamma growing with closure", 4.6e8, 2.0, 0.0, (1.0, 30.0)),
    ],
)
def test_power_law_peak_series_error_falls_like_damping_to_order_plus_one(
    name: str, stiffness: float, exponent: float, preload: float, damping_shape: tuple[float, ...]
) -> None:
    """Free impact (source-study pair, 2.2 m/s) through P = c δⁿ + N0 + γ(δ) δ̇, γ = g·(shape);
    g halves four times from ε = γ(δ₀) w/N(δ₀) = 0.2 to 0.0125.

    Exact answers: at γ = 0 every order is the undamped peak Φ(δ₀) = m* w²/2 (ODE within 2e-9,
    measured ≤ 5e-10, the solver's tolerance). The peak-force error of the order-k estimate
    against the ODE reference (rtol 1e-10) falls like ε^{k+1}: polyfit slope of log error
    against log ε in [1.8, 2.2] for k = 1 and [2.75, 3.25] for k = 2 (measured 1.99–2.04 and
    2.92–3.02; the window for k = 2 excludes the ε^{5/2} the endpoint singularity of u₂ might
    suggest — see power_law_peak_series), and below 1.2 ε² and 0.6 ε³ of the reference at
    every level (measured ≤ 0.85 ε² and ≤ 0.43 ε³). The order-1 function
    power_law_peak_estimate returns the same numbers as order 1 of the series."""
    undamped = PowerLawGear(stiffness, exponent, preload, (0.0,))
    base = power_law_peak_series(PAIR, undamped)
    assert base.closure == base.undamped_closure and base.damping_parameter == 0.0
    assert abs(base.closure - _ode_peak_closure(undamped)) <= 2e-9 * base.closure
    shape_at_peak = sum(s * base.undamped_closure**k for k, s in enumerate(damping_shape))
    top = 0.2 * base.undamped_force / (PAIR.closing_speed * shape_at_peak)
    eps_levels, errors = [], {1: [], 2: []}
    for level in range(5):
        law = PowerLawGear(stiffness, exponent, preload, tuple(top / 2.0**level * s for s in damping_shape))
        closure = _ode_peak_closure(law)
        force = law.force(closure, 0.0, np.zeros(0))
        for order in (1, 2):
            peak = power_law_peak_series(PAIR, law, order)
            errors[order].append(abs(peak.spring_force - force) / force)
        eps_levels.append(peak.damping_parameter)
        assert power_law_peak_estimate(PAIR, law) == (
            power_law_peak_series(PAIR, law, 1).closure,
            power_law_peak_series(PAIR, law, 1).spring_force,
        )
    eps = np.array(eps_levels)
    assert eps[0] == pytest.approx(0.2, rel=1e-12)
    for order, window, bound in [(1, (1.8, 2.2), 1.2), (2, (2.75, 3.25), 0.6)]:
        slope = np.polyfit(np.log(eps), np.log(errors[order]), 1)[0]
        assert window[0] <= slope <= window[1], (name, order, slope)
        assert np.all(np.array(errors[order]) <= bound * eps ** (order + 1)), (name, order, errors[order])


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: StandardLinearDraftGear(4e8, 4e8, 3.4e7, 5e5, 0.0, 2e8), "stroke must be > 0"),
        (lambda: StandardLinearDraftGear(4e8, 4e8, 3.4e7, 0.0, 0.08, 2e8), "gear_damping must be > 0"),
        (lambda: StandardLinearDraftGear(-4e8, 4e8, 3.4e7, 5e5, 0.08, 2e8), "series_stiffness_1 must be > 0"),
        (lambda: PowerLawGear(4.6e8, 0.5), "exponent must be >= 1"),
        (lambda: PowerLawGear(4.6e8, 2.0, -1.0), "preload must be >= 0"),
        (lambda: PowerLawGear(4.6e8, 2.0, 0.0, (float("nan"),)), "damping\\[0\\] must be finite"),
        (lambda: power_law_peak_series(PAIR, PowerLawGear(4.6e8, 2.0), order=3), "order must be 0, 1 or 2"),
        (lambda: power_law_peak_series(ImpactPair(1e5, 1e5, 0.0), PowerLawGear(4.6e8, 2.0)), "closing speed must be > 0"),
        (lambda: KelvinVoigt(0.0, 1.0), "stiffness must be > 0"),
        (lambda: Coupling(KelvinVoigt(1e7), "sticky"), "contact must be one of"),
        (lambda: Coupling(KelvinVoigt(1e7), slack=-0.01), "slack must be >= 0"),
        (lambda: Coupling(KelvinVoigt(1e7), "compression_only", tension_slack=0.01), "tension_slack applies to bilateral"),
        (lambda: coupling_from_name("friction", {}), "coupler law must be one of"),
        (lambda: simulate_impact(PAIR, Coupling(KelvinVoigt(1e7)), [-0.1, 0.2]), "time must start at or after"),
        (lambda: simulate_impact(PAIR, Coupling(KelvinVoigt(1e7)), [[0.0, 0.2]]), "time must be a 1-D array"),
        (lambda: IntegratorSettings(method="Euler"), "method must be one of"),
        (lambda: IntegratorSettings(rtol=-1e-9), "rtol must be > 0"),
        (lambda: Coupling(GEAR).evaluate(0.01, 0.0, np.zeros(3)), "state must have shape"),
        (
            lambda: simulate_impact(PAIR, Coupling(KelvinVoigt(1e7)), [0.0, 0.1], external_force=lambda t: (np.nan, 0.0)),
            "external_force returned non-finite",
        ),
    ],
)
def test_bad_input_is_rejected(call, match: str) -> None:
    """Non-physical parameters, wrong shapes, unknown names, non-finite forces → ValueError naming the rule."""
    with pytest.raises(ValueError, match=match):
        call()
