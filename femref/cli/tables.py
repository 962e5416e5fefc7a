"""The summary tables the commands print: a run (single body or impact), the network study, the bench, the events
of a measured case; and how a table too wide for the terminal is laid out (:func:`fit`).

Headers are short; a legend under each table (its caption) defines every column, with units.
Every relative error is a percentage in one format (:func:`_percent`, ``12.34%``).
A column of figures never wraps (``no_wrap``): a table wider than the terminal is split into panels of whole
columns, each repeating the columns that name a row; only titles, legends and words of text columns wrap.
"""

from __future__ import annotations

import copy
import dataclasses
import io
import math

from rich import box
from rich.console import Console
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text


def run_table(outcome) -> Table:
    """Model, status, wall time, work and the key outputs, with the errors against the reference."""
    if outcome.scene.kind == "impact":
        return impact_table(outcome)
    reference = next((score["reference"] for score in outcome.scores.values() if "reference" in score and not _self_check_only(score)), None)
    against = f"; errors against {reference}" if reference else ""
    table = Table(title=f"{outcome.scene.kind} scene, ε = {outcome.scene.epsilon:.3g}{against}", title_justify="left", caption_justify="left")
    for column in ("model", "status", "wall ms", "work", "|a| peak", "|F| peak", "a err max", "a err rms"):
        table.add_column(column, justify="left" if column in ("model", "status") else "right", no_wrap=column != "status", overflow="fold")
    notes: list[str] = []
    for result in outcome.results:
        work = ""
        if "steps" in result.settings:
            work = f"{result.settings['steps']} steps"
        elif "frequencies" in result.settings:
            work = f"{result.settings['frequencies']} freqs"
        score = outcome.scores.get(result.model, {})
        is_reference = result.ok and (result.model == reference or (reference is None and "reference_warning" in score)) and (
            not score or _self_check_only(score))
        table.add_row(
            result.model,
            result.status,
            _fmt(result.wall_time_s * 1e3, "{:.1f}"),
            work,
            _peak(result, "acceleration"),
            _peak(result, "axial_force"),
            "reference" if is_reference else _percent(score.get("acceleration_max_error_max")),
            "" if is_reference else _percent(score.get("acceleration_rms_error_max")),
        )
        if "reference_warning" in score:  # the fem run checked itself (femref.run.runner.check_reference)
            notes.append(f"[yellow]{result.model}: {_self_check_note(score, 'peak |a|')}[/yellow]")
    table.caption = with_notes(notes, legend(
        ("wall ms", "wall time of the run, ms"),
        ("work", "time steps or frequencies solved"),
        ("|a| peak", "largest |acceleration| over the probes, m/s² @probe"),
        ("|F| peak", "largest |axial force| over the probes, N @probe"),
        ("a err max", "max over time of |a − a_ref| / peak |a_ref|, worst probe"),
        ("a err rms", "rms(a − a_ref) / rms(a_ref), worst probe"),
    ))
    return table


def with_notes(notes: list[str], caption: str) -> str:
    """The caption under a table: its notes (one line each, ``model: …``), then its legend — a note in a row of
    its own would widen a column to the note's length."""
    return "\n".join([*notes, caption])


def legend(*entries: tuple[str, str]) -> str:
    """The line under a table that defines its columns: ``header: meaning`` joined by ``; ``."""
    return "; ".join(f"{header}: {meaning}" for header, meaning in entries)


def _peak(result, quantity: str) -> str:
    """Largest magnitude of a probe output over all probes and the axis, e.g. ``17.5 @right``."""
    peaks = {probe: float(abs(out[quantity]).max()) for probe, out in result.probes.items() if quantity in out}
    if not peaks:
        return ""
    probe = max(peaks, key=peaks.get)
    return f"{peaks[probe]:.4g} @{probe}"


