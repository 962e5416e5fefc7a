"""The fem car's set-up: the row bands it hands the packing, the car masses a scene computes once per body.

The car is checked against the body's assembled operators and the packing's own conversion of their sparse
matrices (the path every car took before its bands were kept from the assembly), on rods uniform and with jumps,
P1 and P2, small (dense) and not, a Voigt-viscous and an inviscid rod; a car that bends carries no bands (its
block matrices are converted as before). Cars alike in a case share one resolved body, whose mass is the
quadrature a body built alone gives, to the bit.
"""

import math

import numpy as np
import pytest
import scipy.sparse as sp

from femref.case import parse_case
from femref.core.body import Body
from femref.core.profiles import Piecewise, Table, Uniform
from femref.fem.build import FemSettings, build_operators
from femref.impact.kernels.packing import _bands_of
from femref.models.base import forget_built
from femref.models.fem import DENSE_CAR_DOFS, dense_of_bands, fem_car
from femref.scene.build import body_from_spec, scene_from_case
from femref.scene.impact import Car

L = 8.0


def rod_car(mass, viscosity) -> Car:
    body = Body("rod", L, mass, Uniform(2.0e9), viscosity, L * math.sqrt(6000.0 / 2.0e9))
    return Car("car", body, 1.0, {"center": 0.0, "front": 6.0})


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("elements", [1, 7, 40])
@pytest.mark.parametrize("profiles", ["uniform", "jumps", "inviscid"])
def test_fem_car_is_its_operators_to_the_bit(order, elements, profiles):
    """The fem car — small (:func:`small_rod_system`, dense M, C, K from bands assembled straight) or not (sparse, from
    :func:`build_operators`) — carries the numbers of the body's assembled operators: its bands are what the packing
    made of the sparse M, C, K (:func:`_bands_of`), its dense matrices theirs, its end and sensor rows, load matrix and
    translation the operators' sampling, ``B`` and rigid mode; P1/P2, 1, 7 and 40 elements (the last above
    :data:`DENSE_CAR_DOFS` for P2), uniform rods, jumps and kinks, and a rod without Voigt viscosity."""
    mass, viscosity = {"uniform": (Uniform(6000.0), Uniform(1.5e6)),
                       "jumps": (Piecewise((-4.0, 4.0), (4000.0, 9000.0, 4000.0)), Table((-8.0, 0.0, 8.0), (1e6, 4e6, 1e6))),
                       "inviscid": (Piecewise((-4.0, 4.0), (4000.0, 9000.0, 4000.0)), Uniform(0.0))}[profiles]
    car, settings = rod_car(mass, viscosity), FemSettings(elements=elements, order=order)
    forget_built()
    system = fem_car(car, settings)
    ops = build_operators(car.body, settings)
    assert sp.issparse(system.mass) == (ops.ndof > DENSE_CAR_DOFS)
    expected = _bands_of(ops.ndof, (ops.mass, ops.damping, ops.stiffness))
    assert system.bands is not None and system.bands[0] == expected[0] == order
    for mine, theirs, matrix, sparse in zip(system.bands[1:], expected[1:], (system.mass, system.damping, system.stiffness),
                                            (ops.mass, ops.damping, ops.stiffness)):
        assert np.array_equal(mine, theirs)
        assert np.array_equal(matrix.toarray() if sp.issparse(matrix) else matrix, sparse.toarray())
    l = car.body.half_length
    assert np.array_equal(system.end_outputs, ops.sampling(np.array([-l, l])))
    assert np.array_equal(system.sensor_outputs, ops.sampling(car.sensor_x))
    assert np.array_equal(system.load_matrix, ops.load_matrix.toarray())
    assert np.array_equal(system.translation, ops.rigid_modes[:, 0])
    assert system.settings["dofs"] == ops.ndof and np.array_equal(system.settings["nodes"], ops.nodes)


def test_dense_of_bands_inverts_the_band_layout():
    """``dense_of_bands`` puts ``bands[k, i]`` at ``[i, i + k − p]``: a random banded matrix back from its bands."""
    rng = np.random.default_rng(3)
    for n, p in ((1, 0), (5, 1), (9, 2)):
        dense = np.triu(np.tril(rng.standard_normal((n, n)), p), -p)
        bands = np.zeros((2 * p + 1, n))
        for i in range(n):
            for j in range(max(0, i - p), min(n, i + p + 1)):
                bands[p + j - i, i] = dense[i, j]
        assert np.array_equal(dense_of_bands([bands], p)[0], dense)


def test_a_car_that_bends_carries_no_rod_bands():
    """The rod and beam side by side (block matrices) are not the rod's bands: the packing converts them itself."""
    car = rod_car(Uniform(6000.0), Uniform(1.5e6))
    beam = Body("beam", L, Uniform(6000.0), Uniform(5.0e9), Uniform(0.0), L * L * math.sqrt(6000.0 / 5.0e9))
    bent = Car(car.name, car.body, car.velocity, car.sensors, bending=beam, coupler_offset=(0.3, 0.3))
    forget_built()
    assert fem_car(bent, FemSettings(elements=4, order=2)).bands is None


def _case(bodies: list[dict]) -> dict:
    cars = [{"name": f"car{k}", "body": body, "velocity": 2.0 if k == 0 else 0.0} for k, body in enumerate(bodies)]
    couplers = [{"name": f"c{k}", "between": [f"car{k}", f"car{k + 1}"], "law": {"kelvin_voigt": {"stiffness": 4e7, "damping": 3e5}},
                 "contact": "bilateral", "slack": 0.0} for k in range(len(bodies) - 1)]
    return {"kind": "impact", "cars": cars, "couplers": couplers, "time": {"end": 0.05}, "models": ["fem"], "fem": {"elements": 4}}


def test_cars_alike_share_one_body_whose_mass_is_a_lone_bodys():
    """Two equal car bodies resolve to one Body object (its mass computed once per scene), a third, heavier one to its
    own; each mass equals, to the bit, that of a body built alone from the same spec."""
    light = {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3e9, "axial_viscosity": 2e6}
    heavy = dict(light, mass_per_length=9000.0)
    case = parse_case(_case([light, light, heavy]), source="<test>")
    scene = scene_from_case(case)
    first, second, third = (car.body for car in scene.cars)
    assert first is second and third is not first
    for spec, body in zip(case.cars, (first, second, third)):
        assert body.total_mass == body_from_spec(spec.body).total_mass
    assert third.total_mass == pytest.approx(17.0 * 9000.0, rel=1e-14)
