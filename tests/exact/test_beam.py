"""Exact harmonic response of free-free Kelvin-Voigt Euler-Bernoulli beams (femref.exact.beam).

Body on x ∈ [−l, l], G = EI w_xx + cI w_xxt, N = G_x, N_x + m w_tt = 0, N(∓l) = N1, N2,
G(∓l) = G1, G2, time factor e^{−iωt}; λ = ωl²√(m/EI), β = (cI/l²)/√(m EI), q⁴ = λ²/(1 − iλβ).
"""

from __future__ import annotations

from fractions import Fraction
from math import factorial

import numpy as np
import pytest

from femref.exact import Segments, beam_harmonic, beam_harmonic_closed_form, beam_harmonic_transfer
from support.convergence import observed_order

L_HALF, MASS, STIFFNESS = 8.0, 7000.0, 1.0e10
LAMBDAS = np.geomspace(1e-3, 5.0, 30)
LOADS = {"N1": (1, 0, 0, 0), "N2": (0, 1, 0, 0), "G1": (0, 0, 1, 0), "G2": (0, 0, 0, 1)}
FIELDS = ("acceleration", "angular_acceleration", "moment", "shear")


def homogeneous(beta: float) -> Segments:
    return Segments.uniform(2 * L_HALF, MASS, STIFFNESS, beta * L_HALF**2 * np.sqrt(MASS * STIFFNESS))


def omega_of(lam):
    return np.asarray(lam, dtype=float) / (L_HALF**2 * np.sqrt(MASS / STIFFNESS))


def split_in_three(segments: Segments) -> Segments:
    l = segments.half_length
    return Segments(np.array([-l, -0.41 * l, 0.23 * l, l]), *(np.full(3, v[0]) for v in (segments.mass_per_length, segments.stiffness, segments.viscosity)))


def gauss_points(segments: Segments, n: int = 30):
    xg, wg = np.polynomial.legendre.leggauss(n)
    xs, ws = [], []
    for a, b, m in zip(segments.edges[:-1], segments.edges[1:], segments.mass_per_length):
        xs.append(0.5 * (b - a) * xg + 0.5 * (a + b))
        ws.append(0.5 * (b - a) * wg * m)
    return np.concatenate(xs), np.concatenate(ws)


# --- exact rational power series in w = q⁴ of the centre responses -------------------------

TERMS = 12


def krylov_series(j: int) -> list[Fraction]:
    """S, T/q, U/q², V/q³ (j = 0…3) as series in w = q⁴: coefficients 1/(4k + j)!."""
    return [Fraction(1, factorial(4 * k + j)) for k in range(TERMS)]


def mul(a, b):
    return [sum(a[i] * b[k - i] for i in range(k + 1)) for k in range(TERMS)]


def sub(a, b):
    return [x - y for x, y in zip(a, b)]


def div(a, b):
    out = []
    for k in range(TERMS):
        out.append((a[k] - sum(out[i] * b[k - i] for i in range(k))) / b[0])
    return out


S, Th, Uh, Vh = (krylov_series(j) for j in range(4))
W = [Fraction(0), Fraction(1)] + [Fraction(0)] * (TERMS - 2)
# vertical  a_v* = q(cos q + cosh q)/(cos q sinh q + sin q cosh q) = S/(S T̂ − w Û V̂)
VERTICAL = div(S, sub(mul(S, Th), mul(W, mul(Uh, Vh))))
# rotation by end shears  α* = q²(sin q + sinh q)/(3(sin q cosh q − cos q sinh q)) = T̂/(3(T̂Û − S V̂))
ROTATION_SHEAR = div(Th, [3 * c for c in sub(mul(Th, Uh), mul(S, Vh))])
# rotation by end moments  J a_x(0)/(G2 − G1) = S/(3(T̂Û − S V̂))
ROTATION_MOMENT = div(S, [3 * c for c in sub(mul(Th, Uh), mul(S, Vh))])


def evaluate(series, w):
    return sum(float(c) * w**k for k, c in reversed(list(enumerate(series))))


