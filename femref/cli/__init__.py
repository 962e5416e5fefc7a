"""The ``femref`` command: the only place that prints and exits (docs/design.md §5, §9).

One module per command family — :mod:`.run` (run, validate), :mod:`.sweep` (sweep,
study, calibrate), :mod:`.bench`, :mod:`.report`, :mod:`.figures`, :mod:`.fleet` — sharing :mod:`.common` (exit
codes, case loading, progress) and :mod:`.tables` (the summaries). Each command
imports the machinery it drives when it runs: ``femref --help`` and every command's
``--help`` import neither numpy nor the solvers (tests/cli/test_first_hour.py holds this).
"""

from __future__ import annotations

import click

from femref.cli.bench import bench_command
from femref.cli.common import PROGRESS_KEY, faults_end_cleanly
from femref.cli.figures import figures_command
from femref.cli.fleet import fleet_command
from femref.cli.report import report_command
from femref.cli.run import run_command, validate_command
from femref.cli.sweep import calibrate_command, study_command, sweep_command


#: Exit codes and environment variables, under ``femref --help`` (every ``FEMREF_`` variable a user may set;
#: tests/cli/test_first_hour.py checks the list against the code). ``\b`` keeps click from rewrapping a block.
EPILOG = """\b
Exit codes:
  0    success
  1    a failure during the run (a model, the sweep machinery, a study step,
       an OS error such as a full disk); one error: line says where
  2    bad input: the message names the key path or option and the rule;
       nothing is written
  130  interrupted (Ctrl-C; SIGTERM alike, with exit code 143): stopped within
       a second, no file left half-written (sweeps and studies keep what they
       stored; run again to resume)

\b
Environment:
  FEMREF_BUDGET=<factor>  multiply the work budget checked before a run
                          (time and memory; e.g. 10 allows ten times more)
  FEMREF_SELF_CHECK=1     the fem reference checks its own discretisation on
                          every run (repeated at dt/2, dt/4), not only when
                          the case under-resolves it
  FEMREF_PROGRESS=1|0     as --progress / --no-progress
  NUMBA_CACHE_DIR=<dir>   where the compiled kernels are cached (default:
                          $XDG_CACHE_HOME/femref, else ~/.cache/femref)
  COLUMNS=<n>             width of the summary tables (default: the terminal's;
                          piped: one line per row)
"""


class FemrefGroup(click.Group):
    """The command group: every command runs inside :func:`femref.cli.common.faults_end_cleanly` (an OS error or a
    signal ends it with one line and its exit code, never a traceback)."""

    def invoke(self, ctx: click.Context):
        with faults_end_cleanly():
            return super().invoke(ctx)


@click.group(cls=FemrefGroup, context_settings={"help_option_names": ["-h", "--help"]}, epilog=EPILOG)
@click.version_option(package_name="femref")
@click.option(
    "--progress/--no-progress",
    default=None,
    envvar="FEMREF_PROGRESS",
    help="progress on stderr: bars on a terminal, status lines when stderr is piped (default: only on a terminal; env FEMREF_PROGRESS=1/0)",
)
@click.pass_context
def main(context: click.Context, progress: bool | None) -> None:
    """femref: FEM reference solver for freight-car impacts, and the scores of cheaper models against it."""
    context.meta[PROGRESS_KEY] = progress


for _command in (run_command, validate_command, sweep_command, study_command, calibrate_command, bench_command, report_command, figures_command,
                 fleet_command):
    main.add_command(_command)

__all__ = ["main"]
