"""What every command shares: exit codes, loading a case (or the default scene), progress, tables fitted to the terminal.

Nothing of femref is imported at module level here or in the command modules: each command
imports what it drives when it runs, so ``femref --help`` stays light.

Exit codes: docs/design.md §5 and ``femref --help``. Every command runs inside :func:`faults_end_cleanly`;
every command that writes checks its output path before any work (:func:`check_output`). Progress
(``femref --progress/--no-progress``, env ``FEMREF_PROGRESS``) goes to stderr.
"""

from __future__ import annotations

import errno
import os
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import Iterable, Iterator, NoReturn

import click
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from femref.cli.tables import fit, natural_width

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILURE = 1
EXIT_INTERRUPTED = 130
#: SIGTERM's exit code (128 + 15, as a shell reports a process it ended): handled as Ctrl-C otherwise.
EXIT_TERMINATED = 128 + signal.SIGTERM


@contextmanager
def faults_end_cleanly() -> Iterator[None]:
    """Run a command so that faults end it in one line: SIGTERM is raised like Ctrl-C (``KeyboardInterrupt``, so
    every writer removes its temporary and a sweep keeps what it stored), an interrupt prints ``interrupted (SIGINT)``
    and exits 130 (SIGTERM: 143), an ``OSError`` prints ``error: …`` (:func:`os_error_message`) and exits 1.

    Long loops return to Python often enough for this to act within a second, compiled ones included
    (:func:`femref.impact.kernels.loop.solve_compiled` steps in chunks of about 0.1 s of work).
    """
    received = [signal.SIGINT]

    def interrupt(signum: int, frame: FrameType | None) -> None:
        received[0] = signum
        raise KeyboardInterrupt

    handled = (signal.SIGINT, signal.SIGTERM)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = {signum: signal.signal(signum, interrupt) for signum in handled} if main_thread else {}
    try:
        yield
    except KeyboardInterrupt:
        click.echo(f"interrupted ({signal.Signals(received[0]).name}): stopped; no file is left half-written", err=True)
        sys.exit(EXIT_TERMINATED if received[0] == signal.SIGTERM else EXIT_INTERRUPTED)
    except OSError as error:
        if error.errno == errno.EPIPE:  # stdout closed early (``femref run | head``): click's own quiet handling
            raise
        fail(os_error_message(error), EXIT_RUN_FAILURE)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def fail(message: object, code: int = EXIT_BAD_INPUT) -> NoReturn:
    """``error: <message>`` on stderr, then exit ``code``."""
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


def os_error_message(error: OSError) -> str:
    """One line for an OS error: the path, the reason and the errno's name, then its notes — what a write left
    (:func:`femref.core.publishing.note_output`): ``/data/.out.h5.femref-7.tmp: No space left on device (ENOSPC);
    nothing was written to /data/out.h5 (the previous out.h5 is unchanged); its temporary … was removed``."""
    reason = error.strerror or str(error)
    code = errno.errorcode.get(error.errno or 0)
    if code:
        reason += f" ({code})"
    paths = [os.fsdecode(name) for name in (error.filename, error.filename2) if name is not None]
    return "; ".join([f"{' -> '.join(paths)}: {reason}" if paths else reason, *getattr(error, "__notes__", [])])


def load_case_or_default(case_path: Path | None):
    """The case at ``case_path`` and its folder, or the built-in default scene and the working folder."""
    from femref.case import load_case, parse_case
    from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data

    if case_path is None:
        return parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE), Path.cwd()
    return load_case(case_path), case_path.resolve().parent


def case_input_files(case, name: str = "CASE", base_dir: Path | None = None) -> dict[str, Path]:
    """The files the validated ``case`` names (:func:`femref.case.inputs.case_inputs`), keyed for messages as
    ``<key path> of <name>`` (``records[0].file of CASE``): inputs to pass to :func:`check_output`."""
    from femref.case.inputs import case_inputs

    return {f"{key} of {name}": path for key, path in case_inputs(case, base_dir).items()}


def check_output(
    path: Path, option: str, inputs: dict[str, Path | None] | None = None, folder: bool = False, default: bool = False, writes: Iterable[Path] = ()
) -> None:
    """Exit 2, nothing written, unless ``path`` can be written (:func:`femref.core.publishing.check_output_path`: the
    rule :func:`femref.api.run_case` applies too); then :func:`clean_leftovers`. Called before any work, so a bad
    output path never costs a run.

    ``option`` names the option (``-o``), ``default`` says the path is its default; ``inputs`` the command's input
    files by name, which the output may not be; ``writes`` the other files the command writes beside the output or
    in the output folder (a sweep's ``.partial``, a study's sweeps and networks), which may not be inputs either.
    """
    from femref.core.publishing import OutputPathError, check_output_path

    try:
        check_output_path(path, option, inputs, folder=folder, default=default, writes=writes)
    except OutputPathError as error:
        fail(error)
    if not folder:
        clean_leftovers(path)


