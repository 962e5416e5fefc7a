"""The ``femref`` command: run and validate case files (docs/design.md §5).

Exit codes: 0 success, 2 bad input (the message names the key path and the rule),
1 a failure during the run (the result file still records which model failed and why).
``femref sweep`` exits 0 when the sweep ran, even with failed samples (the sweep file
records them), 1 when the sweep machinery fails, 130 when interrupted (stored samples kept).
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import click
import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from femref.case import CaseError, load_case, parse_case, resolved_yaml
from femref.case.errors import Problem
from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILURE = 1


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="femref")
def main() -> None:
    """femref: FEM reference solver for freight-car impacts, and the scores of cheaper models against it."""


def _load(case_path: Path | None):
    if case_path is None:
        return parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE), Path.cwd()
    return load_case(case_path), case_path.resolve().parent


@main.command()
@click.argument("case_path", metavar="CASE", required=False, type=click.Path(dir_okay=False, path_type=Path))
def validate(case_path: Path | None) -> None:
    """Check CASE and print the resolved case (every default filled in)."""
    try:
        case, _ = _load(case_path)
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    click.echo(resolved_yaml(case), nl=False)


@main.command()
@click.argument("case_path", metavar="CASE", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), help="result file (default: CASE stem + .h5)")
@click.option(
    "--tolerance",
    type=click.FloatRange(min=0.0, max=1.0, min_open=True, max_open=True),
    help="choose the cheapest model expected within this relative error (impact cases; overrides the case's tolerance.value)",
)
def run(case_path: Path | None, output: Path | None, tolerance: float | None) -> None:
    """Run CASE (no CASE: the built-in default scene) with every requested model; write HDF5 results.

    With a tolerance (--tolerance or the case's tolerance:) the run instead climbs the
    ladder of impact models and resolutions and keeps the cheapest expected within it.
    """
    from femref.results import write_results
    from femref.run import run_scene
    from femref.scene.build import scene_from_case

    console = Console(stderr=True)
    try:
        case, base_dir = _load(case_path)
        case = _with_tolerance(case, tolerance, str(case_path) if case_path else DEFAULT_SCENE_SOURCE)
        scene = scene_from_case(case, base_dir)
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    output = output or Path(f"{case_path.stem if case_path else 'default'}.h5")
    if getattr(case, "tolerance", None) is not None:
        _run_choice(case, scene, output, console)
        return

    with _progress(console) as progress_for:
        outcome = run_scene(scene, progress_for)
    written = write_results(output, resolved_yaml(case), outcome.results, outcome.scores, scene=scene.facts())
    Console(width=max(150, Console().width)).print(_summary(outcome))
    for path in written:
        click.echo(f"wrote {path}")
    for failed in outcome.failed:
        click.echo(f"error: model {failed.model} failed: {failed.message}", err=True)
    if outcome.failed:
        sys.exit(EXIT_RUN_FAILURE)


def _with_tolerance(case, tolerance: float | None, source: str):
    """The case with ``--tolerance`` in its ``tolerance.value`` (kept in the resolved case of the result file)."""
    if tolerance is None:
        return case
    if case.kind != "impact":
        rule = "--tolerance: model choice serves impact cases (the ladder of impact models)"
        raise CaseError(Problem(("kind",), rule, case.kind), source)
    from femref.case.runs import ToleranceSpec

    spec = ToleranceSpec(value=tolerance) if case.tolerance is None else ToleranceSpec(value=tolerance, output=case.tolerance.output)
    return case.model_copy(update={"tolerance": spec})


def _run_choice(case, scene, output: Path, console: Console) -> None:
    """Choose the model (femref.choice), write every run made and ``/choice``, print the ladder."""
    from femref.choice import choose_model, run_rung
    from femref.choice.output import choice_table, write_choice
    from femref.results import write_results

    if scene.estimators or scene.networks:
        click.echo("note: with a tolerance the estimators are not run (they read the records of the models list's fem run)", err=True)
    with _progress(console) as progress_for:
        try:
            choice = choose_model(scene, case.tolerance.value, case.tolerance.output, runner=lambda rung: run_rung(rung, progress_for(rung.label)))
        except RuntimeError as error:
            click.echo(f"error: {error}", err=True)
            sys.exit(EXIT_RUN_FAILURE)
    written = write_results(output, resolved_yaml(case), choice.results, extra=lambda h5: write_choice(h5, choice), scene=scene.facts())
    Console(width=max(150, Console().width)).print(choice_table(choice))
    for path in written:
        click.echo(f"wrote {path}")
    if not choice.met:
        click.echo(f"warning: no model on the ladder is expected within {choice.tolerance:g}; kept {choice.chosen}, the most accurate", err=True)


@contextmanager
def _progress(console: Console) -> Iterator:
    """A per-model progress bar on a terminal; nothing when output is piped."""
    if not console.is_terminal:
        yield lambda model: None
        return
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:

        def progress_for(model: str):
            task = bar.add_task(model, total=None)
            return lambda done, total: bar.update(task, completed=done, total=total)

        yield progress_for


def _summary(outcome) -> Table:
    """Model, status, wall time, work and the key outputs, with the error against the reference."""
    if outcome.scene.kind == "impact":
        return _impact_summary(outcome)
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
            f"{score['acceleration_error_max']:.2g} / {score['acceleration_rms_error_max']:.2g} vs {score['reference']}"
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


def _impact_summary(outcome) -> Table:
    """Per model run and estimator: peak coupler force and its errors against fem, sensor error, cost.

    A network estimator gives a peak only (``peak_force``): its row shows that peak and its
    error; the history columns (peak time, rms, acceleration, energy) stay blank.
    """
    scene = outcome.scene
    title = f"impact scene, {len(scene.cars)} cars, {len(scene.couplers)} couplers, ε = {scene.epsilon:.3g}; errors against fem"
    table = Table(title=title, title_justify="left")
    columns = ("model", "status", "steps", "wall time", "speed-up", "peak P kN @coupler", "peak err", "t_peak err ms", "P rms err", "a rms err max", "energy bal.")
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
            _fmt(balance, "{:.1e}"),
        )
    return table


def _fmt(value, pattern: str, factor: float = 1.0) -> str:
    return "" if value is None else pattern.format(value * factor)


EXIT_INTERRUPTED = 130
#: Failed samples listed after a sweep (the file holds every error).
SHOWN_FAILURES = 5


@main.command()
@click.argument("sweep_path", metavar="SWEEP", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scheduler", metavar="tcp://HOST:PORT", help="run on this Dask scheduler (default: a local cluster)")
@click.option("--workers", type=click.IntRange(min=1), help="local cluster worker processes (default: one per CPU)")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), help="sweep file (default: SWEEP stem + .h5)")
@click.option("--limit", type=click.IntRange(min=0), help="run at most N samples now (the file stays .partial)")
@click.option("--retry-failed", is_flag=True, help="run the samples stored as failed again")
def sweep(sweep_path: Path, scheduler: str | None, workers: int | None, output: Path | None, limit: int | None, retry_failed: bool) -> None:
    """Run the samples of SWEEP not yet stored in the sweep file, on Dask; resumable (docs/design.md §6)."""
    from femref.sweep import SweepInterrupted, load_sweep, run_sweep

    if scheduler is not None and workers is not None:
        raise click.UsageError("--workers sizes the local cluster; the cluster behind --scheduler has its own workers")
    console = Console(stderr=True)
    try:
        loaded = load_sweep(sweep_path)
        output = output or Path(f"{sweep_path.stem}.h5")
        with _sweep_progress(console) as progress:
            summary = run_sweep(loaded, output, scheduler=scheduler, workers=workers, limit=limit, retry_failed=retry_failed, progress=progress)
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except SweepInterrupted as interrupted:
        _sweep_report(interrupted.summary)
        click.echo(f"interrupted: {interrupted.summary.run} samples stored in this call; run again to resume", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except Exception as error:  # the sweep machinery (scheduler, workers, file system), not a sample
        click.echo(f"error: sweep failed: {type(error).__name__}: {error}", err=True)
        sys.exit(EXIT_RUN_FAILURE)
    _sweep_report(summary)


@contextmanager
def _sweep_progress(console: Console) -> Iterator:
    """A samples progress bar on a terminal; None when output is piped."""
    if not console.is_terminal:
        yield None
        return
    columns = (TextColumn("sweep"), BarColumn(), TextColumn("{task.completed}/{task.total} samples"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task("sweep", total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


def _sweep_report(summary) -> None:
    """One line of counts and speed, the first failures, and where the samples are."""
    if summary.run == 0 and summary.complete:
        failed = f" ({summary.stored_failed} failed; --retry-failed runs them again)" if summary.stored_failed else ""
        click.echo(f"all {summary.total} samples already stored in {summary.path}{failed}")
        return
    failed = f"{summary.failed} failed" + (f" ({summary.stored_failed} stored as failed in all)" if summary.stored_failed != summary.failed else "")
    click.echo(
        f"samples: {summary.total} total, {summary.run} run now, {summary.skipped} skipped (already stored), {failed}; "
        f"wall time {summary.wall_time_s:.1f} s, {summary.runs_per_second:.2f} runs/s"
    )
    for index, error in summary.failures[:SHOWN_FAILURES]:
        click.echo(f"  sample {index} failed: {error}", err=True)
    if summary.failed > SHOWN_FAILURES:
        click.echo(f"  … and {summary.failed - SHOWN_FAILURES} more (samples/error in the file)", err=True)
    click.echo(f"wrote {summary.path}" + ("" if summary.complete else " (incomplete: run again to resume)"))


@main.command()
@click.argument("study_path", metavar="STUDY", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "out_dir", type=click.Path(file_okay=False, path_type=Path), help="study folder (default: STUDY stem)")
@click.option("--scheduler", metavar="tcp://HOST:PORT", help="run the sweeps on this Dask scheduler (default: a local cluster)")
@click.option("--workers", type=click.IntRange(min=1), help="local cluster worker processes (default: one per CPU)")
@click.option("--scale", type=click.FloatRange(min=0.0, min_open=True, max=1.0), default=1.0, help="run every set at this fraction of its samples")
def study(study_path: Path, out_dir: Path | None, scheduler: str | None, workers: int | None, scale: float) -> None:
    """Run the network study STUDY: sweeps, networks per training source, scores against fem (issue 5)."""
    from femref.study.run import run_study
    from femref.study.spec import load_study
    from femref.sweep import SweepInterrupted

    if scheduler is not None and workers is not None:
        raise click.UsageError("--workers sizes the local cluster; the cluster behind --scheduler has its own workers")
    console = Console(stderr=True)
    try:
        spec, study_dir = load_study(study_path)
        if scale != 1.0:
            spec = spec.scaled(scale)
        out_dir = out_dir or Path(study_path.stem)
        with _sweep_progress(console) as progress:
            outcome = run_study(spec, study_dir, out_dir, source=str(study_path), scheduler=scheduler, workers=workers, progress=progress)
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except SweepInterrupted:
        click.echo("interrupted: the sweeps keep what they stored; run again to resume", err=True)
        sys.exit(EXIT_INTERRUPTED)
    Console(width=max(150, Console().width)).print(_study_table(outcome))
    click.echo(f"wrote {out_dir / 'study.h5'}, {out_dir / 'study.md'} and {len(outcome.networks)} networks in {out_dir / 'networks'}")


def _study_table(outcome) -> Table:
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


@main.command()
@click.option("-o", "--output", "folder", type=click.Path(file_okay=False, path_type=Path), default=Path("docs/figures"), show_default=True, help="folder for the PNG files")
def figures(folder: Path) -> None:
    """Regenerate the verification figures: FEM convergence orders, FEM and quasi-rigid vs exact, the ε slope."""
    from femref.verification import write_figures

    for path in write_figures(folder):
        click.echo(f"wrote {path}")


def _register_commands() -> None:
    """Commands that live in their own packages."""
    from femref.bench.command import bench_command
    from femref.report import report_command

    main.add_command(report_command)
    main.add_command(bench_command)


_register_commands()
