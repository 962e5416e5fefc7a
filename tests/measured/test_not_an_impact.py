"""Not an impact: a coupler's force is internal to the line, ``Σ m_k a_k ≈ 0`` below the cars' first elastic mode,
and the coupler closes; transients pushed from outside are ``not_an_impact`` and run no estimator.

The law is checked on exact rigid pairs; fem impacts recorded through the measurement chain (free to roll, coupled,
friction gear, declared cars off by their tolerances) and the trigger's 24 ringing impacts stay impacts; transients built
here from their physics — a track joint's zero-mean jolts passing the axles of one car then the next, a brake application
(the same deceleration ramp on both cars), a knock on one car, a noise burst — sent through the same chain (100 Hz
anti-alias, 1 kHz, 0.05 m/s² noise), over several random draws, are not. Measured margins (printed): the largest R of
an impact 0.019 (ringing cars declared 19 % apart as in test_phantom_impacts.py; fem impacts ≤ 3e-4) against thresholds
≥ 0.074, the smallest R of a transient 0.99 (thresholds 0.075–0.47)."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.case import load_case
from femref.case.defaults import default_scene_data
from femref.cli import main
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from measured.test_closing_speed import LAWS
from measured.test_event_trigger import LENGTH, MODEL_DT, POST, PRE, SENSORS, TRIGGER, recorded, ringing
from measured.test_measured_statistics import impact, mismatched
from reduced.signal_tools import IMPACT_KINDS, NOT_AN_IMPACT, momentum_evidence
from support.measured import simulated_event

MASS = 100e3  # kg, each car: the ringing impacts' equal and opposite rigid accelerations are those of equal masses
DRAWS = 6


def test_the_momentum_ratio_follows_the_law():
    """Rigid pair through a Kelvin–Voigt coupler (``m_r a_r = −P``, ``m_f a_f = P``): R = 0 exactly; masses declared
    ``τ`` off in opposite senses: R = 2τ²/(1 + τ²) ≤ the bound ``2τ²/(1 − τ)²`` under the threshold; one car alone: R = 1;
    the same deceleration of both: R = 2; the coupler's relative velocity change is the closing speed lost."""
    dt, m_r, m_f, v0 = 1e-3, 120e3, 80e3, 2.0
    t = np.arange(0.0, 1.0, dt)
    m_star, omega, zeta = m_r * m_f / (m_r + m_f), 40.0, 0.2
    wd = omega * math.sqrt(1.0 - zeta**2)
    tau = np.clip(t - 0.2, 0.0, math.pi / wd)  # one half-period of contact from 0.2 s
    x = v0 / wd * np.exp(-zeta * omega * tau) * np.sin(wd * tau)
    rate = np.gradient(x, dt)
    force = np.where((t > 0.2) & (t < 0.2 + math.pi / wd), m_star * (omega**2 * x + 2 * zeta * omega * rate), 0.0)
    pair = np.array([-force / m_r, force / m_f])
    noise = [0.0, 0.0]
    exact = momentum_evidence(pair, [m_r, m_f], noise, dt, corner=20.0, mass_tolerance=0.05)
    assert exact.ratio < 1e-20 and exact.internal
    assert exact.threshold == pytest.approx(math.sqrt(2 * 0.05**2 / 0.95**2))
    assert exact.velocity_change == pytest.approx(float(np.max(np.cumsum(force)) * dt / m_star), rel=1e-3)  # ∫ P/m* dt
    off = momentum_evidence(pair, [m_r * 1.05, m_f * 0.95], noise, dt, corner=20.0, mass_tolerance=0.05)
    assert off.ratio == pytest.approx(2 * 0.05**2 / (1 + 0.05**2), rel=1e-9) and off.ratio < 2 * 0.05**2 / 0.95**2 and off.internal
    one = momentum_evidence(np.array([pair[0], 0 * t]), [m_r, m_f], noise, dt, corner=20.0, mass_tolerance=0.05)
    assert one.ratio == pytest.approx(1.0) and not one.internal
    brake = np.tile(-np.clip(t, 0.0, 0.5), (2, 1))
    both = momentum_evidence(brake, [MASS, MASS], noise, dt, corner=20.0, mass_tolerance=0.05)
    assert both.ratio == pytest.approx(2.0) and both.velocity_change == 0.0 and not both.internal


