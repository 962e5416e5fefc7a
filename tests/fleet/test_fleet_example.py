"""cases/fleet/yard.yaml through ``femref fleet``: its two recordings (the gallery's two yard impacts, one pair of files
each) give the events cases/measured_yard.yaml finds in the whole stream."""

from __future__ import annotations

from contextlib import contextmanager

import distributed
import pytest
import pandas as pd
from click.testing import CliRunner

from femref.case import load_case
from femref.cli import main
from femref.fleet import runner
from femref.fleet.store import read_estimates, read_events
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from support.measured import yard_case_with_inverse_estimators
from support.paths import CASES


def test_the_example_fleet_finds_the_gallery_streams_events(tmp_path, monkeypatch):
    """The same trigger instants (on each file's own clock, the events' times less the recordings' starts), types, and
    inverse peaks within 0.3 % of the whole-stream case's (measured: at most 0.11 %, inverse_quasi_rigid: the running
    baseline removed from the records starts from a shorter quiet stretch, the records differ by a few mm/s²); the
    gentle impact below the alarm limit and the gear open, the hard one above it and solid. The fleet report is written
    to OUT/report, its exceedance the hard impact; ``femref report OUT/events.sqlite -o FOLDER`` writes it again from the store."""
    @contextmanager
    def in_process(scheduler, workers, given):
        with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as local:
            yield local

    monkeypatch.setattr(runner, "dask_client", in_process)
    out = tmp_path / "yard"
    result = CliRunner().invoke(main, ["fleet", str(CASES / "fleet" / "yard.yaml"), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "2 run now" in result.output and "events: 2 (free_to_roll 2); alarms: certain 1" in result.output
    assert f"wrote {out / 'report' / 'index.html'}" in result.output
    page = (out / "report" / "index.html").read_text(encoding="utf-8")
    assert "G0001" in page and "H0001, A0001" in page
    exported = pd.read_csv(out / "report" / "events.csv", encoding="utf-8-sig")
    assert len(exported) == 2
    again = CliRunner().invoke(main, ["report", str(out / "events.sqlite"), "-o", str(tmp_path / "again")])
    assert again.exit_code == 0, again.output
    assert pd.read_csv(tmp_path / "again" / "events.csv", encoding="utf-8-sig").equals(exported)
    events = read_events(out / "events.sqlite").sort_values("time", ignore_index=True)
    estimates = read_estimates(out / "events.sqlite").set_index(["event_key", "estimator"])
    stream = run_measured(scene_from_case(load_case(yard_case_with_inverse_estimators(tmp_path)))).events
    assert len(events) == len(stream) == 2
    starts = ["2026-11-01 06:12:00", "2026-11-02 14:40:00"]
    for (_, row), whole, start in zip(events.iterrows(), stream, starts):
        assert (row["time"] - pd.Timestamp(start, tz="UTC")).total_seconds() == pytest.approx(whole.trigger_time, abs=1e-9)
        assert row["event_type"] == whole.impact_type and row["estimator"] == "kalman"
        for estimate in whole.estimates:
            assert estimates.loc[(row["event_key"], estimate.estimator), "peak_force"] == pytest.approx(estimate.peak[0], rel=3e-3)
    assert list(events["alarm"]) == ["none", "certain"] and list(events["closure_status"]) == ["not closed", "closed"]
    assert list(events["wear"]) == ["unknown", "ok"] and (events["gear"] == "G0001").all()
