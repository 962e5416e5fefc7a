"""``femref fleet`` end to end on a small fleet of simulated impacts: the rows against ``femref run`` of each recording's
case alone, the same store with one and two workers and after a worker is killed, resumable reruns, a failed
recording, and the question the store is for, asked in plain SQL."""

from __future__ import annotations

import os
import shutil
import signal
import sqlite3
from contextlib import contextmanager
from datetime import datetime, timedelta

import distributed
import h5py
import numpy as np
import pandas as pd
import pytest
import yaml
from click.testing import CliRunner

from femref.cli import main
from femref.events import COMPLETE
from femref.fleet import runner
from femref.fleet.runner import run_fleet
from femref.fleet.store import read_estimates, read_events, read_recordings
from support.fleet import PAIRS, write_fleet

#: (days ago, impact, rear car, front car): the high impacts exceed the alarm limit.
PLAN = [
    (1.0, "high", *PAIRS[0]),
    (2.0, "low", *PAIRS[1]),
    (10.0, "high", *PAIRS[1]),
    (3.0, "high", *PAIRS[2]),
    (12.0, "low", *PAIRS[0]),
    (0.5, "low", *PAIRS[2]),
]
#: Columns of the recordings table that say how a run went, not what it found.
RUN_TIME = ["seconds"]


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory, fleet_records):
    folder = tmp_path_factory.mktemp("fleet")
    write_fleet(folder, fleet_records, PLAN)
    return folder


@pytest.fixture(scope="module")
def reference(fleet_dir):
    """The fleet run on a local cluster of one worker process: the store every other run must equal."""
    summary = run_fleet(fleet_dir / "fleet.yaml", fleet_dir / "out1", workers=1)
    assert summary.run == len(PLAN) and not summary.failures, summary.failures
    return fleet_dir / "out1" / "events.sqlite"


@pytest.fixture(scope="module")
def client(dask_client):
    """The session's cluster of two worker processes (tests/conftest.py)."""
    return dask_client


def _tables(store) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The store's three tables sorted by their keys, the run-time columns dropped."""
    events = read_events(store).sort_values(["event_key", "coupler"], ignore_index=True)
    estimates = read_estimates(store).sort_values(["event_key", "coupler", "estimator"], ignore_index=True)
    return events, estimates, read_recordings(store).drop(columns=RUN_TIME)


def assert_same_store(a, b) -> None:
    for left, right in zip(_tables(a), _tables(b)):
        pd.testing.assert_frame_equal(left, right)


def _case_by_hand(manifest: dict, recording: dict) -> dict:
    """The measured case of ``recording`` written from the manifest's data, as a user would without the fleet."""
    rear, front = recording["cars"]
    gear = manifest["gears"][recording["couplers"][0]["gear"]]
    checks = dict(manifest["defaults"]["checks"])
    if "rated_closure_force" in gear:
        checks["rated_closure_force"] = gear["rated_closure_force"]
    return {"kind": "measured", "records": recording["records"],
            "cars": [{"name": rear, **manifest["cars"][rear]}, {"name": front, **manifest["cars"][front]}],
            "couplers": [{"name": "c1", "between": [rear, front]}], "events": manifest["defaults"]["events"],
            "estimators": manifest["defaults"]["estimators"], "checks": checks}


