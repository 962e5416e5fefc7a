"""Three corrections of the source study's printed derivation, each shown by an error (docs/formulas.md §H1–H3).

For each one the form the study used and the corrected form are run against a reference
that is independent of both, and each error is measured:

* H1: the small-damping series of the two-mass Kelvin-Voigt impact (3.38–3.41) against
  the closed form (:func:`reduced.rigid.kelvin_voigt_impact`). The printed series carries
  an O(ε) error; the corrected series an O(ε⁴) error.
* H2: the centre acceleration of a free Voigt rod with linear density ``m = a x + b``
  (4.81), frequency domain, against the exact solution of the rod equations (integrated
  here by DOP853 at rtol 1e-13) and femref's FEM. The re-derived closed form H2.1 errs by
  O(λ⁴) and equals the general quasi-rigid rod to rounding. The printed formula is not
  available; the notes record only that it gives 4× the homogeneous correction at
  ``a = 0``, so that defect is coded and its O(λ²) error is shown.
* H3: least-squares ``k1``, ``k2`` (§F) from noisy records. Fitted on twice-differentiated
  records, ``k2`` shrinks towards zero several-fold at 2–5 % noise; fitted on the integrated
  form, the mean over seeds stays within 1.5 % of the truth at 1 % noise and 9 % at 2 %.

Each test prints what it measures (run ``pytest -s`` to see the numbers).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from reduced.inverse import CoupledImpactInversion
from reduced.quasi_rigid import QuasiRigidRod
from reduced.rigid import ImpactPair, kelvin_voigt_impact, kelvin_voigt_perturbation, perturbation_terms
from reduced.signal_tools import integrate_twice
from support.convergence import observed_order

# --------------------------------------------------------------------------- H1


def printed_perturbation_terms(tau: ArrayLike, order: int = 3) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Printed (3.38–3.41): ``X_k'' + X_k = −X_{k−1}``, ``X_k(0) = X_k'(0) = 0`` (k ≥ 1), ``X0 = −sin τ``.

    The expansion of ``X'' + εX' + X = 0`` gives ``X_k'' + X_k = −X_{k−1}'`` instead (the
    corrected terms are :func:`reduced.rigid.perturbation_terms`). The printed rule, carried
    to order 3, gives::

        X1 = (sin τ − τ cos τ)/2
        X2 = (τ² sin τ + 3τ cos τ − 3 sin τ)/8
        X3 = τ³ cos τ/48 − τ² sin τ/8 − 5τ cos τ/16 + 5 sin τ/16

    (solved by hand and checked with sympy; the residual test below checks the rule).
    The notes state only the rule for X1; X2 and X3 follow the same rule. With these
    terms the series reproduces the errors recorded when the misprint was found
    (0.28 / 0.15 / 0.077 at ε = 0.2 / 0.1 / 0.05, to 1 %). Returns ``X_k`` and ``X_k'``,
    arrays of shape ``(order + 1, len(τ))``.
    """
    if order not in (0, 1, 2, 3):
        raise ValueError(f"order must be 0, 1, 2 or 3, got {order!r}")
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    s, c = np.sin(tau), np.cos(tau)
    t2, t3 = tau**2, tau**3
    x = np.array(
        [
            -s,
            0.5 * (s - tau * c),
            (t2 * s + 3.0 * tau * c - 3.0 * s) / 8.0,
            t3 * c / 48.0 - t2 * s / 8.0 - 5.0 * tau * c / 16.0 + 5.0 * s / 16.0,
        ]
    )
    xd = np.array(
        [
            -c,
            0.5 * tau * s,
            (t2 * c - tau * s) / 8.0,
            -t3 * s / 48.0 - t2 * c / 16.0 + tau * s / 16.0,
        ]
    )
    return x[: order + 1], xd[: order + 1]


PAIR = ImpactPair.source_study()  # 119 t at 2.2 m/s against 100 t at rest
COUPLER_STIFFNESS = 4.0e7  # N/m


