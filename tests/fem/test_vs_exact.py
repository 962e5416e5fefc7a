"""FEM against the exact solutions: agreement over λ and β, convergence orders, extremes.

Problems: free Voigt rods and beams on [−l, l] loaded at their ends (docs/design.md §2),
harmonic (factor e^{−iωt}) and transient. The exact answers come from femref.exact
(closed forms for one segment, transfer matrices for several, inverse Laplace in time).
"""

import numpy as np
import pytest

from femref.exact import Segments, beam_harmonic, rod_harmonic, rod_transient
from femref.fem import Integrator, Stepper, assemble_beam, assemble_rod, body_nodes, harmonic_response
from femref.core.profiles import Piecewise, Uniform
from femref.core.signals import HalfSine
from support.convergence import observed_order

L = 8.0
M_ROD, EA = 6250.0, 2.0e9
M_BEAM, EI = 6250.0, 2.0e10
T_ROD = L * np.sqrt(M_ROD / EA)
T_BEAM = L**2 * np.sqrt(M_BEAM / EI)
LAMBDAS = np.array([0.05, 0.3, 1.0, 2.0, 3.0])
BETAS = [0.0, 0.01, 0.1, 1.0, 5.0]
X = np.array([-L, -3.0, 0.0, 5.0, L])


def rod_viscosity(beta):
    """cA from β = (cA/l)/√(m EA)."""
    return beta * L * np.sqrt(M_ROD * EA)


def beam_viscosity(beta):
    """cI from β = (cI/l²)/√(m EI)."""
    return beta * L**2 * np.sqrt(M_BEAM * EI)


