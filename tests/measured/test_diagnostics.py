"""The data-quality diagnostics of an event (femref.sensing.diagnostics) against records whose faults are known:
fem impacts of the default scene through the measurement chain (the clean case: the fem, not the diagnostics,
made them), and the same records with a gain mismatch, an offset step or a drift added — each fault's effect on
the statistics in closed form."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.run import run_scene
from femref.scene.build import scene_from_case
from femref.sensing.diagnostics import GAIN_TOLERANCE, OFFSET_LIMIT, amplitude_spectrum, diagnose, end_agreement, end_sensors
from femref.sensing.noise_gate import quiet_corrected

QUIET = 0.2  # s of noise before the contact
NOISE = 0.05  # m/s², the default chain's


@pytest.fixture(scope="module")
def fem_event() -> SimpleNamespace:
    """The default scene's fem run through its measurement chain (1 kHz, 100 Hz, 0.05 m/s² noise), 0.2 s of that
    noise before the contact, 0.8 s in all: cars, time, records by probe and the trigger time."""
    data = default_scene_data()
    data["models"], data["estimators"], data["time"] = ["fem"], [], {"end": 0.8}
    fem = run_scene(scene_from_case(parse_case(data, source="<diagnostics>"))).results[0]
    assert fem.ok, fem.message
    t = np.asarray(fem.measured["time"])
    dt = float(t[1] - t[0])
    before = np.arange(-round(QUIET / dt), 0) * dt
    rng = np.random.default_rng(7)
    records = {}
    cars = []
    for car in data["cars"]:
        cars.append(SimpleNamespace(name=car["name"], sensors=car["sensors"]))
        for sensor in car["sensors"]:
            probe = f"{car['name']}/{sensor}"
            records[probe] = np.concatenate([rng.normal(0.0, NOISE, before.size), np.asarray(fem.measured[probe])])
    return SimpleNamespace(cars=cars, time=np.concatenate([before, t]) + QUIET, records=records, trigger=QUIET + 0.002)


def diagnosed(event: SimpleNamespace, records: dict[str, np.ndarray]):
    corrected, _, noise = quiet_corrected(event.time, records, event.trigger)
    return diagnose(event.cars, event.time, records, corrected, noise, event.trigger), corrected, noise


def test_the_end_sensors_are_the_rear_most_and_front_most():
    assert end_sensors(SimpleNamespace(sensors={"center": 0.0, "front": 8.3, "rear": -8.3})) == ("rear", "front")
    assert end_sensors(SimpleNamespace(sensors={"center": 0.0})) is None


def test_clean_records_raise_no_flag_and_the_ends_return_to_their_length(fem_event):
    """The fem's records: every car's two farthest sensors agree (the body rings about its length), the velocity
    difference after the contact a small share of the 1 % allowed; no offset, no drift."""
    found, _, _ = diagnosed(fem_event, fem_event.records)
    assert found.flags == ()
    assert {end.car for end in found.ends} == {"hammer", "anvil"}
    for end in found.ends:
        assert abs(end.velocity_change) > 0.5  # the impact changes each car's speed by ~1 m/s
        assert abs(end.elongation_rate) < 0.3 * GAIN_TOLERANCE * abs(end.velocity_change), end.basis


@pytest.mark.parametrize("gain", [0.03, -0.05])
def test_a_gain_mismatch_leaks_its_share_of_the_velocity_change(fem_event, gain):
    """The anvil's front sensor reads (1 + g) a: its ``ē`` moves by g × the front sensor's tail-mean velocity
    change (closed form: the added signal g a₂ integrates to g v₂(t)), and the car is flagged."""
    records = dict(fem_event.records)
    records["anvil/front"] = (1.0 + gain) * fem_event.records["anvil/front"]
    found, corrected, noise = diagnosed(fem_event, records)
    clean, clean_corrected, clean_noise = diagnosed(fem_event, fem_event.records)
    anvil = next(end for end in found.ends if end.car == "anvil")
    before = next(end for end in clean.ends if end.car == "anvil")
    dt = float(fem_event.time[1] - fem_event.time[0])
    velocity = np.cumsum(clean_corrected["anvil/front"]) * dt
    after = np.flatnonzero(fem_event.time >= fem_event.trigger)
    expected = gain * float(np.mean(velocity[after[-int(0.25 * after.size):]]))
    assert anvil.elongation_rate - before.elongation_rate == pytest.approx(expected, rel=0.02)
    assert not anvil.agree and any(flag.startswith("end sensors disagree: anvil") for flag in found.flags)
    assert abs(anvil.elongation_rate / anvil.velocity_change) == pytest.approx(abs(gain), rel=0.25)


def test_an_offset_that_moves_at_the_trigger_grows_the_elongation_rate(fem_event):
    """δ = 0.05 m/s² added to the hammer's front sensor from the trigger on (a zero that jumped with the shock): the
    pre-trigger median misses it and ``ė`` gains δ (t − t_trigger), whose tail mean is δ × the tail's mean time since
    the trigger."""
    delta = 0.05
    t = fem_event.time
    records = dict(fem_event.records)
    records["hammer/front"] = fem_event.records["hammer/front"] + np.where(t >= fem_event.trigger, delta, 0.0)
    found, _, _ = diagnosed(fem_event, records)
    clean, _, _ = diagnosed(fem_event, fem_event.records)
    dt = float(t[1] - t[0])
    after = np.flatnonzero(t >= fem_event.trigger)
    tail = after[-int(0.25 * after.size):]
    expected = delta * dt * float(np.mean(tail - after[0] + 1))
    hammer, before = (next(end for end in f.ends if end.car == "hammer") for f in (found, clean))
    assert hammer.elongation_rate - before.elongation_rate == pytest.approx(expected, rel=1e-9)
    assert not hammer.agree


def test_a_drift_before_the_trigger_is_measured_and_flagged_when_it_moves_the_velocity(fem_event):
    """A drift b added to a channel is recovered by the quiet window's slope within its standard error; 2 m/s³ moves
    the velocity over the 1 s window by b T²/2 ≈ 1 m/s ≫ 1 % of Δv (flagged), 0.002 m/s³ does not (not flagged)."""
    t = fem_event.time
    for drift, flagged in ((2.0, True), (0.002, False)):
        records = dict(fem_event.records)
        records["anvil/center"] = fem_event.records["anvil/center"] + drift * (t - t[0])
        found, _, _ = diagnosed(fem_event, records)
        zero = next(z for z in found.zeros if z.probe == "anvil/center")
        clean = next(z for z in diagnosed(fem_event, fem_event.records)[0].zeros if z.probe == "anvil/center")
        assert zero.drift - clean.drift == pytest.approx(drift, rel=1e-9)  # least squares is linear in the record
        assert abs(zero.drift - drift) < 4.0 * zero.drift_error
        assert zero.velocity_error == pytest.approx(0.5 * zero.drift * (t[-1] - t[0]) ** 2)
        assert zero.drift_flag is flagged and any(f.startswith("drift: anvil/center") for f in found.flags) is flagged


def test_an_offset_beyond_a_grade_is_flagged_and_a_small_one_is_not(fem_event):
    for offset, flagged in ((0.2 * 9.80665, True), (0.002 * 9.80665, False)):
        records = {p: a + offset for p, a in fem_event.records.items()}
        found, _, _ = diagnosed(fem_event, records)
        zero = next(z for z in found.zeros if z.probe == "hammer/center")
        assert zero.offset == pytest.approx(offset, abs=0.02)
        assert zero.offset_flag is flagged and (abs(zero.offset) > OFFSET_LIMIT) is flagged
        assert found.ends and all(end.agree for end in found.ends)  # the offset is removed before ė is formed


def test_the_amplitude_spectrum_of_a_half_sine_pulse():
    """``|A(f)|`` of a half-sine pulse ``sin(πt/T)`` on [0, T] against its transform
    ``2T/π |cos(πfT)| / |1 − 4f²T²|`` (A(0) = 2T/π, the pulse's area)."""
    T, dt = 0.1, 1.0e-4
    t = np.arange(0.0, 1.0, dt)
    pulse = np.where(t <= T, np.sin(np.pi * t / T), 0.0)
    f, amplitude = amplitude_spectrum(pulse, dt)
    exact = 2.0 * T / np.pi * np.abs(np.cos(np.pi * f * T)) / np.abs(1.0 - 4.0 * (f * T) ** 2 + 1e-300)
    low = f < 40.0
    low &= np.abs(f * T - 0.5) > 1e-9
    assert np.max(np.abs(amplitude[low] - exact[low])) < 1e-3 * (2.0 * T / np.pi)
    assert amplitude[0] == pytest.approx(2.0 * T / math.pi, rel=1e-6)


def test_a_car_with_one_sensor_has_no_end_check(fem_event):
    one = SimpleNamespace(name="hammer", sensors={"center": 0.0})
    corrected, _, noise = quiet_corrected(fem_event.time, fem_event.records, fem_event.trigger)
    assert end_agreement(one, fem_event.time, corrected, noise, fem_event.trigger) is None


def test_a_gap_leaves_its_car_unchecked_and_raises_nothing(fem_event):
    """NaN samples (a gap, flagged by the stream's quality tracker) in the anvil's front record: no end check for the
    anvil, the hammer's still made; the gap's channel still gets its zero from its finite quiet samples."""
    records = dict(fem_event.records)
    front = records["anvil/front"].copy()
    front[100:120] = np.nan  # before the trigger
    front[400:450] = np.nan  # during the contact
    records["anvil/front"] = front
    found, _, _ = diagnosed(fem_event, records)
    assert [end.car for end in found.ends] == ["hammer"] and found.flags == ()
    zero = next(z for z in found.zeros if z.probe == "anvil/front")
    assert math.isfinite(zero.offset) and math.isfinite(zero.drift)