def test_printed_terms_solve_the_printed_hierarchy_not_the_expansion() -> None:
    """The coded printed terms satisfy ``X_k'' + X_k = −X_{k−1}`` (residual ≤ 1e-6, central
    differences), start from rest, and violate the expansion's ``X_k'' + X_k = −X_{k−1}'``
    by O(1) on τ ∈ [0, π] (measured max residual 1.41, 1.57, 0.31 for k = 1, 2, 3; asserted > 0.25)."""
    tau = np.linspace(0.0, math.pi, 315)
    h = 1e-4
    x, xd = printed_perturbation_terms(tau)
    xp, xdp = printed_perturbation_terms(tau + h)
    xm, xdm = printed_perturbation_terms(tau - h)
    assert np.max(np.abs((xp - xm) / (2 * h) - xd)) <= 1e-6
    xdd = (xdp - xdm) / (2 * h)
    printed_rule = xdd[1:] + x[1:] + x[:-1]
    expansion = xdd[1:] + x[1:] + xd[:-1]
    assert np.max(np.abs(printed_rule)) <= 1e-6
    assert np.all(x[1:, 0] == 0.0) and np.all(xd[1:, 0] == 0.0)
    violation = np.max(np.abs(expansion), axis=1)
    print("H1 printed terms: max |X_k'' + X_k + X_{k-1}'| for k = 1..3:", np.round(violation, 3))
    assert np.all(violation > 0.25)


def test_printed_series_errs_like_eps_corrected_like_eps_to_the_fourth() -> None:
    """Series to order 3 against the closed form over the compression half-cycle τ ∈ [0, π].

    Problem: ``x'' + εx' + x = 0`` in ``τ = t√(c/m*)``, ``x = V X``, ``V = w√(m*/c)``, for the
    119 t / 100 t pair (c = 4e7 N/m, μ = ε√(c m*)). Exact answer: the damped closed form.
    Error: ``max |x_series − x_exact| / V`` at ε = 0.2 / 0.1 / 0.05.
    Printed (3.38–3.41): 0.281 / 0.149 / 0.0765, slope 0.94 (asserted in [0.8, 1.2]);
    corrected (:func:`reduced.rigid.perturbation_terms`): 7.86e-4 / 5.23e-5 / 3.38e-6, slope
    3.93 (asserted in [3.7, 4.3]). Both sets equal the figures recorded when the misprint was
    found (0.28 / 0.15 / 0.077 and 7.9e-4 / 5.2e-5 / 3.4e-6) to 3 %.
    """
    m = PAIR.reduced_mass
    omega = math.sqrt(COUPLER_STIFFNESS / m)
    v_scale = PAIR.closing_speed / omega
    tau = np.linspace(0.0, math.pi, 4001)
    t = tau / omega
    eps_levels = np.array([0.2, 0.1, 0.05])
    printed_errors, corrected_errors = [], []
    for eps in eps_levels:
        mu = eps * math.sqrt(COUPLER_STIFFNESS * m)
        exact = kelvin_voigt_impact(PAIR, COUPLER_STIFFNESS, mu, t).relative_displacement
        corrected = kelvin_voigt_perturbation(PAIR, COUPLER_STIFFNESS, mu, t, order=3).relative_displacement
        xs, _ = printed_perturbation_terms(tau, 3)
        printed = v_scale * (eps ** np.arange(4) @ xs)
        printed_errors.append(np.max(np.abs(printed - exact)) / v_scale)
        corrected_errors.append(np.max(np.abs(corrected - exact)) / v_scale)
    printed_slope = observed_order(eps_levels, printed_errors)
    corrected_slope = observed_order(eps_levels, corrected_errors)
    print(f"H1 printed errors {np.array(printed_errors)} slope {printed_slope:.3f}")
    print(f"H1 corrected errors {np.array(corrected_errors)} slope {corrected_slope:.3f}")
    assert 0.8 <= printed_slope <= 1.2
    assert 3.7 <= corrected_slope <= 4.3
    assert printed_errors == pytest.approx([0.28, 0.15, 0.077], rel=0.03)
    assert corrected_errors == pytest.approx([7.9e-4, 5.2e-5, 3.4e-6], rel=0.03)
    # the corrected library terms and the printed ones share only X0
    x_printed, _ = printed_perturbation_terms(tau)
    x_corrected, _ = perturbation_terms(tau)
    assert np.array_equal(x_printed[0], x_corrected[0])
    assert np.all(np.max(np.abs(x_printed[1:] - x_corrected[1:]), axis=1) > 0.5)


# --------------------------------------------------------------------------- H2