def impact_table(outcome) -> Table:
    """Per model run and estimator: peak coupler force and its errors against fem, sensor error, cost; with
    cars that bend also the vertical-acceleration and pitch-rate errors.

    A network estimator gives a peak only (``peak_force``): its row shows that peak and its
    error; the history columns (peak time, rms, acceleration, energy) stay blank.
    """
    scene = outcome.scene
    title = f"impact scene, {len(scene.cars)} cars, {len(scene.couplers)} couplers, ε = {scene.epsilon:.3g}; errors against fem"
    table = Table(title=title, title_justify="left", caption_justify="left")
    vertical = any(car.bends for car in scene.cars)
    columns = ("model", "status", "steps", "wall ms", "speed-up", "P peak kN", "P peak err", "t peak err ms", "P rms err", "a rms err",
               *(("a_v rms err", "pitch rms err") if vertical else ()), "E err")
    for column in columns:
        table.add_column(column, justify="left" if column in ("model", "status") else "right", no_wrap=column != "status", overflow="fold")
    notes: list[str] = []
    for result in outcome.results:
        score = outcome.scores.get(result.model, {})
        peaks = {c: float((out["force"] if "force" in out else out["peak_force"]).max()) for c, out in result.couplers.items()} if result.ok else {}
        coupler = max(peaks, key=peaks.get) if peaks else None
        balance = result.settings.get("energy_balance_error")
        table.add_row(
            result.model,
            result.status,
            str(result.settings.get("steps", "")),
            _fmt(result.wall_time_s * 1e3, "{:.1f}"),
            f"{score['speedup']:.3g}×" if "speedup" in score else ("ref" if result.ok and ("reference_warning" in score or not score) else ""),
            f"{peaks[coupler] / 1e3:.1f} @{coupler}" if coupler else "",
            _percent(score.get(f"coupler_force_peak_error_{coupler}", score.get(f"reference_error_estimate_{coupler}")),
                     lower=f"coupler_force_peak_error_{coupler}" not in score and "reference_error_bound" in score),
            _fmt(score.get(f"coupler_force_peak_time_error_{coupler}"), "{:+.2f}", 1e3),
            _percent(score.get(f"coupler_force_rms_error_{coupler}")),
            _percent(score.get("acceleration_rms_error_max")),
            *((_percent(score.get("vertical_acceleration_rms_error_max")), _percent(score.get("pitch_rate_rms_error_max"))) if vertical else ()),
            _percent(balance),
        )
        if "reference_warning" in score:  # the reference checked itself (femref.run.runner.check_reference)
            notes.append(f"[yellow]{result.model}: {_self_check_note(score, 'P peak')}, in its P peak err column[/yellow]")
        if "outside_range_fraction" in score:  # quasi-rigid cars outside their range somewhere (femref.run.validity)
            notes.append(f"{result.model}: {_in_range_note(score)}")
    table.caption = with_notes(notes, legend(
        ("wall ms", "wall time of the run, ms"),
        ("speed-up", "fem's wall time / the model's (ref: the reference)"),
        ("P peak kN", "largest coupler compression force, kN @coupler"),
        ("P peak err", "|P − P_fem| / P_fem of that peak"),
        ("t peak err ms", "time of that peak − fem's, ms"),
        ("P rms err", "rms(P − P_fem) / rms(P_fem) at that coupler"),
        ("a rms err", "rms(a − a_fem) / rms(a_fem), worst sensor"),
        *((("a_v rms err", "the same for the vertical acceleration"), ("pitch rms err", "the same for the pitch rate")) if vertical else ()),
        ("E err", "energy balance error of the line, max |E(t) − E(0)| / max |E| with E every energy account (kinetic, strain, stored, dissipated)"),
    ))
    return table


def _fmt(value: float | None, pattern: str, factor: float = 1.0) -> str:
    """``value × factor`` in ``pattern``; blank for a missing or non-finite value."""
    return "" if value is None or not math.isfinite(value) else pattern.format(value * factor)


