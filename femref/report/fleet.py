"""The fleet report: one self-contained page of an event store's rows (docs/design.md §4.6; the store: §10.2).

:func:`write_fleet_report` writes ``folder/index.html`` with, as of ``now`` (only events up to it count):

* the **traffic lights** per gear and per car (:func:`gear_lights`, :func:`car_lights`; the rule is on the page):
  a gear is red when it is ``worn`` (:mod:`femref.fleet.wear`) or one of its impacts raised an alarm in the last
  :data:`RECENT_DAYS` days, amber when it is ``wearing`` or one of its events in those days carries flags (saturated,
  gap), green otherwise; a car red or amber by the same alarms and flags on its couplings. The store ties a gear to a
  coupling, not to a car (the fleet manifest, docs/design.md §10.1), so a car's light reads its impacts, a gear's its trend and impacts;
* the **exceedances** against the alarm limit (:func:`exceedances`: the rows whose alarm is certain or possible,
  newest first) with every estimator's peak of them (the estimates' rows);
* the **distributions** of closing speed and peak force of the impacts, by impact type, and the events that are not
  impacts counted by type and track;
* each gear's **closure force over time** with its trend, wear limit and forecast crossing;
* every event with a **link** to its page.

**Event pages.** An event's page is what ``femref report <events/x.h5>`` writes (:mod:`femref.report.measured`), one per
recording. Drawn, it costs 0.17 s and ~90 kB an event (busy machine: the gallery's measured_yard events, five
estimators) — a 30-day fleet of 20 cars and ~900 events would spend 2–3 minutes and ~80 MB on pages nobody opens,
against ~5 s for the fleet page. So the pages of the recordings that need a look are drawn into ``folder/events/`` (an
exceedance, a flag, a closure of a worn or wearing gear; ``all_event_pages`` draws every recording's), every other
event links to its HDF5 file, which ``femref report`` renders.

The folder is written under a temporary name beside it and renamed into place (a previous report replaced in one
rename; a folder that holds anything else is refused); the exports are :mod:`femref.report.fleet_export`'s.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from html import escape
from pathlib import Path, PurePosixPath
from urllib.parse import quote

import h5py
import pandas as pd

from femref.core.publishing import create_temporary, discard_temporary, remove_leftovers
from femref.events import EVENTS_GROUP
from femref.fleet.wear import MIN_EVENTS, MIN_SPAN_DAYS, RECENT_EVENTS, GearTrend, as_utc, gear_trends
from femref.report.build import build_event_pages, build_report
from femref.report.fleet_export import CSV_NAME, XLSX_EXTRA, XLSX_NAME, can_write_xlsx, write_exports
from femref.report.fleet_figures import distribution_pictures, gear_picture
from femref.report.html import page, pictures_html
from femref.report.measured import EVENTS_PER_PAGE, page_name

EVENT_COLUMNS = ("event_key", "recording", "event_index", "time", "track", "files", "cars", "coupler", "car_front", "car_rear", "gear", "event_type",
                 "closing_speed", "closing_speed_lower", "closing_speed_upper", "estimator", "peak_force", "peak_force_lower", "peak_force_upper",
                 "alarm_limit", "alarm", "closure_force", "closure_status", "wear_limit", "wear", "flags", "femref_version", "calibration", "network",
                 "histories")
"""The event store's columns of ``read_events``."""
ESTIMATE_COLUMNS = ("event_key", "coupler", "estimator", "status", "peak_force", "lower", "upper", "time_of_peak")
"""The event store's columns of ``read_estimates``."""
ALARMED = ("certain", "possible")
NOT_AN_IMPACT = "not_an_impact"
RECENT_DAYS = 7.0
"""Days before ``now`` whose alarms and flags set a light."""
LIGHT_COLORS = {"red": "#c62828", "amber": "#ef8f00", "green": "#2e7d32"}
INDEX = "index.html"
EVENT_PAGES = "events"
WRITTEN = {INDEX, CSV_NAME, XLSX_NAME, EVENT_PAGES}
"""What the report folder holds: a folder holding anything else is not a report to replace."""
KILO = 1e-3