HALF_LENGTH = 8.5  # m: a 17 m car body
MEAN_DENSITY = 7000.0  # kg/m: b, the density at the centre → M = 2bl = 119 t
AXIAL_STIFFNESS = 3.0e9  # N, uniform
WAVE_TIME = HALF_LENGTH * math.sqrt(MEAN_DENSITY / AXIAL_STIFFNESS)  # λ = ω · WAVE_TIME
SLOPES = (0.0, 0.27, -0.4, 0.8)  # a·l/b: the density runs from b(1 − al/b) at −l to b(1 + al/b) at +l
BETAS = (0.0, 0.5)  # β = (cA/l)/√(b·EA)
LOADS = ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.4))  # (F1, F2) in N, tension positive
LAMBDAS = np.array([0.025, 0.05, 0.1, 0.2, 0.4])


def linear_density_centre_acceleration(
    omega: ArrayLike, slope: float, viscosity: float, F1: complex, F2: complex, *, printed_defect: bool = False
) -> NDArray[np.complex128]:
    """H2.1: ``M a(0) = F2 − F1 − (1/EA) L_τ[ d²/dt² ( l²(5b² − 10abl − 4a²l²)/(30b)·(F2 − F1) + (2al³/3)·F2 ) ]``.

    Free rod on ``[−l, l]``, ``m = a x + b`` (``slope`` a in kg/m², b = MEAN_DENSITY),
    uniform EA and Voigt viscosity cA (``viscosity``, N·s), ``τ = cA/EA``, ``M = 2bl``;
    ``a(0)`` is the acceleration at the geometric centre x = 0 (not at the centre of mass
    ``x = a l²/(3b)``). Time-harmonic with the factor ``e^{−iωt}``: ``d²/dt² → −ω²``,
    ``L_τ → 1/(1 − iωτ)``. Returns ``a(0)`` (m/s²) for end-force amplitudes F1, F2 (N).

    ``printed_defect=True`` codes the one property the notes record of the printed (4.81):
    4× the homogeneous correction at ``a = 0``. It replaces the a-independent part of the
    ``(F2 − F1)`` coefficient, ``b l²/6``, by ``4·b l²/6``, i.e. ``5b² → 20b²``, and keeps
    the slope terms of H2.1. It is a stand-in with that defect, not the printed formula.
    """
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    a, b, l, ea = slope, MEAN_DENSITY, HALF_LENGTH, AXIAL_STIFFNESS
    lead = 20.0 if printed_defect else 5.0
    c_difference = l**2 * (lead * b**2 - 10.0 * a * b * l - 4.0 * a**2 * l**2) / (30.0 * b)
    c_right = 2.0 * a * l**3 / 3.0
    lag = 1.0 / (1.0 - 1j * w * viscosity / ea)
    total_mass = 2.0 * b * l
    # −(1/EA) L_τ[d²/dt² G] with d²/dt² → −ω²
    return (F2 - F1 + w**2 * lag * (c_difference * (F2 - F1) + c_right * F2) / ea) / total_mass


def exact_centre_acceleration(omega: float, slope: float, viscosity: float, F1: complex, F2: complex) -> complex:
    """Exact ``a(0)`` of the free Voigt rod ``F_x = m a``, ``a_x = −ω² F/(EA − iω cA)``, ``F(∓l) = F1, F2``.

    The rod equations for the acceleration ``a = −ω² u`` and the axial force F (the state of
    femref.exact, which has no cancellation at low frequency), ``m = slope·x + b``. The
    fundamental matrix from −l is integrated by DOP853 at rtol 1e-13; ``a(−l)`` follows from
    ``F(l) = F2``, then ``a(0)`` from the fundamental matrix at 0. Independent of femref and
    of the quasi-rigid model; equals ``(F2 − F1) q/(M sin q)`` at ``slope = 0`` (tested below).
    """
    k = AXIAL_STIFFNESS - 1j * omega * viscosity

    def rhs(x: float, y: NDArray[np.complex128]) -> NDArray[np.complex128]:
        state = y.reshape(2, 2)  # rows (a, F); columns the two fundamental solutions
        return np.concatenate([-(omega**2) / k * state[1], (slope * x + MEAN_DENSITY) * state[0]])

    start = np.eye(2, dtype=complex).ravel()
    sol = solve_ivp(rhs, (-HALF_LENGTH, HALF_LENGTH), start, method="DOP853", rtol=1e-13, atol=1e-16, dense_output=True)
    assert sol.success, sol.message
    at_end = sol.y[:, -1].reshape(2, 2)
    at_centre = sol.sol(0.0).reshape(2, 2)
    left_acceleration = (F2 - at_end[1, 1] * F1) / at_end[1, 0]
    return complex(at_centre[0, 0] * left_acceleration + at_centre[0, 1] * F1)