def study_table(outcome) -> Table:
    """Peak-force errors against fem: per network (by training source) and inverse estimator, per evaluation set."""
    sets = list(outcome.sets)
    table = Table(title="peak coupler force error against fem, |P̂ − P|/P: mean / 95th percentile", title_justify="left", caption_justify="left")
    table.caption = legend(
        ("own source", "mean error on the held-out part of its own training source"),
        *((name, f"mean / 95th percentile on the {name} set") for name in sets),
        ("train s", "training time, s"),
        ("µs/record", f"estimate time per record on the {sets[0]} set, µs"),
    )
    for column in ("estimator", "trained on", "own source", *sets, "train s", "µs/record"):
        table.add_column(column, justify="left" if column in ("estimator", "trained on") else "right", no_wrap=column != "trained on", overflow="fold")
    timing = {t.name: t.training_time_s for t in outcome.networks}
    first = outcome.sets[sets[0]]
    for row in outcome.table_rows():
        own = row["own source"]
        name = row["estimator"]
        table.add_row(
            name,
            row["trained on"],
            "" if own is None else _percent(own.mean),
            *(f"{_percent(row[s].mean)} / {_percent(row[s].p95)}" if s in row else "" for s in sets),
            f"{timing[name]:.1f}" if name in timing else "",
            f"{first.inference_time_s[name] * 1e6:.0f}" if name in first.inference_time_s else "",
        )
    return table


def bench_table(outcome) -> Table:
    """Every configuration: step, work, median time, ratio to rigid, errors (with cars that bend also the worst
    vertical-acceleration rms error), Pareto flag."""
    title = f"femref bench: median of {outcome.repeats} wall times; errors against {outcome.plan.reference_description}"
    table = Table(title=title, title_justify="left", caption_justify="left")
    vertical = any(math.isfinite(row.vertical_error) for row in outcome.rows)
    columns = ("configuration", "dt ms", "steps", "wall ms", "× rigid", "peak err", "rms err", *(("a_v err",) if vertical else ()), "Pareto", "status")
    for column in columns:
        table.add_column(column, justify="left" if column in ("configuration", "status", "Pareto") else "right", no_wrap=column != "status",
                         overflow="fold")
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
    table.caption = legend(
        ("dt ms", "time step, ms"),
        ("wall ms", "median wall time of the runs, ms"),
        ("× rigid", "wall time / rigid's"),
        ("peak err", "|P − P_ref| / P_ref of the peak coupler force, worst coupler"),
        ("rms err", "rms(P − P_ref) / rms(P_ref), worst coupler"),
        *((("a_v err", "rms(a_v − a_v,ref) / rms(a_v,ref), worst sensor"),) if vertical else ()),
        ("Pareto", "✓: no configuration both faster and with a smaller peak err"),
    )
    return table


def _percent(value: float | None, lower: bool = False) -> str:
    """A relative error in per cent with two decimals (``12.34%``), the one format of every table; a
    positive error below 0.005 % is ``<0.01%``; blank for a missing or non-finite value; ``≥`` before a lower bound."""
    if value is None or not math.isfinite(value):
        return ""
    text = "<0.01%" if 0 < abs(value) < 5e-5 else f"{value:.2%}"
    return f"≥{text}" if lower else text


def _in_range_note(score: dict) -> str:
    """The line under a run whose quasi-rigid cars leave their range: the share of the record outside, and its
    errors where they hold (femref.run.scoring.in_range_errors) — or, when the in-range part does not hold the impact,
    that its scores are degenerate and why."""
    outside = f"outside its range {_percent(score['outside_range_fraction'])} of the record (shaded in the report)"
    if "in_range_degenerate" in score:
        return f"{outside}; no in-range scores, the in-range part is degenerate — {score['in_range_degenerate']}"
    errors = [(label, score.get(f"{q}_rms_in_range_error_max")) for label, q in
              (("P rms err", "coupler_force"), ("a rms err", "acceleration"), ("a_v rms err", "vertical_acceleration"))]
    shown = ", ".join(f"{label} {_percent(value)}" for label, value in errors if value is not None)
    return f"{outside}; in range: {shown}"


