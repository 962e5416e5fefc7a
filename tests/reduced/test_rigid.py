"""Rigid two-mass Kelvin-Voigt impact: closed form and small-damping series (reduced.rigid)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from reduced.rigid import (
    ImpactPair,
    kelvin_voigt_impact,
    kelvin_voigt_perturbation,
    perturbation_terms,
    small_damping_parameter,
)
from support.convergence import observed_order

PAIR = ImpactPair.source_study()  # 119 t at 2.2 m/s against 100 t at rest
STIFFNESS = 4.0e7  # N/m (the example coupler of docs/design.md §3)


def _damping(zeta: float, pair: ImpactPair = PAIR, stiffness: float = STIFFNESS) -> float:
    return 2.0 * zeta * math.sqrt(stiffness * pair.reduced_mass)


def _reference(pair: ImpactPair, c: float, mu: float, t: np.ndarray, compression_only: bool) -> dict[str, np.ndarray]:
    """solve_ivp (DOP853, rtol 1e-13) of m1 x1'' = −P, m2 x2'' = P, P = −(c x + μ x'), x = x2 − x1."""
    m1, m2 = pair.hammer_mass, pair.anvil_mass

    def force(y: np.ndarray) -> float:
        x, xd = y[2] - y[0], y[3] - y[1]
        return -(c * x + mu * xd)

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        p = force(y)
        return [y[1], -p / m1, y[3], p / m2]

    def separation(_t: float, y: np.ndarray) -> float:
        return force(y)

    separation.terminal = True  # type: ignore[attr-defined]
    separation.direction = -1.0  # type: ignore[attr-defined]
    y0 = [0.0, pair.hammer_speed, 0.0, pair.anvil_speed]
    kw = dict(method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, events=[separation] if compression_only else None, **kw)
    ts = sol.t[-1] if compression_only and sol.status == 1 else t[-1] + 1.0
    y = sol.sol(np.minimum(t, ts))
    p = np.array([force(y[:, k]) for k in range(t.size)])
    after = t > ts
    y[0] = np.where(after, y[0] + y[1] * (t - ts), y[0])
    y[2] = np.where(after, y[2] + y[3] * (t - ts), y[2])
    p = np.where(after, 0.0, p)
    return {"x": y[2] - y[0], "p": p, "a1": -p / m1, "a2": p / m2, "ts": ts}


@pytest.mark.parametrize("zeta", [0.2, 1.0, 3.0])
@pytest.mark.parametrize("contact", ["bilateral", "compression_only"])
def test_closed_form_matches_solve_ivp(zeta: float, contact: str) -> None:
    """Under-, critically and over-damped coupler, both contacts.

    Problem: 119 t at 2.2 m/s hits 100 t, c = 4e7 N/m, μ = 2ζ√(c m*). Exact answer: the
    ODE itself, integrated by DOP853 at rtol 1e-13. Closed-form x, a1, a2 and P agree to
    1e-8 of their peak, and the separation time to 1e-9 s.
    """
    mu = _damping(zeta)
    t = np.linspace(0.0, 0.4, 801)
    closed = kelvin_voigt_impact(PAIR, STIFFNESS, mu, t, contact=contact)
    ref = _reference(PAIR, STIFFNESS, mu, t, contact == "compression_only")
    for key, mine in [
        ("x", closed.relative_displacement),
        ("p", closed.coupler_force),
        ("a1", closed.hammer_acceleration),
        ("a2", closed.anvil_acceleration),
    ]:
        scale = np.max(np.abs(ref[key]))
        assert np.max(np.abs(mine - ref[key])) <= 1e-8 * scale, key
    if contact == "compression_only":
        assert closed.separation_time == pytest.approx(ref["ts"], abs=1e-9)
        assert np.all(closed.coupler_force >= 0.0)
    else:
        assert closed.separation_time is None


def test_closed_form_is_continuous_through_critical_damping() -> None:
    """No 0/0 near ζ = 1: ζ = 1 ± 1e-12 and 1 ± 1e-7 give the critical answer to 1e-10 and 1e-6.

    Exact answer at ζ = 1: x = −w t e^{αt}; the solution is analytic in ζ, so a change
    δζ moves it by O(δζ) of its peak.
    """
    t = np.linspace(0.0, 0.3, 301)
    crit = kelvin_voigt_impact(PAIR, STIFFNESS, _damping(1.0), t)
    alpha = -_damping(1.0) / (2.0 * PAIR.reduced_mass)
    exact = -PAIR.closing_speed * t * np.exp(alpha * t)
    scale = np.max(np.abs(exact))
    assert np.max(np.abs(crit.relative_displacement - exact)) <= 1e-14 * scale
    for dz, tol in [(1e-12, 1e-10), (1e-7, 1e-6)]:
        for zeta in (1.0 - dz, 1.0 + dz):
            near = kelvin_voigt_impact(PAIR, STIFFNESS, _damping(zeta), t, contact="compression_only")
            assert np.all(np.isfinite(near.coupler_force))
            assert np.max(np.abs(near.relative_displacement[t < 0.07] - exact[t < 0.07])) <= tol * scale


def test_momentum_conserved_and_undamped_energy_conserved() -> None:
    """Free pair: m1 v1 + m2 v2 = m1 v (exact); undamped coupled impact keeps KE + c x²/2 = m1 v²/2."""
    t = np.linspace(0.0, 0.5, 501)
    h = kelvin_voigt_impact(PAIR, STIFFNESS, 0.0, t)
    momentum = PAIR.hammer_mass * h.hammer_velocity + PAIR.anvil_mass * h.anvil_velocity
    assert np.max(np.abs(momentum - PAIR.hammer_mass * PAIR.hammer_speed)) <= 1e-9 * PAIR.hammer_mass * PAIR.hammer_speed
    energy = (
        0.5 * PAIR.hammer_mass * h.hammer_velocity**2
        + 0.5 * PAIR.anvil_mass * h.anvil_velocity**2
        + 0.5 * STIFFNESS * h.relative_displacement**2
    )
    assert np.max(np.abs(energy - PAIR.kinetic_energy)) <= 1e-12 * PAIR.kinetic_energy


def test_undamped_free_to_roll_is_an_elastic_collision() -> None:
    """μ = 0, compression only: separation at t = π√(m*/c), then the elastic-collision speeds

    v1' = (m1 − m2) v/(m1 + m2), v2' = 2 m1 v/(m1 + m2), zero force and acceleration after.
    """
    t = np.linspace(-0.05, 0.3, 701)
    h = kelvin_voigt_impact(PAIR, STIFFNESS, 0.0, t, contact="compression_only")
    m1, m2, v = PAIR.hammer_mass, PAIR.anvil_mass, PAIR.hammer_speed
    assert h.separation_time == pytest.approx(math.pi * math.sqrt(PAIR.reduced_mass / STIFFNESS), rel=1e-13)
    after = t > h.separation_time
    assert np.allclose(h.hammer_velocity[after], (m1 - m2) * v / (m1 + m2), rtol=1e-12)
    assert np.allclose(h.anvil_velocity[after], 2.0 * m1 * v / (m1 + m2), rtol=1e-12)
    assert np.all(h.coupler_force[after] == 0.0) and np.all(h.anvil_acceleration[after] == 0.0)
    before = t < 0.0
    assert np.all(h.coupler_force[before] == 0.0)
    assert np.allclose(h.relative_displacement[before], -v * t[before], rtol=1e-15)


@pytest.mark.parametrize("order", [0, 1, 2, 3])
def test_perturbation_error_falls_like_eps_to_order_plus_one(order: int) -> None:
    """Series to order k against the closed form at fixed τ ∈ [0, 2π]: max error ∝ ε^{k+1}.

    ε = μ/√(c m*) = 0.01…0.08 (four levels). Exact answer: slope k + 1 of log(err) vs
    log(ε); asserted in [k + 0.7, k + 1.3], plus an absolute bound on the finest level
    (error ≤ 2 (2π ε)^{k+1} of the peak |x|, a loose bound on the first neglected term).
    Measured slopes: 0.98, 1.99, 2.99, 4.00; order-3 error at ε = 0.01: 4.4e-8.
    """
    omega = math.sqrt(STIFFNESS / PAIR.reduced_mass)
    t = np.linspace(0.0, 2.0 * math.pi / omega, 400)
    eps_levels = np.array([0.01, 0.02, 0.04, 0.08])
    errors = []
    for eps in eps_levels:
        mu = eps * math.sqrt(STIFFNESS * PAIR.reduced_mass)
        exact = kelvin_voigt_impact(PAIR, STIFFNESS, mu, t)
        series = kelvin_voigt_perturbation(PAIR, STIFFNESS, mu, t, order=order)
        assert small_damping_parameter(PAIR, STIFFNESS, mu) == pytest.approx(eps, rel=1e-14)
        scale = np.max(np.abs(exact.relative_displacement))
        errors.append(np.max(np.abs(series.relative_displacement - exact.relative_displacement)) / scale)
    slope = observed_order(eps_levels, errors)
    assert order + 0.7 <= slope <= order + 1.3
    assert errors[0] <= 2.0 * (2.0 * math.pi * eps_levels[0]) ** (order + 1)


def test_third_order_series_force_and_slope_window() -> None:
    """Order 3 (the required series): slope of the coupler-force error in [3.7, 4.3]; at ε = 0.01
    the force error is below 1e-6 of the peak force (measured slope 4.00, error 8.8e-8)."""
    omega = math.sqrt(STIFFNESS / PAIR.reduced_mass)
    t = np.linspace(0.0, 2.0 * math.pi / omega, 400)
    eps_levels = np.array([0.01, 0.02, 0.04, 0.08])
    errors = []
    for eps in eps_levels:
        mu = eps * math.sqrt(STIFFNESS * PAIR.reduced_mass)
        exact = kelvin_voigt_impact(PAIR, STIFFNESS, mu, t).coupler_force
        series = kelvin_voigt_perturbation(PAIR, STIFFNESS, mu, t, order=3).coupler_force
        errors.append(np.max(np.abs(series - exact)) / np.max(np.abs(exact)))
    slope = observed_order(eps_levels, errors)
    assert 3.7 <= slope <= 4.3
    assert errors[0] <= 1e-6


def test_perturbation_terms_solve_their_hierarchy() -> None:
    """X_k'' + X_k = −X_{k−1}', X_0 = −sin τ, X_k(0) = X_k'(0) = 0 (k ≥ 1): the returned X_k' is the
    derivative of X_k (central differences, 1e-8) and the hierarchy residual vanishes (1e-6)."""
    tau = np.linspace(0.0, 7.0, 701)
    h = 1e-4
    x, xd = perturbation_terms(tau, 3)
    xp, xdp = perturbation_terms(tau + h, 3)
    xm, xdm = perturbation_terms(tau - h, 3)
    assert np.max(np.abs((xp - xm) / (2 * h) - xd)) <= 1e-6
    xdd = (xdp - xdm) / (2 * h)
    residual = xdd + x
    residual[1:] += xd[:-1]
    assert np.max(np.abs(residual)) <= 1e-6
    assert np.max(np.abs(x[1:, 0])) == 0.0 and np.max(np.abs(xd[1:, 0])) == 0.0
    assert x[0] == pytest.approx(-np.sin(tau), abs=1e-15)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: ImpactPair(-119e3, 100e3, 2.2), "hammer_mass must be > 0"),
        (lambda: ImpactPair(119e3, 0.0, 2.2), "anvil_mass must be > 0"),
        (lambda: ImpactPair(119e3, 100e3, float("nan")), "hammer_speed must be finite"),
        (lambda: kelvin_voigt_impact(PAIR, -1.0, 0.0, [0.0, 1.0]), "stiffness must be > 0"),
        (lambda: kelvin_voigt_impact(PAIR, 1e7, -1.0, [0.0, 1.0]), "damping must be >= 0"),
        (lambda: kelvin_voigt_impact(PAIR, 1e7, 0.0, [0.0, 1.0], contact="glued"), "contact must be one of"),
        (lambda: kelvin_voigt_impact(PAIR, 1e7, 0.0, np.zeros((2, 3))), "time must be a 1-D array"),
        (lambda: kelvin_voigt_impact(PAIR, 1e7, 0.0, [0.0, 0.2, 0.1]), "time must increase strictly"),
        (lambda: kelvin_voigt_impact(PAIR, 1e7, 0.0, [0.0, np.inf]), "non-finite"),
        (lambda: kelvin_voigt_perturbation(PAIR, 1e7, 1e4, [-1.0, 0.0]), "time must be >= 0"),
        (lambda: perturbation_terms([0.0, 1.0], order=4), "order must be 0, 1, 2 or 3"),
    ],
)
def test_bad_input_is_rejected(call, match: str) -> None:
    """Negative or zero masses, non-finite values, wrong shapes, unknown names → ValueError naming the rule."""
    with pytest.raises(ValueError, match=match):
        call()