def _viscosity(beta: float) -> float:
    return beta * HALF_LENGTH * math.sqrt(MEAN_DENSITY * AXIAL_STIFFNESS)


def _rigid(F1: float, F2: float) -> float:
    return (F2 - F1) / (2.0 * MEAN_DENSITY * HALF_LENGTH)


def test_exact_reference_is_q_over_sin_q_for_the_homogeneous_rod() -> None:
    """At a = 0 the integrated reference equals the closed-form exact centre acceleration
    ``(F2 − F1) q/(M sin q)``, ``q² = λ²/(1 − iλβ)``, to 1e-11 of the rigid acceleration
    (λ = 0.025, 0.4, 2; β = 0 and 0.5; measured 2.9e-13); and H2.1 at a = 0 is exactly the
    homogeneous two-term result ``(F2 − F1)(1 + q²/6)/M`` (to 1e-15)."""
    lambdas = np.array([0.025, 0.4, 2.0])
    worst = 0.0
    for beta in BETAS:
        q = np.sqrt(lambdas**2 / (1.0 - 1j * lambdas * beta))
        for F1, F2 in LOADS:
            rigid = _rigid(F1, F2)
            exact = np.array([exact_centre_acceleration(w, 0.0, _viscosity(beta), F1, F2) for w in lambdas / WAVE_TIME])
            worst = max(worst, float(np.max(np.abs(exact - rigid * q / np.sin(q))) / abs(rigid)))
            closed = linear_density_centre_acceleration(lambdas / WAVE_TIME, 0.0, _viscosity(beta), F1, F2)
            assert np.max(np.abs(closed - rigid * (1.0 + q**2 / 6.0))) <= 1e-15 * abs(rigid) * np.max(np.abs(1 + q**2))
    print(f"H2 reference vs q/sin q: {worst:.1e}")
    assert worst <= 1e-11


def test_quasi_rigid_rod_equals_the_closed_form_to_rounding() -> None:
    """The general :class:`QuasiRigidRod` (profile integrals by Gauss quadrature) at x = 0
    equals H2.1 for every slope a·l/b = 0, 0.27, −0.4, 0.8, β = 0 and 0.5, three load cases,
    λ = 0.025…3: ≤ 1e-13 of |a| (measured 2.7e-15). At the centre of mass ``x = a l²/(3b)``
    the rod's acceleration differs from H2.1 by O(λ²) (a·l/b = 0.8, λ = 0.1: measured 2.0e-3
    of the rigid acceleration, asserted > 1e-3): H2.1 is the geometric centre's."""
    lambdas = np.array([0.025, 0.1, 0.4, 1.0, 3.0])
    omega = lambdas / WAVE_TIME
    worst = 0.0
    for ratio in SLOPES:
        slope = ratio * MEAN_DENSITY / HALF_LENGTH
        for beta in BETAS:
            c = _viscosity(beta)
            rod = QuasiRigidRod(HALF_LENGTH, lambda x, s=slope: s * np.asarray(x) + MEAN_DENSITY, AXIAL_STIFFNESS, c)
            for F1, F2 in LOADS:
                model = rod.harmonic(omega, [0.0], F1=F1, F2=F2).acceleration[:, 0]
                closed = linear_density_centre_acceleration(omega, slope, c, F1, F2)
                worst = max(worst, float(np.max(np.abs(model - closed) / np.abs(closed))))
    print(f"H2 QuasiRigidRod(x = 0) vs H2.1: {worst:.1e}")
    assert worst <= 1e-13
    slope = 0.8 * MEAN_DENSITY / HALF_LENGTH
    centre_of_mass = slope * HALF_LENGTH**2 / (3.0 * MEAN_DENSITY)
    rod = QuasiRigidRod(HALF_LENGTH, lambda x: slope * np.asarray(x) + MEAN_DENSITY, AXIAL_STIFFNESS, 0.0)
    w = 0.1 / WAVE_TIME
    off_centre = rod.harmonic(w, [centre_of_mass], F1=0.0, F2=1.0).acceleration[0, 0]
    gap = abs(off_centre - linear_density_centre_acceleration(w, slope, 0.0, 0.0, 1.0)[0]) / _rigid(0.0, 1.0)
    print(f"H2 at the centre of mass instead of x = 0 (λ = 0.1): {gap:.1e}")
    assert gap > 1e-3


