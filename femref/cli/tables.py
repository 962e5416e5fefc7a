"""The summary tables the commands print: a run (single body or impact), the network study, the bench."""

from __future__ import annotations

import math

import numpy as np
from rich.table import Table


def run_table(outcome) -> Table:
    """Model, status, wall time, work and the key outputs, with the error against the reference."""
    if outcome.scene.kind == "impact":
        return impact_table(outcome)
    table = Table(title=f"{outcome.scene.kind} scene, ε = {outcome.scene.epsilon:.3g}", title_justify="left")
    for column in ("model", "status", "wall time", "work", "peak |a| m/s²", "peak |F| N", "error max / rms"):
        table.add_column(column, justify="right" if column not in ("model", "status") else "left")
    for result in outcome.results:
        work = ""
        if "steps" in result.settings:
            work = f"{result.settings['steps']} steps"
        elif "frequencies" in result.settings:
            work = f"{result.settings['frequencies']} freqs"
        score = outcome.scores.get(result.model, {})
        error = (
            f"{_fmt(score.get('acceleration_max_error_max'), '{:.2g}')} / {_fmt(score.get('acceleration_rms_error_max'), '{:.2g}')} vs {score['reference']}"
            if score
            else "reference" if result.ok else ""
        )
        table.add_row(
            result.model,
            result.status,
            f"{result.wall_time_s * 1e3:.1f} ms",
            work,
            _peak(result, "acceleration"),
            _peak(result, "axial_force"),
            error,
        )
    return table


def _peak(result, quantity: str) -> str:
    """Largest magnitude of a probe output over all probes and the axis, e.g. ``17.5 @right``."""
    peaks = {probe: float(abs(out[quantity]).max()) for probe, out in result.probes.items() if quantity in out}
    if not peaks:
        return ""
    probe = max(peaks, key=peaks.get)
    return f"{peaks[probe]:.4g} @{probe}"


def impact_table(outcome) -> Table:
    """Per model run and estimator: peak coupler force and its errors against fem, sensor error, cost; with
    cars that bend also the vertical-acceleration error.

    A network estimator gives a peak only (``peak_force``): its row shows that peak and its
    error; the history columns (peak time, rms, acceleration, energy) stay blank.
    """
    scene = outcome.scene
    title = f"impact scene, {len(scene.cars)} cars, {len(scene.couplers)} couplers, ε = {scene.epsilon:.3g}; errors against fem"
    table = Table(title=title, title_justify="left")
    vertical = any(car.bends for car in scene.cars)
    columns = ("model", "status", "steps", "wall time", "speed-up", "peak P kN @coupler", "peak err", "t_peak err ms", "P rms err", "a rms err max",
               *(("a_vert rms err max", "pitch rate rms err max") if vertical else ()), "energy bal.")
    for column in columns:
        table.add_column(column, justify="left" if column in ("model", "status") else "right", no_wrap=column == "model")
    for result in outcome.results:
        score = outcome.scores.get(result.model, {})
        peaks = {c: float(np.max(out["force"] if "force" in out else out["peak_force"])) for c, out in result.couplers.items()} if result.ok else {}
        coupler = max(peaks, key=peaks.get) if peaks else None
        balance = result.settings.get("energy_balance_error")
        table.add_row(
            result.model,
            result.status,
            str(result.settings.get("steps", "")),
            f"{result.wall_time_s * 1e3:.1f} ms",
            f"{score['speedup']:.3g}×" if "speedup" in score else ("reference" if result.ok and not score else ""),
            f"{peaks[coupler] / 1e3:.1f} @{coupler}" if coupler else "",
            _fmt(score.get(f"coupler_force_peak_error_{coupler}"), "{:.2%}"),
            _fmt(score.get(f"coupler_force_peak_time_error_{coupler}"), "{:+.2f}", 1e3),
            _fmt(score.get(f"coupler_force_rms_error_{coupler}"), "{:.2%}"),
            _fmt(score.get("acceleration_rms_error_max"), "{:.2%}"),
            *((_fmt(score.get("vertical_acceleration_rms_error_max"), "{:.2%}"), _fmt(score.get("pitch_rate_rms_error_max"), "{:.2%}"))
              if vertical else ()),
            _fmt(balance, "{:.1e}"),
        )
    return table


def _fmt(value: float | None, pattern: str, factor: float = 1.0) -> str:
    """``value × factor`` in ``pattern``; blank for a missing or non-finite value."""
    return "" if value is None or not math.isfinite(value) else pattern.format(value * factor)


