"""Cars that bend in an impact: the coupler acts below the body's neutral axis, so a buff force also bends
and pitches the car (femref.models.fem.bending_system, femref.models.rigid.rigid_pitching_system).

The fem car's vertical response is checked against an independent solution: the exact free-free modes of
the homogeneous Euler-Bernoulli beam, driven by the end moment ``h · F1(t)`` of the fem run's own coupler
force, superposed (rigid pitch and 60 elastic modes, each stepped exactly for a force linear between samples).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.run.runner import run_scene
from femref.scene.build import scene_from_case

LENGTH, MASS_PER_LENGTH, EI, OFFSET = 17.0, 7000.0, 4.0e9, 0.6  # m, kg/m, N·m², m


def bending_case(offset: float, models=("fem",), elements: int = 16, end: float = 0.5, dt: float | None = None, viscosity: float = 4.0e6) -> dict:
    """The default scene with both cars homogeneous (17 m, 7 t/m) and bending (EI 4e9 N·m²: first mode 9.3 Hz),
    their couplers ``offset`` below the neutral axis at both ends."""
    data = default_scene_data()
    for car in data["cars"]:
        car["body"].update(length=LENGTH, mass_per_length=MASS_PER_LENGTH, bending_stiffness=EI, bending_viscosity=viscosity)
        car["coupler_offset"] = [offset, offset]
    data.update(models=list(models), estimators=[], fem={"elements": elements})
    data.pop("measurement", None)
    data["time"] = {"end": end, **({"dt": dt} if dt is not None else {})}
    return data


def run(data: dict):
    outcome = run_scene(scene_from_case(parse_case(data, source="<bending>")))
    assert all(r.ok for r in outcome.results), [r.message for r in outcome.results]
    return {r.model: r for r in outcome.results}


def test_zero_offset_gives_the_rod_exactly():
    """Offsets 0: the beam is not loaded — every coupler force and axial acceleration equals the rod car's
    to the last bit, and the vertical and pitch outputs are zero."""
    rod = default_scene_data()
    for car in rod["cars"]:
        car["body"].update(length=LENGTH, mass_per_length=MASS_PER_LENGTH)
    rod.update(models=["fem", "rigid"], estimators=[], fem={"elements": 16})
    rod.pop("measurement", None)
    plain, bent = run(rod), run(bending_case(0.0, ("fem", "rigid")))
    for model in ("fem", "rigid"):
        assert np.array_equal(plain[model].couplers["c1"]["force"], bent[model].couplers["c1"]["force"])
        for probe, outputs in plain[model].probes.items():
            assert np.array_equal(outputs["acceleration"], bent[model].probes[probe]["acceleration"])
            assert not np.any(bent[model].probes[probe]["vertical_acceleration"])
            assert not np.any(bent[model].probes[probe]["pitch_acceleration"])


def _free_free_beam(modes: int) -> tuple[np.ndarray, list]:
    """Angular frequencies (rad/s) and mass-normalised shapes ``(φ, φ')`` of x ∈ [−l, l] of the homogeneous
    free-free beam: ``cosh βL cos βL = 1``, ``ψ = cosh βy + cos βy − σ (sinh βy + sin βy)``, ``y = x + l``,
    ``σ = (cosh βL − cos βL)/(sinh βL − sin βL)``, ``∫ψ² dy = L``; the rigid pitch ``x/√J`` first.

    Evaluated without cancellation: ``cosh βy − σ sinh βy = ½(1 + σ) e^{−βy} + ½(1 − σ) e^{βy}`` with
    ``½(1 − σ) e^{βy} = (cos βL − sin βL − e^{−βL}) e^{β(y − L)} / (1 − e^{−2βL} − 2 e^{−βL} sin βL)``. The
    printed form loses the free end's boundary layer above the 12th mode (σ rounds to 1 while ``(1 − σ) e^{βy}``
    is of order one near ``y = L``): 0.5 % of the slope near the far end."""
    L, m = LENGTH, MASS_PER_LENGTH
    roots = [brentq(lambda b: math.cosh(b) * math.cos(b) - 1.0, (n + 0.5) * math.pi - 0.3, (n + 0.5) * math.pi + 0.3) for n in range(1, modes + 1)]
    J = m * L**3 / 12.0
    shapes = [(lambda x: x / math.sqrt(J), lambda x: np.ones_like(x) / math.sqrt(J))]
    omegas = [0.0]
    for root in roots:
        b = root / L
        decay = math.exp(-root)
        growth = (math.cos(root) - math.sin(root) - decay) / (1.0 - decay * decay - 2.0 * decay * math.sin(root))  # ½(1 − σ) e^{βL}
        sigma = 1.0 - 2.0 * growth * decay

        def phi(x, b=b, sigma=sigma, growth=growth, root=root):
            y = b * (x + 0.5 * L)
            exponentials = 0.5 * (1.0 + sigma) * np.exp(-y) + growth * np.exp(y - root)
            return (exponentials + np.cos(y) - sigma * np.sin(y)) / math.sqrt(m * L)

        def slope(x, b=b, sigma=sigma, growth=growth, root=root):
            y = b * (x + 0.5 * L)
            exponentials = -0.5 * (1.0 + sigma) * np.exp(-y) + growth * np.exp(y - root)
            return b * (exponentials - np.sin(y) - sigma * np.cos(y)) / math.sqrt(m * L)

        shapes.append((phi, slope))
        omegas.append(b * b * math.sqrt(EI / m))
    return np.array(omegas), shapes


def exact_vertical_response(t: np.ndarray, moment_load: np.ndarray, x: np.ndarray, viscosity: float,
                            modes: int = 60) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertical displacement (m), acceleration (m/s²) and pitch rate (rad/s), N × len(x), of the homogeneous
    Voigt free-free beam from rest under a generalised force ``moment_load(t)`` on the rotation at its rear
    end (N·m, linear between samples). A uniform Voigt viscosity keeps the modes apart (``C = (cI/EI) K``)::

        q̈_n + (cI/EI) ω_n² q̇_n + ω_n² q_n = φ_n'(−l) moment_load,
        w(x) = Σ φ_n(x) q_n,   a(x) = Σ φ_n(x) q̈_n,   θ̇(x) = Σ φ_n'(x) q̇_n
    """
    omegas, shapes = _free_free_beam(modes)
    h = float(t[1] - t[0])
    slope = np.diff(moment_load, append=moment_load[-1]) / h
    displacement, acceleration, pitch_rate = (np.zeros((t.size, x.size)) for _ in range(3))
    for omega, (phi, dphi) in zip(omegas, shapes):
        gain = float(dphi(np.array(-0.5 * LENGTH)))
        damping = viscosity / EI * omega**2
        a = np.array([[0.0, 1.0, 0.0, 0.0], [-omega**2, -damping, gain, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0]])
        e = expm(a * h)
        q, qs, rates, acc = np.zeros(2), np.empty(t.size), np.empty(t.size), np.empty(t.size)
        for k in range(t.size):
            qs[k], rates[k] = q
            acc[k] = gain * moment_load[k] - omega**2 * q[0] - damping * q[1]
            q = e[:2, :2] @ q + e[:2, 2] * moment_load[k] + e[:2, 3] * slope[k]
        displacement += np.outer(qs, phi(x))
        acceleration += np.outer(acc, phi(x))
        pitch_rate += np.outer(rates, dphi(x))
    return displacement, acceleration, pitch_rate


