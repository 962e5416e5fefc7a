"""Time stepping: temporal order, energy conservation and decay, numerical damping, momentum."""

import numpy as np
import pytest
import scipy.linalg

from femref.fem import Integrator, Stepper, assemble_beam, assemble_rod, body_nodes
from femref.core.profiles import Piecewise, Uniform
from femref.core.signals import HalfSine, RampStep
from support.convergence import observed_order

L, MASS, EA = 8.0, 6250.0, 2.0e9
T_WAVE = L * np.sqrt(MASS / EA)  # 0.01414 s


def rod(viscosity: float, n: int = 32, order: int = 2):
    return assemble_rod(body_nodes(L, n), order, Uniform(MASS), Uniform(EA), Uniform(viscosity))


@pytest.mark.parametrize("integrator", [Integrator.newmark(), Integrator.generalized_alpha(0.8)])
def test_temporal_order_two(integrator):
    """Viscous rod under a half-sine: centre displacement and acceleration converge at second order in dt.

    Reference: the same mesh with dt/64 (the spatial error cancels). Observed order
    from dt = T/25 … T/200 (T = 0.05 s pulse) must lie in [1.8, 2.3]. (Generalized-α
    reports the equilibrium acceleration at t_n; its internal a_n lags by (αm − αf)dt.)
    """
    ops = rod(viscosity=4.0e6, n=8)
    load = {"F2": HalfSine(-1.0e6, 0.05)}
    end, x = 0.1, np.array([0.0])
    sizes = 0.05 / np.array([25, 50, 100, 200])
    reference = Stepper(ops, integrator, sizes[-1] / 64, load).solve(end, x, output_stride=64 * 8)
    errors = []
    for k, dt in enumerate(sizes):
        stride = 2**k  # outputs every 0.002 s, as the reference
        response = Stepper(ops, integrator, dt, load).solve(end, x, output_stride=stride)
        assert np.allclose(response.time, reference.time, rtol=0, atol=1e-12)
        errors.append([np.max(np.abs(getattr(response, q) - getattr(reference, q))) for q in ("displacement", "acceleration")])
    errors = np.array(errors)
    for j, quantity in enumerate(("displacement", "acceleration")):
        assert 1.8 <= observed_order(sizes, errors[:, j]) <= 2.3, quantity
    assert errors[-1, 1] <= 2e-3 * np.max(np.abs(reference.acceleration))


def test_energy_conserved_undamped_average_acceleration():
    """Undamped rod, Newmark average acceleration: after the pulse, T + V is constant to 1e-8.

    The discrete balance T + V = W (work of the end loads) holds to round-off at all times.
    """
    ops = rod(viscosity=0.0, n=40)
    response = Stepper(ops, Integrator.newmark(), T_WAVE / 10, {"F2": HalfSine(-1.0e6, 2 * T_WAVE)}).solve(
        20 * T_WAVE, np.array([0.0])
    )
    total = response.kinetic + response.strain
    after = response.time > 2 * T_WAVE + 1e-12
    assert np.ptp(total[after]) <= 1e-8 * total[after].max()
    assert response.energy_balance_error <= 1e-8
    assert response.dissipated[-1] == 0.0


@pytest.mark.parametrize("kind", ["rod", "beam"])
def test_energy_never_increases_with_voigt_damping(kind):
    """With Voigt viscosity and no load after the pulse, T + V never increases, and T + V + D = W."""
    nodes = body_nodes(L, 24)
    if kind == "rod":
        ops = assemble_rod(nodes, 2, Uniform(MASS), Uniform(EA), Uniform(2.0e6))
        loads = {"F1": HalfSine(5.0e5, 0.02), "F2": HalfSine(-1.0e6, 0.03)}
    else:
        ops = assemble_beam(nodes, Uniform(MASS), Uniform(5.0e9), Uniform(2.0e7))
        loads = {"N1": HalfSine(5.0e5, 0.02), "G2": HalfSine(1.0e6, 0.03)}
    response = Stepper(ops, Integrator.newmark(), 2.0e-4, loads).solve(0.3, np.array([0.0]))
    total = response.kinetic + response.strain
    after = response.time > 0.03 + 1e-12
    assert np.all(np.diff(total[after]) <= 1e-10 * total.max())
    assert total[-1] < 0.9 * total[after][0] or response.dissipated[-1] > 0.0
    assert response.energy_balance_error <= 1e-9


def test_generalized_alpha_damps_the_highest_mode():
    """Start in the highest eigenmode with ω_max dt ≈ 1e3: generalized-α (ρ∞ = 0.5) removes it
    (energy ratio < 1e-4 after 20 steps, ρ∞² per step asymptotically), Newmark keeps it (> 0.999)."""
    ops = rod(viscosity=0.0, n=12, order=1)
    values, vectors = scipy.linalg.eigh(ops.stiffness.toarray(), ops.mass.toarray())
    mode, omega_max = vectors[:, -1], np.sqrt(values[-1])
    dt = 1000.0 / omega_max

    def energy_ratio(integrator):
        stepper = Stepper(ops, integrator, dt)
        states = stepper.iterate(20, u0=mode)
        next(states)  # the initial state
        e0 = 0.5 * mode @ (ops.stiffness @ mode)
        for state in states:
            pass
        return (0.5 * state.u @ (ops.stiffness @ state.u) + 0.5 * state.v @ (ops.mass @ state.v)) / e0

    assert energy_ratio(Integrator.generalized_alpha(0.5)) < 1e-4
    assert energy_ratio(Integrator.newmark()) > 0.999


def test_momentum_of_free_rod_matches_impulse():
    """Free two-density rod, Newmark: total momentum equals the trapezoidal sum of F2 − F1 to
    round-off (the scheme's discrete impulse), and the exact impulse 2AT/π to O(dt²)."""
    ops = assemble_rod(body_nodes(L, 20, jumps=(-2.0,)), 1, Piecewise((-2.0,), (3000.0, 9000.0)), Uniform(EA), Uniform(1e6))
    amplitude, duration, dt = -1.0e6, 0.04, 1e-4
    pulse = HalfSine(amplitude, duration)
    for state in Stepper(ops, Integrator.newmark(), dt, {"F2": pulse}).iterate(800):
        pass
    momentum = ops.rigid_modes[:, 0] @ (ops.mass @ state.v)
    samples = pulse(dt * np.arange(801))
    assert momentum == pytest.approx(dt * (samples.sum() - 0.5 * (samples[0] + samples[-1])), rel=1e-11)
    assert momentum == pytest.approx(amplitude * 2 * duration / np.pi, rel=1e-5)


def test_steady_ramp_gives_rigid_acceleration_and_linear_force():
    """A ramp to a constant F2 on a viscous rod settles to rigid acceleration F2/M everywhere."""
    ops = rod(viscosity=5.0e6, n=16)
    force = -2.0e5
    response = Stepper(ops, Integrator.newmark(), 1e-3, {"F2": RampStep(force, 0.05)}).solve(1.0, np.array([-L, 0.0, L]))
    assert np.allclose(response.acceleration[-1], force / (2 * L * MASS), rtol=1e-4)
    # internal force is the inertia-balanced F0(x) = F2 (x + l)/(2l): 0, F2/2, F2
    assert np.allclose(response.axial_force[-1], [0.0, force / 2, force], rtol=1e-3, atol=1e-3 * abs(force))


def test_stepper_rejects_bad_step():
    with pytest.raises(ValueError, match="positive and finite"):
        Stepper(rod(0.0, 4), Integrator.newmark(), 0.0)
    with pytest.raises(ValueError, match="rho_inf"):
        Integrator.generalized_alpha(1.5)