def test_each_recordings_rows_are_what_femref_run_of_its_case_alone_writes(reference, fleet_dir):
    """Every recording's case, written by hand and run with ``femref run``: its event file's type, closing speed, alarm,
    wear, flags, every estimator's peak and the closure equal the store's rows, and the fleet's event file holds the same
    force histories; the event time is the recording's start plus the trigger time."""
    manifest = yaml.safe_load((fleet_dir / "fleet.yaml").read_text())
    events, estimates = read_events(reference), read_estimates(reference)
    assert len(events) == len(PLAN) and len(estimates) == 2 * len(PLAN)  # one event each, one coupler, two estimators
    for recording in manifest["recordings"]:
        case = fleet_dir / f"{recording['name']}.yaml"
        case.write_text(yaml.safe_dump(_case_by_hand(manifest, recording), sort_keys=False))
        alone = fleet_dir / f"{recording['name']}.alone.h5"
        result = CliRunner().invoke(main, ["run", str(case), "-o", str(alone)])
        assert result.exit_code == 0, result.output
        row = events[events["recording"] == recording["name"]].iloc[0]
        with h5py.File(alone) as h5, h5py.File(fleet_dir / "out1" / row["histories"].split("#")[0]) as fleet_h5:
            event = h5["events/0"]
            assert list(h5["events"]) == ["0"] and row["event_index"] == 0
            assert row["event_type"] == event.attrs["impact_type"] and row["alarm"] == event.attrs["alarm"] and row["wear"] == event.attrs["wear"]
            assert row["flags"] == "; ".join(yaml.safe_load(event.attrs["flags"]))
            assert row["closing_speed"] == event.attrs["closing_speed"] and row["closing_speed_upper"] == event.attrs["closing_speed_upper"]
            start = datetime.fromisoformat(recording["start"].replace("Z", "+00:00"))
            assert row["time"] == pd.Timestamp(start + timedelta(seconds=float(event.attrs["trigger_time"])))
            primary = event[f"{row['estimator']}/c1"].attrs
            assert row["estimator"] == "inverse_rigid" and row["peak_force"] == primary["peak_force"]
            closure = event["closure/c1"].attrs
            assert row["closure_status"] == closure["status"] and row["closure_force"] == closure["closure_force"]
            for _, estimate in estimates[estimates["event_key"] == row["event_key"]].iterrows():
                stored = event[f"{estimate['estimator']}/c1"]
                assert estimate["peak_force"] == stored.attrs["peak_force"] and estimate["status"] == stored.attrs["status"]
                assert estimate["time_of_peak"] == stored["time"][int(np.argmax(stored["force"][()]))]
                np.testing.assert_array_equal(fleet_h5[f"events/0/{estimate['estimator']}/c1/force"][()], stored["force"][()])
        assert row["histories"] == f"events/{recording['name']}.h5#/events/0"
        assert (row["car_rear"], row["car_front"]) == tuple(recording["cars"])
        assert row["files"] == f"{recording['name']}/hammer.csv; {recording['name']}/anvil.csv"


def test_which_cars_had_impacts_above_the_alarm_limit_in_the_last_7_days(reference):
    """Plain sqlite3 SQL on the store: the high impacts of the last 7 days (the plan's 1st and 4th) name their cars;
    the one 10 days ago and the low ones do not."""
    query = """
        SELECT DISTINCT car FROM (SELECT car_rear AS car, * FROM events UNION ALL SELECT car_front AS car, * FROM events)
        WHERE event_type != 'not_an_impact' AND peak_force > alarm_limit AND time >= datetime('now', '-7 days')
        ORDER BY car"""
    with sqlite3.connect(reference) as connection:
        cars = [car for (car,) in connection.execute(query)]
    expected = sorted({car for days, kind, *pair in PLAN if kind == "high" and days < 7 for car in pair})
    assert cars == expected == ["C0001", "C0002", "C0005", "C0006"]
    events = pd.read_sql_query("SELECT * FROM events", sqlite3.connect(reference))  # pandas reads it as it is
    assert (events["alarm"][events["peak_force"] > events["alarm_limit"]] != "none").all()


def test_one_and_two_workers_give_the_same_store(reference, fleet_dir, client):
    summary = run_fleet(fleet_dir / "fleet.yaml", fleet_dir / "out2", client=client)
    assert summary.run == len(PLAN) and summary.events == {"free_to_roll": len(PLAN)}
    assert_same_store(reference, fleet_dir / "out2" / "events.sqlite")