def test_a_weighed_car_brings_its_own_tolerance_into_the_bound():
    """One tolerance per car (a weighed car ±0.5 %, a declared one ±5 %): the bound ``Σ τ_k²/(1 − max τ)²`` (equal
    tolerances: the one-number bound, to the bit), and the ratio of masses declared off by δ = (+0.5 %, −5 %) in closed
    form, ``(δ_f − δ_r)² / ((1 + δ_r)² + (1 + δ_f)²)``, under it. A tolerance per car of the wrong count, negative or
    ≥ 1 is refused."""
    dt, m_r, m_f = 1e-3, 120e3, 80e3
    t = np.arange(0.0, 1.0, dt)
    force = np.where((t > 0.2) & (t < 0.3), 1e6 * np.sin(np.pi * (t - 0.2) / 0.1), 0.0)
    pair = np.array([-force / m_r, force / m_f])
    noise = [0.0, 0.0]
    one = momentum_evidence(pair, [m_r, m_f], noise, dt, corner=None, mass_tolerance=0.05)
    assert momentum_evidence(pair, [m_r, m_f], noise, dt, corner=None, mass_tolerance=[0.05, 0.05]).threshold == one.threshold
    rear, front = 0.005, -0.05
    mixed = momentum_evidence(pair, [m_r * (1 + rear), m_f * (1 + front)], noise, dt, corner=None, mass_tolerance=[0.005, 0.05])
    assert mixed.threshold == pytest.approx(math.sqrt((0.005**2 + 0.05**2) / 0.95**2), rel=1e-12) and mixed.threshold < one.threshold
    assert mixed.ratio == pytest.approx((front - rear) ** 2 / ((1 + rear) ** 2 + (1 + front) ** 2), rel=1e-9) and mixed.internal
    for bad in ([0.05], [0.05, -0.01], [0.05, 1.0], [0.05, math.nan]):
        with pytest.raises(ValueError, match="mass_tolerance"):
            momentum_evidence(pair, [m_r, m_f], noise, dt, corner=None, mass_tolerance=bad)


def _run(folder: Path, t: np.ndarray, probes: dict[str, np.ndarray], seed: int, masses: tuple[float, float] = (MASS, MASS),
         trigger: float = TRIGGER) -> Path:
    """Model accelerations through the measurement chain, written to one CSV, and the measured case reading it (two
    17 m cars of ``masses`` without bodies, the inverse_rigid estimator); the case's path."""
    folder.mkdir(exist_ok=True)
    records = recorded(t, probes, seed)
    time = records.channels["hammer/center"].time
    columns = {"t": time, **{p.replace("/", "_"): c.acceleration for p, c in records.channels.items()}}
    np.savetxt(folder / "rec.csv", np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns), comments="")
    case = {
        "kind": "measured",
        "records": [{"file": "rec.csv", "time": {"column": "t"},
                     "channels": {p: {"column": p.replace("/", "_"), "unit": "m/s^2"} for p in records.channels}}],
        "cars": [{"name": car, "mass": mass, "length": LENGTH, "sensors": {("center" if x == 0.0 else "end"): x for x in positions}}
                 for (car, positions), mass in zip(SENSORS.items(), masses)],
        "couplers": [{"name": "c1", "between": list(SENSORS)}],
        "events": {"trigger": trigger, "pre": PRE, "post": POST},
        "estimators": ["inverse_rigid"],
        "checks": {"alarm": 1.0e5},
    }
    path = folder / "case.yaml"
    path.write_text(yaml.safe_dump(case, sort_keys=False))
    return path


def _rigid(t: np.ndarray, hammer: np.ndarray, anvil: np.ndarray) -> dict[str, np.ndarray]:
    """Each car's rigid acceleration at both its sensors."""
    return {f"{car}/{'center' if x == 0.0 else 'end'}": a for car, a in (("hammer", hammer), ("anvil", anvil)) for x in SENSORS[car]}


def _ricker(t: np.ndarray, at: float, frequency: float) -> np.ndarray:
    """The zero-mean Ricker wavelet ``(1 − 2u²) e^{−u²}``, ``u = π f (t − at)``."""
    u = (np.pi * frequency * (t - at)) ** 2
    return (1.0 - 2.0 * u) * np.exp(-u)