def test_linear_density_closed_form_errs_like_lambda4_the_printed_defect_like_lambda2() -> None:
    """H2.1 and the printed defect (4× the homogeneous correction at a = 0) against the exact rod.

    Problem: free Voigt rod, 17 m, b = 7 t/m, EA = 3e9 N uniform, m = a x + b with
    a·l/b = 0, 0.27, −0.4, 0.8; β = 0 and 0.5; (F1, F2) = (1, 0), (0, 1), (−1, 0.4) N;
    λ = ω l √(b/EA) = 0.025…0.4. Exact answer: :func:`exact_centre_acceleration`.
    Error: ``|a(0) − a_exact(0)|`` over the rigid acceleration ``|F2 − F1|/M``.
    H2.1: every slope in [3.7, 4.3] (measured 3.99–4.09) and error ≤ 0.2 λ⁴ at λ = 0.025
    (measured 0.004–0.122 λ⁴; 0.019 λ⁴ = 7/360 λ⁴ at a = 0). Printed defect: slopes in
    [1.8, 2.2] (measured 1.98–2.01), error ≥ 0.45 λ² (measured 0.500 λ² at λ = 0.025: the
    defect adds 3 λ²/6 = λ²/2 of the rigid acceleration, whatever a, β and the load).
    """
    lines = []
    for ratio in SLOPES:
        slope = ratio * MEAN_DENSITY / HALF_LENGTH
        for beta in BETAS:
            c = _viscosity(beta)
            for F1, F2 in LOADS:
                rigid = abs(_rigid(F1, F2))
                omega = LAMBDAS / WAVE_TIME
                exact = np.array([exact_centre_acceleration(w, slope, c, F1, F2) for w in omega])
                corrected = np.abs(linear_density_centre_acceleration(omega, slope, c, F1, F2) - exact) / rigid
                defect = np.abs(linear_density_centre_acceleration(omega, slope, c, F1, F2, printed_defect=True) - exact) / rigid
                s_corrected, s_defect = observed_order(LAMBDAS, corrected), observed_order(LAMBDAS, defect)
                lines.append(f"a·l/b={ratio:+.2f} β={beta} F=({F1:+.1f},{F2:+.1f}): H2.1 slope {s_corrected:.3f} "
                             f"err/λ⁴ {corrected[0] / LAMBDAS[0] ** 4:.3f}; defect slope {s_defect:.3f} "
                             f"err/λ² {defect[0] / LAMBDAS[0] ** 2:.3f}")
                assert 3.7 <= s_corrected <= 4.3, lines[-1]
                assert corrected[0] <= 0.2 * LAMBDAS[0] ** 4, lines[-1]
                assert 1.8 <= s_defect <= 2.2, lines[-1]
                assert np.all(defect >= 0.45 * LAMBDAS**2), lines[-1]
    print("\n".join(["H2 against the exact rod:", *lines]))


