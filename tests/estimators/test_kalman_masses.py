"""Measured car masses in the kalman estimator (issue 32 item 4): a measured case states a car's mass tolerance
(``cars[i].mass_tolerance``), the band takes it for that car, and the event file and report say which masses were measured.

Against the closed form: the force the records imply scales with the mass, so two cars both measured to ±0.5 % instead
of declared to ±5 % narrow the band at the peak by ``(0.05 − 0.005) × P`` each way (the common scale, exact: the band's
edges are the corners' envelope × ``(1 ± m)``).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.api import run_case
from femref.case import load_case
from femref.cli import main
from femref.estimators import KalmanEstimator, Recorded
from femref.scene.build import scene_from_case
from femref.sensing.noise_gate import quiet_corrected
from support.case_helpers import expect, load_bad
from support.paths import CASES


@pytest.fixture(scope="module")
def yard() -> dict:
    """cases/measured_yard.yaml with kalman only, its record files by absolute path."""
    data = yaml.safe_load((CASES / "measured_yard.yaml").read_text())
    for record in data["records"]:
        record["file"] = str(CASES / record["file"])
    data["estimators"] = ["kalman"]
    return data


def _case(folder, data, tolerances) -> dict:
    data = json.loads(json.dumps(data))
    for car, tolerance in zip(data["cars"], tolerances):
        if tolerance is not None:
            car["mass_tolerance"] = tolerance
    (folder / "case.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return data


def test_a_cars_mass_tolerance_is_checked_and_reaches_the_scene(tmp_path, yard):
    """Finite, 0 ≤ τ < 0.5, its key path in the error; given for one car, the scene's kalman model has it for that car only."""
    for value, rule in ((0.5, r"must be < 0.5"), (-0.01, r"must be >= 0"), (math.nan, r"must be a finite number")):
        data = _case(tmp_path, yard, (None, value))
        message = str(load_bad(tmp_path, data))
        assert re.search(expect("cars[1].mass_tolerance", rule), message), message
    _case(tmp_path, yard, (0.005, None))
    scene = scene_from_case(load_case(tmp_path / "case.yaml"))
    assert scene.kalman.car_mass_tolerances == (0.005, None) and scene.kalman.mass_tolerance == 0.05


def test_measured_masses_narrow_the_band_by_the_mass_part(tmp_path, yard):
    """The first event's records: the same force; both masses measured to ±0.5 % narrow the band's half-width at the
    peak by 0.045 × the envelope's mid-point (the common scale, to round-off), which is the peak within 2 %; one car
    measured (the other declared) gives a band between the two and names each car's source."""
    _case(tmp_path, yard, (None, None))
    scene = scene_from_case(load_case(tmp_path / "case.yaml"))
    event = run_case(tmp_path / "case.yaml").events[0]
    _, noise, _ = quiet_corrected(event.time, event.records, event.trigger_time)
    recorded = Recorded(event.time, event.records, scene.cars, scene.couplers, noise)
    found = {}
    for label, tolerances in (("declared", ()), ("measured", (0.005, 0.005)), ("mixed", (0.005, None))):
        model = dataclasses.replace(scene.kalman, car_mass_tolerances=tolerances)
        (found[label],) = KalmanEstimator(model, scene.anti_alias).estimate(recorded)
    declared, measured, mixed = found["declared"], found["measured"], found["mixed"]
    assert declared.status == measured.status == mixed.status == "ok"
    np.testing.assert_array_equal(measured.force, declared.force)
    (peak, low_d, up_d), (_, low_m, up_m), (_, low_x, up_x) = declared.peak, measured.peak, mixed.peak
    # edges (1 ± m) × the corners' envelope (U, L): half(0.05) − half(0.005) = 0.045 (U + L)/2, and (U + L)/2 from either
    middle = 0.5 * (up_m / 1.005 + low_m / 0.995)
    assert 0.5 * ((up_d - low_d) - (up_m - low_m)) == pytest.approx(0.045 * middle, rel=1e-9)
    assert middle == pytest.approx(peak, rel=0.02)
    assert low_d <= low_x <= low_m and up_m <= up_x <= up_d
    assert "car_masses" not in declared.settings
    assert measured.settings["car_masses"] == {"hammer": {"tolerance": 0.005, "source": "measured"},
                                               "anvil": {"tolerance": 0.005, "source": "measured"}}
    assert mixed.settings["car_masses"]["anvil"] == {"tolerance": 0.05, "source": "declared"}


def test_the_event_file_and_report_say_which_inputs_were_measured(tmp_path, yard):
    """``femref run -o`` then ``femref report``: the kalman estimate's settings in the event file hold each car's mass
    source; the report's event notes name them, and its closing speed is marked given (a stated radar speed)."""
    data = _case(tmp_path, yard, (0.005, None))
    data["events"]["closing_speed"] = {"value": 2.2, "uncertainty": 0.05}
    (tmp_path / "case.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    output, report = tmp_path / "out.h5", tmp_path / "out.html"
    result = CliRunner().invoke(main, ["run", str(tmp_path / "case.yaml"), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output, "r") as h5:
        event = next(iter(h5["events"].values()))
        masses = json.loads(event["kalman/c1"].attrs["settings"])["car_masses"]
    assert masses == {"hammer": {"tolerance": 0.005, "source": "measured"}, "anvil": {"tolerance": 0.05, "source": "declared"}}
    result = CliRunner().invoke(main, ["report", str(output), "-o", str(report)])
    assert result.exit_code == 0, result.output
    html = report.read_text()
    assert "kalman masses — hammer measured ±0.5 %, anvil declared ±5 %" in html
    assert "(given)" in html
