"""The compiled impact loop against the readable reference loop: the same run, to 1e-9.

Every car fidelity (alone and mixed), both integrators, every coupler law with each kind of
contact (compression only with and without slack, bilateral with and without slack), a
three-car line whose second coupler closes through slack and whose first reopens and
recloses, a draft gear driven solid, and the friction table whose turning points force the
Gauss–Seidel fallback: each scene is stepped by both engines from the same car systems,
and every history (sensor displacements and accelerations, coupler forces and closures,
every energy account) agrees to 1e-9 of its own peak, with the same counters (steps,
Newton iterations, contact changes), status and car settings.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from femref.core.body import Body
from femref.core.profiles import Piecewise, Uniform
from femref.fem.build import FemSettings
from femref.impact import solve_impact
from femref.models import model_form
from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from reduced.couplers import Coupling, HystereticTable, KelvinVoigt, PowerLawGear, StandardLinearDraftGear
from support.reference_engine import solve_reference

RTOL = 1e-9


def hopper(gross: float, ea: float = 3.0e9, ca: float = 2.0e6) -> Body:
    """A 17 m car, 3500 kg/m over each 2 m end and the rest of ``gross`` between the bolsters."""
    inner = (gross - 14000.0) / 13.0
    mass = Piecewise((-6.5, 6.5), (3500.0, inner, 3500.0))
    return Body("rod", 8.5, mass, Uniform(ea), Uniform(ca), 8.5 * math.sqrt(gross / 17.0 / ea))


LAWS = {
    "kelvin_voigt": KelvinVoigt(4.0e7, 3.0e5),
    "power_law": PowerLawGear(2.52e6 / 0.074**2, 2.0, 5.0e4, (2.0e5, 1.0e6)),
    "draft_gear": StandardLinearDraftGear(4.0e8, 4.0e8, 1.7e7, 2.5e5, 0.05, 1.0e8),
    "table": HystereticTable.friction_gear_envelope(slack_in_table=False, switch_velocity=0.01),
}


def scene(
    fidelity: tuple[str, ...] = ("fem", "fem"),
    law: str = "kelvin_voigt",
    contact: str = "compression_only",
    slack: float = 0.0,
    tension_slack: float = 0.0,
    integrator: str = "generalized_alpha",
    speed: float = 2.2,
    end: float = 0.25,
    elements: int = 12,
    order: int = 2,
) -> ImpactScene:
    """Two or three cars in a line (the third at rest behind 0.2 m of slack), one law for every coupler."""
    cars = [Car("hammer", hopper(119e3), speed, {"center": 0.0, "front": 8.3}),
            Car("anvil", hopper(100e3), 0.0, {"rear": -8.3, "center": 0.0})]
    couplers = [Coupler("c1", 0, Coupling(LAWS[law], contact, slack, tension_slack))]
    if len(fidelity) == 3:
        cars.append(Car("third", hopper(80e3), 0.0, {"center": 0.0}))
        couplers.append(Coupler("c2", 1, Coupling(LAWS[law], "compression_only", 0.02)))
    return ImpactScene(
        tuple(cars), tuple(couplers), (ModelRun("run", fidelity),), end=end, integrator=integrator,
        rho_inf=1.0 if integrator == "newmark" else 0.8, fem=FemSettings(elements=elements, order=order), modal_modes=3,
    )


def both(impact: ImpactScene, dt: float):
    systems = [model_form(f, "impact")(car, impact, dt) for car, f in zip(impact.cars, impact.runs[0].fidelity)]
    return solve_impact(impact, systems, dt), solve_reference(impact, systems, dt)


def assert_same_run(compiled, reference) -> None:
    assert (compiled.status, compiled.message, compiled.steps) == (reference.status, reference.message, reference.steps)
    assert compiled.newton_iterations == reference.newton_iterations
    assert compiled.newton_iterations_max == reference.newton_iterations_max
    assert compiled.contact_changes == reference.contact_changes
    np.testing.assert_array_equal(compiled.time, reference.time)

    def close(a, b, what):
        scale = np.nanmax(np.abs(b)) if np.any(np.isfinite(b)) else 0.0
        np.testing.assert_allclose(a, b, rtol=0, atol=RTOL * max(scale, 1e-300), equal_nan=True, err_msg=what)

    for probe, values in reference.sensors.items():
        for key, value in values.items():
            close(compiled.sensors[probe][key], value, f"{probe} {key}")
    for name, values in reference.couplers.items():
        for key, value in values.items():
            close(compiled.couplers[name][key], value, f"{name} {key}")
    energy_scale = np.nanmax(reference.energy["total"])
    for key, value in reference.energy.items():
        np.testing.assert_allclose(compiled.energy[key], value, rtol=0, atol=RTOL * energy_scale, equal_nan=True, err_msg=key)
    assert compiled.energy_balance_error == pytest.approx(reference.energy_balance_error, rel=1e-6, abs=1e-13)
    for mine, theirs in zip(compiled.car_settings, reference.car_settings):
        assert mine.keys() == theirs.keys()
        if "epsilon" in theirs:
            assert mine["epsilon"] == pytest.approx(theirs["epsilon"], rel=1e-9)


@pytest.mark.parametrize(
    "fidelity",
    [("fem", "fem"), ("modal", "modal"), ("quasi_rigid", "quasi_rigid"), ("rigid", "rigid"), ("fem", "rigid"), ("quasi_rigid", "modal")],
    ids=lambda f: "+".join(sorted(set(f))),
)
@pytest.mark.parametrize("integrator", ["newmark", "generalized_alpha"])
def test_every_fidelity_steps_as_the_reference(fidelity, integrator):
    compiled, reference = both(scene(fidelity, integrator=integrator), 5e-4)
    assert reference.ok and reference.contact_changes >= 1  # engaged, then the cars separate
    assert_same_run(compiled, reference)


@pytest.mark.parametrize("order", [1, 2])
def test_fem_meshes_of_either_order_step_as_the_reference(order):
    compiled, reference = both(scene(elements=20, order=order), 2e-4)
    assert_same_run(compiled, reference)


@pytest.mark.parametrize(
    "law, contact, slack, tension_slack",
    [
        ("kelvin_voigt", "bilateral", 0.0, 0.0),
        ("kelvin_voigt", "bilateral", 0.01, 0.005),
        ("kelvin_voigt", "compression_only", 0.01, 0.0),
        ("power_law", "compression_only", 0.0, 0.0),
        ("power_law", "bilateral", 0.0, 0.0),
        ("draft_gear", "compression_only", 0.0, 0.0),
        ("draft_gear", "bilateral", 0.005, 0.005),
        ("table", "compression_only", 0.0119, 0.0),
    ],
)
@pytest.mark.parametrize("fidelity", ["fem", "quasi_rigid"])
def test_every_coupler_law_and_contact_steps_as_the_reference(law, contact, slack, tension_slack, fidelity):
    compiled, reference = both(scene((fidelity, fidelity), law, contact, slack, tension_slack, speed=3.0, end=0.35), 5e-4)
    assert_same_run(compiled, reference)


def test_a_gear_driven_solid_steps_as_the_reference():
    """5 m/s into a 50 mm stroke: the draft gear closes (its state crosses the stroke) and reopens."""
    compiled, reference = both(scene(("fem", "fem"), "draft_gear", speed=5.0, end=0.3), 2.5e-4)
    assert np.max(np.abs(reference.couplers["c1"]["closure"])) > 0.05
    assert_same_run(compiled, reference)


def test_the_friction_tables_turning_point_takes_the_fallback_in_both_engines():
    """The 1 cm/s switch band of the table law cannot be crossed by Newton on FE car ends: the
    bracketed Gauss–Seidel sweeps take over at the turning point (more iterations than Newton's
    12), in both engines alike."""
    compiled, reference = both(scene(("fem", "fem"), "table", slack=0.0119, speed=3.0, end=0.35), 5e-4)
    assert reference.newton_iterations_max > 12
    assert_same_run(compiled, reference)


@pytest.mark.parametrize("fidelity", [("fem", "fem", "fem"), ("rigid", "quasi_rigid", "modal")], ids=["fem", "mixed"])
def test_a_three_car_line_with_slack_steps_as_the_reference(fidelity):
    compiled, reference = both(scene(fidelity, speed=3.0, end=0.8), 1e-3)
    assert np.max(reference.couplers["c2"]["force"]) > 0.0  # the third car is reached through the slack
    assert_same_run(compiled, reference)


def test_output_stride_and_progress_chunks_give_the_same_histories():
    """Every 7th step recorded, stepped in chunks between progress calls: the same run as the
    reference's, and progress reaches the last step."""
    impact = scene()
    impact = ImpactScene(impact.cars, impact.couplers, impact.runs, end=impact.end, output_stride=7, fem=impact.fem)
    systems = [model_form(f, "impact")(car, impact, 5e-4) for car, f in zip(impact.cars, impact.runs[0].fidelity)]
    calls = []
    compiled = solve_impact(impact, systems, 5e-4, lambda done, total: calls.append((done, total)))
    assert_same_run(compiled, solve_reference(impact, systems, 5e-4))
    assert calls[-1] == (500, 500) and len(calls) >= 50 and calls == sorted(calls)


