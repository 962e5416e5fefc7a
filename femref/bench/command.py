"""``femref bench [CASE] [-o FILE] [--repeats N] [--plot PNG]``: the speed–accuracy trade of one impact scene.

docs/design.md §7. Runs the configurations of :mod:`femref.bench.configurations` (fem at
several element counts and steps, modal at several mode counts, quasi-rigid, rigid, the
case's estimators), times each as the median of ``--repeats`` runs, scores each against
the finest fem, writes the HDF5 table (:func:`femref.bench.output.write_bench_table`),
optionally the Pareto plot, and prints the table and the Pareto-optimal configurations.
No CASE: the built-in default scene, as for ``femref run``.

Impact cases only: a single-body (harmonic or transient) case exits 2 with
"femref bench serves impact cases" — their cost is one banded solve per step or
frequency and the trade worth measuring is the impact models'. Exit codes as for
``femref run``: 2 bad input (nothing written), 1 a configuration failed (the table
records which and why) or the reference failed (nothing written), 0 otherwise.
"""

from __future__ import annotations

import math
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import click
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from femref.case import CaseError, load_case, parse_case, resolved_yaml
from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data

__all__ = ["bench_command"]

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILURE = 1
IMPACT_ONLY = "femref bench serves impact cases"


@click.command("bench")
@click.argument("case_path", metavar="CASE", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), help="bench table (default: CASE stem + _bench.h5)")
@click.option("--repeats", type=click.IntRange(min=1), default=3, show_default=True, help="timed runs per configuration (the median is kept)")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False, path_type=Path), help="write the Pareto plot (PNG) here")
def bench_command(case_path: Path | None, output: Path | None, repeats: int, plot_path: Path | None) -> None:
    """Time and score every model of CASE at several resolutions against the finest fem; table + Pareto plot."""
    from femref.bench.output import plot_pareto, write_bench_table
    from femref.bench.run import ReferenceFailed, run_bench
    from femref.scene.build import scene_from_case

    try:
        case = parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE) if case_path is None else load_case(case_path)
        if case.kind != "impact":
            raise CaseError.at("kind", f"{IMPACT_ONLY}; this is a {case.kind} case", source=str(case_path))
        scene = scene_from_case(case, case_path.resolve().parent if case_path else Path.cwd())
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    output = output or Path(f"{case_path.stem if case_path else 'default'}_bench.h5")

    try:
        with _progress(Console(stderr=True)) as progress:
            outcome = run_bench(scene, repeats, progress)
    except ReferenceFailed as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_RUN_FAILURE)
    written = [write_bench_table(output, resolved_yaml(case), outcome)]
    if plot_path is not None:
        name = case_path.name if case_path else DEFAULT_SCENE_SOURCE
        written.append(plot_pareto(plot_path, outcome, title=f"femref bench {name}: peak coupler force error vs wall time"))
    console = Console(width=max(150, Console().width))
    console.print(bench_table(outcome))
    click.echo("Pareto-optimal (fastest first): " + ", ".join(row.configuration.label for row in outcome.pareto_rows))
    for note in outcome.notes:
        click.echo(f"note: {note}")
    for path in written:
        click.echo(f"wrote {path}")
    for row in outcome.failed:
        click.echo(f"error: configuration {row.configuration.label} failed: {row.message}", err=True)
    if outcome.failed:
        sys.exit(EXIT_RUN_FAILURE)


def bench_table(outcome) -> Table:
    """Every configuration: step, work, median time, ratio to rigid, errors, Pareto flag."""
    title = f"femref bench: median of {outcome.repeats} wall times; errors against {outcome.plan.reference_description}"
    table = Table(title=title, title_justify="left")
    columns = ("configuration", "dt ms", "steps", "wall time ms", "× rigid", "peak err", "rms err", "Pareto", "status")
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
            "✓" if row.pareto else "",
            row.status if row.ok else f"{row.status}: {row.message}",
        )
    return table


def _percent(value: float) -> str:
    """A relative error in per cent to three significant digits (``0.0194%``)."""
    return f"{value * 100:.3g}%" if math.isfinite(value) else ""


def _fmt(value: float, pattern: str) -> str:
    return pattern.format(value) if math.isfinite(value) else ""


@contextmanager
def _progress(console: Console) -> Iterator:
    """A configurations progress bar on a terminal; None (no callback) when output is piped."""
    if not console.is_terminal:
        yield None
        return
    columns = (TextColumn("bench {task.description}"), BarColumn(), TextColumn("{task.completed} done"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task("", total=None)
        started = [False]

        def progress(label: str) -> None:
            if started[0]:
                bar.advance(task)
            started[0] = True
            bar.update(task, description=label)

        yield progress
