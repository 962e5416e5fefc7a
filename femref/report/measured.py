"""The report of a measured case's event file (docs/design.md §4.5): the event table and, per event
and coupler, every estimator's force with its 95 % band.

Up to :data:`EVENTS_PER_PAGE` events make one page; a file of more makes an index page (:func:`event_report`)
and a page per :data:`EVENTS_PER_PAGE` events (:func:`event_pages`; docs/design.md §4.4). Read with h5py only
(the report reads files, never the product's objects).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from html import escape
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref.events import COMPLETE, EVENTS_GROUP, EVENTS_WRITTEN, NOT_ESTIMATES, finished_events, record_datasets
from femref.report.figures import MODEL_COLORS, Picture, figure_legend, new_figure, figure_png
from femref.report.html import hide_local_paths, page, pictures_html, table_row
from femref.report.read import attrs_of
from femref.sensing.diagnostics import amplitude_spectrum



@dataclass
class EstimateData:
    """One estimator's force of one coupler over an event (N) with its band and attributes."""

    estimator: str
    coupler: str
    time: NDArray[np.float64]
    force: NDArray[np.float64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    attrs: dict[str, Any]


@dataclass
class EventData:
    index: str
    attrs: dict[str, Any]
    estimates: list[EstimateData] = field(default_factory=list)
    closures: dict[str, dict[str, Any]] = field(default_factory=dict)
    clocks: dict[str, dict[str, Any]] = field(default_factory=dict)
    time: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    records: dict[str, NDArray[np.float64]] = field(default_factory=dict)


def event_report(path: Path, h5: h5py.File, output: str | None = None) -> str:
    """The page of the open event file ``h5`` (read from ``path``): the whole report when it holds at most
    :data:`EVENTS_PER_PAGE` events; else the index of the report written to ``output`` (a file name; default
    ``path``'s stem + ``.html``) — one row per event, read from the events' attributes only, each linking to its
    page of :func:`event_pages`, no figure."""
    names = finished_events(h5)
    title = f"femref report — {path.name}"
    facts = _facts(path, h5, len(names))
    if len(names) <= EVENTS_PER_PAGE:
        events = [_event(name, h5[EVENTS_GROUP][name]) for name in names]
        body = [
            "<h2>Events</h2>",
            _event_table(events, path.resolve().parent) if events else "<p>No event: no channel exceeds the trigger level.</p>",
            "<h2>Coupler forces</h2>",
            pictures_html([picture for event in events for picture in _force_pictures(event)], "no force estimate to draw"),
            "<h2>Data quality</h2>",
            pictures_html([picture for event in events for picture in _quality_pictures(event)], "no car with two sensors to check"),
        ]
        return page(title, facts, [*body, _case_section(path, h5)])
    index = output or f"{path.stem}.html"
    pages = _pages(names)
    rows = []
    for first, chunk in pages:
        link = page_name(index, first, len(chunk), len(names))
        rows += [_index_row(_event(name, h5[EVENTS_GROUP][name], histories=False), link) for name in chunk]
    links = " · ".join(f'<a href="{escape(page_name(index, first, len(chunk), len(names)))}">events {first + 1}–{first + len(chunk)}</a>'
                       for first, chunk in pages)
    body = [
        "<h2>Events</h2>",
        f"<p>{len(names)} events on {len(pages)} pages of at most {EVENTS_PER_PAGE}, each with the events' estimates and "
        f"coupler forces: {links}</p>",
        '<div class="wide"><table>' + table_row(INDEX_COLUMNS) + "".join(rows) + "</table></div>",
        _case_section(path, h5),
    ]
    return page(title, facts + [("pages", str(len(pages)))], body)


#: Events on one page of a report; a file with more gets an index page and a page per this many events.
EVENTS_PER_PAGE = 20
INDEX_COLUMNS = ("event", "trigger (s)", "type", "closing speed (m/s)", "peak (kN) per estimator", "closure", "wear", "alarm", "flags", "page")


def page_name(index: str, first: int, count: int, total: int) -> str:
    """The page of events ``first`` … ``first + count − 1`` (0-based) of a report whose index is the file ``index``:
    ``<index stem>_events_0021-0040.html`` (numbered from 1, as wide as ``total``)."""
    width = len(str(total))
    return f"{Path(index).stem}_events_{first + 1:0{width}d}-{first + count:0{width}d}.html"


def event_pages(path: Path, h5: h5py.File, output: str | None = None, progress_for: Callable[[str], Callable[[int, int], None] | None] | None = None
                ) -> Iterator[tuple[str, str]]:
    """``(file name, page)`` of each page of :data:`EVENTS_PER_PAGE` events of the report whose index is ``output``
    (:func:`event_report`; nothing when the file holds no more than one page): the events' table and their coupler
    forces, drawn one event at a time. ``progress_for(label)`` is called as each page starts (``events 21–40 of
    1000``) and the callback it may return gets ``(done, total)`` after each event drawn."""
    names = finished_events(h5)
    if len(names) <= EVENTS_PER_PAGE:
        return
    index = output or f"{path.stem}.html"
    for first, chunk in _pages(names):
        label = f"events {first + 1}–{first + len(chunk)} of {len(names)}"
        step = progress_for(label) if progress_for is not None else None
        events, pictures, quality = [], [], []
        for done, name in enumerate(chunk, start=1):
            event = _event(name, h5[EVENTS_GROUP][name])
            pictures += _force_pictures(event)
            quality += _quality_pictures(event)
            events.append(event)
            if step is not None:
                step(done, len(chunk))
        body = [
            f'<p><a href="{escape(Path(index).name)}">index of all {len(names)} events</a></p>',
            "<h2>Events</h2>", _event_table(events, path.resolve().parent),
            "<h2>Coupler forces</h2>", pictures_html(pictures, "no force estimate to draw"),
            "<h2>Data quality</h2>", pictures_html(quality, "no car with two sensors to check"),
        ]
        yield page_name(index, first, len(chunk), len(names)), page(f"femref report — {path.name}, {label}", [("result file", path.name)], body)


def _pages(names: list[str]) -> list[tuple[int, list[str]]]:
    return [(first, names[first:first + EVENTS_PER_PAGE]) for first in range(0, len(names), EVENTS_PER_PAGE)]


def _facts(path: Path, h5: h5py.File, count: int) -> list[tuple[str, str]]:
    facts = [("result file", path.name), ("scene", "measured"), ("events", str(count)),
             ("femref version", str(h5.attrs.get("femref_version", "unknown"))), ("created", str(h5.attrs.get("created", "unknown")))]
    if not h5.attrs.get(COMPLETE, True):  # a killed run's temporary: the events finished before the kill
        facts.append(("complete", f"no: the run stopped after {int(h5.attrs.get(EVENTS_WRITTEN, count))} events"))
    return facts


def _case_section(path: Path, h5: h5py.File) -> str:
    return f"<h2>Resolved case</h2>\n<pre>{escape(hide_local_paths(str(h5.attrs.get('case_yaml', '')), path.resolve().parent))}</pre>"


def _index_row(event: EventData, link: str) -> str:
    a = event.attrs
    peaks = "; ".join(f"{e.estimator} {_number(e.attrs['peak_force'] / 1e3, '{:.1f}')}" + ("" if e.attrs["status"] == "ok" else f" ({e.attrs['status']})")
                      for e in event.estimates)
    closure = "; ".join(f"{c}: {v['status']}" for c, v in event.closures.items())
    cells = [event.index, f"{a['trigger_time']:.4f}", a["impact_type"], _closing_speed(a), peaks, closure, a["wear"], a["alarm"],
             "; ".join(json.loads(a.get("flags", "[]")))]
    return "<tr>" + "".join(f"<td>{escape(str(cell))}</td>" for cell in cells) + f'<td><a href="{escape(link)}">page</a></td></tr>'


def _event(name: str, group: h5py.Group, histories: bool = True) -> EventData:
    """An event group as read: its attributes, each estimate's (with its histories unless ``histories`` is False:
    the index reads no dataset) and the closures."""
    event = EventData(name, attrs_of(group.attrs))
    for estimator, sub in group.items():
        if estimator in NOT_ESTIMATES:
            continue
        for coupler, data in sub.items():
            keys = ("time", "force", "force_lower", "force_upper")
            arrays = [np.asarray(data[key][()], dtype=float) if histories else np.empty(0) for key in keys]
            event.estimates.append(EstimateData(estimator, coupler, *arrays, attrs_of(data.attrs)))
    if "closure" in group:
        event.closures = {coupler: attrs_of(sub.attrs) for coupler, sub in group["closure"].items()}
    if "clock" in group:
        event.clocks = {recorder: attrs_of(sub.attrs) for recorder, sub in group["clock"].items()}
    if histories and "records" in group:
        records = group["records"]
        event.time = np.asarray(records["time"][()], dtype=float)
        event.records = {probe: np.asarray(data[()], dtype=float) for probe, data in record_datasets(records).items()}
    return event


def _closing_speed(attrs: dict[str, Any]) -> str:
    """An event's closing speed with its interval and where it came from (m/s); files written before the interval
    existed show the speed alone."""
    speed = _number(attrs["closing_speed"], "{:.2f}")
    if not speed or "closing_speed_lower" not in attrs:
        return speed
    return f"{speed} [{attrs['closing_speed_lower']:.2f} – {attrs['closing_speed_upper']:.2f}] ({attrs['closing_speed_source']})"


def _event_table(events: list[EventData], folder: Path) -> str:
    """The events' table and their notes; every message shows a local path relative to ``folder`` (the result file's)
    or by name (:func:`femref.report.html.hide_local_paths`)."""
    columns = ("event", "trigger (s)", "type", "ρ0", "closing speed (m/s)", "estimator", "coupler", "status", "peak (kN)",
               "95 % band (kN)", "bound", "closure", "wear", "alarm", "flags")
    rows = []
    for event in events:
        a = event.attrs
        closure = "; ".join(f"{c}: {v['status']}" + (f" at {v['closure_force'] / 1e3:.0f} kN" if v["status"] == "closed" else "")
                            for c, v in event.closures.items())
        flags = hide_local_paths("; ".join(json.loads(a.get("flags", "[]"))), folder)
        head = [event.index, f"{a['trigger_time']:.4f}", a["impact_type"], _number(a["zero_harmonic_ratio"], "{:.2f}"), _closing_speed(a)]
        tail = [closure, a["wear"], a["alarm"], flags]
        if not event.estimates:  # not an impact, or no estimator: the event's own row
            rows.append(table_row((), [*head, "none run", "", "", "", "", "", *tail]))
        for k, estimate in enumerate(event.estimates):
            e = estimate.attrs
            band = f"{e['peak_lower'] / 1e3:.0f} – {e['peak_upper'] / 1e3:.0f}" if math.isfinite(e["peak_lower"]) else ""
            status = e["status"] if e["status"] == "ok" else f"{e['status']}: {hide_local_paths(str(e['message']), folder)}"
            rows.append(table_row((), [*(head if k == 0 else [""] * len(head)), estimate.estimator, estimate.coupler, status,
                                       _number(e["peak_force"] / 1e3, "{:.1f}"), band, e["bound"], *(tail if k == 0 else [""] * len(tail))]))
    header = table_row(columns)
    notes = [f"event {event.index}: {_type_basis(event.attrs)}closing speed — {event.attrs.get('closing_speed_basis', '')}; "
             f"alarm — {event.attrs['alarm_basis']}; wear — {event.attrs['wear_basis']}"
             + "".join(f"; clock {recorder}: correction {c['correction']:+.6f} s, drift {c['drift']:+.2f} ppm, lag {c['lag']:+.6f} s "
                       f"(residual {c['residual']:+.2e} s) — {c['basis']}" for recorder, c in event.clocks.items())
             + _kalman_masses(event)
             for event in events]
    return f'<div class="wide"><table>{header}{"".join(rows)}</table></div>' + "".join(f"<p>{escape(hide_local_paths(n, folder))}</p>" for n in notes)


def _kalman_masses(event: EventData) -> str:
    """Which car masses the kalman band took as measured (``settings["car_masses"]``, written only where one was):
    each car's source and relative tolerance; nothing where every mass was declared."""
    for estimate in (e for e in event.estimates if e.estimator == "kalman"):
        masses = json.loads(estimate.attrs.get("settings", "{}")).get("car_masses")
        if masses:
            return "; kalman masses — " + ", ".join(f"{car} {m['source']} ±{100 * m['tolerance']:g} %" for car, m in masses.items())
    return ""


def _type_basis(attrs: dict[str, Any]) -> str:
    """Why the event has its type (files written before the momentum evidence existed: nothing)."""
    basis = attrs.get("classification_basis", "")
    return f"type {attrs['impact_type']} — {basis}; " if basis else ""


def _force_pictures(event: EventData) -> list[Picture]:
    pictures = []
    for coupler in dict.fromkeys(e.coupler for e in event.estimates):
        figure, (ax,) = new_figure()
        drawn = []
        for k, estimate in enumerate(e for e in event.estimates if e.coupler == coupler):
            if estimate.attrs["status"] != "ok":
                continue
            color = MODEL_COLORS[k % len(MODEL_COLORS)]
            t = estimate.time - float(event.attrs["trigger_time"])
            ax.plot(t, estimate.force / 1e3, color=color, lw=1.3, label=f"{estimate.estimator} ({estimate.attrs['bound']})")
            if np.any(np.isfinite(estimate.lower)):
                ax.fill_between(t, estimate.lower / 1e3, estimate.upper / 1e3, color=color, alpha=0.25, lw=0, label=f"{estimate.estimator} 95 % band")
            drawn.append(estimate.estimator)
        ax.set(xlabel="time after the trigger (s)", ylabel="coupler force (kN, compression +)", title=f"event {event.index}, coupler {coupler}")
        figure_legend(ax)
        caption = (f"Event {event.index} ({event.attrs['impact_type']}), coupler {coupler}: each estimator's force, "
                   f"its 95 % band shaded where it has one; drawn: {', '.join(drawn) or 'none'}.")
        pictures.append(Picture(f"event {event.index} — {coupler}", caption, figure_png(figure)))
    return pictures


SPECTRUM_TOP = 250.0
"""Hz: the spectra are drawn up to this frequency (or the records' Nyquist frequency), past a car's first modes."""


def _quality_pictures(event: EventData) -> list[Picture]:
    """The source's data-quality view of an event: the amplitude spectra of each car's rear-most record ``a₁``, of its
    end difference ``a₂ − a₁`` and of the first coupler's first estimate, each scaled to its largest value, with the
    diagnostics' findings in the caption (:mod:`femref.sensing.diagnostics`)."""
    diagnostics = json.loads(event.attrs.get("diagnostics", "{}") or "{}")
    ends = diagnostics.get("ends", [])
    if not ends or event.time.size < 2:
        return []
    time = event.time
    dt = float(time[1] - time[0])
    figure, (ax,) = new_figure()
    k = 0
    for end in ends:
        rear, front = (event.records.get(f"{end['car']}/{sensor}") for sensor in (end["rear"], end["front"]))
        if rear is None or front is None:
            continue
        for label, signal in ((f"{end['car']} a1 ({end['rear']})", rear), (f"{end['car']} a2 − a1 ({end['front']} − {end['rear']})", front - rear)):
            frequency, amplitude = amplitude_spectrum(signal, dt)
            ax.semilogy(frequency, amplitude / max(float(amplitude.max()), 1e-300), color=MODEL_COLORS[k % len(MODEL_COLORS)], lw=1.1, label=label)
            k += 1
    force = next((e for e in event.estimates if e.attrs["status"] == "ok" and e.time.size > 1), None)
    if force is not None:
        frequency, amplitude = amplitude_spectrum(force.force, float(force.time[1] - force.time[0]))
        ax.semilogy(frequency, amplitude / max(float(amplitude.max()), 1e-300), color="black", lw=1.1, ls="--",
                    label=f"force, {force.estimator} at {force.coupler}")
    ax.set(xlim=(0.0, min(SPECTRUM_TOP, 0.5 / dt)), ylim=(1e-4, 2.0), xlabel="frequency (Hz)", ylabel="|A(f)| / max |A|",
           title=f"event {event.index}: spectra")
    figure_legend(ax)
    findings = "; ".join(f"{end['car']}: the ends' velocities differ by {end['elongation_rate']:.3g} m/s after the contact "
                         f"(allowed {end['allowed']:.3g}), |D(0)|/max|D| = {end['zero_ratio']:.3g}" for end in ends)
    caption = (f"Event {event.index}: amplitude spectra, each scaled to its largest value. A car's a2 − a1 should start at the "
               f"origin (its body returns to its length); zero-frequency content there is a gain mismatch or an offset between "
               f"its end sensors. {findings}.")
    return [Picture(f"event {event.index} — spectra", caption, figure_png(figure))]


def _number(value: float, pattern: str) -> str:
    return "" if value is None or not math.isfinite(float(value)) else pattern.format(value)


__all__ = ["EVENTS_PER_PAGE", "event_pages", "event_report", "page_name"]