def study_table(outcome) -> Table:
    """Peak-force errors against fem: per network (by training source) and inverse estimator, per evaluation set."""
    sets = list(outcome.sets)
    table = Table(title="peak coupler force error against fem, |P̂ − P|/P: mean / 95th percentile", title_justify="left")
    for column in ("estimator", "trained on", "own source", *sets, "train s", "µs/record"):
        table.add_column(column, justify="left" if column in ("estimator", "trained on") else "right")
    timing = {t.name: t.training_time_s for t in outcome.networks}
    first = outcome.sets[sets[0]]
    for row in outcome.table_rows():
        own = row["own source"]
        name = row["estimator"]
        table.add_row(
            name,
            row["trained on"],
            "" if own is None else f"{own.mean:.2%}",
            *(f"{row[s].mean:.2%} / {row[s].p95:.2%}" if s in row else "" for s in sets),
            f"{timing[name]:.1f}" if name in timing else "",
            f"{first.inference_time_s[name] * 1e6:.0f}" if name in first.inference_time_s else "",
        )
    return table


def bench_table(outcome) -> Table:
    """Every configuration: step, work, median time, ratio to rigid, errors (with cars that bend also the worst
    vertical-acceleration rms error), Pareto flag."""
    title = f"femref bench: median of {outcome.repeats} wall times; errors against {outcome.plan.reference_description}"
    table = Table(title=title, title_justify="left")
    vertical = any(math.isfinite(row.vertical_error) for row in outcome.rows)
    columns = ("configuration", "dt ms", "steps", "wall time ms", "× rigid", "peak err", "rms err", *(("a_vert err",) if vertical else ()), "Pareto", "status")
    for column in columns:
        table.add_column(column, justify="left" if column in ("configuration", "status", "Pareto") else "right", no_wrap=column == "configuration")
    for row in outcome.rows:
        c = row.configuration
        table.add_row(
            c.label,
            _fmt(c.dt * 1e3, "{:.4g}"),
            str(row.steps) if row.steps else "",
            _fmt(row.wall_time_s * 1e3, "{:.2f}"),
            _fmt(row.time_ratio_rigid, "{:.3g}"),
            _percent(row.peak_error),
            _percent(row.rms_error),
            *((_percent(row.vertical_error),) if vertical else ()),
            "✓" if row.pareto else "",
            row.status if row.ok else f"{row.status}: {row.message}",
        )
    return table


def _percent(value: float) -> str:
    """A relative error in per cent to three significant digits (``0.0194%``)."""
    return f"{value * 100:.3g}%" if math.isfinite(value) else ""


def event_table(outcome) -> Table:
    """One row per event and estimator of a measured case: type, closing speed, peak force with its 95 %
    band (blank without a bound), closure, wear and alarm; flags below the table's rows of their event."""
    several = len(outcome.scene.couplers) > 1
    table = Table(title=f"measured records: {len(outcome.events)} event(s); peak force with its 95 % band", title_justify="left")
    for column in ("event", "t trigger s", "type", "ρ0", "v m/s", "estimator", "status", "peak kN", "band kN", "closure", "wear", "alarm"):
        table.add_column(column, justify="right" if column in ("event", "t trigger s", "ρ0", "v m/s", "peak kN", "band kN") else "left", no_wrap=True)
    for event in outcome.events:
        closure = ", ".join(c.status + (f" at {c.closure_force / 1e3:.0f} kN" if c.status == "closed" else "") for c in event.closures)
        for k, estimate in enumerate(event.estimates):
            peak, lower, upper = estimate.peak
            head = k == 0
            table.add_row(
                str(event.index) if head else "",
                f"{event.trigger_time:.4f}" if head else "",
                event.impact_type if head else "",
                _fmt(event.zero_harmonic_ratio, "{:.2f}") if head else "",
                _fmt(event.closing_speed, "{:.2f}") if head else "",
                estimate.estimator + (f" @{estimate.coupler}" if several else ""),
                estimate.status,
                _fmt(peak / 1e3, "{:.1f}"),
                f"{lower / 1e3:.0f}–{upper / 1e3:.0f}" if math.isfinite(lower) else "",
                closure if head else "",
                event.wear if head else "",
                event.alarm if head else "",
            )
        notes = list(event.flags) + [f"{e.estimator}: {e.message}" for e in event.estimates if not e.ok]
        for note in notes:
            table.add_row("", "", "", "", "", f"[yellow]{note}[/yellow]", "", "", "", "", "", "")
    return table