def test_a_coupler_iteration_that_fails_fails_alike():
    """A 20 kg car between two 2 t cars, friction gears both sides, at 2 m/s: the Gauss–Seidel sweeps
    crawl at 0.029 s (each gear moves the light car for the other). Both engines stop there with the
    same message, the histories up to the step before and NaN after, on the full time axis. (Until
    the scalar root learnt to follow a draft gear's state, the bilateral draft gear with slack of
    tests/impact/test_robustness.py failed here.)"""
    light = lambda mass: Body("rod", 8.5, Uniform(mass / 17.0), Uniform(3.0e9), Uniform(2.0e6), 8.5 * math.sqrt(mass / 17.0 / 3.0e9))  # noqa: E731
    table = HystereticTable.friction_gear_envelope()  # its 11.9 mm slack in the table
    impact = ImpactScene(
        (Car("a", light(2000.0), 2.0, {"center": 0.0}), Car("b", light(20.0), 0.0, {"center": 0.0}), Car("c", light(2000.0), 0.0, {"center": 0.0})),
        (Coupler("c1", 0, Coupling(table)), Coupler("c2", 1, Coupling(table))),
        (ModelRun("run", ("rigid",) * 3),), end=0.1, integrator="newmark", rho_inf=1.0,
    )
    compiled, reference = both(impact, 1e-3)
    assert reference.status == -1
    assert reference.message.startswith("coupler c1 did not converge at t = 0.029 s (step 29 of 100): Newton cycled and 200 Gauss–Seidel sweeps")
    assert_same_run(compiled, reference)
    force = compiled.couplers["c1"]["force"]
    assert compiled.time.size == 101 and np.all(np.isfinite(force[:29])) and np.all(np.isnan(force[29:]))