def test_fem_bending_converges_to_the_exact_free_free_beam():
    """The front car (anvil) takes the coupler force ``P`` at its rear end, ``h`` below its axis: an end
    moment. Its fem vertical displacement, vertical acceleration and pitch rate at the centre and front
    sensors against the exact modal solution under the fem's own ``P(t)`` (a linear 40 MN/m coupler, so the
    force starts without a jump; Voigt bending viscosity 4e6 N·m²·s; dt = 2e-5 s), after the integrator's
    start-up (t > 5 ms), from 2 to 16 Hermite elements. Measured orders: displacement 3.49, 3.47, 3.48
    (4.4e-6 of the peak at 16), acceleration 3.14, 3.66, 3.87 (1.6e-4), pitch rate 3.44, 3.06, 2.88
    (1.4e-4: the slope is one derivative down, ≈ h³ between the nodes).
    """
    x = np.array([0.0, 8.3])
    errors = []
    for elements in (2, 4, 8, 16):
        data = bending_case(OFFSET, elements=elements, end=0.12, dt=2e-5)
        data["couplers"][0]["law"] = {"kelvin_voigt": {"stiffness": 4.0e7}}
        fem = run(data)["fem"]
        t, force = fem.axes["time"], fem.couplers["c1"]["force"]
        w, a, rate = exact_vertical_response(t, OFFSET * force, x, 4.0e6)
        late = t > 0.005
        got_w, got_a, got_rate = (np.column_stack([fem.probes[f"anvil/{s}"][q] for s in ("center", "front")])
                                  for q in ("vertical_displacement", "vertical_acceleration", "pitch_rate"))
        errors.append([np.max(np.abs(got - exact)[late]) / np.max(np.abs(exact)) for got, exact in ((got_w, w), (got_a, a), (got_rate, rate))])
        print(f"{elements} elements: vertical displacement error {errors[-1][0]:.3e}, acceleration {errors[-1][1]:.3e}, pitch rate {errors[-1][2]:.3e}")
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))  # rows: refinements; columns: w, a, θ̇
    print("orders (displacement, acceleration, pitch rate)", np.round(orders, 2).tolist())
    assert np.all((orders[:, 0] >= 3.2) & (orders[:, 0] <= 4.2)), orders
    assert np.all((orders[:, 1] >= 2.8) & (orders[:, 1] <= 4.2)), orders
    assert np.all((orders[:, 2] >= 2.6) & (orders[:, 2] <= 4.0)), orders
    assert max(errors[-1]) < 3e-4