def track_joint(t: np.ndarray, rng: np.random.Generator) -> tuple[dict[str, np.ndarray], float]:
    """A rail joint jolting each axle as it passes at 3–10 m/s: the anvil's trailing truck (axles 1.8 m apart), then the
    hammer's leading truck 5 m behind; same-sign wavelets of 8–15 Hz, 6–15 m/s² on each car."""
    speed, frequency = rng.uniform(3.0, 10.0), rng.uniform(8.0, 15.0)
    axles = {"anvil": (0.0, 1.8), "hammer": (5.0, 6.8)}
    a = {car: rng.uniform(6.0, 15.0) * sum(_ricker(t, 1.0 + s / speed, frequency) for s in at) for car, at in axles.items()}
    return _rigid(t, a["hammer"], a["anvil"]), TRIGGER


def brake_application(t: np.ndarray, rng: np.random.Generator) -> tuple[dict[str, np.ndarray], float]:
    """Both cars decelerated alike, 0.6–1.5 m/s² reached over 0.3–0.8 s from 1 s (a trigger of 0.4 m/s²)."""
    level, rise = rng.uniform(0.6, 1.5), rng.uniform(0.3, 0.8)
    a = -level * np.clip((t - 1.0) / rise, 0.0, 1.0)
    return _rigid(t, a, a.copy()), 0.4


def knock(t: np.ndarray, rng: np.random.Generator) -> tuple[dict[str, np.ndarray], float]:
    """A 5–15 ms half-sine of 20–60 m/s² on the hammer alone (a shunting knock, a load shifting)."""
    width, peak = rng.uniform(0.005, 0.015), rng.uniform(20.0, 60.0)
    tau = t - 1.0
    a = np.where((tau >= 0.0) & (tau < width), peak * np.sin(np.pi * np.clip(tau / width, 0.0, 1.0)), 0.0)
    return _rigid(t, a, 0.0 * t), TRIGGER


def noise_burst(t: np.ndarray, rng: np.random.Generator) -> tuple[dict[str, np.ndarray], float]:
    """0.2–0.5 s of independent 5–10 m/s² white noise on every channel from 1 s (a cable, a radio)."""
    length, level = rng.uniform(0.2, 0.5), rng.uniform(5.0, 10.0)
    on = (t >= 1.0) & (t < 1.0 + length)
    return {probe: np.where(on, rng.normal(0.0, level, t.size), 0.0) for probe in _rigid(t, t, t)}, TRIGGER


TRANSIENTS = {"track joint": track_joint, "brake application": brake_application, "knock": knock, "noise burst": noise_burst}


def test_transients_are_not_impacts_and_run_no_estimator(tmp_path):
    """Every draw of every transient: ``not_an_impact``, no estimate, no closing speed or closure, alarm none and why."""
    t = np.arange(0.0, 4.0, MODEL_DT)
    smallest, found = math.inf, dict.fromkeys(TRANSIENTS, 0)
    for name, transient in TRANSIENTS.items():
        for seed in range(DRAWS):
            probes, trigger = transient(t, np.random.default_rng(seed))
            path = _run(tmp_path / f"{name}{seed}", t, probes, seed, trigger=trigger)
            for event in run_measured(scene_from_case(load_case(path))).events:
                assert event.impact_type == NOT_AN_IMPACT, (name, seed, event.classification_basis)
                assert event.estimates == [] and event.closures == [] and math.isnan(event.closing_speed)
                assert event.alarm == "none" and event.alarm_basis.startswith("not an impact")
                assert event.records and event.classification_basis.startswith("momentum ratio R = ")
                smallest = min(smallest, event.momentum_ratio)
                found[name] += 1
    print(f"smallest R of a transient: {smallest:.3f}; events found: {found}")
    assert smallest > 0.5 and min(found.values()) >= DRAWS - 1  # a noise burst may pass as spikes the trigger ignores