@dataclass(frozen=True)
class Light:
    """The traffic light of a car or gear ``name`` (``red``, ``amber``, ``green``) and why."""

    name: str
    light: str
    why: str


def write_fleet_report(events: pd.DataFrame, estimates: pd.DataFrame, folder: str | Path, *, now: pd.Timestamp | str | None = None,
                       horizon_days: float = 30.0, store_folder: str | Path | None = None, all_event_pages: bool = False,
                       progress: Callable[[int, int], None] | None = None) -> Path:
    """Write the fleet report of ``events`` and ``estimates`` (the event store's frames, docs/design.md §10.2) to ``folder/index.html`` with
    ``events.csv`` (and ``events.xlsx`` with openpyxl) beside it; return the page's path.

    ``now`` (UTC, default the wall clock): the report's time — later events are left out, the lights look
    :data:`RECENT_DAYS` back and the wear trend ``horizon_days`` ahead. ``store_folder`` (default ``folder``'s parent:
    the report beside the store) is where the ``histories`` paths start; ``all_event_pages`` draws every recording's
    event pages, not only those that need a look (module docstring); ``progress(done, total)`` after each drawn.
    ValueError on a missing column, a bad ``horizon_days`` or a ``folder`` that holds something else than a report."""
    missing = [c for c in EVENT_COLUMNS if c not in events.columns] + [f"estimates.{c}" for c in ESTIMATE_COLUMNS if c not in estimates.columns]
    if missing:
        raise ValueError(f"the event store's frames lack the columns {', '.join(missing)} (femref.fleet.store.read_events/read_estimates)")
    folder = Path(folder)
    _check_folder(folder)
    store_folder = Path(store_folder) if store_folder is not None else folder.resolve().parent
    now = as_utc(now) if now is not None else pd.Timestamp.now(tz="UTC")
    known = events[events["time"] <= now].sort_values(["time", "event_key", "coupler"], ascending=[False, True, True], kind="stable")
    trends = gear_trends(known, now=now, horizon_days=horizon_days)
    gears, cars = gear_lights(known, trends, now), car_lights(known, now)
    folder.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(folder)
    temporary = create_temporary(folder, folder=True)
    try:
        drawn = _needing_pages(known, trends) if not all_event_pages else set(known["recording"])
        links = _event_pages(known, drawn, store_folder, temporary, folder, progress)
        write_exports(known.reset_index(drop=True), temporary)
        text = fleet_page(known, estimates, trends, gears, cars, links, now, horizon_days)
        (temporary / INDEX).write_text(text, encoding="utf-8")
        _publish(temporary, folder)
    except BaseException:
        discard_temporary(temporary)
        raise
    return folder / INDEX


def _check_folder(folder: Path) -> None:
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"{folder}: is a file; the fleet report is a folder")
    if folder.is_dir():
        other = sorted(p.name for p in folder.iterdir() if p.name not in WRITTEN)
        if other:
            raise ValueError(f"{folder}: holds {', '.join(other[:5])}{' …' if len(other) > 5 else ''}, not only a fleet report "
                             f"({', '.join(sorted(WRITTEN))}); choose another folder (the report replaces the folder whole)")


def _publish(temporary: Path, folder: Path) -> None:
    """Rename ``temporary`` to ``folder``; a previous report is moved aside first and removed after."""
    if not folder.exists():
        os.replace(temporary, folder)
        discard_temporary(temporary)  # its sidecar
        return
    previous = create_temporary(folder, part="old", folder=True)
    os.replace(folder, previous)
    try:
        os.replace(temporary, folder)
    except OSError:
        os.replace(previous, folder)  # the previous report back under its name
        raise
    discard_temporary(temporary)
    discard_temporary(previous)


def exceedances(events: pd.DataFrame) -> pd.DataFrame:
    """The rows whose alarm against the limit is certain or possible (femref.sensing.findings.alarm: the peak band reaches
    the limit, or a saturated channel leaves it open), newest first."""
    rows = events[events["alarm"].isin(ALARMED)]
    return rows.sort_values(["time", "event_key", "coupler"], ascending=[False, True, True], kind="stable")