def test_bending_keeps_the_energy_balance_and_lowers_the_peak():
    """With the couplers 0.6 m below the axis the cars bend and pitch: the energy balances as well as with
    the couplers on the axis (measured 4.84e-5 and 4.90e-5 of the impact energy at the automatic step: the
    draft gear's own bookkeeping), and the coupler force peaks lower (the end moments add compliance at
    the coupler line)."""
    on_axis, below = run(bending_case(0.0))["fem"], run(bending_case(OFFSET))["fem"]
    assert below.settings["energy_balance_error"] <= 1.1 * on_axis.settings["energy_balance_error"] + 1e-9
    assert np.max(below.couplers["c1"]["force"]) < np.max(on_axis.couplers["c1"]["force"])
    assert np.max(np.abs(below.probes["anvil/center"]["vertical_acceleration"])) > 1.0


def test_rigid_car_pitches_under_the_end_moment():
    """The rigid car of a bending car heaves and pitches: for a symmetric car ``J θ̈ = h (F2 − F1)`` at every
    output step, ``J = m L³/12`` (1e-9 of the largest), and its centre does not heave (no vertical force)."""
    rigid = run(bending_case(OFFSET, models=("rigid",)))["rigid"]
    force = rigid.couplers["c1"]["force"]
    inertia = MASS_PER_LENGTH * LENGTH**3 / 12.0
    pitch = rigid.probes["anvil/center"]["pitch_acceleration"]
    assert np.max(np.abs(pitch - OFFSET * force / inertia)) <= 1e-9 * np.max(np.abs(pitch))
    assert np.max(np.abs(rigid.probes["anvil/center"]["vertical_acceleration"])) <= 1e-9 * np.max(np.abs(pitch))


