"""The closing speed with its interval (femref.sensing.findings): against the exact Kelvin-Voigt pair, and on
fem impacts of every coupler law of the case schema recorded through the measurement chain, read back through
measured cases; the speed a user gives replacing it; the calibrated range checked on the interval."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import h5py
import numpy as np
import pytest
import yaml

from femref.case import CaseError, load_case
from femref.case.defaults import default_scene_data
from support.measured import write_events
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from femref.sensing.calibration import Calibration
from femref.sensing.findings import RESIDUAL_STROKE, from_force
from support.measured import simulated_event, yard_case_with_inverse_estimators

LAWS = {
    "kelvin_voigt": {"kelvin_voigt": {"stiffness": 2.0e7, "damping": 4.0e5}},  # ζ ≈ 0.19 on the yard's cars
    "draft_gear": None,  # the default scene's standard-linear gear
    "table": {"table": {"closure": [0.0, 0.0119, 0.0188, 0.0495, 0.125], "loading": [0.0, 1.0e4, 1.2e5, 6.8e5, 1.35e6],
                        "unloading": [0.0, 3.0e3, 3.6e4, 2.04e5, 4.05e5], "damping": 2.0e4}},  # cases/impact_coupled.yaml's gear
    "power_law": {"power_law": {"stiffness": 2.52e6 / 0.074**2, "exponent": 2.0, "damping": [2.0e5]}},  # M-901E-like P = c δ²
    "friction_gear": {"friction_gear": {"loading": {"cubic": {"linear_stiffness": 1.5e7, "cubic_stiffness": 4.0e9}}, "unloading_ratio": 0.4,
                                        "solid_closure": 0.08, "solid_stiffness": 1.0e9}},  # solid at 3.25 MN: above about 2 m/s
}


def _kelvin_voigt_pair(zeta: float, speed: float, reduced_mass: float = 5.0e4, omega: float = 20.0):
    """The exact compression-only Kelvin-Voigt pair: ``x = (v₀/ω_d) e^{−ζωt} sin ω_d t``, ``P = m*(ω² x + 2ζω ẋ)``
    until ``P`` first returns to zero (the cars part). Returns (t, P, x_s, T) on a 1 kHz grid with quiet before
    and after, the stroke left at separation (m) and the contact's duration (s)."""
    wd = omega * math.sqrt(1.0 - zeta**2)
    fine = np.linspace(0.0, 3.0 * math.pi / wd, 300_001)
    decay = np.exp(-zeta * omega * fine)
    x = speed / wd * decay * np.sin(wd * fine)
    rate = speed * decay * (np.cos(wd * fine) - zeta * omega / wd * np.sin(wd * fine))
    force = reduced_mass * (omega**2 * x + 2.0 * zeta * omega * rate)
    parted = int(np.flatnonzero(force[1:] <= 0.0)[0]) + 1
    duration = float(fine[parted])
    t = np.arange(-0.1, duration + 0.1, 1.0e-3)
    P = np.where((t >= 0.0) & (t <= duration), np.interp(t, fine, force), 0.0)
    return t, P, float(x[parted]), duration


@pytest.mark.parametrize("zeta, stroke_left", [(0.05, 0.028), (0.1, 0.050), (0.2, 0.082), (0.5, 0.123), (0.7, 0.132)])
def test_kelvin_voigt_pair_against_its_exact_stroke(zeta, stroke_left):
    """The exact Kelvin-Voigt pair at 2 m/s (m* = 50 t, ω = 20 rad/s): the stroke left when the cars part,
    ``x_s/(v₀T)``, is within the assumed β at every damping up to 0.7 (the docstring's numbers); the mean
    relative velocity over the contact, ``v₀ − x_s/T``, lies in the interval's timing envelope (its lower end is
    the window between the 5 % crossings, which ends before the cars part: measured 2 % lower at ζ ≤ 0.2, 5 % at
    0.7), and the interval covers v₀ (its upper end 1.6 % above at ζ = 0.7)."""
    speed, reduced_mass = 2.0, 5.0e4
    t, P, left, duration = _kelvin_voigt_pair(zeta, speed, reduced_mass)
    assert left / (speed * duration) == pytest.approx(stroke_left, abs=0.002) and stroke_left <= RESIDUAL_STROKE
    found = from_force(t, P, reduced_mass)
    assert found.source == "records" and found.lower <= speed <= found.upper
    assert found.lower <= speed - left / duration <= 1.06 * found.lower


