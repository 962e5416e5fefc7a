"""The gear's closure through the whole measured chain, on three gear families whose laws are written in the tests.

Each event: two rigid cars (80 t and 70 t, or the source study's 119 t / 100 t for the standard-linear gear)
through a gear of tests/support/gear_families.py, integrated at 10 kHz; each car's centre acceleration
(``−P/m₁``, ``P/m₂``) goes through the measurement chain (:func:`femref.sensing.measurement.measure`: 100 Hz
anti-alias filter, 1 kHz sampling, white noise 0.05 m/s²), is written to a CSV file in g with 0.15 s of quiet
before the impact (1.2 s in all), and read back through a measured case (cars by mass and length, the ``inverse_rigid``
estimator) by :func:`femref.run.measured.run_measured`. Its closure — the primary force and the stroke made
of it with the event's closing speed (``femref.sensing.findings.coupler_stroke``) — is compared with the truth of
the gear's law. The default run takes two events per family; ``pytest -m slow`` eighteen gears drawn at random.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from femref.case import load_case
from femref.events import ClosureResult, ForceEstimate
from femref.run.measured import run_measured
from femref.sensing.findings import coupler_stroke
from femref.scene.build import scene_from_case
from femref.sensing.measurement import Measurement, measure
from support.gear_families import GearRecord, closing_records, random_records

G = 9.80665
MODEL_DT = 1e-4  # s
QUIET = 1500  # model samples before contact (0.15 s)
CHAIN = dict(rate=1000.0, lowpass=100.0, noise=0.05)
RECORD_LENGTH = 1.2  # s: the impact, then the cars apart


def measured_case(folder: Path, record: GearRecord, seed: int) -> Path:
    """The record's centre accelerations through the chain, written as a measured case (module docstring); its path."""
    m1, m2 = record.masses
    force = np.concatenate([record.force, np.zeros(round(RECORD_LENGTH / MODEL_DT) - record.force.size)])  # the cars apart
    accelerations = np.column_stack([-force / m1, force / m2])
    t, a = measure(MODEL_DT * np.arange(force.size), accelerations, Measurement(seed=seed, **CHAIN))
    files = []
    for column, name in enumerate(("hammer", "anvil")):
        path = folder / f"{name}.csv"
        np.savetxt(path, np.column_stack([t + 10.0, a[:, column] / G]), delimiter=",", header="t,center", comments="")
        files.append({"file": path.name, "time": {"column": "t", "unit": "s"}, "channels": {f"{name}/center": {"column": "center", "unit": "g"}},
                      "anti_alias": {"corner": CHAIN["lowpass"], "order": 4}})
    case = {"kind": "measured", "records": files,
            "cars": [{"name": "hammer", "mass": m1, "length": 17.0, "sensors": {"center": 0.0}},
                     {"name": "anvil", "mass": m2, "length": 17.0, "sensors": {"center": 0.0}}],
            "couplers": [{"name": "c1", "between": ["hammer", "anvil"]}],
            "events": {"trigger": 3.0, "pre": 0.1, "post": 0.2}, "estimators": ["inverse_rigid"]}
    (folder / "measured.yaml").write_text(yaml.safe_dump(case, sort_keys=False))
    return folder / "measured.yaml"


def measured_closure(folder: Path, record: GearRecord, seed: int) -> ClosureResult:
    """The event's closure result from the record's centre accelerations through the chain (module docstring)."""
    return run_measured(scene_from_case(load_case(measured_case(folder, record, seed)))).events[0].closures[0]


def _check(tmp_path: Path, records: list[GearRecord]) -> list[float]:
    """Each record through the chain: never ``not closed``, the closure force within 5 % of the law's; the errors."""
    errors = []
    for k, record in enumerate(records):
        assert 0.4 <= record.ratio <= 0.9, (record.name, record.ratio)
        folder = tmp_path / f"event{k}"
        folder.mkdir()
        closure = measured_closure(folder, record, seed=k)
        assert closure.status != "not closed", (record.name, closure.message)
        errors.append(closure.closure_force / record.truth - 1.0)
        assert abs(errors[-1]) <= 0.05, (record.name, errors[-1], closure.message)
    return errors


def test_the_stroke_made_from_the_force_is_the_cars_relative_motion(tmp_path: Path) -> None:
    """``δ = v₀ (t − t₀) − (1/m₁ + 1/m₂) ∫∫ P`` (``coupler_stroke``, trapezoids) from the exact force of a friction
    gear at 10 kHz, against the stroke the test's ODE integrated (DOP853, rtol 1e-10): from contact to the peak
    within 1e-5 of the largest stroke (measured 2.9e-6; after the peak the force's drop to the unloading curve
    costs the trapezoids more); without a closing speed, no stroke."""
    record = closing_records(dt=MODEL_DT, lead=QUIET)[6]
    scene = scene_from_case(load_case(measured_case(tmp_path, record, seed=0)))
    nan = np.full(record.time.size, np.nan)
    primary = {"c1": ForceEstimate("exact", "c1", record.time, record.force, nan, nan)}
    stroke = coupler_stroke(scene.cars, scene.couplers, scene.couplers[0], primary, record.closing_speed)
    exact = record.stroke - record.stroke[0]
    loading = slice(0, int(np.argmax(record.force)) + 1)
    assert np.max(np.abs(stroke - exact)[loading]) <= 1e-5 * np.max(record.stroke)
    with pytest.raises(ValueError, match="no closing speed"):
        coupler_stroke(scene.cars, scene.couplers, scene.couplers[0], primary, float("nan"))


def test_two_gears_of_each_family_close_within_5_percent_through_the_chain(tmp_path: Path) -> None:
    """Six events — the first two of each family of tests/reduced/test_closure_stiffness.py, closing at 44–86 %
    of the peak: never ``not closed``, within 5 % (measured +1.0, +0.9 % standard-linear; −2.4, −1.7 %
    friction; −0.2, +1.9 % polymer; the sine-branch fit this replaced: +0.6, +1.0, +3.5, +4.2, +3.0, +2.7 %)."""
    records = closing_records(dt=MODEL_DT, lead=QUIET)
    _check(tmp_path, [records[k] for k in (0, 1, 6, 7, 12, 13)])


@pytest.mark.slow
def test_eighteen_random_gears_close_within_5_percent_through_the_chain(tmp_path: Path) -> None:
    """Eighteen gears drawn at random (six per family, seed 2026; :func:`support.gear_families.random_records`:
    friction and polymer gears with stops 20–50 × stiffer at 60–90 mm aimed at 45–85 % of the peak), none of
    them used to choose the detector's settings: never ``not closed``, every closure within 5 % (measured
    ≤ 3.2 %: standard-linear +1.8 to +3.2 %, friction −2.0 to −1.1 %, polymer −0.7 to +0.9 %; 16 ``closed``,
    2 ``ambiguous``; the sine-branch fit this replaced: −0.6 to +1.5 %, +3.7 to +6.0 %, +2.5 to +4.3 %)."""
    _check(tmp_path, random_records(np.random.default_rng(2026), 6, dt=MODEL_DT, lead=QUIET))