def _recent(events: pd.DataFrame, now: pd.Timestamp) -> pd.DataFrame:
    return events[(events["time"] > now - pd.Timedelta(days=RECENT_DAYS)) & (events["time"] <= now)]


def _alarms_and_flags(rows: pd.DataFrame) -> tuple[str, str]:
    """Why ``rows`` (a car's or gear's recent events) make a light red (alarms) and amber (flags): "" when they do not."""
    alarmed = rows[rows["alarm"].isin(ALARMED)].drop_duplicates("event_key")
    flagged = rows[rows["flags"].fillna("") != ""].drop_duplicates("event_key")
    red = f"{len(alarmed)} alarm{'s' * (len(alarmed) != 1)} in the last {RECENT_DAYS:g} days (newest {alarmed['time'].max():%Y-%m-%d %H:%M})" if len(alarmed) else ""
    amber = f"{len(flagged)} flagged event{'s' * (len(flagged) != 1)} in the last {RECENT_DAYS:g} days" if len(flagged) else ""
    return red, amber


def gear_lights(events: pd.DataFrame, trends: dict[str, GearTrend], now: pd.Timestamp) -> list[Light]:
    """Per gear: red if worn or an alarm on its impacts in the last :data:`RECENT_DAYS` days, amber if wearing or a flagged
    event in them, else green — the worst of both, each reason given."""
    recent = _recent(events, now)
    lights = []
    for gear, trend in trends.items():
        red, amber = _alarms_and_flags(recent[recent["gear"] == gear])
        reds = [r for r in (f"worn: {trend.basis}" if trend.status == "worn" else "", red) if r]
        ambers = [a for a in (f"wearing: {trend.basis}" if trend.status == "wearing" else "", amber) if a]
        lights.append(_light(gear, reds, ambers, f"{trend.status}: {trend.basis}"))
    return lights


def car_lights(events: pd.DataFrame, now: pd.Timestamp) -> list[Light]:
    """Per car: red if an alarm on one of its couplings in the last :data:`RECENT_DAYS` days, amber if a flagged event of it
    in them, else green."""
    recent = _recent(events, now)
    cars = sorted(set(events["car_front"]) | set(events["car_rear"]) - {""})
    lights = []
    for car in cars:
        red, amber = _alarms_and_flags(recent[(recent["car_front"] == car) | (recent["car_rear"] == car)])
        count = int(((events["car_front"] == car) | (events["car_rear"] == car)).sum())
        lights.append(_light(car, [red] if red else [], [amber] if amber else [], f"no alarm or flag in the last {RECENT_DAYS:g} days ({count} rows in all)"))
    return lights


def _light(name: str, reds: list[str], ambers: list[str], otherwise: str) -> Light:
    if reds:
        return Light(name, "red", "; ".join(reds + ambers))
    if ambers:
        return Light(name, "amber", "; ".join(ambers))
    return Light(name, "green", otherwise)


def _needing_pages(events: pd.DataFrame, trends: dict[str, GearTrend]) -> set[str]:
    """The recordings whose event pages are drawn: an exceedance, a flag, or a closure of a worn or wearing gear."""
    attention = {g for g, t in trends.items() if t.status in ("worn", "wearing")}
    keys = {k for t in trends.values() if t.gear in attention for k in t.closures["event_key"]}
    needed = events["alarm"].isin(ALARMED) | (events["flags"].fillna("") != "") | events["event_key"].isin(keys)
    return set(events.loc[needed, "recording"])


def _event_pages(events: pd.DataFrame, drawn: set[str], store_folder: Path, temporary: Path, folder: Path,
                 progress: Callable[[int, int], None] | None) -> dict[str, str]:
    """Draw the event pages of the ``drawn`` recordings into ``temporary/events/`` and return every event's link (relative
    to the report's ``folder``): its page, or its HDF5 file; none when the store names no file that exists."""
    links: dict[str, str] = {}
    recordings = events.drop_duplicates("event_key")[["event_key", "recording", "event_index", "histories"]]
    todo = sorted(r for r in drawn if r)
    for done, (recording, rows) in enumerate(((r, recordings[recordings["recording"] == r]) for r in todo), start=1):
        source = _histories_file(store_folder, rows["histories"].iloc[0])
        if source is not None:
            try:
                links.update(_draw_recording(recording, source, rows, temporary / EVENT_PAGES))
            except (OSError, KeyError, ValueError):  # not an event file femref report reads (ReportInputError): its events link to it
                pass
        if progress is not None:
            progress(done, len(todo))
    for row in recordings.itertuples():
        if row.event_key not in links and (source := _histories_file(store_folder, row.histories)) is not None:
            links[row.event_key] = quote(PurePosixPath(Path(os.path.relpath(source, folder.resolve()))).as_posix())
    return links


