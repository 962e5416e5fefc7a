"""Matplotlib figures of a result file, every model against the reference, as PNG bytes.

One registry entry per scene kind (:data:`FIGURE_BUILDERS`) turns a :class:`~femref.report.read.ResultFile` into
a list of :class:`Picture` objects, every model drawn against :func:`reference_model`. Acceleration plots take their
y-range from the reference and the bulk of the others (:func:`robust_limits`), so that one model's spike at contact
onset does not flatten the rest. Figures are built on :class:`matplotlib.figure.Figure` directly (Agg canvas, no
pyplot state), so nothing here needs a display.
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
OUTSIDE_ALPHA = 0.12  # shading of the intervals where a model is outside its range
MODEL_COLORS = ("#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")
MODEL_DASHES = ("-", "--", "-.", ":")
REFERENCE_QUANTILES = (0.005, 0.995)  # of the reference's samples: its range on an acceleration plot
BULK_QUANTILES = (0.05, 0.95)  # of every other model's samples: their bulk, always inside the range
LIMIT_MARGIN = 0.15  # of the range's span, added on each side
ENERGY_COMPONENTS = {  # impact energy bookkeeping (J) → label and colour
    "kinetic": ("kinetic", "#1f77b4"),
    "strain": ("strain", "#2ca02c"),
    "body_dissipated": ("dissipated in the bodies", "#9467bd"),
    "coupler_stored": ("stored in the couplers", "#ff7f0e"),
    "coupler_dissipated": ("dissipated in the couplers", "#d62728"),
    "total": ("total", "black"),
}


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
    """The model every other is drawn against: ``exact`` if ok, else ``fem`` (impacts: ``fem``; a tolerance
    run, which has no ``fem``: the finest fem run of its ladder)."""
    order = ("fem",) if result.kind == "impact" else REFERENCE_ORDER
    found = next((result.models[n] for n in order if n in result.models and result.models[n].ok), None)
    if found is None and result.choice is not None:
        fem_runs = [r for r in result.choice.rungs if r.family == "fem" and r.label in result.models and result.models[r.label].ok]
        found = result.models[max(fem_runs, key=lambda r: r.resolution).label] if fem_runs else None
    return found


def model_styles(names: Iterable[str], reference: ModelData | None, chosen: str | None = None) -> dict[str, dict]:
    """A fixed colour and dash pattern per model, the same in every figure of the page.

    The reference is black, heavy, solid and drawn underneath, so that a model lying on it
    stays visible; the other models are thin, coloured and dashed differently. A tolerance
    run's ``chosen`` model says so in its label.
    """
    reference_name = reference.name if reference is not None else None
    others = [n for n in names if n != reference_name]
    styles = {
        name: {"color": MODEL_COLORS[i % len(MODEL_COLORS)], "ls": MODEL_DASHES[i % len(MODEL_DASHES)], "lw": MODEL_WIDTH, "zorder": 3, "label": name}
        for i, name in enumerate(others)
    }
    if reference_name is not None:
        styles[reference_name] = {"color": "black", "ls": "-", "lw": REFERENCE_WIDTH, "zorder": 2, "label": f"{reference_name} (reference)"}
    if chosen in styles:
        styles[chosen]["label"] = f"{chosen} (reference, chosen)" if chosen == reference_name else f"{chosen} (chosen)"
    return styles


def robust_limits(reference: NDArray | None, others: Iterable[NDArray] = ()) -> tuple[float, float] | None:
    """y-limits ``(lo, hi)`` that show the reference and the bulk of every other signal, not their spikes.

    ``[lo, hi]`` is the hull of the reference's 0.5–99.5 % quantiles and each other signal's
    5–95 % quantiles (:data:`REFERENCE_QUANTILES`, :data:`BULK_QUANTILES`), widened by
    :data:`LIMIT_MARGIN` of its span on each side. A brief spike (a quasi-rigid model's
    acceleration at contact onset: ±100–270 m/s² against a reference's ±20) falls outside and
    is clipped; a model whose whole response differs stays inside. None without a finite
    reference sample (the plot then scales itself).
    """
    if reference is None:
        return None
    ref = np.asarray(reference, dtype=float)
    ref = ref[np.isfinite(ref)]
    if ref.size == 0:
        return None
    lo, hi = (float(q) for q in np.quantile(ref, REFERENCE_QUANTILES))
    for other in others:
        values = np.asarray(other, dtype=float)
        values = values[np.isfinite(values)]
        if values.size:
            low, high = np.quantile(values, BULK_QUANTILES)
            lo, hi = min(lo, float(low)), max(hi, float(high))
    span = hi - lo if hi > lo else max(abs(lo), abs(hi), 1.0)
    return lo - LIMIT_MARGIN * span, hi + LIMIT_MARGIN * span


def figure_png(figure: Figure) -> bytes:
    """The figure rendered by Agg as PNG bytes."""
    FigureCanvasAgg(figure)
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def new_figure(rows: int = 1) -> tuple[Figure, list]:
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
    for other in [model] + ([reference] if reference else []) + result.ok_models:
        if other.axis_name == "time" and other.axis is not None and other.axis.size == samples:
            return other.axis
    return None


def figure_legend(ax) -> None:
    """A legend when something labelled was drawn (an empty legend only warns)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small", loc="best")


def _union(keys: Iterable[Iterable[str]]) -> list[str]:
    """Keys in order of first appearance."""
    return list(dict.fromkeys(k for group in keys for k in group))


def impact_figures(result: ResultFile) -> list[Picture]:
    """Coupler force per coupler, force against closure per coupler, the energy balance, then sensor
    acceleration per probe, then — on cars that bend — vertical acceleration per probe."""
    reference = reference_model(result)
    styles = model_styles(result.models, reference, result.choice.chosen if result.choice else None)
    models = _ordered(result, reference)
    couplers = _union(m.couplers for m in models)
    probes = _union(m.probes for m in ([reference] if reference else []) + models)
    pictures = [_coupler_force_picture(c, models, reference, result, styles) for c in couplers]
    pictures += [p for c in couplers if (p := _force_closure_picture(c, models, styles)) is not None]
    if (energy := _energy_picture(models, reference, result, styles)) is not None:
        pictures.append(energy)
    pictures += [_time_acceleration_picture(p, models, reference, result, styles, measured=True) for p in probes]
    bending = [p for p in probes if any("vertical_acceleration" in m.probes.get(p, {}) for m in models)]
    pictures += [_time_acceleration_picture(p, models, reference, result, styles, quantity="vertical_acceleration") for p in bending]
    return pictures


def _coupler_force_picture(
    coupler: str, models: list[ModelData], reference: ModelData | None, result: ResultFile, styles: dict[str, dict]
) -> Picture:
    """Coupler force (kN, compression positive) against time; peak-only estimators as a tick at the peak."""
    figure, (ax,) = new_figure()
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
    ax.set(xlabel="time t (s)", ylabel="coupler force (kN, compression +)", title=f"coupler {coupler}")
    figure_legend(ax)
    caption = f"Coupler {coupler}: force against time, every model against the reference"
    if peak_only:
        caption += "; network estimators give the peak only, drawn as a horizontal tick at the reference's peak time"
    return Picture(f"coupler force — {coupler}", caption + _undrawn_note(undrawn) + ".", figure_png(figure))


def _force_closure_picture(coupler: str, models: list[ModelData], styles: dict[str, dict]) -> Picture | None:
    """Coupler force (kN) against closure (mm), compression positive: the hysteresis loop; None when no model
    stores the closure."""
    drawn = [m for m in models if {"force", "closure"} <= m.couplers.get(coupler, {}).keys()
             and np.size(m.couplers[coupler]["force"]) == np.size(m.couplers[coupler]["closure"])]
    if not drawn:
        return None
    figure, (ax,) = new_figure()
    closures, in_contact = [], []
    for model in drawn:
        outputs = model.couplers[coupler]
        closure_mm = 1e3 * np.asarray(outputs["closure"], dtype=float)
        force = np.asarray(outputs["force"], dtype=float)
        ax.plot(closure_mm, force / 1e3, **styles[model.name])
        closures.append(closure_mm)
        in_contact.append(closure_mm[force > 0.0])
    ax.set(xlabel="closure (mm, compression +)", ylabel="coupler force (kN, compression +)", title=f"coupler {coupler}: force against closure")
    figure_legend(ax)
    caption = (
        f"Coupler {coupler}: force against closure (hysteresis) — loading up, unloading down; the area of the loop "
        f"is the energy the coupler dissipates. Drawn: {', '.join(m.name for m in drawn)}"
    )
    contact = np.concatenate(in_contact)
    if contact.size:  # the loop fills the plot; the cars' opening after they separate runs off the left edge
        lo, hi = min(0.0, float(contact.min())), max(0.0, float(contact.max()))
        margin = 0.1 * ((hi - lo) or 1.0)
        ax.set_xlim(lo - margin, hi + margin)
        if float(np.concatenate(closures).min()) < lo - margin:
            caption += "; x-range: the closures while in contact (the opening after separation runs off the left edge)"
    return Picture(f"force against closure — {coupler}", caption + ".", figure_png(figure))


def _energy_picture(models: list[ModelData], reference: ModelData | None, result: ResultFile, styles: dict[str, dict]) -> Picture | None:
    """The energy balance: the reference's bookkeeping (kJ) against time, and every model's total minus its
    initial total, in % of it; None when no model stores energies."""
    with_energy = [m for m in models if "total" in m.energy]
    if not with_energy:
        return None
    shown = reference if reference in with_energy else with_energy[0]
    figure, (parts_ax, drift_ax) = new_figure(rows=2)
    time = _time_axis(shown, np.size(shown.energy["total"]), result, reference)
    if time is not None:
        for name, (label, color) in ENERGY_COMPONENTS.items():
            if name in shown.energy:
                width = REFERENCE_WIDTH if name == "total" else MODEL_WIDTH + 0.4
                parts_ax.plot(time, np.asarray(shown.energy[name], dtype=float) / 1e3, color=color, lw=width, label=label)
    undrawn = []
    for model in with_energy:
        total = np.asarray(model.energy["total"], dtype=float)
        model_time = _time_axis(model, total.size, result, reference)
        if model_time is None or total.size == 0 or total[0] == 0.0:
            undrawn.append(model.name)
            continue
        drift_ax.plot(model_time, 100.0 * (total - total[0]) / total[0], **styles[model.name])
    parts_ax.set(ylabel="energy (kJ)", title=f"energy balance — {shown.name}")
    drift_ax.set(ylabel="total − initial (% of initial)", xlabel="time t (s)")
    figure_legend(parts_ax)
    figure_legend(drift_ax)
    caption = (
        f"Energy balance. Top: the {shown.name} bookkeeping against time — kinetic, strain, dissipated in the bodies, "
        "stored and dissipated in the couplers, and their total, which a consistent run keeps at the initial kinetic "
        "energy. Bottom: every model's total minus its initial total, in % of it"
    )
    return Picture("energy balance", caption + _undrawn_note(undrawn) + ".", figure_png(figure))


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
    figure, (ax,) = new_figure()
    undrawn = []
    curves: list[tuple[str, NDArray, NDArray, str]] = []  # name, time, values, colour
    for model in models:
        if quantity not in model.probes.get(probe, {}):
            continue
        acceleration = np.asarray(model.probes[probe][quantity], dtype=float)
        time = _time_axis(model, acceleration.size, result, reference)
        if time is None:
            undrawn.append(model.name)
        else:
            ax.plot(time, acceleration, **styles[model.name])
            curves.append((model.name, time, acceleration, styles[model.name]["color"]))
            for start, end in model.outside_range:
                ax.axvspan(start, end, color=styles[model.name]["color"], alpha=OUTSIDE_ALPHA, lw=0)
    outside = [m for m in models if m.outside_range and quantity in m.probes.get(probe, {})]
    shows_measured = measured and reference is not None and probe in reference.measured and reference.measured_time is not None
    if shows_measured:
        record = {"color": "#7f7f7f", "lw": MEASURED_WIDTH, "zorder": 2.5, "label": f"{reference.name} measured"}
        ax.plot(reference.measured_time, reference.measured[probe], **record)
        curves.append((f"{reference.name} measured", reference.measured_time, np.asarray(reference.measured[probe], dtype=float), record["color"]))
    limits_note = _limit_and_mark(ax, curves, reference.name if reference is not None else None, "m/s²")
    vertical = quantity == "vertical_acceleration"
    ax.set(xlabel="time t (s)", ylabel="vertical acceleration (m/s², up +)" if vertical else "acceleration (m/s²)",
           title=f"probe {probe}" + (", vertical" if vertical else ""))
    figure_legend(ax)
    caption = f"{'Vertical acceleration' if vertical else 'Acceleration'} at probe {probe} against time, models overlaid"
    if outside:
        caption += (f"; shaded in its colour: where {', '.join(m.name for m in outside)} is outside its range — an end force "
                    f"changes slope within one wave travel time of a car (ε_loc > {outside[0].outside_limit:g}), where a car carries "
                    "a stress wave and the quasi-rigid expansion has none")
    if shows_measured:
        caption += f"; thin grey: the {reference.name} record through the measurement chain"
    title = f"{'vertical acceleration' if vertical else 'acceleration'} — {probe}"
    return Picture(title, caption + _undrawn_note(undrawn) + limits_note + ".", figure_png(figure))


def _limit_and_mark(ax, curves: list[tuple[str, NDArray, NDArray, str]], reference: str | None, unit: str) -> str:
    """Set the y-limits of ``ax`` by :func:`robust_limits` (reference: the curve named ``reference``), mark every
    clipped sample by a triangle on the edge, and return the caption's sentence on both ("" without a reference)."""
    ref = next((values for name, _, values, _ in curves if name == reference), None)
    limits = robust_limits(ref, [values for name, _, values, _ in curves if name != reference])
    if limits is None:
        return ""
    lo, hi = limits
    ax.set_ylim(lo, hi)
    clipped = []
    for name, time, values, color in curves:
        marks = [(mask, edge, marker) for mask, edge, marker in ((values > hi, hi, "^"), (values < lo, lo, "v")) if mask.any()]
        for mask, edge, marker in marks:
            ax.plot(time[mask], np.full(np.count_nonzero(mask), edge), ls="none", marker=marker, ms=5, color=color, clip_on=False, zorder=5)
        if marks:
            clipped.append(f"{name} ({np.nanmin(values):.3g} to {np.nanmax(values):.3g} {unit})")
    note = (
        f"; y-range {lo:.3g} to {hi:.3g} {unit} set by {reference} (its 0.5–99.5 % quantiles) and the others' "
        f"5–95 % quantiles, with a {100 * LIMIT_MARGIN:.0f} % margin"
    )
    if clipped:
        note += f"; clipped, marked by triangles on the edge: {', '.join(clipped)}"
    return note


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
    figure, (re_ax, im_ax) = new_figure(rows=2)
    for model in models:
        if "acceleration" not in model.probes.get(probe, {}) or model.axis is None:
            continue
        amplitude = np.asarray(model.probes[probe]["acceleration"], dtype=complex)
        style = {**styles[model.name], "ls": "-" if model is reference else "--"}
        re_ax.plot(model.axis, amplitude.real, **style)
        im_ax.plot(model.axis, amplitude.imag, **style)
    re_ax.set_ylabel("Re a (m/s²)")
    im_ax.set(ylabel="Im a (m/s²)", xlabel="nondimensional frequency λ = ω T_wave (1)")
    re_ax.set_title(f"probe {probe}")
    figure_legend(re_ax)
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
