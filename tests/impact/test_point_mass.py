"""A point-mass car in the compiled loop: its diagonal (p = 0) path against the generic banded one and the closed form,
and the packing that cars of one geometry share.

The compiled kernels step a car whose matrices are diagonal (a rigid rod car: one DOF) without the banded sweeps'
views (:mod:`femref.impact.kernels.cars`, :mod:`femref.impact.kernels.pool`). The same car given a second, idle DOF
coupled by stored zeros (half-bandwidth 1) goes through the generic sweeps: every product it adds is an exact zero, so
the two runs agree to the bit. Against docs/formulas.md §A1 (:mod:`reduced.rigid`) the compiled rigid run converges at
second order, as the readable engine's does (tests/impact/test_solver.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp

from femref.core.body import Body
from femref.core.profiles import Uniform
from femref.fem import INTEGRATORS
from femref.impact import solve_impact
from femref.impact.kernels import pool
from femref.impact.kernels.loop import FIRST_CHUNK, FIRST_CHUNK_WORK, first_chunk, line_plan
from femref.impact.kernels.packing import prepared_car
from femref.impact.systems import SecondOrderSystem
from femref.models import model_form
from femref.models.base import forget_built
from femref.models.rigid import rigid_car
from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from reduced.couplers import Coupling, KelvinVoigt, StandardLinearDraftGear
from reduced.rigid import ImpactPair, kelvin_voigt_impact

HAMMER_M, ANVIL_M, LENGTH = 7000.0, 5882.0, 17.0
LAWS = {"kelvin_voigt": KelvinVoigt(4.0e7, 3.0e5), "draft_gear": StandardLinearDraftGear(4.0e8, 4.0e8, 1.7e7, 2.5e5, 0.05, 1.0e8)}


def rod(m: float) -> Body:
    return Body("rod", LENGTH / 2, Uniform(m), Uniform(3.0e9), Uniform(2.0e6), LENGTH / 2 * math.sqrt(m / 3.0e9))


def two_rigid_cars(law: str, contact: str, integrator: str, end: float = 0.2) -> ImpactScene:
    cars = (Car("hammer", rod(HAMMER_M), 2.2, {"center": 0.0, "front": 8.5}), Car("anvil", rod(ANVIL_M), 0.0, {"rear": -8.5}))
    return ImpactScene(cars, (Coupler("c1", 0, Coupling(LAWS[law], contact, 0.0)),), (ModelRun("rigid", ("rigid", "rigid")),),
                       end=end, integrator=integrator, rho_inf=1.0 if integrator == "newmark" else 0.8)


def with_idle_dof(car: SecondOrderSystem) -> SecondOrderSystem:
    """The point mass ``car`` with a second DOF of unit mass that nothing loads, reads or moves, stored with explicit
    zeros between the two (half-bandwidth 1): the same car through the generic banded kernels."""

    def padded(matrix, idle: float) -> sp.csr_matrix:
        value = float(np.asarray(matrix)[0, 0])
        return sp.csr_matrix((np.array([value, 0.0, 0.0, idle]), np.array([0, 1, 0, 1]), np.array([0, 2, 4])), shape=(2, 2))

    def column(matrix) -> np.ndarray:
        return np.hstack([matrix, np.zeros((matrix.shape[0], 1))])

    return SecondOrderSystem(car.fidelity, padded(car.mass, 1.0), padded(car.damping, 0.0), padded(car.stiffness, 0.0),
                             np.vstack([car.load_matrix, np.zeros((1, car.load_matrix.shape[1]))]), column(car.end_outputs),
                             column(car.sensor_outputs), np.append(car.translation, 0.0), settings=car.settings)


@pytest.mark.parametrize("law, contact", [("kelvin_voigt", "bilateral"), ("draft_gear", "compression_only")])
@pytest.mark.parametrize("integrator", ["newmark", "generalized_alpha"])
def test_a_point_mass_steps_as_the_generic_banded_path_to_the_bit(law, contact, integrator):
    """Two rigid cars, once as point masses (the diagonal path) and once with an idle DOF (the generic sweeps, half-bandwidth
    1): every history, energy and counter the same to the bit."""
    impact = two_rigid_cars(law, contact, integrator)
    dt = 5e-4
    point = [rigid_car(car) for car in impact.cars]
    assert all(p.dofs == 1 for p in point)
    diagonal, generic = solve_impact(impact, point, dt), solve_impact(impact, [with_idle_dof(p) for p in point], dt)
    assert (diagonal.status, diagonal.steps, diagonal.newton_iterations, diagonal.contact_changes) == (
        generic.status, generic.steps, generic.newton_iterations, generic.contact_changes)
    assert np.max(diagonal.couplers["c1"]["force"]) > 1e5
    for probe, values in generic.sensors.items():
        for key, value in values.items():
            np.testing.assert_array_equal(diagonal.sensors[probe][key], value, err_msg=f"{probe} {key}")
    for key, value in generic.couplers["c1"].items():
        np.testing.assert_array_equal(diagonal.couplers["c1"][key], value, err_msg=key)
    for key, value in generic.energy.items():
        np.testing.assert_array_equal(diagonal.energy[key], value, err_msg=key)


def test_the_compiled_rigid_run_converges_to_the_two_mass_closed_form_at_second_order():
    """Rigid cars + Kelvin–Voigt coupler, compiled (the point-mass path) = docs/formulas.md §A1: error ∝ dt², below 1e-3
    at dt = 2 ms."""
    impact = two_rigid_cars("kelvin_voigt", "bilateral", "newmark")
    pair = ImpactPair(HAMMER_M * LENGTH, ANVIL_M * LENGTH, 2.2)
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        response = solve_impact(impact, [rigid_car(car) for car in impact.cars], dt)
        exact = kelvin_voigt_impact(pair, 4.0e7, 3.0e5, response.time, "bilateral")
        errors.append(np.max(np.abs(response.couplers["c1"]["force"] - exact.coupler_force)) / np.max(exact.coupler_force))
    assert errors[0] < 1e-3
    assert np.all(np.abs(np.log2(np.array(errors[:-1]) / np.array(errors[1:])) - 2.0) < 0.05)


def test_cars_of_one_geometry_share_one_factorisation_and_a_new_step_factorises_anew():
    """Two cars of one system in a line (other coupler maps): one packed, factorised form (the same layout), values that
    differ only in the coupler maps, each car's gains its own; equal to a system built afresh; another step is another
    factorisation."""
    body = rod(HAMMER_M)
    cars = (Car("hammer", body, 2.2, {"center": 0.0}), Car("anvil", body, 0.0, {"center": 0.0}))
    impact = ImpactScene(cars, (Coupler("c1", 0, Coupling(LAWS["kelvin_voigt"], "bilateral", 0.0)),), (ModelRun("fem", ("fem", "fem")),),
                         end=0.1, integrator="newmark", rho_inf=1.0)
    integrator = INTEGRATORS[impact.integrator](impact.rho_inf)
    systems = [model_form("fem", "impact")(car, impact, 1e-4) for car in impact.cars]
    assert systems[0] is systems[1]
    maps = line_plan(impact).maps
    rear, front = (prepared_car(systems[0], integrator, 1e-4, *m) for m in maps)
    assert rear.layout is front.layout
    maps_at = {rear.layout[f]: rear.layout[f] + int(np.prod(rear.shapes[f])) for f in (pool.COUPLER_LOADS, pool.COUPLER_OUTPUTS)}
    elsewhere = np.ones(rear.values.size, dtype=bool)
    for start, stop in maps_at.items():
        elsewhere[start:stop] = False
    np.testing.assert_array_equal(rear.values[elsewhere], front.values[elsewhere])
    assert not np.array_equal(rear.values, front.values)
    Y, J = rear.shapes[pool.GAIN_U]
    gain = rear.values[rear.layout[pool.GAIN_U]: rear.layout[pool.GAIN_U] + Y * J].reshape(Y, J)
    for car, (loads, outputs) in zip((rear, front), maps):
        np.testing.assert_array_equal(car.gain_u, outputs @ gain @ loads)
    forget_built()
    fresh = model_form("fem", "impact")(cars[0], impact, 1e-4)
    assert fresh is not systems[0]
    np.testing.assert_array_equal(prepared_car(fresh, integrator, 1e-4, *maps[0]).values, rear.values)
    finer = prepared_car(systems[0], integrator, 5e-5, *maps[0])
    assert finer.layout is not rear.layout and finer.values[rear.layout[pool.COEFFICIENTS] + pool.DT] == 5e-5
    assert not np.array_equal(finer.values[rear.layout[pool.RESPONSE]:rear.layout[pool.TRANSLATION]],
                              rear.values[rear.layout[pool.RESPONSE]:rear.layout[pool.TRANSLATION]])


def test_a_small_run_is_one_chunk():
    """The first chunk is ``FIRST_CHUNK_WORK`` pool values × steps, at least ``FIRST_CHUNK`` steps."""
    assert first_chunk(10**9) == FIRST_CHUNK
    assert first_chunk(100) == FIRST_CHUNK_WORK // 100 > 5000


def test_forget_built_drops_what_a_cold_run_builds():
    """After ``forget_built`` (what bench_peer calls before each cold run) nothing built for a size survives: the builds,
    the factorised and prepared forms kept beside them, the sparsity patterns, the pool layouts; a run then builds them
    again and repeats the first run's numbers to the bit."""
    from femref.fem.reference import pattern
    from femref.impact.kernels import packing

    body = rod(HAMMER_M)
    cars = (Car("hammer", body, 2.2, {"center": 0.0}), Car("anvil", body, 0.0, {"center": 0.0}))
    impact = ImpactScene(cars, (Coupler("c1", 0, Coupling(LAWS["kelvin_voigt"], "bilateral", 0.0)),), (ModelRun("fem", ("fem", "fem")),),
                         end=0.02, integrator="newmark", rho_inf=1.0)

    def run():
        systems = [model_form("fem", "impact")(car, impact, 1e-4) for car in impact.cars]
        return solve_impact(impact, systems, 1e-4).couplers["c1"]["force"]

    first = run()
    assert pattern.cache_info().currsize and packing._layout.cache_info().currsize and len(packing._factorised_forms)
    forget_built()
    assert not pattern.cache_info().currsize and not packing._layout.cache_info().currsize
    assert not packing._factorised_forms and not packing._prepared
    np.testing.assert_array_equal(run(), first)