def _self_check_only(score: dict) -> bool:
    """A score entry made by the reference's self-check alone (its ``reference`` is the model's own finer runs)."""
    return "self_check" in score and score.get("reference") == score["self_check"]


def _self_check_note(score: dict, quantity: str) -> str:
    """The warning line of a run that checked itself: why, and its own error of ``quantity`` as a Richardson estimate,
    or as a lower bound when the runs are outside the asymptotic range (femref.run.runner.check_reference)."""
    estimate = _percent(score.get("reference_error_estimate"))
    runs = score.get("self_check", score.get("reference", ""))
    if "reference_error_bound" in score:
        order = score.get("reference_observed_order")
        seen = f"observed order {order:.2f}, " if isinstance(order, float) and math.isfinite(order) else ""
        own = f"its own {quantity} error is at least {estimate} (a lower bound: {seen}outside the asymptotic range; {runs})"
    else:
        own = f"its own {quantity} error is estimated at {estimate} (Richardson, {runs})"
    return f"warning: {score['reference_warning']}; {own}"


def _closing_speed(event) -> str:
    """An event's closing speed and its interval, ``given`` when the case gave it (m/s)."""
    if not math.isfinite(event.closing_speed):
        return ""
    given = " given" if event.closing_speed_source == "given" else ""
    return f"{event.closing_speed:.2f} [{event.closing_speed_lower:.2f}–{event.closing_speed_upper:.2f}]{given}"


def event_table(outcome) -> Table:
    """One row per event and estimator of a measured case: the event's trigger time, type, closing speed with its interval,
    closure, wear and alarm; then each estimator's peak force with its 95 % band (blank without a bound). The events'
    flags and notes, ``event <k>: …``, above the legend."""
    several = len(outcome.scene.couplers) > 1
    table = Table(title=f"measured records: {len(outcome.events)} event(s); peak force with its 95 % band", title_justify="left",
                  caption_justify="left")
    figures = ("t trigger s", "ρ0", "v m/s", "peak kN", "band kN", "contact s")
    columns = ("event", "t trigger s", "type", "ρ0", "v m/s", "closure", "wear", "alarm", "estimator", "status", "peak kN", "band kN")
    for column in columns + (("contact s",) if several else ()):
        table.add_column(column, justify="right" if column in figures else "left", no_wrap=column not in ("closure", "status"), overflow="fold")
    notes: list[str] = []
    for event in outcome.events:
        closure = ", ".join(c.status + (f" at {c.closure_force / 1e3:.0f} kN" if c.status == "closed" else "") for c in event.closures)
        head = [str(event.index), f"{event.trigger_time:.4f}", event.impact_type, _fmt(event.zero_harmonic_ratio, "{:.2f}"), _closing_speed(event),
                closure, event.wear, event.alarm]
        if not event.estimates:  # not an impact: the event's own row, its evidence in the notes
            table.add_row(*head, "none run", "", "", "", *([""] if several else []))
        for k, estimate in enumerate(event.estimates):
            peak, lower, upper = estimate.peak
            contact = [_fmt(estimate.settings.get("contact_time"), "{:.4f}")] if several else []
            table.add_row(
                *(head if k == 0 else [""] * len(head)),
                estimate.estimator + (f" @{estimate.coupler}" if several else ""),
                estimate.status,
                _fmt(peak / 1e3, "{:.1f}"),
                f"{lower / 1e3:.0f}–{upper / 1e3:.0f}" if math.isfinite(lower) else "",
                *contact,
            )
        event_notes = list(event.flags) + [f"{e.estimator}: {e.message}" for e in event.estimates if not e.ok]
        event_notes += [event.classification_basis] if not event.estimates and event.classification_basis else []
        if event.closing_speed_source == "none":
            event_notes.append(f"no closing speed: {event.closing_speed_basis}")
        event_notes += [f"clock {c.recorder}: correction {c.correction:+.6f} s, drift {c.drift:+.2f} ppm, lag {c.lag:+.6f} s (residual {c.residual:+.2e} s)"
                        for c in event.clock_corrections]
        notes += [f"[yellow]event {event.index}: {note}[/yellow]" for note in event_notes]
    table.caption = with_notes(notes, legend(
        ("t trigger s", "time the event triggers, s"),
        ("type", "free_to_roll, coupled or not_an_impact"),
        ("ρ0", "zero-harmonic ratio of the coupler's relative acceleration, which decides the type"),
        ("v m/s", "closing speed [95 % interval], m/s; given: from the case"),
        ("closure", "the draft gear's closure, with its force"),
        ("peak kN", "peak coupler force, kN"),
        ("band kN", "its 95 % band, kN"),
        *([("contact s", "the contact instant at that coupler, s on the records' clock")] if several else []),
    ))
    return table