def test_noise_spread_of_the_mean_relative_velocity():
    """White noise of std σ on the relative acceleration ``P/m*`` (1 kHz, 400 draws) over a 0.2 s pulse that
    jumps on and off (its crossings then barely move with the noise): ``v̂`` scatters by ``σ √(dt T/3)`` (its
    weights ``(t_s − t)/T``), within 15 %. (On a pulse that rises gradually the noise also moves the crossings:
    the timing envelope's part.)"""
    reduced_mass, sigma, dt, duration = 5.0e4, 0.1, 1.0e-3, 0.2  # σ m* = 5 kN, a quarter of the 1 % crossing level
    t = np.arange(-0.05, duration + 0.05, dt)
    inside = (t >= 0.0) & (t <= duration)
    pulse = np.where(inside, 1.0e6 * (1.0 + np.sin(np.pi * np.clip(t, 0.0, duration) / duration)), 0.0)
    rng = np.random.default_rng(3)
    lower = [from_force(t, pulse + reduced_mass * rng.normal(0.0, sigma, t.size), reduced_mass).lower for _ in range(400)]
    assert np.std(lower) == pytest.approx(sigma * math.sqrt(dt * duration / 3.0), rel=0.15)


@dataclass
class Read:
    law: str
    kind: str
    speed: float
    value: float
    lower: float
    upper: float

    @property
    def error(self) -> float:
        return self.value / self.speed - 1.0

    @property
    def covered(self) -> bool:
        return self.lower <= self.speed <= self.upper


def _read(tmp_path, law: str, speed: float, seed: int, coupled: bool = False) -> Read:
    """The default scene's cars at ``speed`` through ``law`` (free to roll, or coupled: bilateral with 25 mm of draft
    slack), fem recorded through the default chain (1 kHz, 100 Hz, 0.05 m/s²), read back by a kalman measured case."""
    data = default_scene_data()
    data["cars"][0]["velocity"] = speed
    data["time"] = {"end": 1.0 if coupled else 0.8}
    if LAWS[law] is not None:
        data["couplers"][0]["law"] = copy.deepcopy(LAWS[law])
    if coupled:
        data["couplers"][0].update(contact="bilateral", tension_slack=0.025)
    folder = tmp_path / f"{law}-{speed:.3f}-{'coupled' if coupled else 'free'}"
    folder.mkdir()
    event = simulated_event(folder, data, estimators=("kalman",), seed=seed)
    found = run_measured(scene_from_case(load_case(event.path))).events[0]
    assert found.impact_type == ("coupled" if coupled else "free_to_roll") and found.closing_speed_source == "records"
    return Read(law, found.impact_type, speed, found.closing_speed, found.closing_speed_lower, found.closing_speed_upper)


def test_intervals_cover_the_truth_on_every_coupler_law(tmp_path):
    """One free-to-roll impact per coupler law of the case schema, 1–4 m/s, read through the measurement chain:
    every interval covers the speed the fem ran at, every speed within 10 % of it (the old estimate, the
    relative velocity at the force peak, read 18 % low on the draft gear and 41 % low on the Kelvin-Voigt
    coupler)."""
    reads = [_read(tmp_path, law, 1.0 + 0.75 * k, seed=k) for k, law in enumerate(LAWS)]
    assert all(r.covered for r in reads), reads
    assert all(abs(r.error) < 0.10 for r in reads), [(r.law, r.speed, round(r.error, 3)) for r in reads]