def test_ringing_impacts_stay_impacts(tmp_path):
    """The trigger's ringing impacts (modes at 16–44 Hz ringing for seconds), declared equal, or 19 % apart as the
    phantom tests declare them: impacts, R far under its threshold."""
    t = np.arange(0.0, 7.0, MODEL_DT)
    largest = 0.0
    for masses in ((MASS, MASS), (119e3, 100e3)):
        for seed in range(DRAWS):
            path = _run(tmp_path / f"{masses[0]:.0f}-{seed}", t, ringing(t, 1.0, np.random.default_rng(seed)), seed, masses)
            (event,) = run_measured(scene_from_case(load_case(path))).events
            assert event.impact_type in IMPACT_KINDS and event.momentum_ratio < 0.5 * event.momentum_threshold, event.classification_basis
            largest = max(largest, event.momentum_ratio)
    print(f"largest R of a ringing impact: {largest:.4f}")


@pytest.mark.parametrize("kind", ["free_to_roll", "coupled", "friction_gear", "mismatched"])
def test_fem_impacts_recorded_stay_impacts(tmp_path, kind):
    """fem impacts through the measurement chain: free to roll, coupled (the friction-gear table), the friction gear, and
    declared cars off by their tolerances (mass ±5 %, stiffness ±15 %): impacts, R far under its threshold."""
    rng = np.random.default_rng(7)
    data = impact("coupled" if kind == "coupled" else "free_to_roll", rng)
    if kind == "friction_gear":
        data = default_scene_data()
        data["couplers"][0]["law"] = LAWS["friction_gear"]
        data["cars"][0]["velocity"] = 2.5
    event = simulated_event(tmp_path, data, estimators=("inverse_rigid",))
    if kind == "mismatched":
        mismatched(event.case, rng)
        event.path.write_text(yaml.safe_dump(event.case, sort_keys=False))
    (found,) = run_measured(scene_from_case(load_case(event.path))).events
    print(f"{kind}: {found.classification_basis}")
    assert found.impact_type == ("coupled" if kind == "coupled" else "free_to_roll")
    assert found.momentum_ratio < 0.5 * found.momentum_threshold and found.velocity_change > 100 * found.velocity_change_noise
    assert found.estimates and found.estimates[0].ok


def test_femref_run_stores_and_reports_the_skipped_transients(tmp_path):
    """One recording with two ringing impacts and a track joint, a knock and a noise burst between them, through
    ``femref run`` and ``femref report``: five events; the transients ``not_an_impact`` with their evidence in the file,
    no estimator group, no closing speed, alarm none and why, shown on the page; the impacts estimated."""
    t = np.arange(0.0, 20.0, MODEL_DT)
    probes = {p: a + b for (p, a), b in zip(ringing(t, 1.0, np.random.default_rng(1)).items(), ringing(t, 16.0, np.random.default_rng(2)).values())}
    for at, transient in ((5.0, track_joint), (9.0, knock), (12.5, noise_burst)):
        shifted = t - at + 1.0
        for probe, a in transient(shifted, np.random.default_rng(int(at)))[0].items():
            probes[probe] = probes[probe] + a
    path = _run(tmp_path, t, probes, 3)
    out = tmp_path / "events.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert result.output.count("none run") == 3 and "momentum ratio R = " in result.output
    with h5py.File(out) as h5:
        events = [h5["events"][k] for k in sorted(h5["events"], key=int)]
        kinds = [str(e.attrs["impact_type"]) for e in events]
        assert kinds[0] in IMPACT_KINDS and kinds[-1] in IMPACT_KINDS and kinds[1:-1] == [NOT_AN_IMPACT] * 3, kinds
        for event in events[1:-1]:
            assert "inverse_rigid" not in event and not list(event["closure"]) and math.isnan(event.attrs["closing_speed"])
            assert event.attrs["momentum_ratio"] > event.attrs["momentum_threshold"] or event.attrs["velocity_change"] < 3 * event.attrs["velocity_change_noise"]
            assert event.attrs["alarm"] == "none" and str(event.attrs["alarm_basis"]).startswith("not an impact")
            assert str(event.attrs["classification_basis"]).startswith("momentum ratio R = ") and "records/hammer/center" in event
        assert events[0]["inverse_rigid/c1"].attrs["status"] == "ok" and events[0].attrs["alarm"] != "none"
    report = CliRunner().invoke(main, ["report", str(out), "-o", str(tmp_path / "events.html")])
    assert report.exit_code == 0, report.output
    page = (tmp_path / "events.html").read_text()
    assert page.count("not_an_impact") >= 3 and page.count("none run") == 3 and "type not_an_impact — momentum ratio R = " in page
