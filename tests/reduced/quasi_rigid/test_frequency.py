"""Quasi-rigid models in the frequency domain against closed forms and the exact solutions.

Problems: free Voigt rods and beams on [−l, l] loaded at their ends (docs/design.md §2),
factor e^{−iωt}. The two-term model must (i) reproduce the printed-and-corrected
low-frequency constants exactly and (ii) differ from the exact response by O(λ⁴)
(rod: q⁴ with q² = λ²/(1 − iλβ); beam: q⁸ with q⁴ = λ²/(1 − iλβ), i.e. λ⁴ too).
"""

import numpy as np
import pytest
from scipy.integrate import quad

from reduced.quasi_rigid import CreepKernel, QuasiRigidBeam, QuasiRigidRod, harmonic_factor, harmonic_factor_at
from support.convergence import observed_order

L = 8.0
M_ROD, EA = 6000.0, 2.0e9
M_BEAM, EI = 6000.0, 5.0e9
LAMBDAS = np.geomspace(0.02, 0.3, 6)
X = np.array([-L, -3.0, 0.0, 5.0, L])


def exact_api():
    """``(Segments, rod_harmonic, beam_harmonic)`` from femref.exact (skip if it is absent)."""
    exact = pytest.importorskip("femref.exact")
    return exact.Segments, exact.rod_harmonic, exact.beam_harmonic


def rod_time(m=M_ROD):
    return L * np.sqrt(m / EA)


def beam_time(m=M_BEAM):
    return L**2 * np.sqrt(m / EI)


# --------------------------------------------------------------------- closed forms


@pytest.mark.parametrize("beta", [0.0, 0.3, 3.0])
def test_rod_centre_is_first_two_terms_of_q_over_sin_q(beta):
    """Homogeneous rod, F2 at +l: the model's centre ``M a/F2`` is ``1 + q²/6`` exactly
    (q² = λ²/(1 − iλβ)), and its error against the exact ``q/sin q`` falls like λ⁴."""
    rod = QuasiRigidRod(L, M_ROD, EA, beta * L * np.sqrt(M_ROD * EA))
    response = rod.harmonic(LAMBDAS / rod_time(), [0.0], F2=1.0)
    q = np.sqrt(LAMBDAS**2 / (1 - 1j * LAMBDAS * beta))
    a_star = response.acceleration[:, 0] * rod.mass
    np.testing.assert_allclose(a_star, 1 + q**2 / 6, rtol=1e-13, atol=0)
    error = np.abs(a_star - q / np.sin(q))
    assert 3.7 < observed_order(LAMBDAS, error) < 4.3
    assert error[-1] < 7 / 360 * 0.3**4 * 1.05  # next Taylor term 7q⁴/360
    np.testing.assert_allclose(response.epsilon, np.abs(q**2), rtol=1e-12)


def test_rod_end_coefficients_are_8_4_and_4_8():
    """Homogeneous elastic rod: ``M a(−l) = F2 − F1 − (ml²/6EA)(8F1'' + 4F2'')``,
    ``M a(+l) = F2 − F1 + (ml²/6EA)(4F1'' + 8F2'')`` (F'' = −ω²F), centre ``−(ml²/6EA)(F2'' − F1'')``."""
    rod = QuasiRigidRod(L, M_ROD, EA)
    omega = np.array([0.1, 1.0, 10.0])
    c = M_ROD * L**2 / (6 * EA)
    F1, F2 = 0.7, -1.3
    a = rod.harmonic(omega, [-L, 0.0, L], F1=F1, F2=F2).acceleration * rod.mass
    d1, d2 = -(omega**2) * F1, -(omega**2) * F2
    np.testing.assert_allclose(a[:, 0], F2 - F1 - c * (8 * d1 + 4 * d2), rtol=1e-13)
    np.testing.assert_allclose(a[:, 1], F2 - F1 - c * (d2 - d1), rtol=1e-13)
    np.testing.assert_allclose(a[:, 2], F2 - F1 + c * (4 * d1 + 8 * d2), rtol=1e-13)


