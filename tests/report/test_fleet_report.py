"""The fleet report (femref.report.fleet) of synthetic event-store frames (the event store's columns, docs/design.md §10.2): the exceedance table
against a pandas filter, the CSV through pandas, the traffic lights against their rule recomputed here, a wearing gear
amber before it crosses and red after, event pages linked, the folder written whole or not at all, and the page in
headless Chromium (the check of tests/report/test_report.py)."""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from femref.fleet.wear import gear_trends
from femref.report.fleet import ALARMED, ESTIMATE_COLUMNS, RECENT_DAYS, write_fleet_report
from femref.report.fleet_export import UNITS, can_write_xlsx, header

from support.fleet_events import RATED, START, WEAR_LIMIT, fleet_events, linear_gear

NOW = START + pd.Timedelta(days=30)
WEARING = "G0007"
CARS = 10  # in the module's fleet: one gear and one figure (~1 s busy) per car


def estimates_of(events: pd.DataFrame) -> pd.DataFrame:
    """Two estimators per impact row: the primary (the row's peak and band) and a second 3 % lower."""
    impacts = events[events["estimator"] != ""]
    primary = pd.DataFrame({"event_key": impacts["event_key"], "coupler": impacts["coupler"], "estimator": impacts["estimator"], "status": "ok",
                            "peak_force": impacts["peak_force"], "lower": impacts["peak_force_lower"], "upper": impacts["peak_force_upper"],
                            "time_of_peak": 0.12})
    second = primary.assign(estimator="kalman", peak_force=0.97 * primary["peak_force"], lower=0.96 * primary["peak_force"], upper=0.98 * primary["peak_force"])
    return pd.concat([primary, second], ignore_index=True)[list(ESTIMATE_COLUMNS)]


class Rows(HTMLParser):
    """The ``data-*`` attributes of the page's rows and cells, in order."""

    def __init__(self) -> None:
        super().__init__()
        self.rows: list[dict[str, str]] = []
        self.table = ""

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self.table = attrs.get("class", "")
        elif tag == "tr":
            self.rows.append({"table": self.table, **{k: v for k, v in attrs.items() if k.startswith("data-")}})
        elif tag == "td" and "data-light" in attrs and self.rows:
            self.rows[-1]["light"] = attrs["data-light"]


def rows_of(page: str, table: str) -> list[dict[str, str]]:
    parser = Rows()
    parser.feed(page)
    return [row for row in parser.rows if row["table"] == table and len(row) > 1]  # the header rows carry no data


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """CARS cars × 30 days with alarms, flags and a gear crossing its wear limit at day 20, reported at day 30."""
    events = fleet_events(cars=CARS, days=30, seed=11, closure=linear_gear(WEARING, RATED, 20.0), saturated=0.01, gaps=0.02)
    folder = tmp_path_factory.mktemp("fleet") / "report"
    index = write_fleet_report(events, estimates_of(events), folder, now=NOW)
    return events, folder, index.read_text(encoding="utf-8")


def test_the_exceedance_table_holds_the_events_above_the_limit(fleet):
    """Exactly the rows whose peak band reaches the limit or whose channel saturated (the store's alarm rule), newest first."""
    events, _, page = fleet
    above = events[(events["peak_force_upper"] >= events["alarm_limit"]) | events["flags"].str.startswith("saturated")]
    above = above[above["time"] <= NOW]
    shown = rows_of(page, "exceedances")
    assert len(above) > 3
    assert sorted((r["data-event"], r["data-coupler"]) for r in shown) == sorted(zip(above["event_key"], above["coupler"]))
    times = events.set_index("event_key").loc[[r["data-event"] for r in shown], "time"]
    assert times.is_monotonic_decreasing


def test_the_csv_round_trips_through_pandas(fleet):
    """events.csv opens with a UTF-8 byte-order mark, carries each SI unit in its header and reads back, through pandas, to
    the rows (newest first) with every number equal, the times to the microsecond (ISO 8601, UTC)."""
    events, folder, _ = fleet
    raw = (folder / "events.csv").read_bytes()
    assert raw.startswith(b"\xef\xbb\xbf")
    back = pd.read_csv(folder / "events.csv", encoding="utf-8-sig", keep_default_na=False, na_values=[""])
    assert list(back.columns) == [header(c) for c in events.columns]
    assert header("peak_force") == "peak_force (N)" and header("closing_speed") == "closing_speed (m/s)" and UNITS["time"] == "UTC"
    expected = events.sort_values(["time", "event_key", "coupler"], ascending=[False, True, True], kind="stable").reset_index(drop=True)
    assert ((pd.to_datetime(back["time (UTC)"], utc=True) - expected["time"]).abs() < pd.Timedelta(microseconds=1)).all()
    for column in UNITS:
        if column != "time":
            np.testing.assert_array_equal(back[header(column)].to_numpy(float), expected[column].to_numpy(float))
    for column in ("event_key", "cars", "alarm", "flags", "histories"):
        assert back[column].fillna("").astype(str).tolist() == expected[column].tolist()
    assert back["event_index"].tolist() == expected["event_index"].tolist()


