"""``femref report RESULTS.h5 [-o REPORT.html]``: one self-contained HTML page of a result file.

The page is assembled in memory and written under a temporary name in the target folder, then
renamed: a failure leaves nothing under the final name.
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
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="HTML file (default: RESULTS stem + .html, next to RESULTS); refused if it is RESULTS.h5 or one of its field files")
def report_command(results: Path, output: Path | None) -> None:
    """Write one self-contained HTML page (scores, plots, field map, case) from a femref result file.

    An event file of more than 20 events gives an index page (one row per event) and, beside it, a page per
    20 events with their figures, REPORT_events_0001-0020.html …, drawn with progress.

    RESULTS.h5 is a result file of femref run (a measured case's event file too) or a study's
    study.h5. Field files that do not match the result (another run's) are named in a warning.

    Exit codes: 0 written, 2 bad input (missing file, not a femref result file, the output
    is the input or one of its field files; nothing written).
    """
    from femref.report import ReportInputError, build_report
    from femref.results import field_files_match, result_field_files

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