def test_linear_density_against_the_fem() -> None:
    """The same rod by femref's FEM (64 quadratic elements, harmonic solve with the rigid part
    exact): FEM = exact reference to 1e-9 of the rigid acceleration (measured ≤ 1.7e-10), and at
    the λ where the misprint was recorded, a·l/b = 0.27, β = 0, load F2: the printed defect is off
    the FEM by 9.7e-4 at λ = 0.044 and 5.4e-2 at λ = 0.33 (recorded for the printed form: 1e-3 and
    6e-2; asserted within 15 %: any error ∝ λ² grows 56-fold between these λ), H2.1 by 2.3e-7 and
    7.5e-4 (asserted ≤ 5e-7 and ≤ 1e-3)."""
    fem = pytest.importorskip("femref.fem")
    profiles = pytest.importorskip("femref.core.profiles")
    worst = 0.0
    for ratio in SLOPES:
        slope = ratio * MEAN_DENSITY / HALF_LENGTH
        density = profiles.Linear(MEAN_DENSITY - slope * HALF_LENGTH, MEAN_DENSITY + slope * HALF_LENGTH, HALF_LENGTH)
        for beta in BETAS:
            c = _viscosity(beta)
            ops = fem.assemble_rod(fem.body_nodes(HALF_LENGTH, 64), 2, density, profiles.Uniform(AXIAL_STIFFNESS), profiles.Uniform(c))
            omega = LAMBDAS / WAVE_TIME
            for F1, F2 in LOADS:
                solved = fem.harmonic_response(ops, omega, {"F1": F1, "F2": F2}, np.array([0.0])).acceleration[:, 0]
                exact = np.array([exact_centre_acceleration(w, slope, c, F1, F2) for w in omega])
                worst = max(worst, float(np.max(np.abs(solved - exact)) / abs(_rigid(F1, F2))))
    print(f"H2 FEM vs exact reference: {worst:.1e}")
    assert worst <= 1e-9

    slope = 0.27 * MEAN_DENSITY / HALF_LENGTH
    density = profiles.Linear(MEAN_DENSITY - slope * HALF_LENGTH, MEAN_DENSITY + slope * HALF_LENGTH, HALF_LENGTH)
    ops = fem.assemble_rod(fem.body_nodes(HALF_LENGTH, 64), 2, density, profiles.Uniform(AXIAL_STIFFNESS), profiles.Uniform(0.0))
    recorded = np.array([0.044, 0.33])
    omega = recorded / WAVE_TIME
    solved = fem.harmonic_response(ops, omega, {"F2": 1.0}, np.array([0.0])).acceleration[:, 0]
    rigid = _rigid(0.0, 1.0)
    defect = np.abs(linear_density_centre_acceleration(omega, slope, 0.0, 0.0, 1.0, printed_defect=True) - solved) / rigid
    corrected = np.abs(linear_density_centre_acceleration(omega, slope, 0.0, 0.0, 1.0) - solved) / rigid
    print(f"H2 against the FEM at λ = {recorded}: printed defect {defect}, H2.1 {corrected}")
    assert defect[0] == pytest.approx(1e-3, rel=0.15) and defect[1] == pytest.approx(6e-2, rel=0.15)
    assert corrected[0] <= 5e-7 and corrected[1] <= 1e-3


# --------------------------------------------------------------------------- H3

CAR_MASS = 2.0 * HALF_LENGTH * MEAN_DENSITY  # 119 t, homogeneous in H3
RECORD_STEP = 1e-3  # s: 1 kHz records
PULSE = 0.3  # s: sin² coupler pulses (λ ≈ 0.27 on this car)
NOISE_SEEDS = range(20)