def test_the_xlsx_or_how_to_get_it(fleet):
    """events.xlsx with openpyxl (the same rows), else the page names the extra that brings it."""
    events, folder, page = fleet
    if not can_write_xlsx():
        assert not (folder / "events.xlsx").exists() and "pip install &#x27;femref[report]&#x27;" in page
        return
    back = pd.read_excel(folder / "events.xlsx", sheet_name="events")
    assert len(back) == len(events) and list(back.columns) == [header(c) for c in events.columns]
    expected = events.sort_values(["time", "event_key", "coupler"], ascending=[False, True, True], kind="stable")
    # a spreadsheet cell keeps 15 significant digits (Excel's precision; openpyxl writes them so)
    np.testing.assert_allclose(back[header("peak_force")].to_numpy(float), expected["peak_force"].to_numpy(float), rtol=1e-15, atol=0.0)


def test_the_traffic_lights_follow_the_rule(fleet):
    """Per car and gear, the light recomputed from the rule on the frame (alarms and flags of the last 7 days, the gear's
    trend status): red, amber, green as the page shows them."""
    events, _, page = fleet
    recent = events[(events["time"] > NOW - pd.Timedelta(days=RECENT_DAYS)) & (events["time"] <= NOW)]
    trends = gear_trends(events, now=NOW)

    def light(rows, red=False, amber=False):
        if red or rows["alarm"].isin(ALARMED).any():
            return "red"
        return "amber" if amber or (rows["flags"] != "").any() else "green"

    cars = {r["data-car"]: r["light"] for r in rows_of(page, "lights cars")}
    gears = {r["data-gear"]: r["light"] for r in rows_of(page, "lights gears")}
    names = sorted(set(events["car_front"]) | set(events["car_rear"]))
    assert cars == {car: light(recent[(recent["car_front"] == car) | (recent["car_rear"] == car)]) for car in names}
    assert gears == {gear: light(recent[recent["gear"] == gear], trends[gear].status == "worn", trends[gear].status == "wearing")
                     for gear in sorted(set(events["gear"]))}
    assert {"red", "amber", "green"} <= set(cars.values()) | set(gears.values())


@pytest.mark.parametrize(("day", "light"), [(14, "amber"), (30, "red")])
def test_a_wearing_gear_is_amber_before_it_crosses_and_red_after(tmp_path, day, light):
    """8 cars × 30 days, no alarm nor flag, gear G0007 falling through its wear limit at day 20: the report at day 14 shows
    it amber (wearing; its closures still above the limit), at day 30 red (worn); every other gear green both days."""
    events = fleet_events(cars=8, days=30, seed=2, closure=linear_gear(WEARING, RATED, 20.0), hot=0.0, saturated=0.0)
    now = START + pd.Timedelta(days=day)
    page = write_fleet_report(events, estimates_of(events), tmp_path / "report", now=now).read_text(encoding="utf-8")
    gears = {r["data-gear"]: r["light"] for r in rows_of(page, "lights gears")}
    assert gears.pop(WEARING) == light
    assert set(gears.values()) == {"green"}
    if day < 20:
        closed = events[(events["gear"] == WEARING) & (events["closure_status"] == "closed") & (events["time"] <= now)]
        assert closed["closure_force"].min() > WEAR_LIMIT


