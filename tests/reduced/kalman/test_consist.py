"""The kalman model over a line of cars (reduced.kalman with n_c coupler forces).

Three checks against something independent of the generalised model: the two-car model through
the new path equals the outputs of the code before the generalisation (``data/two_car_baseline.npz``,
written by the one-coupler ``augmented_model``, ``estimate_force`` and ``forced_response`` at commit
4e417dc on the rod cars of ``tests/reduced/test_kalman.py``) to round-off; the couplers no instrumented
car feels are the ones named undetectable (PBH with the force components of the null vector); and a
three-car line's ``forced_response`` equals a direct integration of ``M q̈ + C q̇ + K q = B B_c P``
with the rigid motion included (scipy's ``solve_ivp``). The line's estimator: its O(dim²) smoother
equals the textbook Joseph-form filter and smoother on the same model and prior, and it recovers
two coupler forces through an uninstrumented middle car from a noisy record of that forced response.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal
from scipy.integrate import solve_ivp

from reduced.kalman import (
    CarDynamics,
    ConsistCars,
    CoupledCars,
    SensorFilter,
    augmented_model,
    estimate_force,
    car_mass_models,
    corner_models,
    estimate_force_with_variants,
    estimate_forces,
    estimate_forces_with_variants,
    forced_response,
    kalman_smoother,
    smoothed_responses,
    undetectable_couplers,
)
from tests.reduced.test_kalman import NOISE, STEP, cars, half_sine, record

BASELINE = Path(__file__).parent / "data" / "two_car_baseline.npz"
HALF_LENGTH = 8.5  # m
AXIAL_STIFFNESS = 3.0e9  # N
LOSS = 2.0e6 / 3.0e9  # s (Voigt: C = LOSS K)


def line_car(index: int, couplers: int, mass: float, sensors: tuple[float, ...], modes: int = 3) -> CarDynamics:
    """Car ``index`` of a line of free-free Voigt rods (rigid mode + ``modes`` axial modes, ``M = I``):
    coupler ``index − 1`` at its −l end (``F1 = −P``), coupler ``index`` at its +l end (``F2 = −P``)."""
    l = HALF_LENGTH
    wave_speed = math.sqrt(AXIAL_STIFFNESS * 2.0 * l / mass)
    j = np.arange(modes + 1)
    omega = j * math.pi * wave_speed / (2.0 * l)

    def shapes(x: np.ndarray) -> np.ndarray:
        s = math.sqrt(2.0 / mass) * np.cos(np.outer(x + l, j) * math.pi / (2.0 * l))
        s[:, 0] = 1.0 / math.sqrt(mass)
        return s

    coupler = np.zeros((2, couplers))
    if index > 0:
        coupler[0, index - 1] = -1.0
    if index < couplers:
        coupler[1, index] = -1.0
    stiffness = np.diag(omega**2)
    return CarDynamics(
        mass=np.eye(modes + 1),
        damping=LOSS * stiffness,
        stiffness=stiffness,
        load_map=np.column_stack([-shapes(np.array([-l]))[0], shapes(np.array([l]))[0]]),
        sensor_map=shapes(np.asarray(sensors, dtype=float)).reshape(len(sensors), modes + 1),
        coupler_load=coupler,
    )


def line(masses: tuple[float, ...], instrumented: tuple[bool, ...]) -> ConsistCars:
    n_c = len(masses) - 1
    return ConsistCars(tuple(line_car(i, n_c, m, (-8.3, 8.3) if on else ()) for i, (m, on) in enumerate(zip(masses, instrumented))))


def test_one_coupler_through_the_new_path_equals_the_code_before_it() -> None:
    before = np.load(BASELINE)
    plain = cars()
    as_line = ConsistCars((plain.rear, plain.front))
    for tag, model in (("plain", plain), ("plain", as_line), ("filtered", CoupledCars(plain.rear, plain.front, SensorFilter(100.0, 4)))):
        aug = augmented_model(model, STEP, NOISE)
        assert aug.couplers == 1 and aug.force_index == aug.transition.shape[0] - 1
        for name in ("system_matrix", "transition", "unit_process_covariance", "observation", "state_unit"):
            old = before[f"{tag}_{name}"]
            np.testing.assert_allclose(getattr(aug, name), old, rtol=0.0, atol=1e-13 * np.max(np.abs(old)), err_msg=f"{tag} {name}")
        np.testing.assert_allclose(aug.noise_input[:, 0], before[f"{tag}_noise_input"], rtol=1e-14)
        np.testing.assert_allclose(aug.quasi_static_direction, before[f"{tag}_quasi_static_direction"], rtol=1e-14, atol=1e-300)
        np.testing.assert_allclose(aug.prior_covariance(1e10, 1e5), before[f"{tag}_prior"], rtol=0.0,
                                   atol=1e-13 * np.max(np.abs(before[f"{tag}_prior"])))
    t, y = before["time"], before["accelerations"]
    for model in (plain, as_line):
        estimate = estimate_force(model, t, y, NOISE)
        np.testing.assert_allclose(estimate.force, before["force"], rtol=0.0, atol=1e-9 * np.max(before["force"]))
        np.testing.assert_allclose(estimate.force_std, before["force_std"], rtol=1e-9)
        assert estimate.force_rate == pytest.approx(float(before["force_rate"]), rel=1e-9)
    filtered = estimate_force(CoupledCars(plain.rear, plain.front, SensorFilter(100.0, 4)), t, y, NOISE, force_rate=5e10)
    np.testing.assert_allclose(filtered.force, before["filtered_force"], rtol=0.0, atol=1e-9 * np.max(before["filtered_force"]))
    np.testing.assert_allclose(filtered.force_std, before["filtered_force_std"], rtol=1e-9)
    _, _, force = record(plain, half_sine, duration=0.4)
    np.testing.assert_allclose(forced_response(as_line, t, force), before["response"], rtol=0.0, atol=1e-12 * np.max(np.abs(before["response"])))


def test_a_coupler_no_instrumented_car_feels_is_named_undetectable() -> None:
    masses = (119.0e3, 100.0e3, 90.0e3)
    middle_blind = augmented_model(line(masses, (True, False, True)), STEP, NOISE)
    assert middle_blind.couplers == 2 and middle_blind.force_slice == slice(18, 20)
    assert middle_blind.undetectable == () and undetectable_couplers(middle_blind) == ()
    middle_blind.stationary_covariance(1e10)  # detectable: the Riccati equation has its stabilising solution
    tail_blind = augmented_model(line(masses, (True, False, False)), STEP, NOISE)
    named = undetectable_couplers(tail_blind)
    assert len(named) == 1 and abs(named[0][0]) < 1e-9 and named[0][1] == (1,)
    head_blind = augmented_model(line(masses, (False, False, True)), STEP, NOISE)
    assert [found for _, found in undetectable_couplers(head_blind)] == [(0,)]
    # the middle car alone: squeezed equally from both ends it does not accelerate, so the common part
    # of P_1 and P_2 is unseen at λ = 0 and both couplers are named
    assert undetectable_couplers(augmented_model(line(masses, (False, True, False)), STEP, NOISE)) == ((0j, (0, 1)),)
    with pytest.raises(ValueError, match="force_slice"):
        _ = tail_blind.force_index


def test_forced_response_of_three_cars_matches_a_direct_integration() -> None:
    """Exact for forces linear between samples (first-order hold), so against an adaptive
    integration of the full cars (rigid modes kept) under the same interpolated forces; agreement
    to 1e-7 of the largest acceleration (the integrator at rtol 1e-10 reaches ≈ 1e-9)."""
    model = line((119.0e3, 100.0e3, 90.0e3), (True, False, True))
    t = STEP * np.arange(150)
    pulse = lambda t0, peak: peak * np.clip((t - t0) / 0.03, 0.0, None) ** 2 * np.exp(2.0 * (1.0 - np.clip((t - t0) / 0.03, 0.0, None)))  # noqa: E731
    force = np.column_stack([pulse(0.01, 1.5e6), pulse(0.03, 0.8e6)])
    expected = forced_response(model, t, force)
    sizes = [c.mass.shape[0] for c in model.cars]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    n = offsets[-1]

    def rates(time: float, state: np.ndarray) -> np.ndarray:
        p = np.array([np.interp(time, t, force[:, c]) for c in range(force.shape[1])])
        q, v = state[:n], state[n:]
        out = np.empty(2 * n)
        out[:n] = v
        for car, a, b in zip(model.cars, offsets[:-1], offsets[1:]):
            out[n + a : n + b] = np.linalg.solve(car.mass, car.load_map @ car.coupler_map @ p - car.damping @ v[a:b] - car.stiffness @ q[a:b])
        return out

    solution = solve_ivp(rates, (t[0], t[-1]), np.zeros(2 * n), method="DOP853", t_eval=t, rtol=1e-10, atol=1e-14, max_step=STEP / 4)
    assert solution.success
    rows = []
    for k in range(t.size):
        accel = rates(t[k], solution.y[:, k])[n:]
        rows.append(np.concatenate([car.sensor_map @ accel[a:b] for car, a, b in zip(model.cars, offsets[:-1], offsets[1:])]))
    direct = np.array(rows)
    assert direct.shape == expected.shape == (t.size, 4)
    np.testing.assert_allclose(expected, direct, rtol=0.0, atol=1e-7 * np.max(np.abs(direct)))
    assert np.max(np.abs(direct)) > 1.0  # the forces move the cars


def line_record(model: ConsistCars, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """``(t, P (N × 2))``: two smooth pulses, the second coupler's 20 ms later and smaller."""
    t = STEP * np.arange(steps)

    def pulse(t0: float, peak: float) -> np.ndarray:
        s = np.clip((t - t0) / 0.03, 0.0, None)
        return peak * s**2 * np.exp(2.0 * (1.0 - s))

    return t, np.column_stack([pulse(0.05, 1.5e6), pulse(0.07, 0.9e6)])


