"""The coupled impact solver: closed forms, convergence orders, energy, contact, extremes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from femref.models import model_form
from femref.core.profiles import Uniform
from femref.core.body import Body
from femref.fem.build import FemSettings
from reduced.couplers import Coupling, KelvinVoigt
from reduced.rigid import ImpactPair, kelvin_voigt_impact
from support.failures import coupler_iteration_fails_at
from support.reference_engine import reference_cars, step_reference

HAMMER_M, ANVIL_M, LENGTH = 7000.0, 5882.0, 17.0


def rod(length: float = LENGTH, m: float = HAMMER_M, ea: float = 3.0e9, ca: float = 2.0e6) -> Body:
    return Body("rod", length / 2, Uniform(m), Uniform(ea), Uniform(ca), length / 2 * math.sqrt(m / ea))


def two_cars(
    fidelity: str = "fem",
    *,
    speed: float = 2.2,
    stiffness: float = 4.0e7,
    damping: float = 3.0e5,
    contact: str = "bilateral",
    slack: float = 0.0,
    elements: int = 16,
    order: int = 2,
    integrator: str = "newmark",
    end: float = 0.2,
    anvil_m: float = ANVIL_M,
    ea: float = 3.0e9,
) -> ImpactScene:
    cars = (
        Car("hammer", rod(m=HAMMER_M, ea=ea), speed, {"center": 0.0, "front": 8.5}),
        Car("anvil", rod(m=anvil_m, ea=ea), 0.0, {"rear": -8.5, "center": 0.0}),
    )
    couplers = (Coupler("c1", 0, Coupling(KelvinVoigt(stiffness, damping), contact, slack)),)
    return ImpactScene(
        cars,
        couplers,
        (ModelRun(fidelity, (fidelity, fidelity)),),
        end=end,
        integrator=integrator,
        rho_inf=1.0 if integrator == "newmark" else 0.8,
        fem=FemSettings(elements=elements, order=order),
    )


def run(scene: ImpactScene, dt: float):
    """Build the cars of the scene's first run by their models and step them with the reference loop:
    ``(response, cars)`` (the compiled loop is held to it in tests/impact/test_compiled.py)."""
    systems = [model_form(f, "impact")(car, scene, dt) for car, f in zip(scene.cars, scene.runs[0].fidelity)]
    cars = reference_cars(scene, systems, dt)
    return step_reference(scene, cars, dt), cars


def observed_orders(errors: list[float]) -> np.ndarray:
    """log2 of successive error ratios (halved parameter each time)."""
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


@pytest.mark.parametrize("contact", ["bilateral", "compression_only"])
def test_rigid_cars_converge_to_the_two_mass_closed_form_at_second_order(contact):
    """Rigid cars + Kelvin–Voigt coupler = docs/formulas.md §A1 (reduced.rigid): error ∝ dt², 8e-4 at dt = 2 ms."""
    pair = ImpactPair(HAMMER_M * LENGTH, ANVIL_M * LENGTH, 2.2)
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        response, _ = run(two_cars("rigid", contact=contact), dt)
        exact = kelvin_voigt_impact(pair, 4.0e7, 3.0e5, response.time, contact)
        force = response.couplers["c1"]["force"]
        errors.append(np.max(np.abs(force - exact.coupler_force)) / np.max(exact.coupler_force))
    assert errors[0] < 1e-3
    assert np.all(np.abs(observed_orders(errors) - 2.0) < 0.05)


@pytest.mark.parametrize("order, expected", [(1, 2.0), (2, 4.0)])
def test_fem_impact_converges_in_element_count_at_the_element_order(order, expected):
    """Coupler force history, P1 → 2 and P2 → 4 (successive refinements at a fixed step).

    The coupler has no dashpot here: a dashpot makes the force jump at contact and the
    wave front it launches caps every element order near 1.5 (measured: P1 1.45–1.75,
    P2 0.4–1.6 over 4…64 elements).
    """
    forces = []
    for elements in (4, 8, 16, 32):
        response, _ = run(two_cars("fem", damping=0.0, elements=elements, order=order, end=0.15), 1e-4)
        forces.append(response.couplers["c1"]["force"])
    scale = rms(forces[-1])
    differences = [rms(a - b) / scale for a, b in zip(forces[:-1], forces[1:])]
    orders = observed_orders(differences)
    assert abs(orders[-1] - expected) < 0.15, orders


@pytest.mark.parametrize("integrator", ["newmark", "generalized_alpha"])
def test_fem_impact_converges_in_time_step_at_second_order(integrator):
    forces = []
    for dt in (4e-4, 2e-4, 1e-4, 5e-5):
        response, _ = run(two_cars("fem", damping=0.0, elements=16, integrator=integrator, end=0.15), dt)
        forces.append(response.couplers["c1"]["force"])
    scale = rms(forces[-1])
    differences = [rms(coarse - fine[::2]) / scale for coarse, fine in zip(forces[:-1], forces[1:])]
    orders = observed_orders(differences)
    assert abs(orders[-1] - 2.0) < 0.15, orders


@pytest.mark.parametrize("fidelity", ["fem", "rigid"])
@pytest.mark.parametrize("contact", ["bilateral", "compression_only"])
def test_energy_balances_to_round_off_with_linear_couplers_and_average_acceleration(fidelity, contact):
    response, cars = run(two_cars(fidelity, contact=contact, end=0.3), 2e-4)
    assert response.energy_balance_error < 1e-6
    if contact == "compression_only":
        assert response.contact_changes == 1  # engaged at contact (dashpot), separates once
    energy = response.energy
    assert energy["coupler_dissipated"][-1] > 0.0
    assert (energy["body_dissipated"][-1] > 0.0) == (fidelity == "fem")  # a rigid body has no viscosity to work


def test_generalized_alpha_dissipates_a_little_numerically():
    """ρ∞ = 0.8 damps the top of the mesh spectrum: the balance is not exact, but close."""
    response, _ = run(two_cars("fem", integrator="generalized_alpha"), 2e-4)
    assert 1e-9 < response.energy_balance_error < 1e-3


def three_rigid_cars(damping: float) -> ImpactScene:
    cars = tuple(Car(name, rod(), speed, {"center": 0.0}) for name, speed in (("a", 2.0), ("b", 0.0), ("c", 0.0)))
    couplers = (
        Coupler("ab", 0, Coupling(KelvinVoigt(4.0e7, damping), "compression_only")),
        Coupler("bc", 1, Coupling(KelvinVoigt(4.0e7, damping), "compression_only", slack=0.3)),
    )
    return ImpactScene(cars, couplers, (ModelRun("rigid", ("rigid",) * 3),), end=3.0, integrator="newmark", rho_inf=1.0)


def test_compression_only_never_pulls_and_a_reopened_gap_recloses():
    """Car a strikes b, b strikes c through slack; the dashpots leave a moving on, so a strikes b again."""
    response, cars = run(three_rigid_cars(damping=6.0e5), 5e-4)
    force = response.couplers["ab"]["force"]
    assert np.min(force) >= 0.0 and np.min(response.couplers["bc"]["force"]) >= 0.0
    contact = force > 0.0
    onsets = np.count_nonzero(contact[1:] & ~contact[:-1]) + int(contact[0])
    assert onsets >= 2, "the a–b gap opens and closes again"
    assert response.contact_changes >= 4
    momentum = sum(car.momentum() for car in cars)
    assert momentum == pytest.approx(2.0 * HAMMER_M * LENGTH, rel=1e-12)
    assert response.energy_balance_error < 1e-6


def test_speed_zero_moves_nothing():
    response, _ = run(two_cars("fem", speed=0.0), 1e-3)
    for probe in response.sensors.values():
        assert np.all(probe["acceleration"] == 0.0) and np.all(probe["displacement"] == 0.0)
    assert np.all(response.couplers["c1"]["force"] == 0.0)
    assert response.energy_balance_error == 0.0


def test_slack_larger_than_the_travel_never_touches():
    """0.5 m of slack at 2.2 m/s for 0.2 s: the hammer travels 0.44 m and never reaches the anvil."""
    response, _ = run(two_cars("fem", contact="compression_only", slack=0.5), 1e-3)
    assert np.all(response.couplers["c1"]["force"] == 0.0)
    hammer = response.sensors["hammer/center"]["displacement"]
    np.testing.assert_allclose(hammer, 2.2 * response.time, rtol=1e-12, atol=1e-15)
    assert np.all(response.sensors["anvil/center"]["displacement"] == 0.0)


@pytest.mark.parametrize(
    "case",
    [
        dict(speed=10.0),
        dict(stiffness=1.0e5, damping=0.0),
        dict(stiffness=1.0e10, damping=1.0e6),
        dict(anvil_m=HAMMER_M * 1e-3),
    ],
    ids=["10 m/s", "k=1e5", "k=1e10", "mass ratio 1e-3"],
)
@pytest.mark.parametrize("fidelity", ["fem", "rigid"])
def test_extremes_stay_finite_and_physical(case, fidelity):
    """No NaN, momentum conserved, the peak force within 10 % of the rigid v√(k M_eff) bound (or below it)."""
    scene = two_cars(fidelity, contact="compression_only", **case)
    speed = case.get("speed", 2.2)
    k = case.get("stiffness", 4.0e7)
    dt = min(1e-4, scene.contact_time() / 200)
    response, cars = run(scene, dt)
    force = response.couplers["c1"]["force"]
    assert np.all(np.isfinite(force)) and np.min(force) >= 0.0
    assert response.energy_balance_error < 1e-6
    m1, m2 = (car.mass for car in scene.cars)
    momentum = sum(car.momentum() for car in cars)
    assert momentum == pytest.approx(m1 * speed, rel=1e-9)
    bound = speed * math.sqrt(k * m1 * m2 / (m1 + m2))
    assert 0.0 < np.max(force) < 1.1 * bound + case.get("damping", 3.0e5) * speed



def test_a_step_that_does_not_converge_ends_the_run_with_its_history(monkeypatch):
    """Like solve_ivp: a coupler iteration that fails at step 40 gives status −1, a message naming the
    coupler and the time, the histories up to step 39 and NaN after, on the full time axis."""
    coupler_iteration_fails_at(monkeypatch, 40)
    dt = 1e-3
    response, _ = run(two_cars("rigid", end=0.1), dt)
    assert response.status == -1 and not response.ok
    assert response.message == "coupler c1 did not converge at t = 0.04 s (step 40 of 100): synthetic: Newton cycled"
    assert response.steps == 39
    assert response.time.size == 101 and response.time[-1] == pytest.approx(0.1)
    force = response.couplers["c1"]["force"]
    assert np.all(np.isfinite(force[:40])) and np.all(np.isnan(force[40:]))
    assert np.all(np.isnan(response.sensors["anvil/center"]["acceleration"][40:]))
    assert math.isfinite(response.energy_balance_error)
