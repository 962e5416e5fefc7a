"""What every command shares: exit codes, loading a case (or the default scene), progress bars, wide tables.

Nothing of femref is imported at module level here or in the command modules: each command
imports what it drives when it runs, so ``femref --help`` stays light.

Exit codes (docs/design.md §5): 0 success, 2 bad input (the message names the key path and
the rule; nothing is written), 1 a failure during the run, 130 interrupted (sweeps and studies
keep what they stored).
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

import click
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILURE = 1
EXIT_INTERRUPTED = 130


def load_case_or_default(case_path: Path | None):
    """The case at ``case_path`` and its folder, or the built-in default scene and the working folder."""
    from femref.case import load_case, parse_case
    from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data

    if case_path is None:
        return parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE), Path.cwd()
    return load_case(case_path), case_path.resolve().parent


def source_name(case_path: Path | None) -> str:
    """How messages name the case: its path, or the default scene."""
    from femref.case.defaults import DEFAULT_SCENE_SOURCE

    return str(case_path) if case_path else DEFAULT_SCENE_SOURCE


def finish(written: Iterable[Path], failures: list[tuple[str, str]]) -> None:
    """Say what was written, then each failure (``what``, ``message``) on stderr; exit 1 if any failed."""
    for path in written:
        click.echo(f"wrote {path}")
    for what, message in failures:
        click.echo(f"error: {what} failed: {message}", err=True)
    if failures:
        sys.exit(EXIT_RUN_FAILURE)


def print_table(table: Table) -> None:
    """Print a summary table at least 150 columns wide (tables are wider than a default terminal)."""
    Console(width=max(150, Console().width)).print(table)


@contextmanager
def model_progress(console: Console) -> Iterator:
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


@contextmanager
def sample_progress(console: Console) -> Iterator:
    """A samples progress bar on a terminal; None when output is piped."""
    if not console.is_terminal:
        yield None
        return
    columns = (TextColumn("sweep"), BarColumn(), TextColumn("{task.completed}/{task.total} samples"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task("sweep", total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


@contextmanager
def configuration_progress(console: Console) -> Iterator:
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
