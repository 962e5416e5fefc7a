"""The body rule's exact pieces: the Lagrange antiderivatives, the moments from the panel interpolant,
and the correction's coefficients at the nodes.

The cumulative moments ``S_p(y) = ∫_{−l}^{y} s^p m ds`` come from the full panels plus the
integral of the interpolant of ``s^p m`` through the partial panel's Gauss nodes
(``Σⱼ h Aⱼ(η) f(sⱼ)``, ``Aⱼ(η) = ∫_{−1}^{η} ℓⱼ``): exact when ``s^p m`` is a polynomial of degree
below the node count, so against closed forms for a linear mass they agree to round-off.
"""

import numpy as np
import pytest

from reduced.quasi_rigid import QuasiRigidRod
from reduced.quasi_rigid.profiles import (
    BodyQuadrature,
    gauss_legendre,
    integration_matrix,
    lagrange_antiderivatives,
)

L, M0, SLOPE = 8.0, 5000.0, 0.3


@pytest.mark.parametrize("points", [2, 5, 16])
def test_lagrange_antiderivatives_integrate_every_polynomial_below_the_node_count(points):
    """``Σⱼ Aⱼ(η) ξⱼ^m = (η^{m+1} − (−1)^{m+1})/(m + 1)`` for m < n, also at η = ±1 and on the table's own points."""
    xi, wi = gauss_legendre(points)
    eta = np.concatenate([np.linspace(-1.0, 1.0, 23), gauss_legendre(points + 1)[0]])
    A = lagrange_antiderivatives(eta, points)
    np.testing.assert_allclose(lagrange_antiderivatives(1.0, points), wi, rtol=0.0, atol=1e-14)
    np.testing.assert_allclose(lagrange_antiderivatives(-1.0, points), 0.0, rtol=0.0, atol=1e-14)
    for m in range(points):
        exact = (eta ** (m + 1) - (-1.0) ** (m + 1)) / (m + 1)
        np.testing.assert_allclose(A @ xi**m, exact, rtol=0.0, atol=2e-14, err_msg=f"degree {m}")


def test_integration_matrix_is_the_antiderivatives_at_the_nodes():
    points = 7
    xi, _ = gauss_legendre(points)
    np.testing.assert_array_equal(integration_matrix(points), lagrange_antiderivatives(xi, points))


@pytest.mark.parametrize("points", [2, 3, 8, 16, 24])
def test_gauss_legendre_rule_against_numpy_and_exactness(points):
    """The Golub–Welsch rule against numpy's (the companion matrix's) and exact for every degree below 2n."""
    xi, wi = gauss_legendre(points)
    reference_nodes, reference_weights = np.polynomial.legendre.leggauss(points)
    np.testing.assert_allclose(xi, reference_nodes, rtol=0.0, atol=4e-15)
    np.testing.assert_allclose(wi, reference_weights, rtol=3e-13, atol=0.0)
    for m in range(2 * points):
        np.testing.assert_allclose(wi @ xi**m, (1.0 - (-1.0) ** (m + 1)) / (m + 1), rtol=0.0, atol=1e-14, err_msg=f"degree {m}")


def linear_mass_rule() -> BodyQuadrature:
    return BodyQuadrature(L, lambda x: M0 * (1.0 + SLOPE * x / L), 2.0e9, 1.0e7, jumps=[2.0])


def exact_moments(y):
    """``∫_{−l}^{y} s^p (a + b s) ds``, p = 0, 1, 2, for the linear mass ``a + b s``."""
    a, b = M0, M0 * SLOPE / L
    def F(s):
        return np.stack([a * s + b * s**2 / 2, a * s**2 / 2 + b * s**3 / 3, a * s**3 / 3 + b * s**4 / 4], axis=-1)

    return F(np.asarray(y)) - F(np.asarray(-L))


def test_moments_at_any_point_and_at_the_nodes_are_exact_for_a_linear_mass():
    q = linear_mass_rule()
    y = np.concatenate([np.linspace(-L, L, 41), [2.0, 2.0 + 1e-9, L]])
    scale = np.abs(exact_moments(L))
    np.testing.assert_allclose(q.moments(y) / scale, exact_moments(y) / scale, rtol=0.0, atol=1e-14)
    np.testing.assert_allclose(q.node_moments / scale, exact_moments(q.nodes) / scale, rtol=0.0, atol=1e-14)


def test_correction_coefficients_at_the_nodes_are_the_coefficients_there():
    """``node_coefficients`` (one table per order) against ``coefficients`` at the same points (an interpolant rule per point)."""
    rod = QuasiRigidRod(L, lambda x: M0 * (1.0 + SLOPE * x / L), lambda x: np.where(x < 2.0, 2.0e9, 3.0e9), 1.0e7, jumps=[2.0])
    correction = rod.correction
    at_nodes = correction.node_coefficients()
    direct = correction.coefficients(rod.quadrature.nodes.ravel())
    np.testing.assert_allclose(at_nodes, direct, rtol=0.0, atol=1e-12 * np.max(np.abs(direct)))
