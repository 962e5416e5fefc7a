"""femref.api.open_events and open_event_histories on the yard case's event file (cases/measured_yard.yaml run by
``femref run``), against the file read here independently with h5py and against the console table's numbers; the
event histories' time axes as HDF5 dimension scales; and each reader refusing the other kind of file by name."""

from __future__ import annotations

import json
import math
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.api import FileKindError, open_event_histories, open_events, open_frames, open_result
from femref.cli import main
from femref.events import ClockCorrection, EventResult, ForceEstimate
from femref.results import ModelResult, write_results

from support.measured import write_events
from support.paths import CASES


@pytest.fixture(scope="module")
def yard(tmp_path_factory) -> tuple[Path, str]:
    """The yard case's event file and ``femref run``'s console output."""
    out = tmp_path_factory.mktemp("yard") / "yard.h5"
    result = CliRunner().invoke(main, ["run", str(CASES / "measured_yard.yaml"), "-o", str(out)], terminal_width=250)
    assert result.exit_code == 0, result.output
    return out, result.output


def h5_rows(path: Path) -> list[dict]:
    """The event table read with h5py alone: (event, estimator, coupler) → the attributes and histories it comes from."""
    rows = []
    with h5py.File(path, "r") as h5:
        limit = yaml.safe_load(h5.attrs["case_yaml"])["checks"]["alarm"]
        for name in h5["events"]:
            event = h5["events"][name]
            for estimator in event:
                if estimator in ("records", "closure", "clock"):
                    continue
                for coupler, data in event[estimator].items():
                    force, time = data["force"][()], data["time"][()]
                    closure = event["closure"][coupler].attrs if coupler in event["closure"] else {}
                    rows.append({
                        "event": int(name), "estimator": estimator, "coupler": coupler, "trigger_time_s": event.attrs["trigger_time"],
                        "type": event.attrs["impact_type"], "alarm": event.attrs["alarm"], "wear": event.attrs["wear"],
                        "closing_speed_m_per_s": event.attrs["closing_speed"], "peak_force_N": data.attrs["peak_force"],
                        "peak_force_lower_N": data.attrs["peak_lower"], "peak_force_upper_N": data.attrs["peak_upper"],
                        "time_of_peak_s": time[np.nanargmax(force)], "above_alarm_limit": data.attrs["peak_force"] > limit,
                        "closure_status": closure.get("status", ""), "closure_force_N": closure.get("closure_force", math.nan),
                        "flags": "; ".join(json.loads(event.attrs["flags"])),
                    })
    return rows


def test_open_events_is_the_files_table(yard):
    path, output = yard
    table = open_events(path)
    expected = h5_rows(path)
    assert len(table) == len(expected) == 8 and table.event.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    assert table.estimator.tolist()[:4] == ["kalman", "inverse_rigid", "inverse_quasi_rigid", "ann_fem"]  # the case's order
    found = {(row.event, row.estimator, row.coupler): row._asdict() for row in table.itertuples(index=False)}
    for want in expected:
        got = found[(want["event"], want["estimator"], want["coupler"])]
        for key, value in want.items():
            assert got[key] == value or (isinstance(value, float) and math.isnan(value) and math.isnan(got[key])), (key, got[key], value)
    assert table.above_alarm_limit.tolist() == [False] * 4 + [True] * 4
    assert set(table.closure_status) == {"not closed", "closed"} and table.alarm.tolist()[-1] == "certain"
    assert table.attrs["units"]["peak_force_N"] == "N" and table.attrs["complete"] and table.attrs["events"] == 2
    assert table.attrs["alarm_limit_N"] == 2.5e6
    for row in table.itertuples():  # the console table prints each peak in kN and each trigger time
        assert f"{row.peak_force_N / 1e3:.1f}" in output and f"{row.trigger_time_s:.4f}" in output


def test_open_event_histories_gives_an_events_histories_on_its_time(yard):
    path, _ = yard
    histories = open_event_histories(path, 1)
    with h5py.File(path, "r") as h5:
        event = h5["events/1"]
        np.testing.assert_array_equal(histories["time"].values, event["records/time"][()])
        assert histories["time"].attrs["units"] == "s"
        for probe in ("hammer/front", "anvil/rear"):
            np.testing.assert_array_equal(histories["acceleration"].sel(probe=probe).values, event[f"records/{probe}"][()])
        for estimator in ("kalman", "inverse_rigid"):
            for name in ("force", "force_lower", "force_upper"):
                np.testing.assert_array_equal(histories[name].sel(estimator=estimator, coupler="c1").values, event[f"{estimator}/c1/{name}"][()])
        assert histories["force_ann_fem"].sel(coupler="c1").item() == event["ann_fem/c1/force"][0]
        assert histories["time_ann_fem"].item() == event["ann_fem/c1/time"][0]
        assert np.isnan(histories["force"].sel(estimator="ann_fem")).all()
        assert histories["peak_force"].sel(estimator="kalman", coupler="c1").item() == event["kalman/c1"].attrs["peak_force"]
        assert histories.attrs["alarm"] == "certain" and histories["force"].attrs["units"].startswith("N")
    with pytest.raises(FileKindError, match=r"yard\.h5: no event 7; the file holds events 0, 1"):
        open_event_histories(path, 7)