def clean_leftovers(path: Path) -> None:
    """Remove the temporaries of ``path`` that no running process writes (:func:`femref.core.publishing.clean_leftovers`)
    and say so on stderr, one line each; name (and keep) those it cannot be sure of."""
    from femref.core.publishing import clean_leftovers as remove

    cleanup = remove(path)
    for removed in cleanup.killed:
        click.echo(f"note: removed {removed}: a temporary of {path.name} left by a killed femref run", err=True)
    for removed in cleanup.legacy:
        click.echo(f"note: removed {removed}: a temporary of {path.name} left by an older femref run", err=True)
    for kept, why in cleanup.kept:
        click.echo(f"note: kept {kept}: it looks like an older femref's temporary of {path.name}, but {why}; "
                   "remove it yourself if no femref run is writing it", err=True)
    for kept, writer in cleanup.unseen:
        click.echo(f"note: kept {kept}: a temporary of {path.name} written by {writer}, which this run cannot see "
                   "(another container or host); remove it yourself if no femref run is writing it", err=True)


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
    least :data:`MIN_TABLE_WIDTH`), laid out by :func:`femref.cli.tables.fit`: every figure whole, a table too
    wide split into panels one under another. Piped without ``COLUMNS`` no width is forced on it: it keeps its
    natural width, one line per row, for grep, logs and the tests that read rows.
    """
    console = Console()
    if not (console.is_terminal or os.environ.get("COLUMNS")):  # its natural width: it fits, as it is (no second layout)
        Console(width=max(MIN_TABLE_WIDTH, natural_width(table))).print(table)
        return
    if console.width < MIN_TABLE_WIDTH:
        console = Console(width=MIN_TABLE_WIDTH)
    for k, part in enumerate(fit(table, console.width)):
        if k and isinstance(part, Table):
            console.print()
        console.print(part)


def echo_summary(line: str) -> None:
    """Echo a summary line on stdout, wrapped at spaces to the terminal's width (or ``COLUMNS``) so that no figure is
    cut; piped without ``COLUMNS`` it stays one line, for grep and logs."""
    console = Console()
    if console.is_terminal or os.environ.get("COLUMNS"):
        import textwrap

        line = "\n".join(textwrap.wrap(line, max(console.width, MIN_TABLE_WIDTH), break_long_words=False, break_on_hyphens=False,
                                        subsequent_indent="  "))
    click.echo(line)


def _show_progress(console: Console) -> bool:
    """Progress on ``console`` (stderr): as ``femref --progress/--no-progress`` says, else when it is a terminal."""
    context = click.get_current_context(silent=True)
    forced = context.meta.get(PROGRESS_KEY) if context is not None else None
    return console.is_terminal if forced is None else forced


@contextmanager
def model_progress(console: Console, keep_finished: bool = True) -> Iterator:
    """A progress bar per stage on a terminal, status lines per stage with ``--progress`` when stderr is
    not one (``<stage>: running`` … ``<stage>: done in 1.2 s``, or ``stopped after`` on an error); nothing
    otherwise. Yields ``progress_for(stage)``, which returns the stage's ``(done, total)`` callback (or None).

    A stage is a model of a run, an event of a measured case, an estimator being calibrated.
    ``keep_finished=False`` hides a finished stage's bar when the next starts (many stages: events).
    Why a first run waits is said on ``console`` whatever the progress setting (:func:`compile_notices`).
    """
    with compile_notices(console), _stages(console, keep_finished) as progress_for:
        yield progress_for


@contextmanager
def compile_notices(console: Console) -> Iterator[None]:
    """Print the library's compile notices (INFO on the logger ``femref.compile``: the first run after an install
    compiles the impact kernels, :func:`femref.run.runner.load_compiled_loop`, and a first sweep its batched ones,
    :func:`femref.sweep.batch.load_batch_kernels`) on ``console`` while in the block."""
    import logging

    class ToConsole(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            console.print(record.getMessage(), markup=False, highlight=False, soft_wrap=True)

    logger, handler = logging.getLogger("femref.compile"), ToConsole(logging.INFO)
    level = logger.level
    logger.setLevel(logging.INFO)
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


@contextmanager
def _stages(console: Console, keep_finished: bool) -> Iterator:
    """:func:`model_progress`'s bars or status lines."""
    if not _show_progress(console):
        yield lambda model: None
        return
    if not console.is_terminal:
        lines = _StatusLines(console)
        try:
            yield lines.start
        except BaseException:
            lines.done(stopped=True)
            raise
        lines.done()
        return
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        shown: list = []

        def progress_for(model: str):
            if shown and not keep_finished:
                bar.update(shown.pop(), visible=False)
            task = bar.add_task(model, total=None)
            shown.append(task)
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

    def done(self, stopped: bool = False) -> None:
        """The line of the current stage's end: ``done in`` (``stopped after`` when an error or interrupt ended it)."""
        import time

        if self.current is not None:
            how = "stopped after" if stopped else "done in"
            self.console.print(f"{self.current}: {how} {time.perf_counter() - self.started:.1f} s", markup=False, highlight=False)
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


@contextmanager
def recording_progress(console: Console, stage: str, unit: str) -> Iterator:
    """``progress(done, total, recording, events)`` of a fleet's recordings (``events < 0``: none to say): a bar of
    ``unit`` with the last recording's name and events on a terminal; with ``--progress`` and stderr not a terminal a
    line per recording (``fleet: 3/40 <recording>: 2 events``); else None (no callback)."""
    if not _show_progress(console):
        yield None
        return

    def last(recording: str, events: int) -> str:
        return f"{recording}: {events} event{'s' if events != 1 else ''}" if events >= 0 else ""

    if not console.is_terminal:
        yield lambda done, total, recording, events: console.print(f"{stage}: {done}/{total} {last(recording, events)}".rstrip(),
                                                                   markup=False, highlight=False)
        return
    columns = (TextColumn(stage), BarColumn(), TextColumn("{task.completed}/{task.total} " + unit), TextColumn("{task.description}"),
               TimeRemainingColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task("", total=None)
        yield lambda done, total, recording, events: bar.update(task, completed=done, total=total, description=last(recording, events))