def relative_error(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def piecewise_body(edges, mass, stiffness, viscosity):
    """Profiles and Segments of the same piecewise-constant body."""
    breaks = tuple(edges[1:-1])
    profiles = [Piecewise(breaks, tuple(v)) if len(v) > 1 else Uniform(v[0]) for v in (mass, stiffness, viscosity)]
    return profiles, Segments(np.asarray(edges, float), np.asarray(mass, float), np.asarray(stiffness, float), np.asarray(viscosity, float))


@pytest.mark.parametrize("beta", BETAS)
def test_homogeneous_rod_matches_closed_form(beta):
    """P2, 64 elements: accelerations and axial force at five points match the closed form for F1 and F2."""
    c = rod_viscosity(beta)
    ops = assemble_rod(body_nodes(L, 64), 2, Uniform(M_ROD), Uniform(EA), Uniform(c))
    seg = Segments.uniform(2 * L, M_ROD, EA, c)
    omega = LAMBDAS / T_ROD
    loads = {"F1": 0.4e6, "F2": -1.0e6}
    fem = harmonic_response(ops, omega, loads, X)
    exact = rod_harmonic(seg, omega, X, **loads)
    assert relative_error(fem.acceleration, exact.acceleration) < 2e-5
    assert relative_error(fem.displacement, exact.displacement) < 2e-5
    interior = slice(1, -1)  # at the free ends the FEM force comes from a one-sided derivative
    assert relative_error(fem.axial_force[:, interior], exact.axial_force[:, interior]) < 5e-3


@pytest.mark.parametrize("beta", BETAS)
def test_homogeneous_beam_matches_closed_form(beta):
    """Hermite, 32 elements: vertical (symmetric shears) and rotation (moments) responses match."""
    c = beam_viscosity(beta)
    ops = assemble_beam(body_nodes(L, 32), Uniform(M_BEAM), Uniform(EI), Uniform(c))
    seg = Segments.uniform(2 * L, M_BEAM, EI, c)
    omega = LAMBDAS / T_BEAM
    for loads in ({"N1": 0.5e5, "N2": -0.5e5}, {"G1": -1.0e5, "G2": 1.0e5}, {"N1": 1.0e5, "G2": 3.0e5}):
        fem = harmonic_response(ops, omega, loads, X)
        exact = beam_harmonic(seg, omega, X, **loads)
        assert relative_error(fem.acceleration, exact.acceleration) < 1e-6, loads


@pytest.mark.parametrize("which", ["density", "viscosity"])
def test_two_segment_rod_matches_transfer_matrix(which):
    """Two-value density (m2/m1 = 5 inside |x| < l/2) or viscosity (β1 = 0.05, β2 = 1)."""
    edges = [-L, -L / 2, L / 2, L]
    if which == "density":
        mass, visc = [M_ROD, 5 * M_ROD, M_ROD], [rod_viscosity(0.1)]
    else:
        mass, visc = [M_ROD], [rod_viscosity(0.05), rod_viscosity(1.0), rod_viscosity(0.05)]
    (m, k, c), seg = piecewise_body(edges, mass if len(mass) > 1 else mass * 3, [EA] * 3, visc if len(visc) > 1 else visc * 3)
    ops = assemble_rod(body_nodes(L, 64, jumps=(-L / 2, L / 2)), 2, m, k, c)
    omega = LAMBDAS / T_ROD
    fem = harmonic_response(ops, omega, {"F2": 1.0}, X)
    exact = rod_harmonic(seg, omega, X, F2=1.0)
    assert relative_error(fem.acceleration, exact.acceleration) < 1e-5


def test_two_segment_beam_matches_transfer_matrix():
    """Beam with a heavy middle third (m2/m1 = 4) and a stiffer middle: vertical and rotation."""
    edges = [-L, -L / 3, L / 3, L]
    (m, k, c), seg = piecewise_body(edges, [M_BEAM, 4 * M_BEAM, M_BEAM], [EI, 3 * EI, EI], [beam_viscosity(0.1)] * 3)
    ops = assemble_beam(body_nodes(L, 48, jumps=(-L / 3, L / 3)), m, k, c)
    omega = LAMBDAS / T_BEAM
    for loads in ({"N1": 1.0, "N2": -1.0}, {"N1": 1.0, "N2": 1.0}):
        fem = harmonic_response(ops, omega, loads, X)
        exact = beam_harmonic(seg, omega, X, **loads)
        assert relative_error(fem.acceleration, exact.acceleration) < 1e-6


@pytest.mark.parametrize(
    "element,window",
    [("P1", (1.85, 2.3)), ("P2", (3.7, 4.4)), ("hermite", (3.7, 4.4))],
)
def test_spatial_convergence_orders(element, window):
    """Acceleration error at x = 0 and x = l, λ = 2, β = 0.1: P1 converges as h², P2 and Hermite
    as h⁴ (the nodal superconvergence of the frequency response, like the eigenvalues).
    A two-segment density with nodes on the jumps keeps these orders."""
    edges = [-L, -L / 2, L / 2, L]
    x = np.array([0.0, L])
    errors = []
    elements = np.array([8, 16, 32, 64])
    if element == "hermite":
        (m, k, c), seg = piecewise_body(edges, [M_BEAM, 3 * M_BEAM, M_BEAM], [EI] * 3, [beam_viscosity(0.1)] * 3)
        omega = np.array([2.0 / T_BEAM])
        exact = beam_harmonic(seg, omega, x, N1=1.0).acceleration
        for n in elements:
            ops = assemble_beam(body_nodes(L, n, jumps=(-L / 2, L / 2)), m, k, c)
            errors.append(relative_error(harmonic_response(ops, omega, {"N1": 1.0}, x).acceleration, exact))
    else:
        (m, k, c), seg = piecewise_body(edges, [M_ROD, 3 * M_ROD, M_ROD], [EA] * 3, [rod_viscosity(0.1)] * 3)
        omega = np.array([2.0 / T_ROD])
        exact = rod_harmonic(seg, omega, x, F2=1.0).acceleration
        for n in elements:
            ops = assemble_rod(body_nodes(L, n, jumps=(-L / 2, L / 2)), int(element[1]), m, k, c)
            errors.append(relative_error(harmonic_response(ops, omega, {"F2": 1.0}, x).acceleration, exact))
    order = observed_order(1.0 / np.asarray(elements), errors)
    assert window[0] <= order <= window[1], (errors, order)
    assert errors[-1] < {"P1": 2e-3, "P2": 1e-6, "hermite": 1e-6}[element]


@pytest.mark.parametrize("beta", [1e-6, 1e4])
def test_extreme_viscosity_stays_finite_and_exact(beta):
    """β = 1e-6 (nearly elastic, away from resonance) and β = 1e4 (nearly rigid) rods and beams."""
    lam = np.array([0.05, 0.7, 1.3])
    for kind in ("rod", "beam"):
        if kind == "rod":
            c = rod_viscosity(beta)
            ops = assemble_rod(body_nodes(L, 64), 2, Uniform(M_ROD), Uniform(EA), Uniform(c))
            seg, omega, loads = Segments.uniform(2 * L, M_ROD, EA, c), lam / T_ROD, {"F2": 1.0}
            exact = rod_harmonic(seg, omega, X, **loads).acceleration
        else:
            c = beam_viscosity(beta)
            ops = assemble_beam(body_nodes(L, 32), Uniform(M_BEAM), Uniform(EI), Uniform(c))
            seg, omega, loads = Segments.uniform(2 * L, M_BEAM, EI, c), lam / T_BEAM, {"N1": 1.0}
            exact = beam_harmonic(seg, omega, X, **loads).acceleration
        fem = harmonic_response(ops, omega, loads, X).acceleration
        assert np.all(np.isfinite(fem))
        assert relative_error(fem, exact) < 1e-5, kind


@pytest.mark.parametrize("contrast", [1e-3, 1e3])
@pytest.mark.parametrize("which", ["density", "stiffness"])
def test_extreme_segment_contrast(contrast, which):
    """Middle half with density or stiffness × 1e-3 or × 1e3: FEM (nodes on jumps) matches the transfer matrix.

    With density × 1e3 the middle's waves are ~30× shorter, so at λ = 1.5 the 48 middle
    elements resolve them to ~7e-4 only; the bound is 1e-3 there, 1e-4 elsewhere."""
    edges = [-L, -L / 2, L / 2, L]
    mass = [M_ROD, M_ROD * (contrast if which == "density" else 1.0), M_ROD]
    stiff = [EA, EA * (contrast if which == "stiffness" else 1.0), EA]
    (m, k, c), seg = piecewise_body(edges, mass, stiff, [rod_viscosity(0.05)] * 3)
    ops = assemble_rod(body_nodes(L, 96, jumps=(-L / 2, L / 2)), 2, m, k, c)
    omega = np.array([0.05, 0.5, 1.5]) / T_ROD
    fem = harmonic_response(ops, omega, {"F2": 1.0}, X).acceleration
    exact = rod_harmonic(seg, omega, X, F2=1.0).acceleration
    assert np.all(np.isfinite(fem))
    assert relative_error(fem, exact) < (1e-3 if (which, contrast) == ("density", 1e3) else 1e-4)


@pytest.mark.parametrize("pulse", [0.5 * T_ROD, 5 * T_ROD])
def test_transient_rod_matches_exact_time_domain(pulse):
    """Viscous rod (β = 0.2) under half-sine pulses shorter and longer than the wave travel time:
    the FEM (P2, 128 elements, generalized-α, dt = pulse/100) matches the exact solution."""
    c = rod_viscosity(0.2)
    ops = assemble_rod(body_nodes(L, 128), 2, Uniform(M_ROD), Uniform(EA), Uniform(c))
    signal = HalfSine(-1.0e6, pulse)
    dt = pulse / 100
    x = np.array([-L, 0.0, L])
    response = Stepper(ops, Integrator.generalized_alpha(0.8), dt, {"F2": signal}).solve(pulse + 4 * T_ROD, x, output_stride=5)
    exact = rod_transient(Segments.uniform(2 * L, M_ROD, EA, c), response.time, x, None, signal)
    assert relative_error(response.displacement, exact.displacement) < 2e-3
    assert relative_error(response.acceleration[:, 1], exact.acceleration[:, 1]) < 2e-2


@pytest.mark.parametrize("ratio", [1e-3, 1e-1, 1.0, 10.0])
def test_time_step_range_is_stable(ratio):
    """dt from 1e-3× to 10× the wave travel time (pulse 40 T_wave): no NaN, no blow-up, and
    the final momentum equals the impulse; for dt ≤ T_wave the centre motion matches exact."""
    c = rod_viscosity(0.05)
    ops = assemble_rod(body_nodes(L, 32), 2, Uniform(M_ROD), Uniform(EA), Uniform(c))
    pulse = 40 * T_ROD
    dt = ratio * T_ROD
    end = pulse + 20 * T_ROD
    signal = HalfSine(-1.0e6, pulse)
    response = Stepper(ops, Integrator.generalized_alpha(0.8), dt, {"F2": signal}).solve(
        end, np.array([0.0]), output_stride=max(1, int(round(T_ROD / dt)))
    )
    assert np.all(np.isfinite(response.acceleration)) and np.all(np.isfinite(response.displacement))
    mass = 2 * L * M_ROD
    energy_bound = 0.5 * (1.0e6 * 2 * pulse / np.pi) ** 2 / mass
    assert np.max(response.kinetic + response.strain) < 1.5 * energy_bound
    if ratio <= 1.0:
        exact = rod_transient(Segments.uniform(2 * L, M_ROD, EA, c), response.time, np.array([0.0]), None, signal)
        assert relative_error(response.displacement, exact.displacement) < 0.02