def test_the_folder_is_written_whole_or_refused(tmp_path):
    """A rerun replaces the previous report (no temporary left beside it); a folder holding anything else is refused with
    nothing written; a frame without the event store's columns is refused."""
    events = fleet_events(cars=3, days=3, seed=1)
    estimates = estimates_of(events)
    folder = tmp_path / "report"
    write_fleet_report(events, estimates, folder, now=NOW)
    (folder / "index.html").write_text("old", encoding="utf-8")
    write_fleet_report(events, estimates, folder, now=NOW)
    assert (folder / "index.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("keep", encoding="utf-8")
    with pytest.raises(ValueError, match="notes.txt"):
        write_fleet_report(events, estimates, other, now=NOW)
    assert sorted(p.name for p in other.iterdir()) == ["notes.txt"]
    with pytest.raises(ValueError, match="closure_force"):
        write_fleet_report(events.drop(columns="closure_force"), estimates, tmp_path / "x", now=NOW)
    assert not (tmp_path / "x").exists()


@pytest.fixture(scope="module")
def yard_events(tmp_path_factory) -> Path:
    """The event file of cases/measured_yard.yaml (two events, the inverse estimators)."""
    from femref.api import run_case

    from support.measured import yard_case_with_inverse_estimators

    folder = tmp_path_factory.mktemp("yard")
    output = folder / "events" / "2026-11-01T06-12_C0001_C0002.h5"
    output.parent.mkdir()
    run_case(yard_case_with_inverse_estimators(folder), output)
    return output


def test_events_link_to_their_pages(tmp_path, yard_events):
    """A recording with an exceedance gets its event page drawn beside the report (the page femref report writes of its
    HDF5 file); a recording that needs no look links to its HDF5 file, and so does one whose file is no event file; a
    recording whose file is missing links nowhere."""
    store = tmp_path / "out"
    (store / "events").mkdir(parents=True)
    shutil.copy(yard_events, store / "events" / yard_events.name)
    shutil.copy(yard_events, store / "events" / "quiet.h5")
    (store / "events" / "broken.h5").write_bytes(b"not HDF5")
    events = fleet_events(cars=2, days=1, seed=4, hot=0.0, saturated=0.0).head(4).copy()
    events["recording"] = [yard_events.stem, "quiet", "gone", "broken"]
    events["event_index"] = [1, 0, 0, 0]
    events["event_key"] = [f"{r}/{k}" for r, k in zip(events["recording"], events["event_index"])]
    events["histories"] = [f"events/{r}.h5#events/{k}" for r, k in zip(events["recording"], events["event_index"])]
    events["event_type"], events["estimator"] = "free_to_roll", "inverse_rigid"
    for row in (0, 3):
        events.loc[events.index[row], ["peak_force", "peak_force_lower", "peak_force_upper", "alarm"]] = [2.6e6, 2.55e6, 2.65e6, "certain"]
    page = write_fleet_report(events, estimates_of(events), store / "report", now=NOW).read_text(encoding="utf-8")
    inverse = {text: href for href, text in re.findall(r'<a href="([^"]+)">([^<]+)</a>', page)}
    drawn = inverse[f"{yard_events.stem}/1"]
    assert drawn == f"events/{yard_events.stem}.html"
    assert "inverse_rigid" in (store / "report" / drawn).read_text(encoding="utf-8")
    assert inverse["quiet/0"] == "../events/quiet.h5" and inverse["broken/0"] == "../events/broken.h5"
    assert "gone/0" not in inverse
    assert sorted(p.name for p in (store / "report" / "events").iterdir()) == [f"{yard_events.stem}.html"]


def _chromium() -> str | None:
    return next((p for name in ("chromium", "chromium-browser", "google-chrome") if (p := shutil.which(name))), None)


PROBE = """<script>
var femrefErrors = [];
window.addEventListener("error", function (e) { femrefErrors.push(String(e.message || (e.target && e.target.tagName) || "error")); }, true);
window.addEventListener("load", function () {
  var images = Array.prototype.slice.call(document.images);
  var loaded = images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var sections = Array.prototype.map.call(document.querySelectorAll("h2"), function (h) { return h.id; });
  document.body.setAttribute("data-images", loaded + "/" + images.length);
  document.body.setAttribute("data-errors", femrefErrors.join(" | "));
  document.body.setAttribute("data-width", document.documentElement.scrollWidth + "/" + window.innerWidth);
  document.body.setAttribute("data-sections", sections.join(" "));
});
</script>"""


@pytest.mark.skipif(_chromium() is None, reason="no headless Chromium (chromium, chromium-browser or google-chrome) on PATH; scripts/install-chromium.sh")
def test_the_page_renders_in_chromium(fleet, tmp_path):
    """Headless Chromium at 1280 px renders the page: every section, every image decoded (two distributions and one
    figure per gear that closed), no error event or console message, nothing wider than the window."""
    _, _, page = fleet
    assert "<script" not in page and 'src="http' not in page and "<link" not in page
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</head>", PROBE + "</head>"), encoding="utf-8")
    command = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
               "--virtual-time-budget=10000", "--window-size=1280,900", "--dump-dom", probe.as_uri()]
    done = subprocess.run(command, capture_output=True, text=True, timeout=180)
    found = {key: re.search(rf'data-{key}="([^"]*)"', done.stdout) for key in ("images", "errors", "width", "sections")}
    assert all(found.values()), done.stderr[-2000:]
    facts = {key: match.group(1) for key, match in found.items()}
    assert facts["sections"] == "lights exceedances distributions not-impacts wear events"
    images = page.count("<img ")
    assert images == 2 + CARS and facts["images"] == f"{images}/{images}"
    assert facts["errors"] == ""
    assert [line for line in done.stderr.splitlines() if ":CONSOLE" in line] == []
    assert facts["width"] == "1280/1280"


def test_the_command_refuses_an_sqlite_file_that_is_no_store(tmp_path):
    """``femref report X.sqlite`` knows a store by its SQLite header and reads it with femref.fleet.store's readers (the
    store written by ``femref fleet``: tests/fleet/test_fleet_example.py renders one); an SQLite file that is no event
    store exits 2 with nothing written."""
    import sqlite3

    from femref.cli.report import report_command

    store = tmp_path / "events.sqlite"
    with sqlite3.connect(store) as connection:
        connection.execute("CREATE TABLE t (x)")
    done = CliRunner().invoke(report_command, [str(store), "-o", str(tmp_path / "other")])
    assert done.exit_code == 2 and "not a femref event store" in done.output and not (tmp_path / "other").exists()