def centre_ratios(body: Segments, lam):
    """(M a(0)/(N1 − N2), J a_x(0)/(−l(N1 + N2)), J a_x(0)/(G2 − G1)) from beam_harmonic."""
    w = omega_of(lam)
    vertical = beam_harmonic(body, w, [0.0], N1=0.5, N2=-0.5).acceleration[:, 0] * body.mass
    shear = beam_harmonic(body, w, [0.0], N1=0.5, N2=0.5).angular_acceleration[:, 0] * body.rotary_inertia / (-L_HALF)
    moment = beam_harmonic(body, w, [0.0], G1=-0.5, G2=0.5).angular_acceleration[:, 0] * body.rotary_inertia
    return vertical, shear, moment


def test_series_constants_match_the_corrected_source():
    """The exact rational series start 1 + 3w/40, 1 + 11w/840, 1 + 13w/280 (w = q⁴): the
    constants docs/formulas.md §E and §X quote (3/40 for rotation is the misprint)."""
    assert VERTICAL[:2] == [1, Fraction(3, 40)]
    assert ROTATION_SHEAR[:2] == [1, Fraction(11, 840)]
    assert ROTATION_MOMENT[:2] == [1, Fraction(13, 280)]


@pytest.mark.parametrize("beta", [0.0, 0.2, 10.0])
def test_centre_responses_match_exact_series_at_low_frequency(beta):
    """λ ∈ [1e-3, 0.3]: vertical, rotation-by-shear and rotation-by-moment centre ratios equal
    their 12-term rational series (exact there to < 1e-16) to 1e-13, closed form and transfer."""
    lam = np.geomspace(1e-3, 0.3, 15)
    w4 = lam**2 / (1 - 1j * lam * beta)
    expected = [evaluate(s, w4) for s in (VERTICAL, ROTATION_SHEAR, ROTATION_MOMENT)]
    for body in (homogeneous(beta), split_in_three(homogeneous(beta))):
        for got, exact in zip(centre_ratios(body, lam), expected):
            assert np.max(np.abs(got / exact - 1)) < 1e-13


def test_two_term_expansions_err_like_lambda_to_the_fourth():
    """a_v* − (1 + 3q⁴/40) and α* − (1 + 11q⁴/840) are O(q⁸) = O(λ⁴): fitted slopes in [3.8, 4.2];
    with the misprinted 3/40 the rotation error is O(λ²) (slope in [1.8, 2.2])."""
    lam = np.geomspace(0.01, 0.1, 8)
    beta = 0.5
    w4 = lam**2 / (1 - 1j * lam * beta)
    vertical, shear, _ = centre_ratios(homogeneous(beta), lam)

    assert 3.8 < observed_order(lam, vertical - (1 + 3 * w4 / 40)) < 4.2
    assert 3.8 < observed_order(lam, shear - (1 + 11 * w4 / 840)) < 4.2
    assert 1.8 < observed_order(lam, shear - (1 + 3 * w4 / 40)) < 2.2


def test_trigonometric_centre_forms_at_moderate_frequency():
    """λ ∈ [0.3, 5]: a_v* = q(cos q + cosh q)/(cos q sinh q + sin q cosh q) and
    α* = q²(sin q + sinh q)/(3(sin q cosh q − cos q sinh q)) written directly, to 1e-12."""
    lam = np.geomspace(0.3, 5.0, 20)
    for beta in (0.0, 0.1, 3.0):
        q = (lam**2 / (1 - 1j * lam * beta)) ** 0.25
        vertical_exact = q * (np.cos(q) + np.cosh(q)) / (np.cos(q) * np.sinh(q) + np.sin(q) * np.cosh(q))
        shear_exact = q**2 * (np.sin(q) + np.sinh(q)) / (3 * (np.sin(q) * np.cosh(q) - np.cos(q) * np.sinh(q)))
        vertical, shear, _ = centre_ratios(homogeneous(beta), lam)
        assert np.max(np.abs(vertical / vertical_exact - 1)) < 1e-12
        assert np.max(np.abs(shear / shear_exact - 1)) < 1e-12