def test_the_line_estimator_equals_the_joseph_filter_and_smoother() -> None:
    """Three cars, middle one uninstrumented, two forces at a fixed force rate: mean and std of each
    force to 1e-9 of the peak / relative, log-likelihood to 1e-7 absolute, against ``kalman_smoother``
    with the prior ``P∞ + σ_0² U Uᵀ``."""
    model = line((119.0e3, 100.0e3, 90.0e3), (True, False, True))
    t, force = line_record(model, 300)
    y = forced_response(model, t, force) + NOISE * np.random.default_rng(3).standard_normal((t.size, 4))
    rate, force_std0 = 5.0e10, 1.0e4
    fast = estimate_forces(model, t, y, NOISE, force_rate=rate, initial_force_std=force_std0)
    aug = augmented_model(model, STEP, NOISE)
    p0 = aug.prior_covariance(rate, force_std0)
    reference = kalman_smoother(aug.transition, aug.process_covariance(rate), aug.observation, np.diag(aug.noise_std**2),
                                np.zeros(p0.shape[0]), p0, y)
    assert len(fast) == 2
    for c, i in enumerate(range(aug.force_slice.start, aug.force_slice.stop)):
        unit = aug.state_unit[i]
        assert np.max(np.abs(fast[c].force - reference.smoothed_mean[:, i] * unit)) <= 1e-9 * 1.5e6
        assert np.max(np.abs(fast[c].force_std / (np.sqrt(reference.smoothed_covariance[:, i, i]) * unit) - 1.0)) <= 1e-9
        assert fast[c].log_likelihood == pytest.approx(reference.log_likelihood, rel=1e-12, abs=1e-7)