def _histories_file(store_folder: Path, histories: str) -> Path | None:
    """The HDF5 file of an event's ``histories`` (``events/<recording>.h5#<group>``, relative to the store's folder)."""
    file = str(histories).split("#", 1)[0]
    path = (store_folder / file).resolve()
    return path if file and path.is_file() else None


def _draw_recording(recording: str, source: Path, rows: pd.DataFrame, target: Path) -> dict[str, str]:
    """Write the event pages of one recording's event file ``source`` to ``target`` and return its events' links."""
    target.mkdir(exist_ok=True)
    index = f"{recording}.html"
    (target / index).write_text(build_report(source, index), encoding="utf-8")
    for name, text in build_event_pages(source, index):
        (target / name).write_text(text, encoding="utf-8")
    with h5py.File(source, "r") as h5:
        names = sorted(h5[EVENTS_GROUP], key=int) if EVENTS_GROUP in h5 else []
    links = {}
    for row in rows.itertuples():
        group = str(row.histories).split("#", 1)[-1].rstrip("/").rsplit("/", 1)[-1]
        name = group if group in names else str(row.event_index)
        shown = index
        if len(names) > EVENTS_PER_PAGE and name in names:
            first = names.index(name) // EVENTS_PER_PAGE * EVENTS_PER_PAGE
            shown = page_name(index, first, len(names[first:first + EVENTS_PER_PAGE]), len(names))
        links[row.event_key] = f"{EVENT_PAGES}/{quote(shown)}"
    return links


def fleet_page(events: pd.DataFrame, estimates: pd.DataFrame, trends: dict[str, GearTrend], gears: list[Light], cars: list[Light],
               links: dict[str, str], now: pd.Timestamp, horizon_days: float) -> str:
    """The page (module docstring) of ``events`` as of ``now``."""
    impacts = events[events["event_type"] != NOT_AN_IMPACT]
    over = exceedances(events)
    counts = events.drop_duplicates("event_key")["event_type"].value_counts()
    facts = [("as of", f"{now:%Y-%m-%d %H:%M:%S} UTC"), ("events", f"{events['event_key'].nunique()} ({', '.join(f'{k} {v}' for k, v in counts.items())})"),
             ("recordings", str(events["recording"].nunique())), ("cars", str(len(cars))), ("gears", str(len(gears))),
             ("period", f"{events['time'].min():%Y-%m-%d} – {events['time'].max():%Y-%m-%d}" if len(events) else "no events"),
             ("exceedances", f"{over['event_key'].nunique()} events above the alarm limit (certain or possible)"),
             ("femref versions", ", ".join(sorted(set(events["femref_version"])))), ("export", _export_note())]
    drawn = [trends[g] for g in sorted(trends, key=lambda g: (["worn", "wearing"].index(trends[g].status) if trends[g].status in ("worn", "wearing") else 2, g))
             if len(trends[g].closures)]
    body = [
        '<h2 id="lights">Traffic lights</h2>', _light_rule(horizon_days), _lights_table("gear", gears, trends), _lights_table("car", cars, {}),
        '<h2 id="exceedances">Exceedances</h2>', _exceedance_table(over, estimates, links),
        '<h2 id="distributions">Distributions</h2>', pictures_html(distribution_pictures(impacts), "no impact to draw"),
        '<h2 id="not-impacts">Events that are not impacts</h2>', _not_impacts(events),
        '<h2 id="wear">Gear wear</h2>', _wear_note(horizon_days), pictures_html([gear_picture(t, now, horizon_days) for t in drawn], "no gear closed in an impact"),
        '<h2 id="events">Events</h2>', _events_table(events, links),
    ]
    return page("femref fleet report", facts, body)


