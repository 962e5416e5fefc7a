"""Matplotlib figures of a result file, every model against the reference, as PNG bytes.

One registry entry per scene kind turns a :class:`~femref.report.read.ResultFile` into
a list of :class:`Picture` objects:

* ``impact``: coupler force (kN) against time per coupler — the fem reference heavier,
  network estimators (a peak only) as a horizontal tick at their peak — and sensor
  acceleration (m/s²) per probe, with fem's measured records thinner;
* ``transient``: acceleration (m/s²) per probe against time;
* ``harmonic``: real and imaginary parts of the stored complex acceleration amplitude
  against λ per probe, the reference solid and the others dashed.

The reference is ``exact`` where it is present and ok, else ``fem`` (impacts: ``fem``).
Figures are built on :class:`matplotlib.figure.Figure` directly (Agg canvas, no pyplot
state), so nothing here needs a display.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from femref.report.read import ModelData, ResultFile

REFERENCE_ORDER = ("exact", "fem")
FIGURE_SIZE = (8.0, 4.2)  # inches
DPI = 100
REFERENCE_WIDTH = 2.6
MODEL_WIDTH = 1.3
MEASURED_WIDTH = 0.7
MODEL_COLORS = ("#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")
MODEL_DASHES = ("-", "--", "-.", ":")


@dataclass(frozen=True)
class Picture:
    """One picture of the page: a PNG, or the one-line reason it could not be made."""

    title: str
    caption: str
    png: bytes | None
    problem: str = ""


def figures_for(result: ResultFile) -> list[Picture]:
    """The plots of ``result`` for its scene kind (none for an unknown kind)."""
    builder = FIGURE_BUILDERS.get(result.kind)
    return builder(result) if builder else []


def reference_model(result: ResultFile) -> ModelData | None:
    """The model every other is drawn against: ``exact`` if ok, else ``fem`` (impacts: ``fem``)."""
    order = ("fem",) if result.kind == "impact" else REFERENCE_ORDER
    return next((result.models[n] for n in order if n in result.models and result.models[n].ok), None)


def model_styles(names: Iterable[str], reference: ModelData | None) -> dict[str, dict]:
    """A fixed colour and dash pattern per model, the same in every figure of the page.

    The reference is black, heavy, solid and drawn underneath, so that a model lying on it
    stays visible; the other models are thin, coloured and dashed differently.
    """
    reference_name = reference.name if reference is not None else None
    others = [n for n in names if n != reference_name]
    styles = {
        name: {"color": MODEL_COLORS[i % len(MODEL_COLORS)], "ls": MODEL_DASHES[i % len(MODEL_DASHES)], "lw": MODEL_WIDTH, "zorder": 3, "label": name}
        for i, name in enumerate(others)
    }
    if reference_name is not None:
        styles[reference_name] = {"color": "black", "ls": "-", "lw": REFERENCE_WIDTH, "zorder": 2, "label": f"{reference_name} (reference)"}
    return styles


def figure_png(figure: Figure) -> bytes:
    """The figure rendered by Agg as PNG bytes."""
    FigureCanvasAgg(figure)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def _new_figure(rows: int = 1) -> tuple[Figure, list]:
    height = FIGURE_SIZE[1] * (1.0 if rows == 1 else 0.75 * rows)
    figure = Figure(figsize=(FIGURE_SIZE[0], height), layout="constrained")
    axes = figure.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return figure, list(axes)


def _ordered(result: ResultFile, reference: ModelData | None) -> list[ModelData]:
    """Ok models, the reference first (drawn underneath, first in the legend)."""
    others = [m for m in result.ok_models if m is not reference]
    return ([reference] if reference is not None else []) + others


def _time_axis(model: ModelData, samples: int, result: ResultFile, reference: ModelData | None) -> NDArray | None:
    """The time axis (s) of a history of ``samples`` values of ``model``.

    A model that stores no axis of its own (e.g. ``exact`` on the runner's common grid)
    shares the time axis of the reference, or of another model, of the same length.
    """
    if model.axis_name == "time" and model.axis is not None and model.axis.size == samples:
        return model.axis
    for other in ([reference] if reference else []) + result.ok_models:
        if other.axis_name == "time" and other.axis is not None and other.axis.size == samples:
            return other.axis
    return None


def _legend(ax) -> None:
    """A legend when something labelled was drawn (an empty legend only warns)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small", loc="best")


def _union(keys: Iterable[Iterable[str]]) -> list[str]:
    """Keys in order of first appearance."""
    return list(dict.fromkeys(k for group in keys for k in group))


# --- impacts -----------------------------------------------------------------------


def impact_figures(result: ResultFile) -> list[Picture]:
    """Coupler force per coupler, then sensor acceleration per probe, then — on cars that bend — vertical
    acceleration per probe."""
    reference = reference_model(result)
    styles = model_styles(result.models, reference)
    models = _ordered(result, reference)
    couplers = _union(m.couplers for m in models)
    probes = _union(m.probes for m in ([reference] if reference else []) + models)
    pictures = [_coupler_force_picture(c, models, reference, result, styles) for c in couplers]
    pictures += [_time_acceleration_picture(p, models, reference, result, styles, measured=True) for p in probes]
    bending = [p for p in probes if any("vertical_acceleration" in m.probes.get(p, {}) for m in models)]
    pictures += [_time_acceleration_picture(p, models, reference, result, styles, quantity="vertical_acceleration") for p in bending]
    return pictures


def _coupler_force_picture(
    coupler: str, models: list[ModelData], reference: ModelData | None, result: ResultFile, styles: dict[str, dict]
) -> Picture:
    """Coupler force (kN, compression positive) against time; peak-only estimators as a tick at the peak."""
    figure, (ax,) = _new_figure()
    peak_only, undrawn = [], []
    for model in models:
        outputs = model.couplers.get(coupler, {})
        if "force" in outputs:
            force = np.asarray(outputs["force"], dtype=float)
            time = _time_axis(model, force.size, result, reference)
            if time is None:
                undrawn.append(model.name)
            else:
                ax.plot(time, force / 1e3, **styles[model.name])
        elif "peak_force" in outputs:
            peak_only.append((model, float(np.asarray(outputs["peak_force"]))))
    tick_time = _reference_peak_time(coupler, reference, result)
    for model, peak in peak_only:
        tick = {"color": styles[model.name]["color"], "label": f"{model.name} (peak only)", "zorder": 4}
        if tick_time is None:
            ax.axhline(peak / 1e3, xmin=0.92, xmax=1.0, lw=3, **tick)
        else:
            ax.plot([tick_time], [peak / 1e3], ls="none", marker="_", markersize=40, mew=3, **tick)
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("coupler force (kN, compression +)")
    ax.set_title(f"coupler {coupler}")
    _legend(ax)
    caption = f"Coupler {coupler}: force against time, every model against the reference"
    if peak_only:
        caption += "; network estimators give the peak only, drawn as a horizontal tick at the reference's peak time"
    return Picture(f"coupler force — {coupler}", caption + _undrawn_note(undrawn) + ".", figure_png(figure))


def _undrawn_note(names: list[str]) -> str:
    return f"; not drawn (no time axis of matching length): {', '.join(names)}" if names else ""


def _reference_peak_time(coupler: str, reference: ModelData | None, result: ResultFile) -> float | None:
    """Time (s) of the reference's largest compression at ``coupler``; None without a reference history."""
    if reference is None or "force" not in reference.couplers.get(coupler, {}):
        return None
    force = np.asarray(reference.couplers[coupler]["force"], dtype=float)
    time = _time_axis(reference, force.size, result, reference)
    return None if time is None or force.size == 0 else float(time[int(np.argmax(force))])


def _time_acceleration_picture(
    probe: str,
    models: list[ModelData],
    reference: ModelData | None,
    result: ResultFile,
    styles: dict[str, dict],
    measured: bool = False,
    quantity: str = "acceleration",
) -> Picture:
    """Acceleration (m/s², ``quantity``: the axial ``acceleration`` or the ``vertical_acceleration`` of a car
    that bends) at ``probe`` against time; with ``measured``, the reference's measured record thinner."""
    figure, (ax,) = _new_figure()
    undrawn = []
    for model in models:
        if quantity not in model.probes.get(probe, {}):
            continue
        acceleration = np.asarray(model.probes[probe][quantity], dtype=float)
        time = _time_axis(model, acceleration.size, result, reference)
        if time is None:
            undrawn.append(model.name)
        else:
            ax.plot(time, acceleration, **styles[model.name])
    shows_measured = measured and reference is not None and probe in reference.measured and reference.measured_time is not None
    if shows_measured:
        record = {"color": "#7f7f7f", "lw": MEASURED_WIDTH, "zorder": 2.5, "label": f"{reference.name} measured"}
        ax.plot(reference.measured_time, reference.measured[probe], **record)
    vertical = quantity == "vertical_acceleration"
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("vertical acceleration (m/s², up +)" if vertical else "acceleration (m/s²)")
    ax.set_title(f"probe {probe}" + (", vertical" if vertical else ""))
    _legend(ax)
    caption = f"{'Vertical acceleration' if vertical else 'Acceleration'} at probe {probe} against time, models overlaid"
    if shows_measured:
        caption += f"; thin grey: the {reference.name} record through the measurement chain"
    title = f"{'vertical acceleration' if vertical else 'acceleration'} — {probe}"
    return Picture(title, caption + _undrawn_note(undrawn) + ".", figure_png(figure))


# --- one body ------------------------------------------------------------------------


def transient_figures(result: ResultFile) -> list[Picture]:
    """Acceleration per probe against time, models overlaid."""
    reference = reference_model(result)
    styles = model_styles(result.models, reference)
    models = _ordered(result, reference)
    probes = _union(m.probes for m in models)
    return [_time_acceleration_picture(p, models, reference, result, styles) for p in probes]


def harmonic_figures(result: ResultFile) -> list[Picture]:
    """Re and Im of the stored complex acceleration amplitude against λ, per probe."""
    reference = reference_model(result)
    styles = model_styles(result.models, reference)
    models = [m for m in _ordered(result, reference) if m.axis_name == "lambda"]
    probes = _union(m.probes for m in models)
    return [_harmonic_picture(p, models, reference, styles) for p in probes]


def _harmonic_picture(probe: str, models: list[ModelData], reference: ModelData | None, styles: dict[str, dict]) -> Picture:
    figure, (re_ax, im_ax) = _new_figure(rows=2)
    for model in models:
        if "acceleration" not in model.probes.get(probe, {}) or model.axis is None:
            continue
        amplitude = np.asarray(model.probes[probe]["acceleration"], dtype=complex)
        style = {**styles[model.name], "ls": "-" if model is reference else "--"}
        re_ax.plot(model.axis, amplitude.real, **style)
        im_ax.plot(model.axis, amplitude.imag, **style)
    re_ax.set_ylabel("Re a (m/s²)")
    im_ax.set_ylabel("Im a (m/s²)")
    im_ax.set_xlabel("nondimensional frequency λ = ω T_wave (1)")
    re_ax.set_title(f"probe {probe}")
    _legend(re_ax)
    caption = (
        f"Complex acceleration amplitude at probe {probe} as stored (per the case's load amplitudes, "
        "time factor e^(−iωt)) against λ; reference solid, other models dashed."
    )
    return Picture(f"frequency response — {probe}", caption, figure_png(figure))


FIGURE_BUILDERS: dict[str, Callable[[ResultFile], list[Picture]]] = {
    "impact": impact_figures,
    "transient": transient_figures,
    "harmonic": harmonic_figures,
}