@pytest.mark.parametrize("beta", [0.0, 0.5])
def test_beam_constants_3_40_11_840_13_280(beta):
    """Homogeneous beam, q⁴ = λ²/(1 − iλβ). Vertical (N1 = −N2 = ½): centre ``a_v* = 1 + 3q⁴/40``;
    rotation, centre slope over Ω: ``α* = 1 + 11q⁴/840`` by end shears (N1 = N2 = 1) and
    ``1 + 13q⁴/280`` by end moments (G2 = −G1 = 1). Exact:
    ``a_v* = q(cos q + cosh q)/(cos q sinh q + sin q cosh q)``,
    ``α* = q²(sin q + sinh q)/(3(sin q cosh q − cos q sinh q))`` (shears); error O(λ⁴)."""
    beam = QuasiRigidBeam(L, M_BEAM, EI, beta * L**2 * np.sqrt(M_BEAM * EI))
    omega = LAMBDAS / beam_time()
    q4 = LAMBDAS**2 / (1 - 1j * LAMBDAS * beta)
    q = q4**0.25
    vertical = beam.harmonic(omega, [0.0], N1=0.5, N2=-0.5).ratio[:, 0]
    shears = beam.harmonic(omega, [0.0], N1=1.0, N2=1.0, rotation=True).ratio[:, 0]
    moments = beam.harmonic(omega, [0.0], G1=-1.0, G2=1.0, rotation=True).ratio[:, 0]
    np.testing.assert_allclose(vertical, 1 + 3 * q4 / 40, rtol=1e-12)
    np.testing.assert_allclose(shears, 1 + 11 * q4 / 840, rtol=1e-12)
    np.testing.assert_allclose(moments, 1 + 13 * q4 / 280, rtol=1e-12)
    a_v = q * (np.cos(q) + np.cosh(q)) / (np.cos(q) * np.sinh(q) + np.sin(q) * np.cosh(q))
    alpha = q**2 * (np.sin(q) + np.sinh(q)) / (3 * (np.sin(q) * np.cosh(q) - np.cos(q) * np.sinh(q)))
    # next Taylor coefficients (numerically): 2.49e-3 q⁸ (vertical), −3.97e-4 q⁸ (rotation)
    for model, exact, bound in ((vertical, a_v, 3e-3), (shears, alpha, 5e-4)):
        error = np.abs(model - exact)
        assert 3.7 < observed_order(LAMBDAS, error) < 4.3
        assert error[-1] < bound * 0.3**4


def test_two_value_density_and_viscosity_closed_forms():
    """Rod, F2 at +l, centre. Two-value density (m1 for |x| > l/2, m2 inside, r = m2/m1,
    λ with the mean mass): ``a* = 1 + (r² + 6r + 1)λ²/(12(1 + r)²(1 − iλβ))``. Two-value
    viscosity (β1 outside, β2 inside): ``a* = 1 + (λ²/12)(1/(1 − iλβ1) + 1/(1 − iλβ2))``."""
    beta = 0.2
    for r in (0.1, 1.0, 5.0):
        m_mean = 0.5 * (1 + r) * M_ROD
        rod = QuasiRigidRod(L, lambda x, r=r: np.where(np.abs(x) < L / 2, r * M_ROD, M_ROD), EA,
                            beta * L * np.sqrt(m_mean * EA), jumps=[-L / 2, L / 2])
        a = rod.harmonic(LAMBDAS / rod_time(m_mean), [0.0], F2=1.0).acceleration[:, 0] * rod.mass
        expected = 1 + (r * r + 6 * r + 1) * LAMBDAS**2 / (12 * (1 + r) ** 2 * (1 - 1j * LAMBDAS * beta))
        np.testing.assert_allclose(a, expected, rtol=1e-13)
    b1, b2 = 0.1, 2.0
    unit = L * np.sqrt(M_ROD * EA)
    rod = QuasiRigidRod(L, M_ROD, EA, lambda x: np.where(np.abs(x) < L / 2, b2 * unit, b1 * unit), jumps=[-L / 2, L / 2])
    a = rod.harmonic(LAMBDAS / rod_time(), [0.0], F2=1.0).acceleration[:, 0] * rod.mass
    expected = 1 + LAMBDAS**2 / 12 * (1 / (1 - 1j * LAMBDAS * b1) + 1 / (1 - 1j * LAMBDAS * b2))
    np.testing.assert_allclose(a, expected, rtol=1e-13)
    assert rod.tau_groups.size == 2 and not rod.correction.interpolated


# --------------------------------------------------------------------- exact solutions