def test_two_forces_through_an_uninstrumented_middle_car() -> None:
    """The force rate searched (one level for both couplers): each coupler's peak within 1 % of the
    truth, inside its 95 % band at the peak, the status ok."""
    model = line((119.0e3, 100.0e3, 90.0e3), (True, False, True))
    t, force = line_record(model, 400)
    y = forced_response(model, t, force) + NOISE * np.random.default_rng(5).standard_normal((t.size, 4))
    estimates = estimate_forces(model, t, y, NOISE)
    for c, estimate in enumerate(estimates):
        truth = float(np.max(force[:, c]))
        assert estimate.status == "ok"
        assert abs(estimate.peak_force / truth - 1.0) <= 0.01
        assert estimate.peak_lower <= float(force[np.argmax(estimate.force), c]) <= estimate.peak_upper
    assert estimates[0].force_rate == estimates[1].force_rate


def test_line_variants_cover_stiffer_cars_per_coupler() -> None:
    """The record made by cars 10 % stiffer in frequency than declared (``K × 1.21``): with the corners
    (frequency ± 15 %, damping × 0.6 and 1.6) at the nominal's force-rate level and a 2 % mass tolerance,
    each coupler's envelope holds its true peak and contains the nominal's band; one model alone gives
    back :func:`estimate_forces`."""
    declared = line((119.0e3, 100.0e3, 90.0e3), (True, False, True))
    stiffer = ConsistCars(tuple(CarDynamics(c.mass, c.damping, 1.21 * c.stiffness, c.load_map, c.sensor_map, c.coupler_load)
                                for c in declared.cars))
    t, force = line_record(declared, 400)
    y = forced_response(stiffer, t, force) + NOISE * np.random.default_rng(8).standard_normal((t.size, 4))
    models = [declared, *corner_models(declared, 0.15, (0.6, 1.6))]
    assert len(models) == 5 and all(isinstance(m, ConsistCars) and m.couplers == 2 for m in models)
    banded = estimate_forces_with_variants(models, t, y, NOISE, variant_force_rate="nominal", mass_tolerance=0.02)
    alone = estimate_forces(declared, t, y, NOISE, noise_scale="estimated")
    for c, band in enumerate(banded):
        assert band.status == "ok" and len(band.estimates) == 5
        truth = float(np.max(force[:, c]))
        assert not band.nominal.peak_lower <= truth <= band.nominal.peak_upper  # the declared cars alone read ≈ 5 % low
        assert band.peak_lower <= truth <= band.peak_upper
        assert np.all(band.lower <= band.nominal.lower) and np.all(band.upper >= band.nominal.upper)
        np.testing.assert_array_equal(band.force, alone[c].force)
    with pytest.raises(ValueError, match="one coupler force"):
        estimate_force_with_variants(models, t, y, NOISE)