@pytest.mark.slow
def test_interval_coverage_study(tmp_path):
    """The study the issue asks for: 50 events — each coupler law free to roll at 8 speeds drawn in 1–4 m/s, the
    draft gear and the table coupled (bilateral) at 5 — with the measurement chain's noise: intervals cover the
    truth in at least 90 % (measured 100 %, docs/formulas.md §K3 has the bias and spread per law)."""
    rng = np.random.default_rng(28)
    reads = []
    for k, law in enumerate(LAWS):
        for j, speed in enumerate(np.sort(rng.uniform(1.0, 4.0, 8))):
            reads.append(_read(tmp_path, law, float(speed), seed=100 * k + j))
    for k, law in enumerate(("draft_gear", "table")):
        for j, speed in enumerate(np.sort(rng.uniform(1.0, 4.0, 5))):
            reads.append(_read(tmp_path, law, float(speed), seed=1000 + 100 * k + j, coupled=True))
    for law in LAWS:
        for kind in ("free_to_roll", "coupled"):
            errors = np.array([r.error for r in reads if r.law == law and r.kind == kind])
            widths = np.array([(r.upper - r.lower) / r.speed for r in reads if r.law == law and r.kind == kind])
            if errors.size:
                print(f"{law:14s} {kind:12s} n={errors.size}: error mean {errors.mean():+.3f} sd {errors.std():.3f} "
                      f"range [{errors.min():+.3f}, {errors.max():+.3f}], interval width {widths.mean():.3f} of v₀")
    covered = sum(r.covered for r in reads)
    print(f"covered {covered} of {len(reads)}")
    assert len(reads) >= 40 and covered >= 0.9 * len(reads), [r for r in reads if not r.covered]


def test_a_speed_the_user_gives_replaces_the_estimate(tmp_path):
    """cases/measured_yard.yaml with a wayside speed for its first event (2.2 ± 0.05 m/s at 1.6 s): that event's
    speed is the given one (``source = given``, its interval ±0.05), the second's is estimated from its records
    and covers the 4.0 m/s the records were made at; both written to the result file."""
    data = yaml.safe_load(yard_case_with_inverse_estimators(tmp_path).read_text())
    data["events"]["closing_speed"] = [{"value": 2.2, "uncertainty": 0.05, "time": 1.6}]
    (tmp_path / "given.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    first, second = run_measured(scene_from_case(load_case(tmp_path / "given.yaml"))).events
    assert (first.closing_speed_source, first.closing_speed, first.closing_speed_lower, first.closing_speed_upper) == ("given", 2.2, pytest.approx(2.15), pytest.approx(2.25))
    assert "given in the case at 1.6 s" in first.closing_speed_basis
    assert second.closing_speed_source == "records" and second.closing_speed_lower <= 4.0 <= second.closing_speed_upper
    write_events(tmp_path / "given.h5", {}, [first, second])
    with h5py.File(tmp_path / "given.h5") as h5:
        attrs = [h5[f"events/{k}"].attrs for k in ("0", "1")]
        assert [a["closing_speed_source"] for a in attrs] == ["given", "records"]
        assert attrs[0]["closing_speed_lower"] == pytest.approx(2.15) and attrs[1]["closing_speed_upper"] > 4.0


def test_several_given_speeds_each_need_a_time(tmp_path):
    data = yaml.safe_load(yard_case_with_inverse_estimators(tmp_path).read_text())
    data["events"]["closing_speed"] = [{"value": 2.2, "uncertainty": 0.05, "time": 1.6}, {"value": 4.0, "uncertainty": 0.05}]
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(CaseError, match=r"events\.closing_speed\[1\]\.time: required when more than one closing speed"):
        load_case(tmp_path / "bad.yaml")


def test_the_calibrated_range_is_checked_on_the_interval():
    """Outside the calibrated speeds only when the interval lies wholly outside them; an interval across an edge is
    inside, and said."""
    errors = np.linspace(0.0, 0.1, 30)
    calibration = Calibration("c1", {"inverse_rigid": errors}, closing_speed=(1.5, 3.0), masses={})
    assert calibration.outside((2.0, 2.4), {}) == [] and calibration.edge_notes((2.0, 2.4)) == []
    assert calibration.outside((2.8, 3.3), {}) == []
    assert calibration.edge_notes((2.8, 3.3)) == ["the closing speed [2.8, 3.3] m/s straddles the calibrated edge 3 m/s"]
    assert calibration.outside((3.1, 3.5), {}) == ["closing speed [3.1, 3.5] m/s outside the calibrated [1.5, 3] m/s"]
    assert calibration.outside((1.0, 1.4), {}) and calibration.outside((math.nan, math.nan), {})