def test_a_rerun_skips_what_is_stored_and_replaces_a_changed_recording(reference, fleet_dir, client):
    """Rerun into a copy of the reference: nothing runs. Recording 1's recorder files replaced by the high impact's:
    only it runs again, its rows replaced (now above the limit), no row duplicated, the others' rows unchanged."""
    out = fleet_dir / "out3"
    shutil.copytree(reference.parent, out)
    manifest = fleet_dir / "fleet.yaml"
    assert run_fleet(manifest, out, client=client).skipped == len(PLAN)
    recordings = yaml.safe_load(manifest.read_text())["recordings"]
    name = recordings[1]["name"]
    kept = fleet_dir / "kept"
    shutil.copytree(fleet_dir / name, kept)  # with their modification times, put back for the tests after this one
    for file in ("hammer.csv", "anvil.csv"):
        shutil.copy(fleet_dir / recordings[0]["name"] / file, fleet_dir / name / file)
    try:
        summary = run_fleet(manifest, out, client=client)
        assert (summary.run, summary.skipped) == (1, len(PLAN) - 1)
        before, after = read_events(reference), read_events(out / "events.sqlite")
        assert len(after) == len(before) and after["event_key"].is_unique
        changed = after["recording"] == name
        pd.testing.assert_frame_equal(after[~changed].reset_index(drop=True), before[before["recording"] != name].reset_index(drop=True))
        assert after[changed]["peak_force"].iloc[0] > after[changed]["alarm_limit"].iloc[0] > before[before["recording"] == name]["peak_force"].iloc[0]
    finally:
        shutil.rmtree(fleet_dir / name)
        kept.rename(fleet_dir / name)


def test_a_recording_failing_during_its_run_is_stored_failed_and_the_others_run(fleet_dir, monkeypatch):
    """A RecordError in one recording's run (raised here for recording 2): it is stored failed with its message and no
    rows, the others run; ``femref fleet`` names it and exits 1."""
    from femref.run import measured
    from femref.sensing.recordings import RecordError

    name = yaml.safe_load((fleet_dir / "fleet.yaml").read_text())["recordings"][2]["name"]
    run_measured = measured.run_measured

    def failing(scene, *args, **kwargs):
        if any(name in str(record.path) for record in scene.records):
            raise RecordError(f"{name}/hammer.csv: row 3: time goes back")
        return run_measured(scene, *args, **kwargs)

    @contextmanager
    def in_process(scheduler, workers, given):
        with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as local:
            yield local

    monkeypatch.setattr(measured, "run_measured", failing)
    monkeypatch.setattr(runner, "dask_client", in_process)
    out = fleet_dir / "out_failed"
    result = CliRunner().invoke(main, ["fleet", str(fleet_dir / "fleet.yaml"), "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert f"error: recording {name} failed: {name}/hammer.csv: row 3: time goes back" in result.output
    assert f"{len(PLAN)} run now, 0 skipped (stored, unchanged), 1 failed" in result.output
    recordings = read_recordings(out / "events.sqlite").set_index("name")
    assert recordings.loc[name, "status"] == "failed" and "time goes back" in recordings.loc[name, "message"]
    assert (recordings.drop(index=name)["status"] == "ok").all()
    events = read_events(out / "events.sqlite")
    assert name not in set(events["recording"]) and len(events) == len(PLAN) - 1
    assert not (out / "events" / f"{name}.h5").exists()


def test_a_worker_killed_mid_run_is_restarted_and_its_recordings_run_again(reference, fleet_dir, client):
    """SIGKILL to a worker process holding tasks, after the first recording is stored: its nanny starts a new one, the
    scheduler runs the lost tasks again, and the store equals the reference."""
    pids = client.run(os.getpid)
    killed = []

    def kill_one(done, total, recording, events):
        if killed:
            return
        busy = [address for address, keys in client.processing().items() if keys]
        if busy:
            os.kill(pids[busy[0]], signal.SIGKILL)
            killed.append(pids[busy[0]])

    summary = run_fleet(fleet_dir / "fleet.yaml", fleet_dir / "out4", client=client, progress=kill_one)
    assert killed and summary.run == len(PLAN) and not summary.failures
    assert_same_store(reference, fleet_dir / "out4" / "events.sqlite")
    client.wait_for_workers(2, timeout=60)
    assert killed[0] not in client.run(os.getpid).values()
    # every event file whole under its final name and no temporary left (a kill between the creation of a temporary's
    # writer sidecar and its first byte can leave that empty sidecar: femref.core.publishing cannot tell whose it is)
    names = yaml.safe_load((fleet_dir / "fleet.yaml").read_text())["recordings"]
    files = [p for p in (fleet_dir / "out4" / "events").iterdir() if not p.name.endswith(".writer")]
    assert sorted(p.name for p in files) == sorted(f"{r['name']}.h5" for r in names)
    for path in files:
        with h5py.File(path) as h5:
            assert h5.attrs[COMPLETE], path
