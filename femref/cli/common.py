"""What every command shares: exit codes, loading a case (or the default scene), progress, tables fitted to the terminal.

Nothing of femref is imported at module level here or in the command modules: each command
imports what it drives when it runs, so ``femref --help`` stays light.

Exit codes (docs/design.md §5): 0 success, 2 bad input (the message names the key path and
the rule; nothing is written), 1 a failure during the run, 130 interrupted (sweeps and studies
keep what they stored). Every command that writes checks its output path before any work
(:func:`check_output`: exit 2, nothing written).
"""

from __future__ import annotations

import os
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


def check_output(path: Path, option: str, inputs: dict[str, Path | None] | None = None, folder: bool = False, default: bool = False) -> None:
    """Exit 2, nothing written, unless ``path`` can be written (:func:`output_problem`); then remove the temporaries
    a killed run left of it (:func:`femref.results.remove_leftovers`: never a live run's).

    Called before any work, so a bad output path never costs a run. ``option`` names the
    option (``-o``), ``default`` says the path is its default; ``inputs`` the command's input
    files by name (``CASE``), which the output may not be.
    """
    problem = output_problem(path, inputs or {}, folder)
    if problem:
        named = f"{option} (default)" if default else option
        click.echo(f"error: {named} {path}: {problem}; nothing was written", err=True)
        sys.exit(EXIT_BAD_INPUT)
    if not folder:
        from femref.results import remove_leftovers

        remove_leftovers(path)


def output_problem(path: Path, inputs: dict[str, Path | None], folder: bool = False) -> str:
    """Why ``path`` cannot be the output, or ``""``: its folder must exist and be writable, a file output must not be
    a folder (a folder output not a file), and it must not be one of ``inputs`` (the same path, or the same file
    through another relative path, a symbolic or a hard link)."""
    if folder:
        if path.exists() and not path.is_dir():
            return "is a file; the output is a folder"
        where = path if path.is_dir() else path.parent
    else:
        if path.is_dir():
            return "is a folder; the output is a file"
        where = path.parent
    if not where.exists():
        return f"the folder {where} does not exist (the output's folder must exist)"
    if not where.is_dir():
        return f"{where} is not a folder"
    if not os.access(where, os.W_OK | os.X_OK):
        return f"the folder {where} is not writable (the output's folder must be writable)"
    for name, given in inputs.items():
        if given is not None and _same_file(path, Path(given)):
            return f"is the input {name} {given} (the output may not overwrite an input)"
    return ""


def _same_file(a: Path, b: Path) -> bool:
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # either does not exist
        return False


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


#: Narrowest a table is laid out on a terminal: below it rich would fold nearly every cell.
MIN_TABLE_WIDTH = 60
#: Key of ``click.Context.meta``: ``femref --progress/--no-progress`` (None: progress when stderr is a terminal).
PROGRESS_KEY = "femref.progress"


def print_table(table: Table) -> None:
    """Print a summary table (its legend is its caption) on stdout, fitted to where it goes.

    On a terminal, or with ``COLUMNS`` set, the table takes that width (rich's own detection; at
    least :data:`MIN_TABLE_WIDTH`): a table wider than that loses its frame and padding (columns one
    space apart), then cells wrap at spaces, and a word longer than its column folds.
    Piped without ``COLUMNS`` no width is forced on it: it keeps its natural width, one line per
    row, for grep, logs and the tests that read rows.
    """
    console = Console()
    natural = _natural_width(table)
    if not (console.is_terminal or os.environ.get("COLUMNS")):
        console = Console(width=natural)
    elif console.width < MIN_TABLE_WIDTH:
        console = Console(width=MIN_TABLE_WIDTH)
    if natural > console.width:  # too wide: one space between columns, no frame, before any cell wraps
        import copy

        from rich import box

        table = copy.copy(table)
        table.box, table.show_edge, table.padding = box.SIMPLE_HEAD, False, (0, 0)
    console.print(table)


def _natural_width(table: Table) -> int:
    """The width ``table`` takes when nothing limits it (every cell on one line)."""
    import io

    from rich.measure import Measurement

    unlimited = Console(width=100_000, file=io.StringIO())
    return max(MIN_TABLE_WIDTH, Measurement.get(unlimited, unlimited.options, table).maximum)


def _show_progress(console: Console) -> bool:
    """Progress on ``console`` (stderr): as ``femref --progress/--no-progress`` says, else when it is a terminal."""
    context = click.get_current_context(silent=True)
    forced = context.meta.get(PROGRESS_KEY) if context is not None else None
    return console.is_terminal if forced is None else forced


@contextmanager
def model_progress(console: Console) -> Iterator:
    """A per-model progress bar on a terminal, per-model status lines with ``--progress`` when stderr is
    not one (``<model>: running`` … ``<model>: done in 1.2 s``); nothing otherwise."""
    if not _show_progress(console):
        yield lambda model: None
        return
    if not console.is_terminal:
        lines = _StatusLines(console)
        try:
            yield lines.start
        finally:
            lines.done()
        return
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:

        def progress_for(model: str):
            task = bar.add_task(model, total=None)
            return lambda done, total: bar.update(task, completed=done, total=total)

        yield progress_for


class _StatusLines:
    """One line when a model starts and one when it is done (the next one starts, or all are)."""

    def __init__(self, console: Console) -> None:
        self.console = console
        self.current: str | None = None
        self.started = 0.0

    def start(self, model: str):
        import time

        self.done()
        self.current, self.started = model, time.perf_counter()
        self.console.print(f"{model}: running", markup=False, highlight=False)
        return None

    def done(self) -> None:
        import time

        if self.current is not None:
            self.console.print(f"{self.current}: done in {time.perf_counter() - self.started:.1f} s", markup=False, highlight=False)
        self.current = None


@contextmanager
def sample_progress(console: Console) -> Iterator:
    """A samples progress bar on a terminal; with ``--progress`` and stderr not a terminal a line per tenth
    of the samples (``sweep: 150/1500 samples``); else None (no callback)."""
    if not _show_progress(console):
        yield None
        return
    if not console.is_terminal:
        shown = [-1]

        def line(done: int, total: int) -> None:
            tenth = 10 * done // max(total, 1)
            if tenth > shown[0]:
                shown[0] = tenth
                console.print(f"sweep: {done}/{total} samples", markup=False, highlight=False)

        yield line
        return
    columns = (TextColumn("sweep"), BarColumn(), TextColumn("{task.completed}/{task.total} samples"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task("sweep", total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


@contextmanager
def configuration_progress(console: Console) -> Iterator:
    """A configurations progress bar on a terminal; with ``--progress`` and stderr not a terminal a line per
    configuration (``bench: fem N=16 dt=…``); else None (no callback)."""
    if not _show_progress(console):
        yield None
        return
    if not console.is_terminal:
        yield lambda label: console.print(f"bench: {label}", markup=False, highlight=False)
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
