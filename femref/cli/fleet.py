"""``femref fleet MANIFEST -o OUT``: every recording of a fleet on Dask into the event store (docs/design.md §10).

The manifest is validated whole before any work (exit 2, nothing written); the output folder is checked
(:func:`femref.cli.common.check_output`); the runs stream into ``OUT/events.sqlite`` and ``OUT/events/`` as they
finish (:func:`femref.fleet.runner.run_fleet`); then the summary, and the fleet report when this femref has one.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.console import Console

from femref.cli.common import EXIT_INTERRUPTED, EXIT_RUN_FAILURE, PROGRESS_KEY, check_output, echo_summary, fail, recording_progress

#: Failed recordings listed after a run (the store holds every message).
SHOWN_FAILURES = 5


@click.command("fleet")
@click.argument("manifest_path", metavar="MANIFEST", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="output folder (made in an existing folder): events.sqlite, events/<recording>.h5 and the fleet report report/; "
                   "refused if the store or an event file would overwrite an input")
@click.option("--workers", type=click.IntRange(min=1), help="local cluster worker processes (default: one per CPU)")
@click.option("--scheduler", metavar="tcp://HOST:PORT", help="run on this Dask scheduler (default: a local cluster)")
@click.option("--progress/--no-progress", default=None, help="as femref --progress/--no-progress (default: only on a terminal)")
@click.pass_context
def fleet_command(context: click.Context, manifest_path: Path, out_dir: Path, workers: int | None, scheduler: str | None,
                  progress: bool | None) -> None:
    """Run every recording of the fleet MANIFEST on Dask into the event store OUT/events.sqlite.

    Each recording is a measured case (the manifest's defaults, its cars, gears and records); its
    events' histories go to OUT/events/<recording>.h5, its rows to the store, one transaction per
    recording as it finishes. Resumable: a recording stored ok and unchanged (its case, its files'
    sizes and times) is skipped; a changed one replaces its rows; Ctrl-C keeps what is stored.
    Progress on stderr: recordings done with the last one's name and events (a bar on a terminal,
    a line per recording with femref --progress). Then a summary: recordings run, skipped and
    failed, events by type, alarms, throughput; and the fleet report, when femref has one.

    Exit codes: 0 every recording ran, 1 a recording failed (named; stored failed, the others ran)
    or the Dask machinery failed, 2 bad input (nothing written), 130 interrupted (run again to resume).
    """
    from femref.case import CaseError
    from femref.fleet.manifest import load_manifest
    from femref.fleet.runner import FleetInterrupted, fleet_inputs, run_fleet
    from femref.fleet.store import STORE_NAME, StoreError
    from femref.fleet.worker import event_path

    if scheduler is not None and workers is not None:
        raise click.UsageError("--workers sizes the local cluster; the cluster behind --scheduler has its own workers")
    if progress is not None:
        context.meta[PROGRESS_KEY] = progress
    console = Console(stderr=True)
    try:
        with recording_progress(console, "validate", "recordings checked") as checked:
            fleet = load_manifest(manifest_path, progress=None if checked is None else lambda done, total: checked(done, total, "", -1))
    except CaseError as error:
        fail(error)
    writes = [out_dir / STORE_NAME, *(event_path(out_dir, recording.name) for recording in fleet.recordings)]
    check_output(out_dir, "-o", fleet_inputs(fleet, out_dir), folder=True, writes=writes)
    try:
        with recording_progress(console, "fleet", "recordings") as stored:
            summary = run_fleet(fleet, out_dir, scheduler=scheduler, workers=workers, progress=stored)
    except StoreError as error:
        fail(error)
    except FleetInterrupted as interrupted:
        _summary(interrupted.summary)
        click.echo(f"interrupted: {interrupted.summary.run} recordings stored in this call; run again to resume", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except OSError:  # a full disk, a quota: faults_end_cleanly's one line
        raise
    except Exception as error:  # the Dask machinery or the store, not a recording (those are stored as failed)
        fail(f"fleet failed: {type(error).__name__}: {error}", EXIT_RUN_FAILURE)
    _summary(summary)
    _fleet_report(summary.store, out_dir)
    if summary.failures:
        for name, message in summary.failures[:SHOWN_FAILURES]:
            click.echo(f"error: recording {name} failed: {message}", err=True)
        if summary.failed > SHOWN_FAILURES:
            click.echo(f"  … and {summary.failed - SHOWN_FAILURES} more (recordings.message in the store)", err=True)
        sys.exit(EXIT_RUN_FAILURE)


def _summary(summary) -> None:
    """Counts of recordings and events, alarms, throughput and wall time, and where the store is."""
    echo_summary(f"recordings: {summary.total} in the manifest, {summary.run} run now, {summary.skipped} skipped (stored, unchanged), "
               f"{summary.failed} failed")
    if summary.run:
        types = ", ".join(f"{kind} {count}" for kind, count in sorted(summary.events.items())) or "none"
        alarms = ", ".join(f"{level} {count}" for level, count in sorted(summary.alarms.items())) or "none"
        echo_summary(f"events: {summary.event_count} ({types}); alarms: {alarms}")
        echo_summary(f"throughput: {summary.events_per_second:.2f} events/s, {summary.megabytes_per_second:.2f} MB/s of record files, "
                   f"{summary.samples_per_second:.3g} samples/s; wall time {summary.wall_time_s:.1f} s")
    click.echo(f"store: {summary.store}")


#: The fleet report's folder in the output folder (where ``femref report OUT/events.sqlite`` writes it too).
REPORT_FOLDER = "report"


def _fleet_report(store: Path, out_dir: Path) -> None:
    """The fleet report of the store in ``OUT/report/`` (:func:`femref.report.fleet.write_fleet_report`)."""
    from femref.fleet.store import read_estimates, read_events
    from femref.report.fleet import write_fleet_report

    try:
        written = write_fleet_report(read_events(store), read_estimates(store), out_dir / REPORT_FOLDER)
    except Exception as error:  # the store is written and stays; the report can be made again from it
        fail(f"fleet report failed: {type(error).__name__}: {error} (the store {store} is complete)", EXIT_RUN_FAILURE)
    click.echo(f"wrote {written}")