def test_filtered_line_is_the_butterworth_of_its_accelerations() -> None:
    """Three cars, every channel through a 100 Hz 4th-order anti-alias filter: the model's samples
    equal scipy's analogue Butterworth (``signal.butter(analog=True)``, ``lsim``) run on the
    unfiltered accelerations at a tenth of the step, to 1e-4 of the largest sample (lsim's first-order
    hold of the accelerations there is good to ≈ 2e-5)."""
    unfiltered = line((119.0e3, 100.0e3, 90.0e3), (True, False, True))
    filtered = ConsistCars(unfiltered.cars, SensorFilter(100.0, 4))
    t, force = line_record(unfiltered, 200)
    fine = STEP / 10.0 * np.arange(10 * (t.size - 1) + 1)
    fine_force = np.column_stack([np.interp(fine, t, force[:, c]) for c in range(2)])
    acceleration = forced_response(unfiltered, fine, fine_force)
    b, a = signal.butter(4, 2.0 * math.pi * 100.0, analog=True)
    expected = np.column_stack([signal.lsim((b, a), acceleration[:, c], fine)[1] for c in range(4)])[::10]
    got = forced_response(filtered, t, force)
    np.testing.assert_allclose(got, expected, rtol=0.0, atol=1e-4 * np.max(np.abs(expected)))


