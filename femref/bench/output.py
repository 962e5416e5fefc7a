"""The bench's files: the HDF5 table and the Pareto plot (error against wall time).

The HDF5 layout (written under a temporary name in the target folder, then renamed): docs/design.md §4.4,
``/bench`` one row per configuration (:data:`COLUMNS`).

The plot is log–log: primary error (y) against median wall time (x, s; the top axis
gives the same times as ratios to the rigid model's), one marker per model family, the
Pareto-optimal configurations ringed, labelled (:func:`place_labels`) and joined by a step line.
Errors that a log axis cannot show — 0, or NaN (not scored) — are drawn at :func:`error_floor`,
with open markers, and the legend says so.
"""

from __future__ import annotations

import json
import math
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Sequence

import h5py
import numpy as np

from femref import __version__
from femref.bench.run import PRIMARY_ERROR, RATIO_BASE, SECONDARY_ERROR, VERTICAL_ERROR, BenchOutcome, BenchRow
from femref.core.hdf5_writing import hdf5_writer
from femref.core.publishing import atomic_path

__all__ = ["COLUMNS", "LABEL_GID", "pareto_figure", "place_labels", "plot_pareto", "write_bench_table"]

_STR = h5py.string_dtype("utf-8")

COLUMNS: dict[str, tuple[Any, str, Callable[[BenchRow], Any]]] = {
    "label": (_STR, "", lambda r: r.configuration.label),
    "model": (_STR, "", lambda r: r.configuration.family),
    "kind": (_STR, "solve | estimator", lambda r: r.configuration.kind),
    "setting": (_STR, "elements | dt_factor | modes | ''", lambda r: r.configuration.setting),
    "value": (np.float64, "1 (NaN: no setting)", lambda r: r.configuration.value),
    "elements": (np.int64, "1 (fem elements per car; 0: not fem)", lambda r: _elements(r)),
    "dt_s": (np.float64, "s (NaN: estimator)", lambda r: r.configuration.dt),
    "steps": (np.int64, "1 (0: estimator or failed)", lambda r: r.steps),
    "wall_time_s": (np.float64, "s (median of the repeats)", lambda r: r.wall_time_s),
    "time_ratio_rigid": (np.float64, "1 (wall_time_s / rigid wall_time_s)", lambda r: r.time_ratio_rigid),
    "peak_error": (np.float64, f"1 ({PRIMARY_ERROR})", lambda r: r.peak_error),
    "rms_error": (np.float64, f"1 ({SECONDARY_ERROR})", lambda r: r.rms_error),
    "vertical_error": (np.float64, f"1 ({VERTICAL_ERROR}; NaN: no car bends)", lambda r: r.vertical_error),
    "pareto": (np.bool_, "Pareto-optimal in (wall_time_s, peak_error)", lambda r: r.pareto),
    "status": (_STR, "ok | failed", lambda r: r.status),
    "message": (_STR, "", lambda r: r.message),
}
"""Column → (HDF5 type, unit/meaning, value of a row)."""

PARETO_RULE = "no other configuration is at least as fast and as accurate and strictly better in one (NaN never optimal)"


def _elements(row: BenchRow) -> int:
    c = row.configuration
    return int(c.scene.fem.elements) if c.family == "fem" and c.scene is not None else 0