def test_a_second_run_reuses_each_prepared_car_and_repeats_the_first():
    """Runs of the same systems at the same step share each car's packed, factorised form (the
    kernels only read it: a second run is the first to the bit); another step prepares anew."""
    from femref.fem import INTEGRATORS
    from femref.impact.kernels.loop import line_plan
    from femref.impact.kernels.packing import prepared_car

    impact = scene(("fem", "quasi_rigid"), "draft_gear")
    systems = [model_form(f, "impact")(car, impact, 5e-4) for car, f in zip(impact.cars, impact.runs[0].fidelity)]
    first = solve_impact(impact, systems, 5e-4)
    integrator = INTEGRATORS[impact.integrator](impact.rho_inf)
    maps = line_plan(impact).maps
    prepared = [prepared_car(system, integrator, 5e-4, *m) for system, m in zip(systems, maps)]
    frozen = [car.values.copy() for car in prepared]
    second = solve_impact(impact, systems, 5e-4)
    assert [prepared_car(system, integrator, 5e-4, *m) for system, m in zip(systems, maps)] == prepared  # the same objects
    for car, values in zip(prepared, frozen):
        np.testing.assert_array_equal(car.values, values)
    for name, values in first.couplers.items():
        np.testing.assert_array_equal(second.couplers[name]["force"], values["force"])
    np.testing.assert_array_equal(second.energy["total"], first.energy["total"])
    assert prepared_car(systems[0], integrator, 2.5e-4, *maps[0]) is not prepared[0]


