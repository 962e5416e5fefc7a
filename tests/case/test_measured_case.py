"""The measured case: a valid one loads into a scene; every bad key names its path and rule."""

from __future__ import annotations

import copy
import re

import numpy as np
import pytest
import yaml

from femref.case import load_case
from femref.scene.build import scene_from_case
from support.case_helpers import expect, load_bad

BODY = {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}


@pytest.fixture
def valid(tmp_path):
    """A two-car measured case and its CSV files (hammer in g at 1 kHz, anvil's HDF5-free CSV in m/s²)."""
    t = np.arange(0, 1.0, 1e-3)
    np.savetxt(tmp_path / "hammer.csv", np.column_stack([t, np.zeros_like(t), np.zeros_like(t)]), delimiter=",", header="t,center,front", comments="")
    np.savetxt(tmp_path / "anvil.csv", np.column_stack([np.zeros_like(t)]), delimiter=",", header="rear", comments="")
    return {
        "kind": "measured",
        "records": [
            {"file": "hammer.csv", "time": {"column": "t"}, "channels": {"hammer/center": {"column": "center", "unit": "g"}, "hammer/front": {"column": "front", "unit": "g"}}},
            {"file": "anvil.csv", "time": {"rate": 1000.0, "start": 0.0}, "clock_offset": 0.002, "channels": {"anvil/rear": {"column": "rear", "unit": "m/s^2"}}},
        ],
        "cars": [
            {"name": "hammer", "body": BODY, "sensors": {"center": 0.0, "front": 8.3}},
            {"name": "anvil", "mass": 100e3, "length": 17.0, "sensors": {"rear": -8.3}},
        ],
        "couplers": [{"between": ["hammer", "anvil"]}],
        "events": {"trigger": 5.0},
        "estimators": ["inverse_rigid"],
        "checks": {"alarm": 2.5e6},
    }


def test_a_valid_measured_case_resolves(tmp_path, valid):
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(valid, sort_keys=False))
    scene = scene_from_case(load_case(path))
    assert scene.kind == "measured" and [c.name for c in scene.couplers] == ["c1"]
    assert scene.cars[0].mass == pytest.approx(119e3) and scene.cars[1].body is None and scene.cars[1].mass == 100e3
    assert scene.records[1].clock_offset == 0.002 and scene.checks.alarm == 2.5e6 and scene.trigger == 5.0


def _bad(tmp_path, valid, edit):
    data = copy.deepcopy(valid)
    edit(data)
    return str(load_bad(tmp_path, data))