@pytest.mark.parametrize("r", [0.1, 1.0, 5.0])
def test_rod_two_segment_density_error_is_order_lambda4(r):
    """Rod with m = m1 for |x| > l/2 and r·m1 inside, β = 0.2, loads F1 = 0.4, F2 = 1 at
    X = (−l, −3, 0, 5, l): ``max_x M|a − a_exact|`` falls like λ⁴ (exact: transfer matrices)."""
    Segments, rod_harmonic, _ = exact_api()
    m = np.array([M_ROD, r * M_ROD, M_ROD])
    m_mean = 0.5 * (1 + r) * M_ROD
    cA = 0.2 * L * np.sqrt(m_mean * EA)
    segments = Segments(np.array([-L, -L / 2, L / 2, L]), m, EA, cA)
    rod = QuasiRigidRod(L, lambda x: np.where(np.abs(x) < L / 2, r * M_ROD, M_ROD), EA, cA, jumps=[-L / 2, L / 2])
    omega = LAMBDAS / rod_time(m_mean)
    exact = rod_harmonic(segments, omega, X, F1=0.4, F2=1.0).acceleration
    model = rod.harmonic(omega, X, F1=0.4, F2=1.0).acceleration
    error = np.max(np.abs(model - exact), axis=1) * rod.mass
    assert 3.7 < observed_order(LAMBDAS, error) < 4.3
    assert error[-1] < 1.0 * 0.3**4  # measured 0.25–0.80 λ⁴, largest at the ends


@pytest.mark.parametrize("betas", [(0.1, 1.0), (0.0, 2.0)])
def test_rod_two_segment_viscosity_error_is_order_lambda4(betas):
    """Rod with β1 for |x| > l/2 and β2 inside (one segment elastic in the second case),
    F2 = 1: error against the exact transfer-matrix response falls like λ⁴."""
    Segments, rod_harmonic, _ = exact_api()
    unit = L * np.sqrt(M_ROD * EA)
    c1, c2 = betas[0] * unit, betas[1] * unit
    segments = Segments(np.array([-L, -L / 2, L / 2, L]), M_ROD, EA, np.array([c1, c2, c1]))
    rod = QuasiRigidRod(L, M_ROD, EA, lambda x: np.where(np.abs(x) < L / 2, c2, c1), jumps=[-L / 2, L / 2])
    omega = LAMBDAS / rod_time()
    exact = rod_harmonic(segments, omega, X, F2=1.0).acceleration
    error = np.max(np.abs(rod.harmonic(omega, X, F2=1.0).acceleration - exact), axis=1) * rod.mass
    assert 3.7 < observed_order(LAMBDAS, error) < 4.3
    assert error[-1] < 0.5 * 0.3**4  # measured 0.28–0.34 λ⁴


@pytest.mark.parametrize("r", [0.1, 1.0, 5.0])
def test_beam_two_segment_density_error_is_order_lambda4(r):
    """Beam with m = m1 for |x| > l/2 and r·m1 inside, β = 0.2, under vertical, rotational
    and mixed end loads: ``max_x |a − a_exact| / max|a_rigid|`` falls like λ⁴."""
    Segments, _, beam_harmonic = exact_api()
    m_mean = 0.5 * (1 + r) * M_BEAM
    cI = 0.2 * L**2 * np.sqrt(m_mean * EI)
    segments = Segments(np.array([-L, -L / 2, L / 2, L]), np.array([M_BEAM, r * M_BEAM, M_BEAM]), EI, cI)
    beam = QuasiRigidBeam(L, lambda x: np.where(np.abs(x) < L / 2, r * M_BEAM, M_BEAM), EI, cI, jumps=[L / 2])
    omega = LAMBDAS / beam_time(m_mean)
    for loads in (dict(N1=0.5, N2=-0.5), dict(N1=1.0, N2=1.0), dict(G1=-1.0, G2=1.0), dict(N1=1.0, G2=3.0)):
        exact = beam_harmonic(segments, omega, X, **loads).acceleration
        model = beam.harmonic(omega, X, **loads)
        error = np.max(np.abs(model.acceleration - exact), axis=1) / np.max(np.abs(model.rigid_acceleration))
        assert 3.7 < observed_order(LAMBDAS, error) < 4.3, loads
        assert error[-1] < 5e-3 * 0.3**4, loads  # measured up to 4.1e-3 λ⁴


