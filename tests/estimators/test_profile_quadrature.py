"""The inverse_quasi_rigid estimator's profile integrals by a fixed Gauss–Legendre rule
(femref.estimators.inverse.quasi_rigid_inversion) against a closed form and against scipy.integrate.quad
(reduced.inverse.CoupledImpactInversion.from_profiles, adaptive, relative 1e-12)."""

from __future__ import annotations

import pytest

from femref.core.body import Body
from femref.core.profiles import Linear, Piecewise, Table, Uniform
from femref.estimators.inverse import quasi_rigid_inversion
from reduced.inverse import CoupledImpactInversion

HALF_LENGTH = 8.5  # m: 17 m cars


def rod(mass_per_length, axial_stiffness) -> Body:
    return Body("rod", HALF_LENGTH, mass_per_length, axial_stiffness, Uniform(0.0), 1.0)


#: Uniform, stepped (jumps of m and EA at different places), linear, and tabulated with EA from 1e8 to 1e10 N (100 to 1
#: on each piece: without cutting the pieces the rule would err by ~1e-3).
BODIES = {
    "uniform": rod(Uniform(7.0e3), Uniform(3.0e9)),
    "stepped": rod(Piecewise((-4.0, 4.0), (9.0e3, 5.0e3, 9.0e3)), Piecewise((0.5,), (2.0e9, 4.0e9))),
    "linear": rod(Linear(5.0e3, 9.0e3, HALF_LENGTH), Linear(1.0e9, 5.0e9, HALF_LENGTH)),
    "table": rod(Table((-8.5, -2.0, 3.0, 8.5), (6.0e3, 9.0e3, 4.0e3, 7.0e3)), Table((-8.5, 0.0, 8.5), (1.0e8, 1.0e10, 2.0e8))),
}
SPANS = [(-HALF_LENGTH, HALF_LENGTH), (-0.9 * HALF_LENGTH, 0.85 * HALF_LENGTH), (-0.3 * HALF_LENGTH, 0.6 * HALF_LENGTH)]


@pytest.mark.parametrize("span", SPANS, ids=["ends", "sensors", "inner"])
@pytest.mark.parametrize("name", list(BODIES))
def test_the_fixed_rule_gives_the_adaptive_quadratures_coefficients(name: str, span: tuple[float, float]) -> None:
    """k1, k2 and M as scipy.integrate.quad gives them (its tolerance: relative 1e-12, 1e-11 for the nested integral)."""
    body = BODIES[name]
    l = body.half_length
    fixed = quasi_rigid_inversion(body, span)
    adaptive = CoupledImpactInversion.from_profiles(body.mass_per_length, body.stiffness, l, breakpoints=tuple(j for j in body.jumps if -l < j < l),
                                                    span=span)
    assert fixed.k1 == pytest.approx(adaptive.k1, rel=1e-12, abs=0.0)
    assert fixed.k2 == pytest.approx(adaptive.k2, rel=1e-11, abs=0.0)
    assert fixed.total_mass == pytest.approx(adaptive.total_mass, rel=1e-12, abs=0.0)


def test_a_uniform_rod_between_two_sensors() -> None:
    """Uniform ``m``, ``EA`` on ``[x1, x2]``: ``C = (x2 − x1)/EA``, ``μ = m (x + l)``, so ``k1 = EA/(x2 − x1)``,
    ``k2 = −m ((x2 + l)² − (x1 + l)²) / (2 (x2 − x1))`` and ``M = 2 m l``."""
    m, ea, l = 7.0e3, 3.0e9, HALF_LENGTH
    x1, x2 = -0.8 * l, 0.7 * l
    inversion = quasi_rigid_inversion(rod(Uniform(m), Uniform(ea)), (x1, x2))
    assert inversion.k1 == pytest.approx(ea / (x2 - x1), rel=1e-14)
    assert inversion.k2 == pytest.approx(-m * ((x2 + l) ** 2 - (x1 + l) ** 2) / (2.0 * (x2 - x1)), rel=1e-14)
    assert inversion.total_mass == pytest.approx(2.0 * m * l, rel=1e-14)


def test_a_span_outside_the_car_is_refused() -> None:
    with pytest.raises(ValueError, match=r"span must satisfy -l <= x1 < x2 <= l"):
        quasi_rigid_inversion(BODIES["uniform"], (-9.0, 8.0))