def test_each_history_runs_along_its_groups_time_scale(yard):
    """Every history dataset of an event has its group's ``time`` (the records': the ``records`` group's) attached
    as the dimension scale of its axis, and xarray (h5netcdf) reads it as the coordinate."""
    path, _ = yard
    found: dict[str, list[str]] = {"scales": [], "attached": []}

    def check(name: str, item) -> None:
        if not isinstance(item, h5py.Dataset):
            return
        if name.endswith("/time"):
            assert item.is_scale, name
            found["scales"].append(name)
            return
        group = item.parent if "time" in item.parent else item.parent.parent  # a probe's records: the records group's
        assert item.dims[0][0] == group["time"], name
        found["attached"].append(name)

    with h5py.File(path, "r") as h5:
        h5["events"].visititems(check)
    assert len(found["scales"]) == 2 * (1 + 4) and len(found["attached"]) == 2 * (5 + 4 * 3)
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    with xr.open_dataset(path, group="events/1/kalman/c1", engine="h5netcdf") as ds:
        assert list(ds["force"].dims) == ["time"]
        with h5py.File(path, "r") as h5:
            np.testing.assert_array_equal(ds["time"].values, h5["events/1/kalman/c1/time"][()])


def test_a_reader_refuses_the_other_kind_of_file_by_name(yard, tmp_path):
    path, _ = yard
    for reader in (open_result, open_frames):
        with pytest.raises(FileKindError, match=r"yard\.h5: the event file of a measured case.*femref\.api\.open_events"):
            reader(path)
    simulated = tmp_path / "run.h5"
    result = ModelResult(model="rigid", axes={"time": np.linspace(0.0, 1.0, 5)})
    result.couplers = {"c1": {"force": np.arange(5.0)}}
    write_results(simulated, "kind: impact\n", [result])
    with pytest.raises(FileKindError, match=r"run\.h5: a simulated result file \(models rigid\).*femref\.api\.open_result"):
        open_events(simulated)
    with pytest.raises(FileKindError, match=r"run\.h5: a simulated result file"):
        open_event_histories(simulated, 0)


def test_an_event_without_estimates_is_one_row_and_flags_are_columns(tmp_path):
    """A ``not_an_impact`` event (no estimator run) is one row with estimator and coupler None; its gap flag and an
    estimated clock's correction are columns; a case without an alarm limit gives NaN and no row above it."""
    t = np.linspace(0.0, 0.1, 11)
    event = EventResult(index=0, start=0.0, end=0.1, trigger_time=0.02, trigger_probe="a/front", flags=("gap: a/front 0.03–0.04 s",),
                        time=t, records={"a/front": np.sin(t)}, impact_type="not_an_impact",
                        clock_corrections=(ClockCorrection("r2", 0.01, 3.0, 0.011, 0.001, "fitted"),))
    estimate = ForceEstimate("kalman", "c1", t + 0.2, np.cos(t), np.cos(t) - 1.0, np.cos(t) + 1.0, bound="covariance")
    second = EventResult(index=1, start=0.2, end=0.3, trigger_time=0.22, trigger_probe="a/front", flags=(), time=t + 0.2,
                         records={"a/front": np.sin(t)}, impact_type="coupled", estimates=[estimate])
    path = write_events(tmp_path / "events.h5", {"cars": ["a", "b"], "couplers": ["c1"], "estimators": ["kalman"]}, [event, second],
                        "kind: measured\nchecks: {}\n")
    table = open_events(path)
    assert table.event.tolist() == [0, 1] and table.estimator.isna().tolist() == [True, False]
    assert table.status.tolist() == ["not run", "ok"] and table.type.tolist() == ["not_an_impact", "coupled"]
    assert table.gap.tolist() == [True, False] and table.clock_corrected.tolist() == [True, False] and not table.saturated.any()
    assert np.isnan(table.alarm_limit_N).all() and not table.above_alarm_limit.any()
    assert table.peak_force_N[1] == 1.0 and table.time_of_peak_s[1] == 0.2 and table.peak_force_upper_N[1] == 2.0
    histories = open_event_histories(path, 1)
    np.testing.assert_array_equal(histories["force"].sel(estimator="kalman", coupler="c1").values, np.cos(t))
    assert "force" not in open_event_histories(path, 0) and open_event_histories(path, 0)["acceleration"].shape == (11, 1)


def test_a_killed_runs_torn_event_is_never_read(tmp_path):
    """A killed run's temporary (``complete = false``, ``events_written = 1``) holding event 0 whole, event 1 whole but
    not yet counted and a torn group 2 (no attributes, no records: the kill came while HDF5 wrote it): the table, the
    histories and the report read event 0 only (a report that read the torn group raised KeyError in a clean-clone CI)."""
    t = np.linspace(0.0, 0.1, 11)
    events = [EventResult(index=k, start=0.2 * k, end=0.2 * k + 0.1, trigger_time=0.2 * k + 0.02, trigger_probe="a/front", flags=(),
                          time=t + 0.2 * k, records={"a/front": np.sin(t)}, impact_type="coupled") for k in range(2)]
    path = write_events(tmp_path / "events.h5", {"cars": ["a", "b"], "couplers": ["c1"], "estimators": []}, events, "kind: measured\nchecks: {}\n")
    with h5py.File(path, "a") as h5:
        h5.attrs.update(complete=False, events_written=1)
        h5["events"].create_group("2")
    table = open_events(path)
    assert table.event.tolist() == [0] and not table.attrs["complete"]
    with pytest.raises(FileKindError, match="no event 1; the file holds events 0$"):
        open_event_histories(path, 1)
    result = CliRunner().invoke(main, ["report", str(path), "-o", str(tmp_path / "events.html")])
    assert result.exit_code == 0, result.output
    page = (tmp_path / "events.html").read_text()
    assert "the run stopped after 1 events" in page and "<th>events</th><td>1</td>" in page