def test_homogeneous_rod_and_beam_match_exact_everywhere():
    """Homogeneous Voigt rod (β = 0.3) and beam (β = 0.3), all end loads at once, five
    positions: the error against femref.exact falls like λ⁴."""
    Segments, rod_harmonic, beam_harmonic = exact_api()
    cA = 0.3 * L * np.sqrt(M_ROD * EA)
    rod = QuasiRigidRod(L, M_ROD, EA, cA)
    omega = LAMBDAS / rod_time()
    exact = rod_harmonic(Segments(np.array([-L, L]), M_ROD, EA, cA), omega, X, F1=-0.5, F2=1.0).acceleration
    error = np.max(np.abs(rod.harmonic(omega, X, F1=-0.5, F2=1.0).acceleration - exact), axis=1) * rod.mass
    assert 3.7 < observed_order(LAMBDAS, error) < 4.3
    cI = 0.3 * L**2 * np.sqrt(M_BEAM * EI)
    beam = QuasiRigidBeam(L, M_BEAM, EI, cI)
    omega = LAMBDAS / beam_time()
    loads = dict(N1=1.0, N2=0.3, G1=-2.0, G2=5.0)
    exact = beam_harmonic(Segments(np.array([-L, L]), M_BEAM, EI, cI), omega, X, **loads).acceleration
    model = beam.harmonic(omega, X, **loads)
    error = np.max(np.abs(model.acceleration - exact), axis=1) / np.max(np.abs(model.rigid_acceleration))
    assert 3.7 < observed_order(LAMBDAS, error) < 4.3


# --------------------------------------------------------------------- general profiles and kernels


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_continuously_varying_viscous_time_against_direct_quadrature():
    """Rod with cA(x) = c0·10^{x/l} (τ varies 100-fold, so time constants are interpolated in log τ),
    linear mass m(x) = m0(1 + 0.4x/l) and EA(x) = EA0(1 + 0.2 cos x): the correction
    ``u₁(x) = ∫ [S₀(s)/M − H(s − x)] F₀(s)/(EA − iωcA) ds`` by adaptive quadrature agrees to
    1e-6 of the correction (measured ≤ 2e-7 with the default 24 interpolation points)."""
    c0 = 0.3 * L * np.sqrt(M_ROD * EA)

    def mass(x):
        return M_ROD * (1 + 0.4 * x / L)

    def stiffness(x):
        return EA * (1 + 0.2 * np.cos(x))

    def viscosity(x):
        return c0 * 10.0 ** (x / L)

    rod = QuasiRigidRod(L, mass, stiffness, viscosity)
    assert rod.correction.interpolated
    M = 2 * L * M_ROD

    def S0(s):
        return M_ROD * ((s + L) + 0.2 * (s * s - L * L) / L)

    for lam in (0.1, 3.0, 100.0):
        omega = lam / rod_time()
        model = rod.harmonic([omega], [-L, 0.0, 3.0], F2=1.0).acceleration[0]
        for x, value in zip([-L, 0.0, 3.0], model):
            def integrand(s, part):
                v = (S0(s) / M - (s > x)) * (S0(s) / M) / (stiffness(s) - 1j * omega * viscosity(s))
                return getattr(v, part)
            points = [x] if -L < x < L else None
            u1 = sum(quad(integrand, -L, L, args=(p,), points=points, limit=200, epsrel=1e-13, epsabs=0.0)[0] * w
                     for p, w in (("real", 1.0), ("imag", 1j)))
            expected = 1 / M - omega**2 * u1
            assert abs(value - expected) < 1e-6 * abs(expected - 1 / M)


def test_zener_kernel_against_complex_modulus_closed_form():
    """Homogeneous rod with a standard-linear creep kernel K(s) = 0.6 e^{−s/0.6}
    (instantaneous compliance 0.4/EA): complex compliance ``c(ω) = (0.4 + 0.6/(1 − iωτ/ (1/0.6)))/EA``;
    exact centre response ``q/sin q`` with ``q² = ω² m l² EA c(ω)``; the model gives ``1 + q²/6``."""
    kernel = CreepKernel((0.6,), (1 / 0.6,))
    cA = 0.5 * L * np.sqrt(M_ROD * EA)
    rod = QuasiRigidRod(L, M_ROD, EA, cA, creep=kernel)
    omega = LAMBDAS / rod_time()
    tau = cA / EA * 0.6
    q2 = (omega * rod_time()) ** 2 * (0.4 + 0.6 / (1 - 1j * omega * tau))
    a = rod.harmonic(omega, [0.0], F2=1.0).acceleration[:, 0] * rod.mass
    np.testing.assert_allclose(a, 1 + q2 / 6, rtol=1e-13)
    q = np.sqrt(q2)
    assert 3.7 < observed_order(LAMBDAS, np.abs(a - q / np.sin(q))) < 4.3


def test_prony_fit_reproduces_a_kernel():
    """``CreepKernel.fit`` of K(s) = 0.5 e^{−s} + 0.3 e^{−3s} (a Prony series itself) to 1e-3."""
    kernel = CreepKernel.fit(lambda s: 0.5 * np.exp(-s) + 0.3 * np.exp(-3 * s), s_max=10.0, n_terms=16)
    s = np.linspace(0, 10, 101)
    assert np.max(np.abs(kernel(s) - (0.5 * np.exp(-s) + 0.3 * np.exp(-3 * s)))) < 1e-3
    assert 0.0 <= kernel.instantaneous <= 1.0