def write_bench_table(path: str | Path, case_yaml: str, outcome: BenchOutcome) -> Path:
    """Write the bench file (module docstring) atomically; return its path."""
    path = Path(path)
    dtype = np.dtype([(name, column[0]) for name, column in COLUMNS.items()])
    table = np.array([tuple(column[2](row) for column in COLUMNS.values()) for row in outcome.rows], dtype=dtype)
    times = np.full((len(outcome.rows), outcome.repeats), np.nan)
    for i, row in enumerate(outcome.rows):
        times[i, : len(row.wall_times_s)] = row.wall_times_s
    with atomic_path(path) as tmp_name, hdf5_writer(tmp_name) as h5:
        h5.attrs["femref_version"] = __version__
        h5.attrs["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        bench = h5.create_dataset("bench", data=table)
        bench.attrs.update(
            case_yaml=case_yaml, reference=outcome.plan.reference_description, reference_wall_time_s=outcome.reference_wall_time_s,
            reference_steps=outcome.reference_steps, repeats=outcome.repeats, primary_error=PRIMARY_ERROR,
            secondary_error=SECONDARY_ERROR, time_ratio_base=RATIO_BASE, pareto_rule=PARETO_RULE,
            units=json.dumps({name: column[1] for name, column in COLUMNS.items()}), notes="\n".join(outcome.notes),
        )
        h5.create_dataset("bench_wall_times_s", data=times).attrs["units"] = "s"
    return path


MARKERS = {"fem": "o", "modal": "s", "quasi_rigid": "^", "rigid": "D"}
ESTIMATOR_MARKERS = ("v", "P", "X", "*", "h", "<", ">")


def error_floor(errors: np.ndarray) -> float:
    """A decade below the least positive finite error (1e-6 when there is none): where 0 and NaN are drawn."""
    positive = errors[np.isfinite(errors) & (errors > 0.0)]
    return float(positive.min()) / 10.0 if positive.size else 1e-6


LABEL_GID = "pareto-label"
"""The ``gid`` of every configuration label in the Pareto plot (how a test or a caller finds them)."""
LABEL_RADII = (10.0, 18.0, 28.0, 40.0, 54.0, 70.0, 88.0, 108.0)  # points: rings of candidate offsets, nearest first
LABEL_DIRECTIONS = ((1, 1), (1, -1), (-1, 1), (-1, -1), (1, 0), (-1, 0), (0, 1), (0, -1))
LABEL_PAD = 2.0  # pixels kept clear around each label
MARKER_RADIUS = 7.0  # points: a ringed marker's half-width, kept clear of labels where there is room


def _aligned(direction: tuple[int, int]) -> tuple[str, str]:
    """Text alignment that makes a label grow away from its point in ``direction``."""
    dx, dy = direction
    return {1: "left", -1: "right", 0: "center"}[dx], {1: "bottom", -1: "top", 0: "center"}[dy]


def place_labels(
    ax: Any, points: Sequence[tuple[float, float]], texts: Sequence[str], renderer: Any,
    obstacles: Sequence[tuple[float, float]] = (), avoid: Sequence[Any] = (), fontsize: float = 8.0,
) -> list[Any]:
    """Label ``points`` (data coordinates) with ``texts``, each at the first free offset: no two labels overlap.

    Greedy, in the order given: for each label the candidate offsets are
    :data:`LABEL_DIRECTIONS` on rings of :data:`LABEL_RADII` (points), nearest ring first;
    a candidate's cost is, in order, its overlaps with labels already placed (boxes padded
    by :data:`LABEL_PAD` px), with the markers at ``points`` and ``obstacles`` (boxes of
    :data:`MARKER_RADIUS`) and the boxes ``avoid`` (display-coordinate ``Bbox``, e.g. the
    legend), and how far it leaves the axes; the first candidate of cost zero is taken, else
    the cheapest. A label placed beyond the nearest ring gets a thin leader line to its
    point. Boxes are the renderer's ``get_window_extent``, so the figure's layout must be
    final (call after ``tight_layout``); the labels stay out of later layouts. Returns the
    annotations (``gid`` :data:`LABEL_GID`).
    """
    from matplotlib.transforms import Bbox

    figure = ax.get_figure()
    pixels = figure.dpi / 72.0
    to_display = ax.transData.transform
    marker = MARKER_RADIUS * pixels
    markers = [Bbox.from_extents(x - marker, y - marker, x + marker, y + marker)
               for x, y in to_display(np.array([*points, *obstacles], dtype=float).reshape(-1, 2))]
    frame = ax.get_window_extent(renderer)
    placed: list[Any] = []
    labels = []
    for (x, y), text in zip(points, texts):
        best, best_cost = None, None
        for radius in LABEL_RADII:
            for direction in LABEL_DIRECTIONS:
                ha, va = _aligned(direction)
                offset = (direction[0] * radius, direction[1] * radius)
                label = ax.annotate(text, (x, y), xytext=offset, textcoords="offset points", ha=ha, va=va, fontsize=fontsize, gid=LABEL_GID)
                label.set_in_layout(False)
                box = label.get_window_extent(renderer).padded(LABEL_PAD)
                outside = max(frame.x0 - box.x0, box.x1 - frame.x1, frame.y0 - box.y0, box.y1 - frame.y1, 0.0)
                cost = (
                    sum(box.overlaps(other) for other in placed),
                    sum(box.overlaps(other) for other in (*markers, *avoid)),
                    outside,
                )
                if best_cost is None or cost < best_cost:
                    if best is not None:
                        best[0].remove()
                    best, best_cost = (label, radius, box), cost
                else:
                    label.remove()
                if best_cost == (0, 0, 0.0):
                    break
            if best_cost == (0, 0, 0.0):
                break
        label, radius, box = best
        placed.append(box)
        labels.append(label)
        if radius > LABEL_RADII[0]:  # a leader from the point to the label's anchor
            anchor = ax.transData.inverted().transform(to_display((x, y)) + np.array(label.xyann) * pixels)
            (leader,) = ax.plot([x, anchor[0]], [y, anchor[1]], color="0.45", lw=0.6, zorder=2.5)
            leader.set_in_layout(False)
    return labels


def pareto_figure(outcome: BenchOutcome, title: str = "") -> Any:
    """The log–log Pareto plot (module docstring) as a matplotlib figure, its labels placed (:func:`place_labels`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [row for row in outcome.rows if math.isfinite(row.wall_time_s) and row.wall_time_s > 0.0]
    times = np.array([row.wall_time_s for row in rows])
    errors = np.array([row.peak_error for row in rows])
    floor = error_floor(errors)
    clipped = ~(np.isfinite(errors) & (errors > 0.0))
    shown = np.where(clipped, floor, errors)

    fig, ax = plt.subplots(figsize=(9.0, 6.0), dpi=110)
    families = list(dict.fromkeys(row.configuration.family for row in rows))
    extra = iter(ESTIMATOR_MARKERS)
    for k, family in enumerate(families):
        marker = MARKERS.get(family) or next(extra, "o")
        color = f"C{k % 10}"
        pick = np.array([row.configuration.family == family for row in rows])
        for hollow, sel in ((False, pick & ~clipped), (True, pick & clipped)):
            if sel.any():
                ax.scatter(
                    times[sel], shown[sel], marker=marker, s=45, zorder=3, edgecolors=color,
                    facecolors="none" if hollow else color, label=None if hollow and (pick & ~clipped).any() else family,
                )
    front = [i for i, row in enumerate(rows) if row.pareto]
    front.sort(key=lambda i: times[i])
    if front:
        ax.plot(times[front], shown[front], drawstyle="steps-post", color="black", lw=1.2, zorder=2, label="Pareto front")
        ax.scatter(times[front], shown[front], s=160, facecolors="none", edgecolors="red", linewidths=1.5, zorder=4, label="Pareto-optimal")
    if clipped.any():
        ax.plot([], [], ls="none", marker="o", mfc="none", mec="grey", label=f"error 0 or NaN: drawn at floor {floor:.1e}")
        ax.axhline(floor, color="grey", lw=0.6, ls=":")
    ax.set(xscale="log", yscale="log", xlabel=f"wall time, s (median of {outcome.repeats})", ylabel="peak coupler force error vs reference")
    rigid = next((row.wall_time_s for row in outcome.rows if row.configuration.family == RATIO_BASE and row.ok), math.nan)
    if math.isfinite(rigid) and rigid > 0.0:
        top = ax.secondary_xaxis("top", functions=(lambda x: x / rigid, lambda r: r * rigid))
        top.set_xlabel("wall time / rigid wall time")
    note = " (errors 0/NaN clipped to floor)" if clipped.any() else ""
    ax.set_title((title + "\n" if title else "") + f"reference: {outcome.plan.reference_description}{note}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    legend = ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    if front:
        fig.canvas.draw()  # the final layout and the legend's "best" place, which then stays put
        renderer = fig.canvas.get_renderer()
        box = legend.get_window_extent(renderer)
        legend.set_loc(tuple(ax.transAxes.inverted().transform((box.x0, box.y0))))
        others = [(times[i], shown[i]) for i in range(len(rows)) if i not in front]
        place_labels(ax, [(times[i], shown[i]) for i in front], [rows[i].configuration.label for i in front], renderer,
                     obstacles=others, avoid=[box])
    return fig


def plot_pareto(path: str | Path, outcome: BenchOutcome, title: str = "") -> Path:
    """The log–log Pareto plot (module docstring, :func:`pareto_figure`) as a PNG, written under a temporary name and renamed."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = pareto_figure(outcome, title)
    try:
        with atomic_path(path) as tmp_name:
            fig.savefig(tmp_name, format="png")
    finally:
        plt.close(fig)
    return path