def test_sensor_velocities_are_the_rates_of_the_displacements():
    """Every fidelity's sensor velocities — axial, vertical and the pitch rate — are the time derivatives of
    its sensor displacements: against their central differences (dt = 2.5e-5 s, after the first samples, where
    the modal car's massless static correction jumps with the load) within 2e-3 rms of each history (measured
    at most 1.3e-3 modal, at the coupler ends, where the force's kink at separation puts one sample off;
    2.1e-4 quasi-rigid, 4.7e-6 fem, 3.2e-8 rigid). The rigid car's pitch rate is the impulse of its end moment, ``J θ̇ = h ∫ P dt`` (1e-6 of the
    peak: the trapezoid rule is generalized-α's own velocity update for a rigid body)."""
    from scipy.integrate import cumulative_trapezoid

    results = run(bending_case(OFFSET, models=("fem", "modal", "quasi_rigid", "rigid"), dt=2.5e-5, end=0.2))
    for model, result in results.items():
        t = result.axes["time"]
        for probe, outputs in result.probes.items():
            for prefix, rate in (("", "velocity"), ("vertical_", "vertical_velocity"), ("pitch_", "pitch_rate")):
                velocity = outputs[rate][3:]
                difference = np.gradient(outputs[prefix + "displacement"], t)[3:]
                scale = np.sqrt(np.mean(velocity**2))
                if scale > 0.0:
                    assert np.sqrt(np.mean((difference - velocity) ** 2)) <= 2e-3 * scale, (model, probe, rate)
    rigid = results["rigid"]
    impulse = OFFSET * cumulative_trapezoid(rigid.couplers["c1"]["force"], rigid.axes["time"], initial=0.0) / (MASS_PER_LENGTH * LENGTH**3 / 12.0)
    pitch_rate = rigid.probes["anvil/front"]["pitch_rate"]
    assert np.max(np.abs(pitch_rate - impulse)) <= 1e-6 * np.max(np.abs(pitch_rate))


@pytest.mark.parametrize("model", ["fem", "modal", "quasi_rigid", "rigid"])
def test_both_engines_step_a_bending_car_alike(model):
    """The compiled loop and the readable reference loop step the same bending cars to the same histories
    (1e-7 of each quantity's largest value: round-off of a different summation order, carried over 1000 steps of
    a coupler iteration converged to 1e-10 of the force; measured up to 1.1e-8): no kernel of its own — only more sensor rows."""
    from femref.impact.solver import solve_impact
    from support.reference_engine import solve_reference
    from femref.models import REGISTRY

    data = bending_case(OFFSET, models=(model,), end=0.2)
    data["couplers"][0].update(vertical_offset=0.03, pivot_distance=1.8)  # an inclined coupler too
    scene = scene_from_case(parse_case(data, source="<bending>"))
    systems = [REGISTRY[model].car(car, scene, 2e-4) for car in scene.cars]
    fast, slow = solve_impact(scene, systems, 2e-4), solve_reference(scene, systems, 2e-4)
    assert fast.ok and slow.ok
    for probe, outputs in slow.sensors.items():
        for quantity, values in outputs.items():
            scale = max(np.max(np.abs(values)), 1e-300)
            assert np.max(np.abs(fast.sensors[probe][quantity] - values)) <= 1e-7 * scale, (probe, quantity)
    assert np.max(np.abs(fast.couplers["c1"]["force"] - slow.couplers["c1"]["force"])) <= 1e-9 * np.max(slow.couplers["c1"]["force"])