@pytest.mark.parametrize("beta", [0.0, 1e-6, 0.1, 10.0, 1e4])
def test_closed_form_equals_transfer_for_one_segment(beta):
    """Homogeneous beam, each unit end load, λ ∈ [1e-3, 5]: closed form and the transfer-matrix
    solution on the same body cut in three give the same a, θ, G, N (to 1e-11 of each field's
    largest value along the beam at that frequency)."""
    body = homogeneous(beta)
    x = np.linspace(-L_HALF, L_HALF, 11)
    w = omega_of(LAMBDAS)
    for name, load in LOADS.items():
        closed = beam_harmonic_closed_form(body, w, x, *load)
        transfer = beam_harmonic_transfer(split_in_three(body), w, x, *load)
        for field in FIELDS:
            a, b = getattr(transfer, field), getattr(closed, field)
            scale = np.max(np.abs(b), axis=1, keepdims=True)
            assert np.all(np.abs(a - b) <= 1e-11 * scale), (name, field)


def test_end_values_are_the_loads():
    """G(∓l) = G1, G2 and N(∓l) = N1, N2 (boundary conditions), piecewise body, to 1e-12 of the loads."""
    body = Segments(np.array([-L_HALF, -1.0, 2.0, L_HALF]), np.array([5000.0, 20000.0, 3000.0]), np.array([1e10, 3e9, 2e10]), np.array([1e8, 0.0, 5e8]))
    loads = dict(N1=1.0 + 0.3j, N2=-0.4, G1=2.5, G2=-1.5j)
    r = beam_harmonic(body, omega_of(LAMBDAS), [-L_HALF, L_HALF], **loads)
    assert np.max(np.abs(r.shear[:, 0] - loads["N1"])) < 1e-12 * 3
    assert np.max(np.abs(r.shear[:, 1] - loads["N2"])) < 1e-12 * 3
    assert np.max(np.abs(r.moment[:, 0] - loads["G1"])) < 1e-12 * 3 * L_HALF
    assert np.max(np.abs(r.moment[:, 1] - loads["G2"])) < 1e-12 * 3 * L_HALF


@pytest.mark.parametrize("beta", [0.0, 0.3])
def test_reciprocity_on_an_asymmetric_beam(beta):
    """Betti with generalised loads (+N1, −G1 at −l; −N2, +G2 at +l) and displacements (w, w_x):
    w(−l; N2) = −w(l; N1), w(−l; G2) = θ(l; N1)… in accelerations; to 1e-11."""
    c = beta * L_HALF**2 * np.sqrt(MASS * STIFFNESS)
    body = Segments(np.array([-L_HALF, -3.0, 1.0, L_HALF]), np.array([4000.0, 15000.0, 6000.0]), np.array([2e10, 5e9, 1e10]), np.array([c, 3 * c, 0.2 * c]))
    w = omega_of(LAMBDAS)
    ends = [-L_HALF, L_HALF]
    r = {name: beam_harmonic(body, w, ends, *load) for name, load in LOADS.items()}

    def close(a, b):
        return np.max(np.abs(a - b) / np.abs(b)) < 1e-11

    assert close(r["N2"].acceleration[:, 0], -r["N1"].acceleration[:, 1])
    assert close(r["G2"].acceleration[:, 0], r["N1"].angular_acceleration[:, 1])
    assert close(r["G2"].angular_acceleration[:, 0], -r["G1"].angular_acceleration[:, 1])
    assert close(-r["G1"].acceleration[:, 1], -r["N2"].angular_acceleration[:, 0])


@pytest.mark.parametrize("contrast", [1e-3, 1e3])
@pytest.mark.parametrize("which", ["mass", "stiffness"])
def test_momentum_balances_with_contrast(contrast, which):
    """Contrast 1e-3 … 1e3: ∫ m a dx = N1 − N2 and ∫ x m a dx = G2 − G1 − l(N1 + N2)
    (from N_x = −m a, G_x = N), Gauss quadrature of the transfer fields, to 1e-9 of the loads."""
    m = np.array([MASS, MASS * (contrast if which == "mass" else 1.0), MASS])
    k = np.array([STIFFNESS, STIFFNESS * (contrast if which == "stiffness" else 1.0), STIFFNESS])
    body = Segments(np.array([-L_HALF, -2.0, 3.0, L_HALF]), m, k, 0.05 * L_HALF**2 * np.sqrt(m * k))
    x, weights = gauss_points(body, 40)
    N1, N2, G1, G2 = 1.0, -0.3 + 0.1j, 4.0, -2.0
    r = beam_harmonic(body, omega_of(np.geomspace(1e-3, 5.0, 10)), x, N1, N2, G1, G2)
    assert all(np.all(np.isfinite(getattr(r, f))) for f in FIELDS)
    assert np.max(np.abs(r.acceleration @ weights - (N1 - N2))) < 1e-9 * 2
    assert np.max(np.abs(r.acceleration @ (weights * x) - (G2 - G1 - L_HALF * (N1 + N2)))) < 1e-9 * 30