def coupled_impact_records() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Time, a1, a2 of a homogeneous 17 m, 119 t car (EA = 3e9 N) under sin² pulses of 0.3 s
    (1 MN at −l from 0.02 s, 0.4 MN at +l 0.06 s later, both compressive), by the two-term
    quasi-rigid rod, 1 kHz, cut at the end of the pulses (0.38 s); and ``F1 = k1 ∬(a2 − a1) + k2 a1``
    with ``k1 = EA/2l``, ``k2 = −M/2`` — a force record that obeys the fitted law exactly."""
    t = np.arange(0.0, 1.2 * PULSE + 0.02, RECORD_STEP)

    def pulse(start: float) -> NDArray[np.float64]:
        s = np.clip((t - start) / PULSE, 0.0, 1.0)
        return np.sin(np.pi * s) ** 2

    rod = QuasiRigidRod(HALF_LENGTH, MEAN_DENSITY, AXIAL_STIFFNESS)
    response = rod.transient(t, [-HALF_LENGTH, HALF_LENGTH], F1=-1.0e6 * pulse(0.02), F2=-0.4e6 * pulse(0.02 + 0.2 * PULSE))
    a1, a2 = response.acceleration[:, 0], response.acceleration[:, 1]
    truth = CoupledImpactInversion.uniform(CAR_MASS, AXIAL_STIFFNESS, HALF_LENGTH)
    force = truth.k1 * integrate_twice(a2 - a1, RECORD_STEP) + truth.k2 * a1
    return t, a1, a2, force


def _fitted_ratios(
    records: tuple[NDArray[np.float64], ...], level: float, form: str
) -> NDArray[np.float64]:
    """``(k1/k1_true, k2/k2_true)`` per seed with white noise of ``level`` × the acceleration peak on each sensor."""
    t, a1, a2, force = records
    truth = CoupledImpactInversion.uniform(CAR_MASS, AXIAL_STIFFNESS, HALF_LENGTH)
    peak = np.max(np.abs(np.concatenate([a1, a2])))
    ratios = []
    for seed in NOISE_SEEDS:
        n1, n2 = level * peak * np.random.default_rng(seed).standard_normal((2, t.size))
        fit = CoupledImpactInversion.fit(t, a1 + n1, a2 + n2, force, form=form)
        ratios.append((fit.k1 / truth.k1, fit.k2 / truth.k2))
    return np.array(ratios)


def test_differentiated_fit_shrinks_k2_the_integrated_fit_does_not() -> None:
    """Least squares for k1, k2 on noisy records: the twice-differentiated fit is biased towards zero.

    Problem: :func:`coupled_impact_records` (peak a1 6.2 m/s², peak a2 − a1 0.74 m/s²) with
    seeded white noise of 1 %, 2 % and 5 % of the acceleration peak on each sensor, 20 seeds
    per level, the force record noise-free; truth k1 = EA/2l = 1.76e8 N/m, k2 = −M/2 = −59.5 t.
    Fits: ``CoupledImpactInversion.fit`` with ``form="differentiated"`` (default Savitzky-Golay
    31/4) and ``form="integrated"``. Noise-free both recover the truth (integrated to 1e-12,
    measured 3e-16; differentiated to 1 %, measured k1 +3.5e-4, k2 −7.0e-3).
    Measured mean k2/k2_true over the seeds — differentiated 0.77 / 0.42 / 0.12 (every seed
    below 0.94 / 0.57 / 0.23), integrated 1.00 / 1.09 / 1.54; mean k1/k1_true — differentiated
    1.10 / 1.24 / 1.30 (biased away from zero), integrated 1.01 / 0.97 / 0.66.
    Asserted: differentiated mean k2 ratio ≤ 0.85 at 1 %, ≤ 0.5 at 2 % and ≤ 0.2 at 5 % (factor
    ≥ 2 and ≥ 5), every seed below 0.7 at 2 % and 5 %; integrated means within 4 % at 1 % and
    within 12 % at 2 %, and no shrinking of k2 at any level (mean ≥ 0.95).
    Not asserted, a limit: single integrated fits scatter (k1 0.81–1.19 at 1 %, 0.66–1.21 at
    2 %), and at 5 % the doubly integrated noise biases its k1 towards zero too (mean 0.66).
    """
    records = coupled_impact_records()
    t, a1, a2, force = records
    truth = CoupledImpactInversion.uniform(CAR_MASS, AXIAL_STIFFNESS, HALF_LENGTH)
    clean_integrated = CoupledImpactInversion.fit(t, a1, a2, force)
    clean_differentiated = CoupledImpactInversion.fit(t, a1, a2, force, form="differentiated")
    assert clean_integrated.k1 == pytest.approx(truth.k1, rel=1e-12) and clean_integrated.k2 == pytest.approx(truth.k2, rel=1e-12)
    assert clean_differentiated.k1 == pytest.approx(truth.k1, rel=0.01) and clean_differentiated.k2 == pytest.approx(truth.k2, rel=0.01)

    means = {}
    for level in (0.01, 0.02, 0.05):
        for form in ("differentiated", "integrated"):
            ratios = _fitted_ratios(records, level, form)
            means[level, form] = ratios.mean(axis=0)
            print(f"H3 noise {level:.0%} {form}: k1/k1 mean {ratios[:, 0].mean():.3f} "
                  f"[{ratios[:, 0].min():.3f}, {ratios[:, 0].max():.3f}], k2/k2 mean {ratios[:, 1].mean():.3f} "
                  f"[{ratios[:, 1].min():.3f}, {ratios[:, 1].max():.3f}]")
            if form == "differentiated" and level >= 0.02:
                assert np.all(ratios[:, 1] < 0.7)
    assert means[0.01, "differentiated"][1] <= 0.85
    assert means[0.02, "differentiated"][1] <= 0.5
    assert means[0.05, "differentiated"][1] <= 0.2
    assert np.all(np.abs(means[0.01, "integrated"] - 1.0) <= 0.04)
    assert np.all(np.abs(means[0.02, "integrated"] - 1.0) <= 0.12)
    assert all(means[level, "integrated"][1] >= 0.95 for level in (0.01, 0.02, 0.05))