def natural_width(table: Table) -> int:
    """The width ``table`` takes when nothing limits it (every cell on one line)."""
    unlimited = Console(width=100_000, file=io.StringIO())
    return Measurement.get(unlimited, unlimited.options, table).maximum


def fit(table: Table, width: int) -> list[Table | Text]:
    """``table`` laid out in ``width`` columns with every figure whole, as renderables printed one under another.

    As it is when its natural width fits; else without frame and padding (columns one space apart); else split into
    panels of whole columns, left to right, each led by the columns that name a row (those before the first
    right-justified column, at least one), a row whose cells are all blank in a panel left out of it: the title above
    the first panel, the legend under the last at the full ``width``. Only text columns (not ``no_wrap``), the title
    and the legend wrap, at spaces. A panel holds at least one column besides its keys, so a single column wider than
    ``width`` overflows.
    """
    if natural_width(table) <= width:
        return [table]
    compact = copy.copy(table)
    compact.box, compact.show_edge, compact.padding = box.SIMPLE_HEAD, False, (0, 0)
    narrowest = _narrowest_widths(compact)
    if sum(narrowest) + len(narrowest) - 1 <= width:
        return [compact]
    keys = next((k for k, column in enumerate(table.columns) if column.justify == "right"), 1) or 1
    if keys >= len(table.columns):  # nothing to split off
        return [compact]
    panels: list[list[int]] = []
    for k in range(keys, len(table.columns)):
        taken = [*range(keys), *(panels[-1][keys:] if panels else ()), k]
        if panels and sum(narrowest[j] for j in taken) + len(taken) - 1 <= width:
            panels[-1].append(k)
        else:
            panels.append([*range(keys), k])
    legend_text = [Text.from_markup(table.caption)] if isinstance(table.caption, str) else [table.caption] if table.caption else []
    return [*(_panel(compact, columns, first=n == 0) for n, columns in enumerate(panels)), *legend_text]


def _narrowest_widths(table: Table) -> list[int]:
    """Per column, the narrowest it can be laid out: its widest cell (header included) if it does not wrap, else its
    longest word."""
    console = Console(width=100_000, file=io.StringIO())
    widths = []
    for column in table.columns:
        cells = [console.render_str(cell) if isinstance(cell, str) else cell for cell in (column.header, *column.cells)]
        measured = [Measurement.get(console, console.options, cell) for cell in cells]
        widths.append(max(m.maximum if column.no_wrap else m.minimum for m in measured))
    return widths


def _panel(table: Table, columns: list[int], first: bool) -> Table:
    """The table of ``table``'s ``columns`` (indices), with its title if ``first``; no legend."""
    panel = Table(title=table.title if first else None, title_justify=table.title_justify,
                  caption_justify=table.caption_justify, box=table.box, show_edge=table.show_edge, padding=table.padding)
    kept = [table.columns[k] for k in columns]
    for column in kept:
        panel.add_column(**{f.name: getattr(column, f.name) for f in dataclasses.fields(column) if not f.name.startswith("_")})
    for row in zip(*(list(column.cells) for column in kept), strict=True):
        if any(cell != "" for cell in row):
            panel.add_row(*row)
    return panel
