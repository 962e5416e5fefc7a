"""The friction gear tabulated as a table law (reduced.couplers.friction_gear).

Exact values (the node at the solid closure, the solid line, the unloading ratio, the reference
stiffness in closed form), the tabulation's stated bound against the curves written here, its
convergence order (nodes ∝ tolerance^(−1/2), the chord error h² L''/8), the stored energy
against its closed form, and the input rules.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from reduced.couplers import TABULATION_TOLERANCE, CubicLoading, ExponentialLoading, friction_gear, rated_closure_force, tabulation_nodes

SOLID_CLOSURE = 0.075  # m

# name → (curve, L(δ) written here)
CURVES = {
    "cubic": (CubicLoading(1.0e7, 3.0e9), lambda d: 1.0e7 * d + 3.0e9 * d**3),
    "pure cubic": (CubicLoading(0.0, 4.7e9), lambda d: 4.7e9 * d**3),
    "exponential": (ExponentialLoading(1.05e5, 40.0), lambda d: 1.05e5 * np.expm1(40.0 * d)),
    "steep exponential": (ExponentialLoading(100.0, 133.0), lambda d: 100.0 * np.expm1(133.0 * d)),
}


def gear(curve, ratio: float = 0.4, factor: float = 30.0, **options):
    """The gear on ``curve`` with a solid stop ``factor`` times the loading slope at δ_c."""
    return friction_gear(curve, unloading_ratio=ratio, solid_closure=SOLID_CLOSURE, solid_stiffness=factor * curve.slope(SOLID_CLOSURE), **options)


@pytest.mark.parametrize("name", list(CURVES))
def test_the_tabulated_curves_are_within_the_stated_bound(name: str) -> None:
    """On 30001 closures over [0, δ_c] the table's loading is within 1e-5 · L(δ_c) of L and its unloading
    within r · 1e-5 · L(δ_c) of r L; the nodes are not wasted (the largest error is above half the bound)
    and number at most 250."""
    curve, exact = CURVES[name]
    law = gear(curve)
    rated = exact(SOLID_CLOSURE)
    closure = np.linspace(0.0, SOLID_CLOSURE, 30001)
    table = np.array([[c[0] for c in law.curves(d)] for d in closure])
    loading_error = np.max(np.abs(table[:, 0] - exact(closure)))
    assert 0.5 * TABULATION_TOLERANCE * rated < loading_error <= TABULATION_TOLERANCE * rated
    assert np.max(np.abs(table[:, 1] - 0.4 * exact(closure))) <= 0.4 * TABULATION_TOLERANCE * rated
    assert len(law.closure) <= 250


@pytest.mark.parametrize("name", ["cubic", "exponential"])
def test_the_node_count_grows_like_the_inverse_square_root_of_the_tolerance(name: str) -> None:
    """The chord error is h² L''/8, so nodes ∝ tolerance^(−1/2): the slope of log(nodes) against
    log(tolerance) over 1e-3 … 1e-7 lies in [−0.55, −0.45], and the finest still meets its bound."""
    curve, exact = CURVES[name]
    tolerances = np.array([1e-3, 1e-4, 1e-5, 1e-6, 1e-7])
    counts = np.array([tabulation_nodes(curve, SOLID_CLOSURE, tol).size for tol in tolerances])
    slope = np.polyfit(np.log(tolerances), np.log(counts), 1)[0]
    assert -0.55 <= slope <= -0.45
    nodes = tabulation_nodes(curve, SOLID_CLOSURE, 1e-7)
    mid = 0.5 * (nodes[1:] + nodes[:-1])
    chord = 0.5 * (exact(nodes[1:]) + exact(nodes[:-1]))
    assert np.max(np.abs(chord - exact(mid))) <= 1e-7 * exact(SOLID_CLOSURE)


def test_the_solid_closure_is_a_node_and_the_solid_line_continues_it() -> None:
    """A node exactly at δ_c with L(δ_c) and r L(δ_c); beyond it both curves rise with k_s (L − U stays
    (1 − r) L(δ_c)); the last node is where the loading force doubles, δ_c + L(δ_c)/k_s, and the
    reference stiffness is the secant there, 2 L(δ_c)/(δ_c + L(δ_c)/k_s)."""
    curve, exact = CURVES["cubic"]
    solid = 30.0 * (1.0e7 + 3 * 3.0e9 * SOLID_CLOSURE**2)
    law = gear(curve)
    rated = exact(SOLID_CLOSURE)
    k = law.closure.index(SOLID_CLOSURE)
    assert (law.loading[k], law.unloading[k]) == (pytest.approx(rated, rel=1e-15), pytest.approx(0.4 * rated, rel=1e-15))
    assert law.closure[-1] == pytest.approx(SOLID_CLOSURE + rated / solid, rel=1e-14) and k == len(law.closure) - 2
    for closure in (0.08, 0.2):
        (up, up_slope, _), (down, down_slope, _) = law.curves(closure)
        assert up == pytest.approx(rated + solid * (closure - SOLID_CLOSURE), rel=1e-12)
        assert down == pytest.approx(0.4 * rated + solid * (closure - SOLID_CLOSURE), rel=1e-12)
        assert up_slope == pytest.approx(solid, rel=1e-9) and down_slope == pytest.approx(solid, rel=1e-9)
    assert law.reference_stiffness == pytest.approx(2 * rated / (SOLID_CLOSURE + rated / solid), rel=1e-12)
    assert rated_closure_force(curve, SOLID_CLOSURE) == pytest.approx(rated, rel=1e-15)


def test_the_stored_energy_is_the_integral_of_the_unloading_curve() -> None:
    """``∫₀^δ U = r (k1 δ²/2 + k3 δ⁴/4)`` within ``r · 1e-5 · L(δ_c) · δ`` below δ_c; beyond it the solid
    part adds ``r L(δ_c)(δ − δ_c) + k_s (δ − δ_c)²/2`` exactly."""
    curve, exact = CURVES["cubic"]
    law = gear(curve)
    energy = lambda d: 0.4 * (1.0e7 * d**2 / 2 + 3.0e9 * d**4 / 4)  # noqa: E731
    rated = exact(SOLID_CLOSURE)
    for closure in (0.01, 0.04, SOLID_CLOSURE):
        assert abs(law.curves(closure)[1][2] - energy(closure)) <= 0.4 * TABULATION_TOLERANCE * rated * closure
    solid, beyond = 30.0 * curve.slope(SOLID_CLOSURE), 0.01
    expected = law.curves(SOLID_CLOSURE)[1][2] + 0.4 * rated * beyond + solid * beyond**2 / 2
    assert law.curves(SOLID_CLOSURE + beyond)[1][2] == pytest.approx(expected, rel=1e-10)


def test_a_polymer_like_gear_has_little_hysteresis_and_a_dashpot() -> None:
    """Unloading ratio 0.9 and c_v = 2e5 N·s/m: loading at 0.5 m/s gives L + c_v δ̇, unloading at −0.5 m/s
    gives 0.9 L + c_v δ̇ (at a node, so exactly)."""
    curve, exact = CURVES["exponential"]
    law = gear(curve, ratio=0.9, damping=2.0e5)
    node = law.closure[len(law.closure) // 2]
    state = np.zeros(0)
    assert law.force(node, 0.5, state) == pytest.approx(exact(node) + 1.0e5, rel=1e-12)
    assert law.force(node, -0.5, state) == pytest.approx(0.9 * exact(node) - 1.0e5, rel=1e-12)


def test_a_linear_curve_needs_one_segment() -> None:
    """``L = k1 δ`` is its own chord: nodes 0 and δ_c only (then the solid node)."""
    law = gear(CubicLoading(2.7e7, 0.0))
    assert law.closure[:2] == (0.0, SOLID_CLOSURE) and len(law.closure) == 3


@pytest.mark.parametrize(
    "build, message",
    [
        (lambda: CubicLoading(0.0, 0.0), "both 0: a gear that never pushes"),
        (lambda: CubicLoading(-1.0, 3e9), "linear_stiffness must be >= 0"),
        (lambda: ExponentialLoading(0.0, 40.0), "amplitude must be > 0"),
        (lambda: ExponentialLoading(1e5, -1.0), "rate must be > 0"),
        (lambda: gear(CURVES["cubic"][0], ratio=1.2), r"unloading_ratio must be in \[0, 1\]"),
        (lambda: gear(CURVES["cubic"][0], factor=0.5), "solid_stiffness must be at least the loading slope at the solid closure"),
        (lambda: friction_gear(CURVES["cubic"][0], unloading_ratio=0.4, solid_closure=0.0, solid_stiffness=1e9), "solid_closure must be > 0"),
        (lambda: gear(CURVES["cubic"][0], tolerance=0.0), "tolerance must be > 0"),
        (lambda: friction_gear(ExponentialLoading(1e5, 1e4), unloading_ratio=0.4, solid_closure=SOLID_CLOSURE, solid_stiffness=1e9),
         r"the loading curve overflows at the solid closure 0.075 m: L\(δ_c\) is not finite"),
    ],
    ids=["flat cubic", "negative k1", "zero amplitude", "negative rate", "ratio above 1", "soft stop", "zero closure", "zero tolerance", "overflow"],
)
def test_bad_input_names_the_argument_and_the_rule(build, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        build()


def test_the_cubic_curve_derivatives_are_its_own() -> None:
    """``L' = k1 + 3 k3 δ²`` and ``L'' = 6 k3 δ`` against central differences (step 1e-6 m, 1e-7 relative)."""
    for curve in (CURVES["cubic"][0], CURVES["exponential"][0]):
        for d in (0.01, 0.05):
            h = 1e-6
            assert curve.slope(d) == pytest.approx((curve.force(d + h) - curve.force(d - h)) / (2 * h), rel=1e-7)
            assert curve.curvature(d) == pytest.approx((curve.slope(d + h) - curve.slope(d - h)) / (2 * h), rel=1e-7)
    assert math.isclose(CURVES["cubic"][0].curvature(0.05), 6 * 3.0e9 * 0.05)
