"""The event store on its own: the event store's columns and dtypes, a recording replaced whole in one transaction, no
duplicate row possible, and files that are not this fleet's store refused."""

from __future__ import annotations

import math
import sqlite3
from datetime import datetime, timezone

import numpy as np
import pandas as pd
import pytest

from femref.fleet.store import ESTIMATE_COLUMNS, EVENT_COLUMNS, EventStore, RecordingRow, StoreError, read_estimates, read_events

#: The event store's columns, written out: the events columns in order.
CONTRACT_EVENTS = ["event_key", "recording", "event_index", "time", "track", "files", "cars", "coupler", "car_front", "car_rear", "gear",
                   "event_type", "closing_speed", "closing_speed_lower", "closing_speed_upper", "estimator", "peak_force",
                   "peak_force_lower", "peak_force_upper", "alarm_limit", "alarm", "closure_force", "closure_status", "wear_limit", "wear",
                   "flags", "femref_version", "calibration", "network", "histories"]
CONTRACT_ESTIMATES = ["event_key", "coupler", "estimator", "status", "peak_force", "lower", "upper", "time_of_peak"]


def _row(recording: str, index: int, coupler: str = "c1", peak: float = 1.0e6) -> dict:
    row = {column: "" for column, dtype in EVENT_COLUMNS.items() if dtype == "str"}
    row.update({column: math.nan for column, dtype in EVENT_COLUMNS.items() if dtype == "float64"})
    row.update(event_key=f"{recording}/{index}", recording=recording, event_index=index, coupler=coupler, peak_force=peak,
               time=datetime(2026, 11, 1, 6, 12, index, 250_000, tzinfo=timezone.utc), event_type="free_to_roll")
    return row


def _estimate(recording: str, index: int, estimator: str = "inverse_rigid") -> dict:
    return {"event_key": f"{recording}/{index}", "coupler": "c1", "estimator": estimator, "status": "ok", "peak_force": 1.0e6,
            "lower": math.nan, "upper": math.nan, "time_of_peak": 0.1}


def _recording(name: str, stamp: str = "s1", events: int = 2) -> RecordingRow:
    return RecordingRow(name=name, stamp=stamp, status="ok", message="", events=events, samples=10, bytes_read=100, seconds=0.1,
                        femref_version="x", start="2026-11-01 06:12:00.000000", track="yard 1", event_file=f"events/{name}.h5")


def test_the_readers_give_contract_ds_columns_and_dtypes(tmp_path):
    path = tmp_path / "events.sqlite"
    with EventStore(path, "west-yard") as store:
        store.put(_recording("r1"), [_row("r1", 0), _row("r1", 1)], [_estimate("r1", 0), _estimate("r1", 1)])
    events, estimates = read_events(path), read_estimates(path)
    assert list(events.columns) == CONTRACT_EVENTS and list(estimates.columns) == CONTRACT_ESTIMATES
    assert str(events["time"].dtype) == "datetime64[ns, UTC]" and events["event_index"].dtype == np.int64
    assert all(events[c].dtype == np.float64 for c in ("closing_speed", "peak_force", "alarm_limit", "wear_limit", "closure_force"))
    assert all(pd.api.types.is_string_dtype(events[c]) for c in ("event_key", "coupler", "alarm", "flags", "histories"))
    assert events["time"].iloc[1] == pd.Timestamp("2026-11-01 06:12:01.25", tz="UTC")  # to the microsecond, in UTC
    assert np.isnan(events["closure_force"]).all()  # NaN stored as NULL, read back as NaN
    assert list(estimates["time_of_peak"]) == [0.1, 0.1] and estimates["peak_force"].dtype == np.float64
    assert list(ESTIMATE_COLUMNS) == CONTRACT_ESTIMATES


def test_a_recording_is_replaced_whole_or_not_at_all(tmp_path):
    """Putting a recording again replaces its rows (fewer events now); a put that fails half-way (a duplicate event
    key among its rows) leaves the store as it was; the other recordings are never touched."""
    path = tmp_path / "events.sqlite"
    with EventStore(path, "west-yard") as store:
        store.put(_recording("r1"), [_row("r1", 0), _row("r1", 1)], [_estimate("r1", 0), _estimate("r1", 1)])
        store.put(_recording("r2", events=1), [_row("r2", 0)], [_estimate("r2", 0)])
        store.put(_recording("r1", stamp="s2", events=1), [_row("r1", 0, peak=2.0e6)], [_estimate("r1", 0)])
        before = read_events(path)
        with pytest.raises(sqlite3.IntegrityError):
            store.put(_recording("r2", stamp="s3"), [_row("r2", 0), _row("r2", 0)], [])
        assert store.stamps() == {"r1": ("s2", "ok"), "r2": ("s1", "ok")}
    after = read_events(path)
    pd.testing.assert_frame_equal(before, after)
    assert list(after["event_key"]) == ["r1/0", "r2/0"] and list(after["peak_force"]) == [2.0e6, 1.0e6]
    assert list(read_estimates(path)["event_key"]) == ["r1/0", "r2/0"]


def test_a_row_cannot_be_stored_twice(tmp_path):
    """The keys: (event_key, coupler) for events, (event_key, coupler, estimator) for estimates."""
    path = tmp_path / "events.sqlite"
    with EventStore(path, "west-yard") as store:
        store.put(_recording("r1"), [_row("r1", 0), _row("r1", 0, coupler="c2")], [_estimate("r1", 0), _estimate("r1", 0, "kalman")])
    with sqlite3.connect(path) as connection:
        with pytest.raises(sqlite3.IntegrityError):
            connection.execute("INSERT INTO events SELECT * FROM events LIMIT 1")
        with pytest.raises(sqlite3.IntegrityError):
            connection.execute("INSERT INTO estimates SELECT * FROM estimates LIMIT 1")


def test_another_file_or_another_fleets_store_is_refused(tmp_path):
    path = tmp_path / "events.sqlite"
    path.write_text("station,time\n")
    with pytest.raises(StoreError, match="not a femref event store"):
        EventStore(path, "west-yard")
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as connection:
        connection.execute("CREATE TABLE t (x)")
    with pytest.raises(StoreError, match="another application"):
        read_events(other)
    mine = tmp_path / "mine.sqlite"
    EventStore(mine, "west-yard").close()
    with pytest.raises(StoreError, match="the store of fleet 'west-yard', not 'east-yard'"):
        EventStore(mine, "east-yard")
