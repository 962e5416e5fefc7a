"""``femref report RESULTS.h5 [-o REPORT.html]``: one self-contained HTML page of a result file; ``femref report
OUT/events.sqlite [-o FOLDER]``: the fleet report of an event store (:mod:`femref.report.fleet`).

The page is assembled in memory and written under a temporary name in the target folder, then
renamed: a failure leaves nothing under the final name (the fleet report: its folder, the same way).
"""

from __future__ import annotations

from pathlib import Path

import click

from femref.cli.common import check_output, fail


def default_output(results: Path) -> Path:
    """The report next to the result file: its stem + ``.html``."""
    return results.with_name(results.stem + ".html")


def write_atomically(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to a temporary file beside ``path`` and rename it into place."""
    from femref.core.publishing import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


SQLITE_HEADER = b"SQLite format 3\x00"
FLEET_FOLDER = "report"


def is_event_store(path: Path) -> bool:
    """Whether ``path`` is an SQLite file (the event store of ``femref fleet``, docs/design.md §10.2) by its header."""
    try:
        with open(path, "rb") as file:
            return file.read(len(SQLITE_HEADER)) == SQLITE_HEADER
    except OSError:
        return False


def _write_fleet_report(store: Path, output: Path | None, all_event_pages: bool) -> None:
    """The fleet report of the event store ``store`` into ``output`` (default: ``report/`` beside the store), the event
    pages drawn with progress."""
    import sqlite3

    from rich.console import Console

    from femref.cli.common import model_progress
    from femref.fleet.store import read_estimates, read_events
    from femref.report.fleet import write_fleet_report

    folder = output or store.parent / FLEET_FOLDER
    check_output(folder, "-o", {"STORE": store}, folder=True, default=output is None)
    try:
        events, estimates = read_events(store), read_estimates(store)
    except (sqlite3.DatabaseError, KeyError, ValueError) as error:
        fail(f"{store}: not a femref event store ({error})")
    with model_progress(Console(stderr=True)) as progress_for:
        try:
            index = write_fleet_report(events, estimates, folder, store_folder=store.parent, all_event_pages=all_event_pages,
                                       progress=progress_for("event pages"))
        except ValueError as error:
            fail(error)
    click.echo(f"wrote {index}")


def _write_event_pages(results: Path, output: Path) -> None:
    """The pages of an event file of many events beside the index ``output`` (femref.report.measured), each written
    atomically, with progress per event (a bar per page on a terminal, status lines with femref --progress)."""
    from rich.console import Console

    from femref.cli.common import model_progress
    from femref.report.build import build_event_pages

    with model_progress(Console(stderr=True), keep_finished=False) as progress_for:
        for name, text in build_event_pages(results, output.name, progress_for):
            write_atomically(output.with_name(name), text)


@click.command("report")
@click.argument("results", metavar="RESULTS.h5", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path),
              help="HTML file (default: RESULTS stem + .html, next to RESULTS); refused if it is RESULTS.h5 or one of its field files. "
                   "For an event store: the report's folder (default: report/ beside it)")
@click.option("--all-event-pages", is_flag=True, help="An event store: draw every event's page, not only those that need a look")
def report_command(results: Path, output: Path | None, all_event_pages: bool) -> None:
    """Write one self-contained HTML page (scores, plots, field map, case) from a femref result file.

    OUT/events.sqlite, the event store of femref fleet, gives the fleet report: FOLDER/index.html (traffic lights per car
    and gear, exceedances, distributions, gear-wear trends, every event linked), FOLDER/events.csv and, with openpyxl,
    FOLDER/events.xlsx.

    An event file of more than 20 events gives an index page (one row per event) and, beside it, a page per
    20 events with their figures, REPORT_events_0001-0020.html …, drawn with progress.

    RESULTS.h5 is a result file of femref run (a measured case's event file too) or a study's
    study.h5. Field files that do not match the result (another run's) are named in a warning.

    Exit codes: 0 written, 2 bad input (missing file, not a femref result file, the output
    is the input or one of its field files; nothing written).
    """
    from femref.report import ReportInputError, build_report
    from femref.results import field_files_match, result_field_files

    if is_event_store(results):
        _write_fleet_report(results, output, all_event_pages)
        return
    defaulted = output is None
    output = output or default_output(results)
    try:
        if output.resolve() == results.resolve():
            raise ReportInputError(f"{output}: the report would overwrite the result file; choose another -o")
        page = build_report(results, output.name)
    except ReportInputError as error:
        fail(error)
    # After the input's own errors. The result's field files are inputs too (the page reads them; an -o onto one would
    # replace a ParaView file of the run with HTML): those it records, or femref's names for them.
    check_output(output, "-o", {"RESULTS.h5": results, **result_field_files(results)}, default=defaulted)
    _write_event_pages(results, output)
    write_atomically(output, page)
    click.echo(f"wrote {output}")
    for problem in field_files_match(results):
        click.echo(f"warning: {problem}", err=True)