def test_complex_mass_and_epsilon():
    """Complex mass at the centre of a homogeneous Voigt rod: ``M* = M/(1 + q²/6)`` for F2
    and for F1 alike; ε(ω) = |q²| and ε = 0 for a rigid (cA = ∞) rod."""
    beta = 0.4
    rod = QuasiRigidRod(L, M_ROD, EA, beta * L * np.sqrt(M_ROD * EA))
    omega = LAMBDAS / rod_time()
    q2 = LAMBDAS**2 / (1 - 1j * LAMBDAS * beta)
    for end in ("F1", "F2"):
        np.testing.assert_allclose(rod.complex_mass(omega, [0.0], end)[:, 0], rod.mass / (1 + q2 / 6), rtol=1e-13)
    np.testing.assert_allclose(rod.epsilon(omega), np.abs(q2), rtol=1e-12)
    rigid = QuasiRigidRod(L, M_ROD, EA, np.inf)
    np.testing.assert_array_equal(rigid.epsilon(omega), 0.0)
    np.testing.assert_allclose(rigid.harmonic(omega, X, F2=1.0).acceleration, 1 / rigid.mass, rtol=1e-15)


def test_epsilon_of_a_time_scale_is_epsilon_at_its_frequency():
    """``epsilon_of_time_scale(T)`` (one frequency, plain complex arithmetic) equals ``epsilon(1/T)`` (the arrays'
    path) to rounding for exact τ groups with τ = 0 and ∞ among them, interpolated ones and a rigid rod, and is 0 for
    T = ∞; the scalar filter factor equals the array one at τ = 0, finite and ∞, ω = 0 and not."""
    def viscosity(x):
        return np.where(x < -2.0, 0.0, np.where(x < 3.0, 4.0e6, np.inf))

    rods = (QuasiRigidRod(L, M_ROD, EA, viscosity, jumps=[-2.0, 3.0]),
            QuasiRigidRod(L, M_ROD, EA, lambda x: 1.0e6 * 10.0 ** (x / L), max_tau_groups=8),
            QuasiRigidRod(L, M_ROD, EA, np.inf))
    assert rods[0].tau_groups[0] == 0.0 and np.isinf(rods[0].tau_groups[-1])
    for rod in rods:
        for scale in (1e-3, 0.02, 0.5):
            assert rod.epsilon_of_time_scale(scale) == pytest.approx(rod.epsilon(1.0 / scale)[0], rel=1e-14, abs=1e-300)
        assert rod.epsilon_of_time_scale(np.inf) == 0.0
    for omega in (0.0, 3.0):
        for tau in (0.0, 2.0e-3, np.inf):
            assert harmonic_factor_at(omega, tau) == pytest.approx(harmonic_factor(omega, tau), rel=1e-15, abs=0.0)


def test_bad_input_is_rejected():
    """Non-positive mass or stiffness, negative viscosity, odd beam profiles, unknown loads,
    positions outside the body and invalid kernels raise ValueError naming the rule."""
    with pytest.raises(ValueError, match="mass_per_length must be > 0"):
        QuasiRigidRod(L, lambda x: M_ROD * x / L, EA)
    with pytest.raises(ValueError, match="stiffness must be > 0"):
        QuasiRigidRod(L, M_ROD, 0.0)
    with pytest.raises(ValueError, match="viscosity must be ≥ 0"):
        QuasiRigidRod(L, M_ROD, EA, -1.0)
    with pytest.raises(ValueError, match="half_length"):
        QuasiRigidRod(0.0, M_ROD, EA)
    with pytest.raises(ValueError, match="even"):
        QuasiRigidBeam(L, lambda x: M_ROD * (1 + 0.1 * x / L), EI)
    rod = QuasiRigidRod(L, M_ROD, EA)
    with pytest.raises(ValueError, match="unknown loads"):
        rod._harmonic([1.0], [0.0], {"N1": 1.0})
    with pytest.raises(ValueError, match=r"\[−l, l\]"):
        rod.harmonic([1.0], [2 * L], F2=1.0)
    with pytest.raises(ValueError, match="sum to at most 1"):
        CreepKernel((0.7, 0.5), (1.0, 2.0))
    with pytest.raises(ValueError, match="rates"):
        CreepKernel((0.5,), (0.0,))
