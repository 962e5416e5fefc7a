"""The report page of a measured case's event file (docs/design.md §4.5): the event table and, per event
and coupler, every estimator's force with its 95 % band.

Read with h5py only (the report reads files, never the product's objects); drawn with the
figures' Agg helpers; assembled like the result-file page (:mod:`femref.report.html`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from html import escape
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from femref.core.catalog import SCENE_GROUP
from femref.events import EVENTS_GROUP
from femref.report.figures import MODEL_COLORS, Picture, _legend, _new_figure, figure_png
from femref.report.html import STYLE, _pictures, hide_local_paths

NOT_ESTIMATES = ("records", "closure")


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


def is_event_file(h5: h5py.File) -> bool:
    """Whether an open femref file is a measured case's event file."""
    return SCENE_GROUP in h5 and h5[SCENE_GROUP].attrs.get("kind") == "measured"


def event_report(path: Path, h5: h5py.File) -> str:
    """The whole page of the open event file ``h5`` (read from ``path``)."""
    events = [_event(name, group) for name, group in sorted(h5[EVENTS_GROUP].items(), key=lambda item: int(item[0]))] if EVENTS_GROUP in h5 else []
    title = f"femref report — {path.name}"
    facts = [("result file", path.name), ("scene", "measured"), ("events", str(len(events))),
             ("femref version", str(h5.attrs.get("femref_version", "unknown"))), ("created", str(h5.attrs.get("created", "unknown")))]
    body = [
        f"<h1>{escape(title)}</h1>",
        '<table class="facts">' + "".join(f"<tr><th>{escape(k)}</th><td>{escape(v)}</td></tr>" for k, v in facts) + "</table>",
        "<h2>Events</h2>",
        _event_table(events) if events else "<p>No event: no channel exceeds the trigger level.</p>",
        "<h2>Coupler forces</h2>",
        _pictures([picture for event in events for picture in _force_pictures(event)], "no force estimate to draw"),
        "<h2>Resolved case</h2>",
        f"<pre>{escape(hide_local_paths(str(h5.attrs.get('case_yaml', '')), path.resolve().parent))}</pre>",
    ]
    head = f'<head><meta charset="utf-8"/><title>{escape(title)}</title><style>{STYLE}</style></head>'
    return "<!DOCTYPE html>\n<html lang=\"en\">\n" + head + "\n<body>\n" + "\n".join(body) + "\n</body>\n</html>\n"


def _event(name: str, group: h5py.Group) -> EventData:
    event = EventData(name, {k: _value(v) for k, v in group.attrs.items()})
    for estimator, sub in group.items():
        if estimator in NOT_ESTIMATES:
            continue
        for coupler, data in sub.items():
            arrays = [np.asarray(data[key][()], dtype=float) for key in ("time", "force", "force_lower", "force_upper")]
            event.estimates.append(EstimateData(estimator, coupler, *arrays, {k: _value(v) for k, v in data.attrs.items()}))
    if "closure" in group:
        event.closures = {coupler: {k: _value(v) for k, v in sub.attrs.items()} for coupler, sub in group["closure"].items()}
    return event


def _closing_speed(attrs: dict[str, Any]) -> str:
    """An event's closing speed with its interval and where it came from (m/s); files written before the interval
    existed show the speed alone."""
    speed = _number(attrs["closing_speed"], "{:.2f}")
    if not speed or "closing_speed_lower" not in attrs:
        return speed
    return f"{speed} [{attrs['closing_speed_lower']:.2f} – {attrs['closing_speed_upper']:.2f}] ({attrs['closing_speed_source']})"


def _event_table(events: list[EventData]) -> str:
    columns = ("event", "trigger (s)", "type", "ρ0", "closing speed (m/s)", "estimator", "coupler", "status", "peak (kN)",
               "95 % band (kN)", "bound", "closure", "wear", "alarm", "flags")
    rows = []
    for event in events:
        a = event.attrs
        closure = "; ".join(f"{c}: {v['status']}" + (f" at {v['closure_force'] / 1e3:.0f} kN" if v["status"] == "closed" else "")
                            for c, v in event.closures.items())
        flags = "; ".join(json.loads(a.get("flags", "[]")))
        for k, estimate in enumerate(event.estimates):
            e = estimate.attrs
            band = f"{e['peak_lower'] / 1e3:.0f} – {e['peak_upper'] / 1e3:.0f}" if math.isfinite(e["peak_lower"]) else ""
            status = e["status"] if e["status"] == "ok" else f"{e['status']}: {e['message']}"
            head = k == 0
            cells = [
                event.index if head else "", f"{a['trigger_time']:.4f}" if head else "", a["impact_type"] if head else "",
                _number(a["zero_harmonic_ratio"], "{:.2f}") if head else "", _closing_speed(a) if head else "",
                estimate.estimator, estimate.coupler, status, _number(e["peak_force"] / 1e3, "{:.1f}"), band, e["bound"],
                closure if head else "", a["wear"] if head else "", a["alarm"] if head else "", flags if head else "",
            ]
            rows.append("<tr>" + "".join(f"<td>{escape(str(cell))}</td>" for cell in cells) + "</tr>")
    header = "<tr>" + "".join(f"<th>{escape(c)}</th>" for c in columns) + "</tr>"
    notes = [f"event {event.index}: closing speed — {event.attrs.get('closing_speed_basis', '')}; alarm — {event.attrs['alarm_basis']}; "
             f"wear — {event.attrs['wear_basis']}" for event in events]
    return f'<div class="wide"><table>{header}{"".join(rows)}</table></div>' + "".join(f"<p>{escape(n)}</p>" for n in notes)


def _force_pictures(event: EventData) -> list[Picture]:
    pictures = []
    for coupler in dict.fromkeys(e.coupler for e in event.estimates):
        figure, (ax,) = _new_figure()
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
        ax.set_xlabel("time after the trigger (s)")
        ax.set_ylabel("coupler force (kN, compression +)")
        ax.set_title(f"event {event.index}, coupler {coupler}")
        _legend(ax)
        caption = (f"Event {event.index} ({event.attrs['impact_type']}), coupler {coupler}: each estimator's force, "
                   f"its 95 % band shaded where it has one; drawn: {', '.join(drawn) or 'none'}.")
        pictures.append(Picture(f"event {event.index} — {coupler}", caption, figure_png(figure)))
    return pictures


def _number(value: float, pattern: str) -> str:
    return "" if value is None or not math.isfinite(float(value)) else pattern.format(value)


def _value(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


__all__ = ["event_report", "is_event_file"]
