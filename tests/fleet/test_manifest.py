"""The fleet manifest: each recording expanded into the measured case a user would write by hand, every problem named by
its manifest key path, exit 2 and nothing written."""

from __future__ import annotations

import copy

import pytest
import yaml
from click.testing import CliRunner

from femref.case import CaseError, load_case, resolved_yaml
from femref.cli import main
from femref.fleet.manifest import load_manifest, parse_manifest
from support.fleet import ALARM, PAIRS, RATED, car_entries, write_fleet


@pytest.fixture
def manifest(tmp_path, fleet_records):
    return write_fleet(tmp_path, fleet_records, [(1.0, "low", *PAIRS[0]), (2.0, "high", *PAIRS[1])])


def test_a_recording_expands_into_the_case_written_by_hand(manifest):
    """Recording 1 (gear G0001, rated 2.9 MN) written out as a measured case by hand resolves to the same case."""
    fleet = load_manifest(manifest)
    data = yaml.safe_load(manifest.read_text())
    recording = data["recordings"][1]
    rear, front = PAIRS[1]
    by_hand = {
        "kind": "measured",
        "records": recording["records"],
        "cars": [{"name": rear, **car_entries(4)[rear]}, {"name": front, **car_entries(4)[front]}],
        "couplers": [{"name": "c1", "between": [rear, front]}],
        "events": {"trigger": 3.0, "pre": 0.05, "post": 0.39},
        "estimators": ["inverse_rigid", "inverse_quasi_rigid"],
        "checks": {"alarm": ALARM, "rated_closure_force": RATED, "wear_tolerance": 0.15},
    }
    path = manifest.parent / "by_hand.yaml"
    path.write_text(yaml.safe_dump(by_hand, sort_keys=False))
    assert fleet.recordings[1].resolved == resolved_yaml(load_case(path))
    assert fleet.recordings[1].wear_limit == pytest.approx(RATED * 0.85)
    assert fleet.recordings[0].rated_closure_force == 2.0e6  # G0002 has no rating: the defaults' checks hold
    assert fleet.recordings[1].cars == PAIRS[1] and fleet.recordings[1].gears == ("G0001",)
    assert [p.name for p in fleet.recordings[1].record_files] == ["hammer.csv", "anvil.csv"]


def _bad(data, change):
    data = copy.deepcopy(data)
    change(data)
    return data


BAD = [
    (lambda d: d["recordings"][1]["records"][0].update(file="missing.csv"), "recordings[1].records[0]", "file not found"),
    (lambda d: d["recordings"][0]["records"][1]["channels"].update({"C0002/side": {"column": "front", "unit": "g"}}),
     "recordings[0].records[1].channels.C0002/side", "has no sensor 'side'"),
    (lambda d: d["cars"]["C0001"]["sensors"].update(front=20.0), "cars.C0001.sensors.front", "must lie on the car"),
    (lambda d: d["defaults"]["events"].update(trigger=-1.0), "defaults.events.trigger", "must be > 0"),
    (lambda d: d["gears"]["G0001"].update(rated_closure_force=0.0), "gears.G0001.rated_closure_force", "must be > 0"),
    (lambda d: d["recordings"][0]["couplers"][0].update(gear="G0009"), "recordings[0].couplers[0].gear", "unknown gear"),
    (lambda d: d["recordings"][1].update(cars=["C0003", "C0007"]), "recordings[1].cars[1]", "unknown car"),
    (lambda d: d["recordings"][1].update(name=d["recordings"][0]["name"]), "recordings[1].name", "names are unique"),
    (lambda d: d["recordings"][0].update(name="../up"), "recordings[0].name", "letters, digits"),
    (lambda d: d["recordings"][0].update(start="2026-11-01T06:12:00"), "recordings[0].start", "give the time's zone"),
    (lambda d: d["defaults"].update(records=[]), "defaults.records", "a recording gives its own records"),
    (lambda d: d["recordings"][0]["couplers"].append({"gear": "G0001"}), "recordings[0].couplers", "coupler k joins cars k and k + 1"),
]


@pytest.mark.parametrize("change, key_path, rule", BAD, ids=[key for _, key, _ in BAD])
def test_a_problem_is_named_by_its_manifest_key_path(manifest, change, key_path, rule):
    data = _bad(yaml.safe_load(manifest.read_text()), change)
    with pytest.raises(CaseError) as raised:
        parse_manifest(data, source=str(manifest), base_dir=manifest.parent)
    assert raised.value.key_path == key_path and rule in raised.value.rule, str(raised.value)


def test_femref_fleet_exits_2_on_a_bad_manifest_and_writes_nothing(manifest, tmp_path):
    data = _bad(yaml.safe_load(manifest.read_text()), lambda d: d["defaults"]["events"].update(trigger=-1.0))
    manifest.write_text(yaml.safe_dump(data, sort_keys=False))
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["fleet", str(manifest), "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert f"{manifest}: defaults.events.trigger: must be > 0 (in recording " in result.output
    assert not out.exists()


def test_femref_fleet_exits_2_on_an_output_folder_holding_something_else(manifest, tmp_path):
    """An ``events.sqlite`` in the output folder that is not a femref event store is refused and left as it was."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "events.sqlite").write_text("station,time\n")
    result = CliRunner().invoke(main, ["fleet", str(manifest), "-o", str(out)])
    assert result.exit_code == 2 and "not a femref event store" in result.output, result.output
    assert (out / "events.sqlite").read_text() == "station,time\n" and sorted(p.name for p in out.iterdir()) == ["events.sqlite"]


def test_femref_fleet_refuses_an_output_folder_where_an_event_file_would_overwrite_a_record(manifest, tmp_path):
    """A recording whose record file sits where another recording's event file would go: exit 2, nothing written."""
    data = yaml.safe_load(manifest.read_text())
    target = f"out/events/{data['recordings'][1]['name']}.h5"
    (tmp_path / "out" / "events").mkdir(parents=True)
    (tmp_path / target).write_bytes((manifest.parent / data["recordings"][0]["records"][0]["file"]).read_bytes())
    data["recordings"][0]["records"][0].update(file=target, format="csv")
    manifest.write_text(yaml.safe_dump(data, sort_keys=False))
    result = CliRunner().invoke(main, ["fleet", str(manifest), "-o", str(tmp_path / "out")])
    assert result.exit_code == 2 and "would write" in result.output and "(the output may not overwrite an input)" in result.output, result.output
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["events"]
