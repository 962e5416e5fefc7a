"""Exact transient response of Voigt rods (femref.exact.transient, femref.exact.laplace).

Rod at rest at t = 0, F = EA u_x + cA u_xt, F_x = m u_tt, F(−l, t) = F1(t), F(l, t) = F2(t).
The reference is an independent modal superposition for the homogeneous rod (Voigt damping
is proportional, so the free-free modes cos(kπ(x + l)/2l) decouple) with the exact Duhamel
response of each mode to a half-sine, by partial fractions.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import polygamma

from femref.exact import Segments, invert_laplace, rod_transient
from femref.core.signals import Constant, HalfSine, RampStep, Tabulated

L_HALF, MASS, STIFFNESS = 1.0, 1.0, 1.0  # wave travel time l√(m/EA) = 1 s
MODES = 3000


def voigt_rod(beta: float) -> Segments:
    return Segments.uniform(2 * L_HALF, MASS, STIFFNESS, beta * L_HALF * np.sqrt(MASS * STIFFNESS))


def _residues(poles: np.ndarray, numerator) -> np.ndarray:
    """Residues of numerator(s)/Π(s − p_j) at each pole (distinct poles along axis 0)."""
    res = np.empty_like(poles)
    for j in range(poles.shape[0]):
        others = np.prod([poles[j] - poles[i] for i in range(poles.shape[0]) if i != j], axis=0)
        res[j] = numerator(poles[j]) / others
    return res


def modal_half_sine(beta: float, amplitude: float, duration: float, t, x, side: str):
    """Acceleration and axial force of the homogeneous Voigt rod under a half-sine at one end.

    a(x, t) = (F2 − F1)/M + Σ_k φ_k(x) q̈_k(t),  q̈_k + τω_k² q̇_k + ω_k² q_k = Q_k(t)/(m l),
    Q_k = F2 (−1)^k − F1,  τ = cA/EA;  F(x) = F1 + ∫_{−l}^{x} m a dx (termwise, converges like k⁻³).
    The loaded-end acceleration series converges like 1/K: the modes above K are added
    quasi-statically (mode-acceleration correction, Σ_{k>K} φ_k φ_k(load)/(m l ω_k²) times the
    Voigt-filtered load acceleration)."""
    tau = beta * L_HALF * np.sqrt(MASS / STIFFNESS)
    k = np.arange(1, MODES + 1)
    wk = k * np.pi / (2 * L_HALF) * np.sqrt(STIFFNESS / MASS)
    b = tau * wk**2
    p1 = -(b + np.sqrt((b * b - 4 * wk**2).astype(complex))) / 2
    p2 = wk**2 / p1
    big_omega = np.pi / duration
    ones = np.ones(MODES)
    poles = np.stack([p1, p2, 1j * big_omega * ones, -1j * big_omega * ones])
    res = _residues(poles, lambda p: p * p * big_omega)  # s² Ω/((s − p1)(s − p2)(s² + Ω²))

    def response(tt):
        tt = np.asarray(tt, dtype=float)
        on = (tt > 0)[:, None]
        return np.where(on, np.real(np.einsum("jk,tjk->tk", res, np.exp(poles[None] * np.maximum(tt, 0)[:, None, None]))), 0.0)

    sign = (-1.0) ** k if side == "right" else -ones
    modal = (response(t) + response(t - duration)) * amplitude / (MASS * L_HALF) * sign
    phi = np.cos(np.outer(k, x + L_HALF) * np.pi / (2 * L_HALF))
    load = HalfSine(amplitude, duration)(t)
    rigid = (load if side == "right" else -load) / (2 * MASS * L_HALF)
    acceleration = rigid[:, None] + modal @ phi

    # quasi-static tail of the modes k > K: (4l/(EA π²)) Σ_{k>K} φ_k(x) sign_k / k² · g(t)
    filt = np.array([-1 / tau, 1j * big_omega, -1j * big_omega])
    g_res = _residues(filt, lambda p: p * p * big_omega / tau)

    def g(tt):
        return np.where(tt > 0, np.real(np.exp(np.outer(np.maximum(tt, 0), filt)) @ g_res), 0.0)

    load_end = L_HALF if side == "right" else -L_HALF
    kk = np.arange(MODES + 1, 200_001)
    tail_sign = (-1.0) ** kk if side == "right" else -np.ones(kk.size)
    coefficient = np.array([np.sum(np.cos(kk * np.pi * (xi + L_HALF) / (2 * L_HALF)) * tail_sign / kk**2) for xi in x])
    # at the loaded end the terms no longer alternate: add Σ_{k>200000} ±1/k² = ±ψ'(200001)
    coefficient += np.where(np.isclose(x, load_end), (1.0 if side == "right" else -1.0) * float(polygamma(1, 200_001)), 0.0)
    acceleration += amplitude * (g(t) + g(t - duration))[:, None] * coefficient * 4 * L_HALF / (STIFFNESS * np.pi**2)

    integral = (2 * L_HALF / (k * np.pi))[:, None] * np.sin(np.outer(k, x + L_HALF) * np.pi / (2 * L_HALF))
    F1 = np.zeros_like(t) if side == "right" else load
    force = F1[:, None] + MASS * (rigid[:, None] * (x + L_HALF) + modal @ integral)
    return acceleration, force


def peak_error(got, reference):
    """Largest error relative to the peak of the reference, per position."""
    return np.max(np.abs(got - reference), axis=0) / np.max(np.abs(reference))


@pytest.mark.parametrize("beta, side, duration", [(0.05, "right", 5.0), (0.01, "left", 3.0), (1.0, "right", 1.0)])
def test_matches_modal_superposition(beta, side, duration):
    """Homogeneous Voigt rod, half-sine of unit amplitude at one end, t ∈ [0, 3 pulses]:
    acceleration at the free end, centre, 0.3l and the loaded end, and the force at interior
    points, equal the modal solution to 1e-5 of their peaks (measured 1e-10 … 1e-7)."""
    t = np.linspace(0.0, 3 * duration, 400)
    x = np.array([-1.0, 0.0, 0.3, 1.0]) * L_HALF
    a_ref, F_ref = modal_half_sine(beta, 1.0, duration, t, x, side)
    load = HalfSine(1.0, duration)
    r = rod_transient(voigt_rod(beta), t, x, load if side == "left" else None, load if side == "right" else None)
    assert np.all(peak_error(r.acceleration, a_ref) < 1e-5)
    assert np.all(peak_error(r.axial_force, F_ref) < 1e-5)


def test_long_record_at_light_damping():
    """β = 0.01 over 60 travel times (12 pulse lengths): the record holds ~30 lightly damped wave
    passages; the acceleration still matches the modal solution to 2e-4 of its peak at the
    centre (the hardest point: equally spaced arrivals) and 2e-5 elsewhere."""
    duration = 5.0
    t = np.linspace(0.0, 60.0, 600)
    x = np.array([-1.0, 0.0, 0.3]) * L_HALF
    a_ref, _ = modal_half_sine(0.01, 1.0, duration, t, x, "right")
    r = rod_transient(voigt_rod(0.01), t, x, None, HalfSine(1.0, duration))
    error = peak_error(r.acceleration, a_ref)
    assert error[1] < 2e-4 and error[0] < 2e-5 and error[2] < 2e-5


def test_momentum_of_a_piecewise_rod():
    """Three segments (mass, stiffness, viscosity contrasts up to 10), loads at both ends
    (half-sine, ramp to a step, tabulated): ∫ m a dx = F2(t) − F1(t) for t > 0 to 1e-6 of the
    peak load (Gauss quadrature of the exact accelerations, 40 points per segment)."""
    body = Segments(np.array([-1.0, -0.3, 0.4, 1.0]), np.array([1.0, 5.0, 0.5]), np.array([1.0, 0.2, 3.0]), np.array([0.05, 0.01, 0.2]))
    xg, wg = np.polynomial.legendre.leggauss(40)
    x = np.concatenate([0.5 * (b - a) * xg + 0.5 * (a + b) for a, b in zip(body.edges[:-1], body.edges[1:])])
    weights = np.concatenate([0.5 * (b - a) * wg * m for a, b, m in zip(body.edges[:-1], body.edges[1:], body.mass_per_length)])
    t = np.linspace(0.0, 20.0, 400)[1:]
    cases = [
        (HalfSine(0.7, 3.0, 1.0), RampStep(1.0, 2.0, 0.5)),
        (None, Tabulated(np.array([0.0, 1.0, 2.0, 4.0]), np.array([0.0, 1.0, -0.5, 0.0]))),
    ]
    for F1, F2 in cases:
        r = rod_transient(body, t, x, F1, F2)
        target = (F2(t) if F2 else 0.0) - (F1(t) if F1 else 0.0)
        assert np.max(np.abs(r.acceleration @ weights - target)) < 1e-6 * np.max(np.abs(target))


def test_step_load_settles_to_rigid_motion():
    """Constant F2 = 1 from t = 0 on a well-damped rod (β = 1): after 40 travel times the body
    accelerates rigidly, a = F2/M, with the inertia-balanced force F = F2 (x + l)/2l, and the
    displacement of the centre follows F2 t²/(2M) + const (to 1e-6)."""
    x = np.array([-1.0, 0.0, 0.5, 1.0]) * L_HALF
    t = np.array([40.0, 45.0, 50.0])
    r = rod_transient(voigt_rod(1.0), t, x, None, Constant(1.0))
    M = 2 * MASS * L_HALF
    assert np.max(np.abs(r.acceleration - 1.0 / M)) < 1e-6
    assert np.max(np.abs(r.axial_force - (x + L_HALF) / (2 * L_HALF))) < 1e-6
    drift = r.displacement[:, 1] - t**2 / (2 * M)
    assert np.ptp(drift) < 1e-6 * np.max(r.displacement[:, 1])


def test_viscosity_extremes():
    """β = 1e4: the rod is rigid on the load's time scale, a = F2(t)/M to 1e-3; β = 1e-6 (nearly
    elastic): results finite and the momentum ∫ m a dx = F2 holds in the mean (its jumps ring)."""
    t = np.linspace(0.0, 10.0, 200)
    x = np.array([-1.0, 0.0, 1.0]) * L_HALF
    load = HalfSine(1.0, 5.0)
    stiff = rod_transient(voigt_rod(1e4), t, x, None, load)
    assert np.max(np.abs(stiff.acceleration - load(t)[:, None] / (2 * MASS * L_HALF))) < 1e-3
    soft = rod_transient(voigt_rod(1e-6), t, x, None, load)
    assert all(np.all(np.isfinite(f)) for f in (soft.acceleration, soft.axial_force, soft.displacement))
    assert np.max(np.abs(soft.axial_force[:, -1] - load(t))) < 1e-2


def test_no_load_gives_rest_and_shapes():
    """No loads (or only t = 0): the body stays at rest; every field has shape (Nt, Nx)."""
    t = np.linspace(0.0, 1.0, 7)
    r = rod_transient(voigt_rod(0.1), t, [0.0, 0.5], None, None)
    for field in (r.displacement, r.acceleration, r.axial_force):
        assert field.shape == (7, 2) and not np.any(field)
    assert rod_transient(voigt_rod(0.1), [0.0], [0.0], None, HalfSine(1.0, 1.0)).acceleration.shape == (1, 1)


def test_a_run_of_2000_times_and_5_positions_is_vectorised():
    """Nt = 2000, Nx = 5 on a three-segment rod runs through a handful of transform batches
    (a smoke test of the vectorised path; the measured wall time is ≈ 0.1 s)."""
    body = Segments(np.array([-1.0, -0.2, 0.5, 1.0]), np.array([1.0, 2.0, 1.0]), np.array([1.0, 0.5, 2.0]), np.array([0.05, 0.05, 0.1]))
    calls = []
    from femref.exact import transient

    original = transient.rod_unit_response

    def counting(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    transient.rod_unit_response = counting
    try:
        r = rod_transient(body, np.linspace(0.0, 40.0, 2000), np.linspace(-1.0, 1.0, 5), HalfSine(0.5, 8.0), HalfSine(1.0, 10.0, 2.0))
    finally:
        transient.rod_unit_response = original
    assert r.acceleration.shape == (2000, 5) and np.all(np.isfinite(r.acceleration))
    assert len(calls) < 60


@pytest.mark.parametrize(
    "transform, exact",
    [
        (lambda s: 1.0 / (s + 1.0), lambda t: np.exp(-t)),
        (lambda s: 2.0 / (s * s + 4.0), lambda t: np.sin(2.0 * t)),
        (lambda s: 1.0 / s**2, lambda t: t),
        (lambda s: HalfSine(1.0, 2.0, 0.5).laplace(s), HalfSine(1.0, 2.0, 0.5)),
    ],
)
def test_invert_laplace_on_known_pairs(transform, exact):
    """e^{−t} ↔ 1/(s+1), sin 2t ↔ 2/(s²+4), t ↔ 1/s², a delayed half-sine ↔ its transform:
    to 1e-8; the half-sine to 3e-3 (measured 1.6e-3 at its corners, which sit inside the time
    windows — the reason rod_transient splits loads at their corners). t > 0: at t = 0 a jump
    of f is seen as the Fourier series' mean value."""
    t = np.linspace(0.0, 6.0, 61)[1:]
    tolerance = 3e-3 if isinstance(exact, HalfSine) else 1e-8
    assert np.max(np.abs(invert_laplace(transform, t, terms=32) - exact(t))) < tolerance


def test_invert_laplace_of_zero_is_zero():
    """F(s) ≡ 0 (a degenerate QD table) gives f ≡ 0, without warnings."""
    assert not np.any(invert_laplace(lambda s: np.zeros((s.size, 2), dtype=complex), np.linspace(0, 1, 5)))


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: rod_transient(voigt_rod(0.1), [-1.0, 0.0], [0.0], None, Constant(1.0)), "times"),
        (lambda: rod_transient(voigt_rod(0.1), [0.0, 1.0], [2.0], None, Constant(1.0)), "positions x"),
        (lambda: rod_transient(voigt_rod(0.1), [1.0], [0.0], None, Constant(1.0), terms=1), "terms"),
        (lambda: invert_laplace(lambda s: 1 / s, [np.nan]), "times"),
        (lambda: rod_transient(voigt_rod(0.1), [1.0], [0.0], HalfSine(1.0, 1.0, -0.5), None), "F1 must start"),
    ],
)
def test_bad_input_is_rejected(call, message):
    """Negative or non-finite times, x outside the body, fewer than 2 terms, a load that
    starts before t = 0: ValueError."""
    with pytest.raises(ValueError, match=message):
        call()