def _export_note() -> str:
    xlsx = f"{XLSX_NAME} (Excel)" if can_write_xlsx() else f"no {XLSX_NAME}: pip install '{XLSX_EXTRA}' (openpyxl) and report again"
    return f"{CSV_NAME} (UTF-8 with BOM, one row per event and coupler, SI units in the header); {xlsx}"


def _light_rule(horizon_days: float) -> str:
    return (f"<p>A gear is <strong>red</strong> when it is worn (the median of its last {RECENT_EVENTS} closure forces below its wear "
            f"limit) or one of its impacts raised an alarm (certain or possible) in the last {RECENT_DAYS:g} days; <strong>amber</strong> "
            f"when it is wearing (its closure force falls significantly and its trend crosses the wear limit within {horizon_days:g} days, "
            "and no farther ahead than its closures span, or its band's latest crossing does) "
            f"or one of its events in the last {RECENT_DAYS:g} days carries flags (a saturated channel, a gap); <strong>green</strong> "
            "otherwise. A car is red or amber by the same alarms and flags on its couplings (the store ties a gear to a coupling, not to "
            "a car).</p>")


def _dot(light: str) -> str:
    return f'<td data-light="{light}"><span style="color: {LIGHT_COLORS[light]}; font-size: 1.2em;">●</span> {light}</td>'


def _lights_table(kind: str, lights: list[Light], trends: dict[str, GearTrend]) -> str:
    order = sorted(lights, key=lambda x: (list(LIGHT_COLORS).index(x.light), x.name))
    head = f"<th>{kind}</th><th>light</th>" + ("<th>status</th><th>slope (kN/day)</th><th>forecast crossing</th>" if trends else "") + "<th>why</th>"
    rows = []
    for light in order:
        extra = ""
        if trends:
            t = trends[light.name]
            slope = f"{t.slope * KILO:+.3g} [{t.slope_lower * KILO:+.3g}, {t.slope_upper * KILO:+.3g}]" if math.isfinite(t.slope) else "–"
            crossing = f"{t.crossing:%Y-%m-%d} [{_day(t.crossing_early)} – {_day(t.crossing_late)}]" if not pd.isna(t.crossing) else "–"
            extra = f"<td>{escape(t.status)}</td><td class=\"num\">{escape(slope)}</td><td>{escape(crossing)}</td>"
        rows.append(f'<tr data-{kind}="{escape(light.name)}"><th scope="row">{escape(light.name)}</th>{_dot(light.light)}{extra}<td>{escape(light.why)}</td></tr>')
    tally = ", ".join(f"{sum(x.light == c for x in lights)} {c}" for c in LIGHT_COLORS)
    return (f'<details{" open" if kind == "gear" else ""} class="{kind}s"><summary>{escape(f"{kind}s: {tally}")}</summary>'
            f'<div class="wide"><table class="lights {kind}s"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}</tbody></table></div></details>')


def _day(stamp: pd.Timestamp) -> str:
    return "never" if pd.isna(stamp) else f"{stamp:%Y-%m-%d}"


def _link(key: str, links: dict[str, str], text: str) -> str:
    return f'<a href="{escape(links[key])}">{escape(text)}</a>' if key in links else escape(text)


def _band(peak: float, lower: float, upper: float) -> str:
    if not math.isfinite(peak):
        return "–"
    band = f" [{lower * KILO:.0f} – {upper * KILO:.0f}]" if math.isfinite(lower) and math.isfinite(upper) else ""
    return f"{peak * KILO:.1f}{band}"