@pytest.mark.parametrize(
    "edit, key_path, rule",
    [
        (lambda d: d["records"][0]["channels"].update({"caboose/center": {"column": "center", "unit": "g"}}), "records[0].channels.caboose/center", r"unknown car 'caboose'"),
        (lambda d: d["records"][0]["channels"].update({"hammer/rear": {"column": "center", "unit": "g"}}), "records[0].channels.hammer/rear", r"car hammer has no sensor 'rear'"),
        (lambda d: d["records"][0]["channels"].update({"hammer": {"column": "center", "unit": "g"}}), "records[0].channels.hammer", r"channels are named <car>/<sensor>"),
        (lambda d: d["records"][0]["channels"]["hammer/center"].update(unit="gee"), "records[0].channels.hammer/center.unit", r"unknown acceleration unit; units: m/s\^2, g, mm/s\^2; got 'gee'"),
        (lambda d: d["records"][0]["channels"]["hammer/center"].update(dataset="/a"), "records[0].channels.hammer/center", r"give exactly one of column \(CSV\), dataset \(HDF5\), channel \(MDF4"),
        (lambda d: d["records"][0]["time"].update(rate=100.0), "records[0].time", r"give exactly one of column \(CSV\), dataset \(HDF5\), channel \(.*\) or rate"),
        (lambda d: d["records"][0]["channels"]["hammer/center"].update(column="centre"), "records[0]", r"hammer\.csv: channel hammer/center \(column 'centre'\): no such column"),
        (lambda d: d["records"][1]["channels"].update({"hammer/center": {"column": "rear", "unit": "g"}}), "records[1].channels.hammer/center", r"recorded twice"),
        (lambda d: d["cars"][1].update(body=BODY), "cars[1].mass", r"give a body or mass and length, not both"),
        (lambda d: d["cars"][1].pop("mass"), "cars[1].mass", r"required key is missing \(a car without a body needs mass and length\)"),
        (lambda d: d["cars"][0]["sensors"].update(front=9.0), "cars[0].sensors.front", r"must lie on the car"),
        (lambda d: d.update(estimators=["kalman"]), "estimators[0]", r"kalman needs every car's body \(profiles\); cars anvil give only mass and length"),
        (lambda d: d.update(estimators=["inverse_rigid", "kalmann"]), "estimators[1]", r"unknown estimator.*did you mean 'kalman'"),
        (lambda d: d.update(estimators=[]), "estimators", r"name at least one estimator"),
        (lambda d: d["couplers"][0].update(between=["anvil", "hammer"]), "couplers[0].between", r"lists the cars in reverse order"),
        (lambda d: d.update(models=["fem"]), "models", r"'models' is a key of simulated cases"),
        (lambda d: d["events"].update(trigger=0.0), "events.trigger", r"must be > 0"),
        (lambda d: d.update(calibration="nope.h5"), "calibration", r"calibration file .*nope\.h5 not found"),
        (lambda d: d["records"][0].update(anti_alias={"corner": 600.0}), "records[0].anti_alias.corner", r"must be below the file's Nyquist frequency rate/2 = 500 Hz"),
        (lambda d: d["records"][0].update(anti_alias={"corner": 100.0, "order": 9}), "records[0].anti_alias.order", r"must be <= 8; got 9"),
        (lambda d: d["records"][0].update(anti_alias={"order": 4}), "records[0].anti_alias.corner", r"required"),
        (lambda d: d.update(estimators=["ann_fem"]), "estimators[0]", r"unknown estimator \(a network estimator is a mapping \{name: ann_fem, network: file.npz\}\)"),
    ],
)
def test_a_bad_measured_case_names_the_key_and_rule(tmp_path, valid, edit, key_path, rule):
    message = _bad(tmp_path, valid, edit)
    assert re.search(expect(key_path, rule), message), message


def test_kalman_tolerances_are_checked(tmp_path, valid):
    valid["cars"][1] = {"name": "anvil", "body": BODY, "sensors": {"rear": -8.3}}
    valid["estimators"] = ["kalman"]
    for settings, key_path, rule in (
        ({"damping_factors": [1.2, 1.6]}, "kalman.damping_factors", r"must be \[low, high\] with low <= 1 <= high"),
        ({"mass_tolerance": 0.6}, "kalman.mass_tolerance", r"must be < 0.5"),
        ({"modes": 0}, "kalman.modes", r"must be >= 1"),
    ):
        message = _bad(tmp_path, valid, lambda d, settings=settings: d.update(kalman=settings))
        assert re.search(expect(key_path, rule), message), message


NETWORK = str((__import__("pathlib").Path(__file__).parents[2] / "cases" / "networks" / "fem_mlp.npz").resolve())


def test_a_network_on_measured_records_is_checked_against_them(tmp_path, valid):
    """A saved network's contract against a measured case: its probes recorded, the recorders' filter
    that of its training records (100 Hz, 4th order), kalman listed for the contact instant, its
    records within the event window; each problem names the estimator."""
    data = copy.deepcopy(valid)
    data["estimators"] = ["inverse_rigid", {"name": "ann_fem", "network": NETWORK}]
    data["events"]["post"] = 0.4
    message = _bad(tmp_path, valid, lambda d: d.update(estimators=data["estimators"], events=data["events"]))
    for rule in (r"the network reads probe\(s\) anvil/center, anvil/front, which are not recorded",
                 r"the network was trained on records low-passed at 100 Hz \(order 4\); declare the anti_alias of the file recording hammer/center",
                 r"a network's records start at contact, read from the kalman force: list kalman among the estimators",
                 r"the network reads 0\.5 s after contact, beyond events\.post = 0\.4 s"):
        assert re.search(expect("estimators[1]", rule), message), (rule, message)
    filtered = copy.deepcopy(valid)
    filtered["records"][0]["anti_alias"] = {"corner": 200.0}
    message = _bad(tmp_path, filtered, lambda d: d.update(estimators=data["estimators"]))
    assert re.search(expect("estimators[1]", r"the network was trained on records low-passed at 100 Hz \(order 4\); hammer/center is recorded through 200 Hz \(order 4\)"), message), message
