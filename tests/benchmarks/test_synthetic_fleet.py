"""benchmarks/synthetic/fleet.py: the manifest's recordings expand to measured cases today's schema takes (reading
their files), and the truth's worn gear follows its wear law to the wear limit.

The fem runs are replaced by a closed form (a rigid pair through a Kelvin–Voigt coupler, every sensor of a car alike,
support.synthetic.rigid_pair): what is checked is the manifest and the truth, not the physics (``fleet.py --check`` runs
the fem fleet's worn gear through femref and checks the wear shows)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from femref.case import load_case
from support.synthetic import fleet, impacts, rigid_pair


def closed_form(recording: fleet.Recording) -> impacts.SimulatedImpact:
    time = np.arange(0.0, 0.5, 1e-3)
    pair = rigid_pair(time, recording.speed, coupled=False)
    accelerations = {f"{car}/{sensor}": pair[f"{car}/center"] for car in ("car1", "car2") for sensor in fleet.SENSORS}
    spec = impacts.ImpactSpec("fleet_friction_gear", recording.speed, recording.scale)
    return impacts.SimulatedImpact(spec, time, accelerations, time, np.zeros(time.size), np.zeros(time.size))


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("fleet")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fleet, "simulated", closed_form)
        truth = fleet.write_fleet(out, days=3, cars=8, seed=2)
    return out, truth


def test_each_recording_expands_to_a_valid_measured_case(written, tmp_path):
    """Contract C's keys; each recording's coupler is its rear car's gear, and its expanded case loads (files read)."""
    out, truth = written
    data = yaml.safe_load((out / "manifest.yaml").read_text())
    assert list(data) == ["fleet", "defaults", "cars", "gears", "recordings"]
    assert len(data["recordings"]) == 3 * (1 + fleet.OTHERS_PER_DAY) == len(truth["recordings"])
    assert len({r["name"] for r in data["recordings"]}) == len(data["recordings"])
    for recording in data["recordings"]:
        rear, front = recording["cars"]
        assert recording["couplers"] == [{"name": "c1", "gear": fleet.gear_of(rear)}] and rear != front
        path = out / f"{recording['name']}.yaml"
        path.write_text(yaml.safe_dump(fleet.expanded_case(data, recording)))
        case = load_case(path)
        assert [car.name for car in case.cars] == [rear, front]
        assert {p for r in case.records for p in r.channels} == {f"{car}/{s}" for car in (rear, front) for s in fleet.SENSORS}


def test_the_worn_gear_crosses_the_wear_limit_on_its_day(written):
    """The worn gear's closure force is ``(1 − 0.15 d/28)`` of its rating, the limit ``0.85`` of it: equal on day 28;
    the other gears keep one factor within 4 % of 1."""
    out, truth = written
    assert truth["wear_limit"] == pytest.approx(fleet.rated_closure() * (1 - fleet.WEAR_LOSS))
    assert fleet.rated_closure() * fleet.wear_factor(truth["crossing_day"]) == pytest.approx(truth["wear_limit"], rel=1e-12)
    assert json.loads((out / "truth.json").read_text()) == json.loads(json.dumps(truth))
    for row in truth["recordings"]:
        if row["gear"] == truth["worn_gear"]:
            assert row["scale"] == pytest.approx(fleet.wear_factor(row["day"]), abs=1e-6)
    others: dict[str, set[float]] = {}
    for row in truth["recordings"]:
        if row["gear"] != truth["worn_gear"]:
            others.setdefault(row["gear"], set()).add(row["scale"])
    assert others and all(len(s) == 1 and abs(next(iter(s)) - 1) <= 2 * fleet.SCATTER + 1e-12 for s in others.values())