def _exceedance_table(over: pd.DataFrame, estimates: pd.DataFrame, links: dict[str, str]) -> str:
    if over.empty:
        return "<p>No event reached the alarm limit.</p>"
    by_coupler = {key: rows for key, rows in estimates.groupby(["event_key", "coupler"], sort=False)}
    head = "".join(f"<th>{c}</th>" for c in ("time (UTC)", "cars", "coupler", "estimator", "peak (kN) [95 % band]", "limit (kN)", "alarm", "track",
                                             "every estimator's peak (kN)", "event"))
    rows = []
    for row in over.itertuples():
        others = by_coupler.get((row.event_key, row.coupler))
        shown = "; ".join(f"{e.estimator} {_band(e.peak_force, e.lower, e.upper)}" + ("" if e.status == "ok" else f" ({e.status})")
                          for e in others.itertuples()) if others is not None else "–"
        cells = [f"{row.time:%Y-%m-%d %H:%M:%S}", row.cars, row.coupler, row.estimator, _band(row.peak_force, row.peak_force_lower, row.peak_force_upper),
                 f"{row.alarm_limit * KILO:.0f}", row.alarm, row.track, shown]
        rows.append(f'<tr data-event="{escape(row.event_key)}" data-coupler="{escape(row.coupler)}">' + "".join(f"<td>{escape(str(c))}</td>" for c in cells)
                    + f"<td>{_link(row.event_key, links, row.event_key)}</td></tr>")
    return (f"<p>{len(over)} rows of {over['event_key'].nunique()} events whose peak band reaches the alarm limit (certain: its lower end; "
            "possible: its upper end, or a saturated channel), newest first.</p>"
            f'<div class="wide"><table class="exceedances"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}</tbody></table></div>')


def _not_impacts(events: pd.DataFrame) -> str:
    per_event = events.drop_duplicates("event_key")
    table = per_event.groupby(["event_type", "track"]).size().unstack(fill_value=0)
    tracks = list(table.columns)
    head = "<th>type</th>" + "".join(f"<th>{escape(str(t))}</th>" for t in tracks) + "<th>all</th>"
    rows = "".join(f'<tr data-type="{escape(kind)}"><th scope="row">{escape(kind)}</th>' + "".join(f'<td class="num">{int(table.loc[kind, t])}</td>' for t in tracks)
                   + f'<td class="num">{int(table.loc[kind].sum())}</td></tr>' for kind in table.index)
    count = int((per_event["event_type"] == NOT_AN_IMPACT).sum())
    return (f"<p>{count} of {len(per_event)} events are not impacts (a track joint, a switch, brakes, a knock: forces not internal to the "
            "line, or no closing); the estimators skip them and they count in no distribution nor trend. Events by type and track:</p>"
            f'<div class="wide"><table class="types"><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table></div>')


def _wear_note(horizon_days: float) -> str:
    return (f"<p>Per gear, the closure force (the force at which it went solid) of each impact where it closed, against time; the Theil–Sen "
            f"line (the median of the pairwise slopes) with its 95 % band, the wear limit (the rated closure force less the wear "
            f"tolerance) and where the line and the band cross it, shown {horizon_days:g} days ahead. A trend needs at least {MIN_EVENTS} "
            f"closures over {MIN_SPAN_DAYS:g} days. Worn and wearing gears first.</p>")


def _events_table(events: pd.DataFrame, links: dict[str, str]) -> str:
    per_event = events.drop_duplicates("event_key")
    head = "".join(f"<th>{c}</th>" for c in ("time (UTC)", "event", "type", "track", "cars", "alarm", "wear", "flags"))
    rows = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in (escape(f"{r.time:%Y-%m-%d %H:%M:%S}"), _link(r.event_key, links, r.event_key), escape(r.event_type),
                                                               escape(r.track), escape(r.cars), escape(r.alarm), escape(r.wear), escape(r.flags or "")))
                   + "</tr>" for r in per_event.itertuples())
    pages = sum(1 for link in links.values() if link.startswith(f"{EVENT_PAGES}/"))
    note = (f"<p>{len(per_event)} events, newest first; {pages} link to their page (drawn for the events that need a look: an alarm, a flag, "
            "a closure of a worn or wearing gear), the others to their HDF5 file (femref report renders it).</p>")
    return f'{note}<details class="events"><summary>every event</summary><div class="wide"><table class="events"><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table></div></details>'


__all__ = ["ALARMED", "ESTIMATE_COLUMNS", "EVENT_COLUMNS", "RECENT_DAYS", "Light", "car_lights", "exceedances", "fleet_page", "gear_lights",
           "write_fleet_report"]