def test_modal_bending_car_converges_to_the_fem_car():
    """The modal car of a bending car — the rod's modes beside the beam's heave, pitch and lowest bending
    modes, each with its static correction — against the fem car (64 elements) on the front car's
    vertical acceleration: the rms error falls as modes are added (measured 30 %, 18 %, 5.5 %, 1.1 % with
    1, 2, 4, 8 bending modes), and the coupler force peaks within 0.2 % of the fem's."""
    fem = run(bending_case(OFFSET, elements=64))["fem"]
    reference = np.column_stack([fem.probes[f"anvil/{s}"]["vertical_acceleration"] for s in ("center", "front")])
    errors = []
    for modes in (1, 2, 4, 8):
        data = bending_case(OFFSET, models=("modal",), elements=64)
        data["modal"] = {"modes": modes}
        modal = run(data)["modal"]
        got = np.column_stack([np.interp(fem.axes["time"], modal.axes["time"], modal.probes[f"anvil/{s}"]["vertical_acceleration"]) for s in ("center", "front")])
        errors.append(float(np.sqrt(np.mean((got - reference) ** 2)) / np.sqrt(np.mean(reference**2))))
        peak = np.max(modal.couplers["c1"]["force"]) / np.max(fem.couplers["c1"]["force"]) - 1.0
        print(f"{modes} modes: vertical acceleration rms error {errors[-1]:.3e}, peak force {peak:+.2%}")
    assert all(b < a for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 0.03 and abs(peak) < 0.002


def test_the_measurement_chain_records_vertical_accelerations_and_pitch_rates_too():
    """With a measurement chain each sensor's vertical acceleration goes through it as the axial one does
    (same filter, rate and noise stream) and its pitch rate through the same filter and rate with the
    gyroscopes' own noise (``pitch_rate_noise``, rad/s, an independent stream: the accelerometers' records do
    not change when gyroscope noise is added); written under measured/<probe>/ and scored
    (``measured_vertical_acceleration_rms_error_max``, ``measured_pitch_rate_rms_error_max``)."""
    from femref.sensing.measurement import Measurement, measure

    data = bending_case(OFFSET, models=("fem", "modal"))
    data["measurement"] = {"rate": 1000.0, "lowpass": 100.0, "noise": 0.0}
    outcome = run_scene(scene_from_case(parse_case(data, source="<bending>")))
    fem = next(r for r in outcome.results if r.model == "fem")
    assert set(fem.measured_bending) == set(fem.probes)
    chain = Measurement(rate=1000.0, lowpass=100.0)
    for quantity in ("vertical_acceleration", "pitch_rate"):
        _, expected = measure(fem.axes["time"], fem.probes["anvil/front"][quantity], chain)
        assert np.allclose(fem.measured_bending["anvil/front"][quantity], expected, rtol=0.0, atol=1e-12 * np.max(np.abs(expected)))
        assert np.isfinite(outcome.scores["modal"][f"measured_{quantity}_rms_error_max"])
    data["measurement"].update(noise=0.05, pitch_rate_noise=1e-3)
    noisy = next(r for r in run_scene(scene_from_case(parse_case(data, source="<bending>"))).results if r.model == "fem")
    data["measurement"].update(pitch_rate_noise=0.0)
    quiet_gyros = next(r for r in run_scene(scene_from_case(parse_case(data, source="<bending>"))).results if r.model == "fem")
    assert np.array_equal(noisy.measured_bending["anvil/front"]["vertical_acceleration"], quiet_gyros.measured_bending["anvil/front"]["vertical_acceleration"])
    gyro_noise = noisy.measured_bending["anvil/front"]["pitch_rate"] - quiet_gyros.measured_bending["anvil/front"]["pitch_rate"]
    assert 0.9e-3 < np.std(gyro_noise) < 1.1e-3


def test_quasi_rigid_bending_car_matches_the_fem_car_to_order_epsilon_squared():
    """A free homogeneous car (l = 8 m, EI 4e9 N·m², cI 2e6 N·m²·s, couplers 0.6 m below the axis) under
    a smooth end-force pulse ``F1 = −A sin⁴(πt/T)``, ``T = π T_b/√ε`` (``T_b = l²√(m/EI)``, 1000 steps per
    pulse), stepped as the coupled solver steps a car: the quasi-rigid car's vertical and pitch
    accelerations and pitch rate against the fem car's (32 elements) during the pulse. Errors fall like ε²:
    vertical 3.9e-3, 2.0e-4, 1.2e-5 of the peak at ε = 0.16, 0.04, 0.01 (orders 2.1, 2.0); pitch
    9.7e-3, 5.3e-4 (order 2.1; at ε = 0.01 the fem's own 1e-4 shows); pitch rate 1.8e-3, 1.1e-4, 8.9e-6
    (orders 2.0, 1.8)."""
    from femref.core.body import Body
    from femref.core.profiles import Uniform
    from femref.fem.build import FemSettings
    from femref.fem.transient import Integrator
    from support.reference_engine import LinearCar, StateSpaceCar
    from femref.models.fem import fem_car
    from femref.models.quasi_rigid import quasi_rigid_car
    from femref.scene.impact import Car

    l, m, EA = 8.0, 6000.0, 2.0e9
    rod = Body("rod", l, Uniform(m), Uniform(EA), Uniform(0.0), l * math.sqrt(m / EA))
    beam = Body("beam", l, Uniform(m), Uniform(EI), Uniform(2.0e6), l * l * math.sqrt(m / EI))
    car = Car("car", rod, 0.0, {"center": 0.0, "front": 6.0}, bending=beam, coupler_offset=(OFFSET, OFFSET))
    sensors = 2
    errors = []
    for epsilon in (0.16, 0.04, 0.01):
        duration = math.pi * beam.wave_travel_time / math.sqrt(epsilon)
        dt = duration / 1000
        t = dt * np.arange(1501)
        force = -1.0e6 * np.where(t < duration, np.sin(np.pi * t / duration) ** 4, 0.0)
        loads = np.stack([force, np.zeros_like(force)], axis=1)
        cars = [StateSpaceCar(quasi_rigid_car(car, dt), 0.0, loads[0]),
                LinearCar(fem_car(car, FemSettings(elements=32, order=2)), Integrator.generalized_alpha(0.8), dt, 0.0, loads[0])]
        histories = []
        for stepper in cars:
            out = [np.concatenate([stepper.observe().acceleration, stepper.observe().velocity])]
            for load in loads[1:]:
                stepper.predict()
                stepper.advance(load)
                seen = stepper.observe()
                out.append(np.concatenate([seen.acceleration, seen.velocity]))
            histories.append(np.array(out))
        qr, fem = histories
        inside = t <= duration
        rows = 3 * sensors  # accelerations (axial, vertical, pitch), then the velocities
        vertical, pitch, pitch_rate = slice(sensors, 2 * sensors), slice(2 * sensors, rows), slice(rows + 2 * sensors, 2 * rows)
        errors.append(tuple(np.max(np.abs(qr[inside, part] - fem[inside, part])) / np.max(np.abs(fem[:, part])) for part in (vertical, pitch, pitch_rate)))
        print(f"ε = {epsilon}: vertical acceleration error {errors[-1][0]:.3e}, pitch {errors[-1][1]:.3e}, pitch rate {errors[-1][2]:.3e}")
    vertical_orders = [math.log(a[0] / b[0]) / math.log(4.0) for a, b in zip(errors, errors[1:])]
    pitch_order = math.log(errors[0][1] / errors[1][1]) / math.log(4.0)
    assert all(1.8 <= order <= 2.4 for order in vertical_orders), vertical_orders
    assert 1.8 <= pitch_order <= 2.4, pitch_order
    rate_orders = [math.log(a[2] / b[2]) / math.log(4.0) for a, b in zip(errors, errors[1:])]
    assert all(1.7 <= order <= 2.4 for order in rate_orders), rate_orders
    assert errors[-1][0] < 3e-5


@pytest.mark.parametrize(("stiffness", "beta"), [(4.0e6, 1e-6), (4.0e6, 1e4), (4.0e13, 1e-6), (4.0e13, 1e4)])
def test_extremes_of_bending_stiffness_and_viscosity(stiffness, beta):
    """Bending stiffness 1000× below and 10⁴× above a hopper's, each nearly elastic (β = 1e-6) and
    overdamped (β = 1e4; ``β = (cI/l²)/√(m EI)``), every fidelity: each run reaches the end with finite
    outputs and the fem energy balance of the rod's order (≤ 1e-4 of the impact energy). A very stiff
    car pitches as the rigid car does: the pitch rate its centre gains, ``∫ θ̈ dt``, within 1 % of
    ``∫ h P/J dt`` (the elastic one also rings at its high bending frequencies about that)."""
    l = 0.5 * LENGTH
    viscosity = beta * l * l * math.sqrt(MASS_PER_LENGTH * stiffness)
    data = bending_case(OFFSET, models=("fem", "modal", "quasi_rigid", "rigid"), end=0.3)
    for car in data["cars"]:
        car["body"].update(bending_stiffness=stiffness, bending_viscosity=viscosity)
    results = run(data)
    for result in results.values():
        for outputs in result.probes.values():
            assert all(np.all(np.isfinite(v)) for v in outputs.values())
    fem = results["fem"]
    assert fem.settings["energy_balance_error"] < 1e-4
    if stiffness > 1e12:
        force = fem.couplers["c1"]["force"]
        pitch = fem.probes["anvil/center"]["pitch_acceleration"]
        rigid = OFFSET * force / (MASS_PER_LENGTH * LENGTH**3 / 12.0)
        t = fem.axes["time"]
        gained, expected = np.trapezoid(pitch, t), np.trapezoid(rigid, t)
        assert abs(gained - expected) <= 0.01 * abs(expected)


def _inclined(offset: float, models=("rigid",)) -> dict:
    """:func:`bending_case` with the anvil's coupler line 30 mm above the hammer's, pivots 1.8 m apart."""
    data = bending_case(OFFSET, models=models)
    data["couplers"][0].update(vertical_offset=offset, pivot_distance=1.8)
    return data


def test_an_inclined_coupler_pushes_the_cars_vertically():
    """The anvil's coupler line 30 mm above the hammer's (s = 0.03/1.8): the compressed coupler pushes the
    anvil up and the hammer down by ``s P``. Rigid cars (symmetric, ``S = 0``): the anvil's centre heaves at
    ``s P/m`` and the hammer's at ``−s P/m`` at every output step (1e-9); lifting the anvil's rear end
    takes ``l s P`` off its nose-up pitch, ``J θ̈ = (h − l s) P``. fem: energy still balances, and the
    vertical response changes."""
    rigid = run(_inclined(0.03))["rigid"]
    s, mass, inertia, l = 0.03 / 1.8, MASS_PER_LENGTH * LENGTH, MASS_PER_LENGTH * LENGTH**3 / 12.0, 0.5 * LENGTH
    force = rigid.couplers["c1"]["force"]
    heave = rigid.probes["anvil/center"]["vertical_acceleration"]
    assert np.max(np.abs(heave - s * force / mass)) <= 1e-9 * np.max(np.abs(heave))
    assert np.max(np.abs(rigid.probes["hammer/center"]["vertical_acceleration"] + s * force / mass)) <= 1e-9 * np.max(np.abs(heave))
    pitch = rigid.probes["anvil/center"]["pitch_acceleration"]
    assert np.max(np.abs(pitch - (OFFSET - l * s) * force / inertia)) <= 1e-9 * np.max(np.abs(pitch))
    level = run(_inclined(0.0, ("fem",)))["fem"]
    fem = run(_inclined(0.03, ("fem",)))["fem"]
    assert fem.settings["energy_balance_error"] <= 1.1 * level.settings["energy_balance_error"] + 1e-9
    assert np.max(np.abs(fem.probes["anvil/center"]["vertical_acceleration"] - level.probes["anvil/center"]["vertical_acceleration"])) > 0.1


def test_a_level_coupler_with_pivots_changes_nothing():
    """``vertical_offset: 0`` with a pivot distance is the level coupler to the last bit."""
    plain, level = run(bending_case(OFFSET, models=("fem",)))["fem"], run(_inclined(0.0, ("fem",)))["fem"]
    assert np.array_equal(plain.couplers["c1"]["force"], level.couplers["c1"]["force"])
    assert np.array_equal(plain.probes["anvil/front"]["vertical_acceleration"], level.probes["anvil/front"]["vertical_acceleration"])


def test_the_model_choice_on_vertical_accelerations():
    """``--tolerance`` on ``vertical_acceleration`` climbs the ladder on the cars' bending: within 10 % the
    rigid car (no bending) and the quasi-rigid car (bending ε ≈ 0.7, out of range) are not chosen; the
    chosen run's estimate meets the tolerance and its error against fem at 128 elements is below it
    (measured: fem at 32 elements, estimate 7.0 %, 0.8 % from fem at 128 elements)."""
    from femref.choice import choose_model
    from femref.choice.estimates import output_distance

    data = bending_case(OFFSET, models=("fem",))
    scene = scene_from_case(parse_case(data, source="<bending>"))
    choice = choose_model(scene, 0.1, "vertical_acceleration")
    assert choice.met and choice.chosen_row.rung.family not in ("rigid", "quasi_rigid")
    assert choice.chosen_row.estimate <= 0.1
    finest = run(bending_case(OFFSET, models=("fem",), elements=128))["fem"]
    error = output_distance(choice.chosen_row.result, finest, "vertical_acceleration")
    print(f"chosen {choice.chosen}: estimate {choice.chosen_row.estimate:.3g}, error against fem at 128 elements {error:.3g}")
    assert error < 0.1
