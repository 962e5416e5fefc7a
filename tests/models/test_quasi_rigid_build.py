"""The quasi-rigid car build against the previous build's answer (issue 31: built at the cost of its arithmetic, not
re-derived), and its reuse.

``data/quasi_rigid_cars.npz`` holds every matrix of :func:`support.quasi_rigid_cars.tables` as the build of commit
2017624 computed them for cars with profile jumps: three exact τ groups, 24 interpolated ones, an elastic car and a car
that bends; the build now is vectorised over the profile: the same numbers to rounding.
"""

import numpy as np
import pytest

from femref.core.body import Body
from femref.core.profiles import Piecewise, Uniform
from femref.models.base import forget_built
from femref.models.quasi_rigid import quasi_rigid_car
from femref.scene.impact import Car
from support.quasi_rigid_cars import DT, STORED, cars, tables

STORED_TABLES = np.load(STORED)


@pytest.fixture(scope="module")
def built():
    return tables()


@pytest.mark.parametrize("name", STORED_TABLES.files)
def test_car_matrices_equal_the_previous_build_to_rounding(built, name):
    stored = STORED_TABLES[name]
    assert built[name].shape == stored.shape
    scale = np.max(np.abs(stored)) if stored.size else 0.0
    np.testing.assert_allclose(built[name], stored, rtol=0.0, atol=1e-13 * scale)


def test_a_changed_body_or_step_builds_a_fresh_car():
    """The car is reused for an equal body, sensors and step (one build per process), and built afresh when any of
    them changes: the mass of one segment, the step, a sensor."""
    forget_built()
    car = cars()["stepped"]
    first = quasi_rigid_car(car, DT)
    assert quasi_rigid_car(Car("other", car.body, 0.0, dict(car.sensors)), DT) is first
    heavier = Body("rod", car.body.half_length, Piecewise((-6.5, -1.0, 6.5), (3500.0, 8300.0, 6100.0, 3500.0)),
                   car.body.stiffness, car.body.viscosity, 0.01)
    changed = quasi_rigid_car(Car("heavier", heavier, 1.5, dict(car.sensors)), DT)
    assert changed is not first and changed.momentum[1] > first.momentum[1]
    assert quasi_rigid_car(car, 0.5 * DT).transition[0, 1] == pytest.approx(0.5 * DT)
    moved = quasi_rigid_car(Car("moved", car.body, 1.5, dict(car.sensors, middle=2.8)), DT)
    assert not np.array_equal(moved.sensor_displacement, first.sensor_displacement)
    forget_built()
    assert quasi_rigid_car(car, DT) is not first


def test_uniform_cars_alike_share_their_build():
    """Two cars of equal bodies, sensors and step are one build (the default scene's kind of train)."""
    forget_built()
    body = Body("rod", 8.0, Uniform(6000.0), Uniform(2.0e9), Uniform(1.0e6), 0.01)
    one, two = Car("one", body, 1.0, {"front": 7.0}), Car("two", body, 0.0, {"front": 7.0})
    assert quasi_rigid_car(one, DT) is quasi_rigid_car(two, DT)