def test_a_line_is_validated() -> None:
    car = line_car(0, 2, 1.0e5, (8.3,))
    with pytest.raises(ValueError, match="same couplers"):
        ConsistCars((car, line_car(1, 1, 1.0e5, (8.3,))))
    with pytest.raises(ValueError, match="no car is instrumented"):
        ConsistCars((line_car(0, 1, 1.0e5, ()), line_car(1, 1, 1.0e5, ())))
    with pytest.raises(ValueError, match="one coupler between two cars"):
        CoupledCars(car, line_car(1, 2, 1.0e5, (8.3,)))
    model = line((1.0e5, 1.0e5, 1.0e5), (True, True, True))
    t = STEP * np.arange(10)
    with pytest.raises(ValueError, match="estimates one coupler force"):
        estimate_force(model, t, np.zeros((10, 6)), NOISE)
    with pytest.raises(ValueError, match="10 samples × 2 couplers"):
        forced_response(model, t, np.zeros(10))


def test_each_cars_mass_corners_sum_to_the_common_scale() -> None:
    """Every mass and the forces scaled by one factor leave the accelerations unchanged, so to first order the
    shifts of one car's mass at a time add up to the common scale's ``m P``: ``Σ_i δ_i⁺ = m P`` within 2 % of
    ``m max P`` at m = 1e-3 (the remainder O(m²)). The widened band contains the common-scale band, and in
    this line the per-car shifts do not all share a sign, so it is wider somewhere."""
    model = line((119.0e3, 100.0e3, 90.0e3), (True, True, True))
    t, force = line_record(model, 300)
    y = forced_response(model, t, force) + NOISE * np.random.default_rng(11).standard_normal((t.size, 6))
    m = 1.0e-3
    nominal = estimate_forces(model, t, y, NOISE, noise_scale="estimated")
    level = nominal[0].force_rate / nominal[0].noise_scale**2
    pairs = car_mass_models(model, m)
    assert len(pairs) == 3 and all(len(pair) == 2 for pair in pairs)
    shifted = [estimate_forces(pair[1], t, y, NOISE, noise_scale="estimated", force_rate=level) for pair in pairs]
    for c in range(2):
        total = sum(s[c].force - nominal[c].force for s in shifted)
        assert np.max(np.abs(total - m * nominal[c].force)) <= 0.02 * m * np.max(nominal[c].force)
    plain = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", mass_tolerance=0.05)
    wide = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", mass_tolerance=0.05, car_mass_corners=True)
    for p, w in zip(plain, wide):
        np.testing.assert_array_equal(w.force, p.force)
        assert np.all(w.lower <= p.lower) and np.all(w.upper >= p.upper)
        assert w.peak_lower <= p.peak_lower and w.peak_upper >= p.peak_upper
        assert np.max(w.upper - p.upper) > 1e-3 * np.max(p.force) or np.max(p.lower - w.lower) > 1e-3 * np.max(p.force)
        assert len(w.variant_status) == 1 + 6


def test_smoothed_responses_are_the_estimator_on_forced_samples() -> None:
    """One filter model and one stationary filter for several prescribed forces give what ``estimate_forces`` gives
    on each one's ``forced_response`` at the same force rate, to 1e-12 of the force (filtered line, middle car blind)."""
    model = ConsistCars(line((119.0e3, 100.0e3, 90.0e3), (True, False, True)).cars, SensorFilter(100.0, 4))
    t, force = line_record(model, 300)
    forces = [force, force[:, ::-1] * 0.5, np.column_stack([np.where(t > 0.1, 1.0e6, 0.0), np.zeros(t.size)])]
    got = smoothed_responses(model, t, forces, NOISE, 5.0e10)
    for f, g in zip(forces, got):
        expected = estimate_forces(model, t, forced_response(model, t, f), NOISE, force_rate=5.0e10, nis_range=(1e-300, math.inf))
        for c in range(2):
            np.testing.assert_allclose(g[:, c], expected[c].force, rtol=0.0, atol=1e-12 * np.max(np.abs(f)))