def test_one_blas_thread_limits_and_restores_every_blas_library():
    """Inside the context every BLAS library runs one thread; after it, each has its count back."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from femref.core.threads import one_blas_thread

    def blas_threads():
        return [info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"]

    with threadpool_limits(limits=2, user_api="blas"):
        before = blas_threads()
        assert before and set(before) == {2}, "numpy's BLAS is not visible to threadpoolctl"
        with one_blas_thread():
            assert blas_threads() == [1] * len(before)
        assert blas_threads() == before


@pytest.mark.parametrize("fidelity", ["fem", "modal", "quasi_rigid", "rigid"])
def test_a_prepared_car_holds_its_system_field_by_field(fidelity):
    """Packed straight into its values, a car reads back its system: the load, end and sensor maps as given, a
    second-order car's mass, damping and stiffness as row bands ``bands[k, i] = A[i, i + k − p]`` (from the dense
    matrices, entry by entry), a state-space car's transition; its state starts at zero. The layout kept per kind
    and sizes differs between cars of other sizes."""
    from femref.fem import INTEGRATORS
    from femref.impact.kernels import pool
    from femref.impact.kernels.loop import line_plan
    from femref.impact.kernels.packing import prepared_car
    from femref.impact.systems import StateSpaceSystem

    impact = scene((fidelity, "rigid"), elements=5)
    dt = 5e-4
    systems = [model_form(f, "impact")(car, impact, dt) for car, f in zip(impact.cars, impact.runs[0].fidelity)]
    integrator = INTEGRATORS[impact.integrator](impact.rho_inf)
    cars = [prepared_car(s, integrator, dt, *m) for s, m in zip(systems, line_plan(impact).maps)]
    car, system = cars[0], systems[0]
    packed = pool.CarPool(car.layout.reshape(1, -1), car.values, (car.shapes,))

    def dense(matrix):
        return matrix.toarray() if hasattr(matrix, "toarray") else np.asarray(matrix, dtype=float)

    if isinstance(system, StateSpaceSystem):
        n = system.transition.shape[0]
        S = system.sensor_displacement.shape[0]
        np.testing.assert_array_equal(pool.dense_of(packed.field(0, pool.TRANSITION), n, n), system.transition)
        np.testing.assert_array_equal(packed.field(0, pool.LOAD), system.input)
        np.testing.assert_array_equal(pool.dense_of(packed.field(0, pool.SENSOR_OUTPUTS), S, n), system.sensor_displacement)
        assert not np.any(packed.field(0, pool.X))
    else:
        n, p = system.dofs, int(car.layout[pool.BAND])
        for field, matrix in ((pool.MASS, system.mass), (pool.DAMPING, system.damping), (pool.STIFFNESS, system.stiffness)):
            full, bands = dense(matrix), packed.field(0, field)
            for k in range(2 * p + 1):
                for i in range(n):
                    j = i + k - p
                    assert bands[k, i] == (full[i, j] if 0 <= j < n else 0.0)
        np.testing.assert_array_equal(packed.field(0, pool.LOAD), dense(system.load_matrix))
        np.testing.assert_array_equal(packed.field(0, pool.SENSOR_OUTPUTS), system.sensor_outputs)
        np.testing.assert_array_equal(packed.field(0, pool.END_OUTPUTS), system.end_outputs)
        for field in (pool.U, pool.V, pool.A):
            assert not np.any(packed.field(0, field))
    if fidelity != "rigid":
        assert not np.array_equal(car.layout[pool.COUPLER_COUNT + 1:], cars[1].layout[pool.COUPLER_COUNT + 1:])