def test_rigid_body_limit():
    """λ → 0: a(x) = (N1 − N2)/M + Ω x with J Ω = G2 − G1 − l(N1 + N2) (piecewise body, λ = 1e-5,
    to 1e-8 of the rigid values)."""
    body = Segments(np.array([-L_HALF, -2.0, 3.0, L_HALF]), np.array([5000.0, 9000.0, 3000.0]), np.array([1e10, 2e10, 5e9]), np.array([1e8, 0.0, 1e8]))
    x = np.linspace(-L_HALF, L_HALF, 9)
    N1, N2, G1, G2 = 1.0, 0.4, -3.0, 2.0
    # centre of mass is not at 0: solve M a_c + (∫x m) Ω = N1 − N2, (∫x m) a_c + J Ω = moment about 0
    first_moment = float(np.sum(body.mass_per_length * (body.edges[1:] ** 2 - body.edges[:-1] ** 2) / 2))
    a0, omega = np.linalg.solve([[body.mass, first_moment], [first_moment, body.rotary_inertia]], [N1 - N2, G2 - G1 - L_HALF * (N1 + N2)])
    r = beam_harmonic(body, omega_of([1e-5]), x, N1, N2, G1, G2)
    assert np.max(np.abs(r.acceleration[0] - (a0 + omega * x))) < 1e-8 * np.max(np.abs(a0 + omega * x))


def test_viscosity_extremes_are_finite_and_sensible():
    """β = 1e-6 matches the elastic beam to 1e-5 (λ ≤ 1); β = 1e4 is nearly rigid (a_v* within 1e-3 of 1)."""
    lam = np.geomspace(1e-3, 1.0, 15)
    x = np.linspace(-L_HALF, L_HALF, 5)
    elastic = beam_harmonic(homogeneous(0.0), omega_of(lam), x, 1.0, 0.2).acceleration
    nearly = beam_harmonic(homogeneous(1e-6), omega_of(lam), x, 1.0, 0.2).acceleration
    assert np.max(np.abs(nearly - elastic)) < 1e-5 * np.max(np.abs(elastic))
    vertical, shear, moment = centre_ratios(homogeneous(1e4), LAMBDAS)
    for ratio in (vertical, shear, moment):
        assert np.all(np.isfinite(ratio)) and np.max(np.abs(ratio - 1)) < 1e-3


def test_high_frequency_uses_stable_transfer():
    """λ = 2000 (|q| ≈ 45 per unit length, far past cosh overflow of a single transfer matrix
    over a stiff-contrast body): transfer fields are finite and momentum still balances to 1e-8."""
    body = Segments(np.array([-L_HALF, 0.0, L_HALF]), np.array([MASS, 1000 * MASS]), np.array([STIFFNESS, STIFFNESS / 1000]), np.array([1e7, 1e7]))
    x, weights = gauss_points(body, 200)
    r = beam_harmonic(body, omega_of([200.0, 2000.0]), x, N1=1.0)
    assert np.all(np.isfinite(r.acceleration))
    assert np.max(np.abs(r.acceleration @ weights - 1.0)) < 1e-8


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda b: beam_harmonic(b, [1.0], [-L_HALF * 1.5]), "positions x"),
        (lambda b: beam_harmonic(b, [0.0], [0.0]), "omega"),
        (lambda b: beam_harmonic(b, [1.0, 2.0], [0.0], G2=np.ones(3)), "G2"),
        (lambda b: beam_harmonic_closed_form(Segments(np.array([-1.0, 0.0, 1.0]), [1.0, 1.0], [1.0, 2.0], [0.0, 0.0]), [1.0], [0.0]), "homogeneous"),
    ],
)
def test_bad_input_is_rejected(call, message):
    """x outside the body, ω ≤ 0, a load of the wrong shape, closed form on a piecewise body: ValueError."""
    with pytest.raises(ValueError, match=message):
        call(homogeneous(0.1))
