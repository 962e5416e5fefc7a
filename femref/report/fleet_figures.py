"""The fleet report's figures (:mod:`femref.report.fleet`): the distributions of closing speed and peak force, and
each gear's closure force over time with its trend, wear limit and forecast crossing — PNG pictures drawn as the
other reports' (:mod:`femref.report.figures`: Agg, no pyplot state)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from femref.fleet.wear import GearTrend
from femref.report.figures import MODEL_COLORS, Picture, figure_legend, figure_png, new_figure

KILO = 1e-3
BINS = 30
TYPE_COLORS = {"free_to_roll": MODEL_COLORS[1], "coupled": MODEL_COLORS[3], "unknown": "#7f7f7f"}
STATUS_COLORS = {"worn": "#c62828", "wearing": "#ef8f00", "ok": "#2e7d32", "insufficient data": "#555555", "no wear limit": "#555555"}


def distribution_pictures(impacts: pd.DataFrame) -> list[Picture]:
    """Histograms of the closing speed (one per event) and of the peak force (one per event and coupler) of the
    ``impacts`` rows, stacked by event type, the alarm limit marked on the force's."""
    events = impacts.drop_duplicates("event_key")
    pictures = [_histogram(events, "closing_speed", 1.0, "closing speed (m/s)", "events",
                           "Closing speed of each impact (the middle of its interval), stacked by impact type", [])]
    limits = sorted({float(v) for v in impacts["alarm_limit"] if math.isfinite(v)})
    pictures.append(_histogram(impacts, "peak_force", KILO, "peak coupler force (kN, compression +)", "events × couplers",
                               "Peak coupler force of each impact and coupler (the primary estimator's), stacked by impact type; "
                               "dashed: the alarm limit", limits))
    return pictures


def _histogram(rows: pd.DataFrame, column: str, scale: float, label: str, count: str, caption: str, limits: list[float]) -> Picture:
    figure, (ax,) = new_figure()
    values = rows[column].to_numpy(dtype=float) * scale
    finite = values[np.isfinite(values)]
    kinds = [k for k in dict.fromkeys(rows["event_type"]) if k in TYPE_COLORS] + [k for k in dict.fromkeys(rows["event_type"]) if k not in TYPE_COLORS]
    if finite.size:
        edges = np.histogram_bin_edges(np.concatenate([finite, np.asarray(limits) * scale]) if limits else finite, bins=BINS)
        stacks = [values[(rows["event_type"] == kind).to_numpy() & np.isfinite(values)] for kind in kinds]
        colors = [TYPE_COLORS.get(kind, MODEL_COLORS[(4 + k) % len(MODEL_COLORS)]) for k, kind in enumerate(kinds)]
        ax.hist(stacks, bins=edges, stacked=True, color=colors, label=[f"{kind} ({stack.size})" for kind, stack in zip(kinds, stacks)])
    for limit in limits:
        ax.axvline(limit * scale, color="black", ls="--", lw=1.2, label=f"alarm limit {limit * scale:.4g}")
    ax.set(xlabel=label, ylabel=count)
    figure_legend(ax)
    missing = values.size - finite.size
    note = f"; {missing} without a number left out" if missing else ""
    return Picture(label, f"{caption} ({finite.size} {count}{note}).", figure_png(figure))


def gear_picture(trend: GearTrend, now: pd.Timestamp, horizon_days: float) -> Picture:
    """The gear's closure forces (kN) against time, its Theil–Sen line with the band, the wear limit and the forecast
    crossing with its interval, up to ``now + horizon_days``."""
    figure, (ax,) = new_figure()
    closed = trend.closures
    color = STATUS_COLORS.get(trend.status, "black")
    ax.plot(closed["time"], closed["closure_force"] * KILO, ls="none", marker="o", ms=4, color="#1f77b4", label=f"closure force ({len(closed)})")
    end = now + pd.Timedelta(days=horizon_days)
    if math.isfinite(trend.slope):
        times = pd.date_range(closed["time"].iloc[0], end, periods=200)
        line, lower, upper = trend.at(times)
        ax.plot(times, line * KILO, color=color, lw=1.6, label=f"trend {trend.slope * KILO:+.3g} kN/day")
        ax.fill_between(times, lower * KILO, upper * KILO, color=color, alpha=0.15, lw=0, label="95 % band")
    if math.isfinite(trend.wear_limit):
        ax.axhline(trend.wear_limit * KILO, color="black", ls="--", lw=1.2, label=f"wear limit {trend.wear_limit * KILO:.4g} kN")
    ax.axvline(now, color="#555555", ls=":", lw=1.0, label="now")
    crossing = ""
    if not pd.isna(trend.crossing) and trend.crossing <= end:
        ax.axvline(trend.crossing, color=color, lw=1.0)
        late = trend.crossing_late if not pd.isna(trend.crossing_late) else end
        ax.axvspan(max(trend.crossing_early, closed["time"].iloc[0]), min(late, end), color=color, alpha=0.08, lw=0)
        crossing = f"; forecast crossing {trend.crossing:%Y-%m-%d} (shaded: its interval)"
    ax.set(xlabel="time (UTC)", ylabel="closure force (kN)", title=f"gear {trend.gear}: {trend.status}")
    ax.set_xlim(closed["time"].iloc[0] - pd.Timedelta(days=1), end)
    figure.autofmt_xdate()
    figure_legend(ax)
    caption = (f"Gear {trend.gear} ({trend.status}): the force at which it went solid in each impact, its Theil–Sen trend with the "
               f"95 % band, the wear limit and the next {horizon_days:g} days{crossing}.")
    return Picture(f"gear {trend.gear}", caption, figure_png(figure))


__all__ = ["distribution_pictures", "gear_picture"]
