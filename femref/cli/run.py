"""``femref validate [CASE]`` and ``femref run [CASE] [-o FILE] [--tolerance T]`` (docs/design.md §5).

Which flow a case runs by (simulate, choose, measure) and its result file are :mod:`femref.flow`'s (as for
:func:`femref.api.run_case`); here the output check, the printing and the exit codes.
"""

from __future__ import annotations

import atexit
import gc
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import click
from rich.console import Console

from femref.cli.common import EXIT_RUN_FAILURE, check_output, fail, finish, load_case_or_default, model_progress, print_table, source_name
from femref.cli.tables import run_table


@click.command("validate")
@click.argument("case_path", metavar="[CASE]", required=False, type=click.Path(dir_okay=False, path_type=Path))
def validate_command(case_path: Path | None) -> None:
    """Check CASE (no CASE: the built-in default scene) and print the resolved case (every default filled in).

    Files the case names (records, CSV loads, network and calibration files) are read and checked too.

    Exit codes: 0 valid, 2 not (the message names the key path and the rule).
    """
    freeze_at_exit()
    with start_up_uncollected():
        from femref.case import CaseError, resolved_yaml

        try:
            case, _ = load_case_or_default(case_path)
        except CaseError as error:
            fail(error)
        click.echo(resolved_yaml(case), nl=False)


@click.command("run")
@click.argument("case_path", metavar="[CASE]", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="result file (default: CASE stem + .h5, in the working folder); refused if it is CASE or a file CASE names")
@click.option(
    "--tolerance",
    type=click.FloatRange(min=0.0, max=1.0, min_open=True, max_open=True),
    help="choose the cheapest model expected within this relative error (impact cases; overrides the case's tolerance.value)",
)
def run_command(case_path: Path | None, output: Path | None, tolerance: float | None) -> None:
    """Run CASE (no CASE: the built-in default scene) with every requested model; write HDF5 results.

    With a tolerance (--tolerance or the case's tolerance:) the run instead climbs the
    ladder of impact models and resolutions and keeps the cheapest expected within it.
    A measured case runs its estimators on every event of its records and writes the events.

    Before any work: the case is checked, its predicted cost against the work budget
    (FEMREF_BUDGET=<factor> multiplies it), and the output, which may not be CASE or a
    file CASE names (records, CSV loads, network and calibration files). Fields go to
    <output stem>_<model>_fields.xdmf/.h5 beside the result. Progress on stderr: a bar per
    model (per event of a measured case) on a terminal, status lines with femref --progress.

    Exit codes: 0 written, 1 a model failed (the message says where; the file keeps every
    run), 2 bad input (nothing written).
    """
    freeze_at_exit()
    with start_up_uncollected() as runs_begin:
        from femref.case import CaseError
        from femref.case.inputs import field_models
        from femref.flow import plan_case
        from femref.results import field_file_paths

        try:
            case, base_dir = load_case_or_default(case_path)
            plan = plan_case(case, base_dir, source_name(case_path), tolerance)
        except CaseError as error:
            fail(error)
        defaulted = output is None
        output = output or Path(f"{case_path.stem if case_path else 'default'}.h5")
        check_output(output, "-o", _inputs(plan.case, case_path), default=defaulted, writes=field_file_paths(output, field_models(plan.case)))
        for note in plan.notes:
            click.echo(f"note: {note}", err=True)
        if plan.flow == "measure":
            _run_measured(plan, output, runs_begin)
        elif plan.flow == "choose":
            _run_choice(plan, output, runs_begin)
        else:
            _run_simulated(plan, output, runs_begin)


def freeze_at_exit() -> None:
    """At the process's exit, before the interpreter's final collections, move every object to the collector's
    permanent generation (``gc.freeze``): those collections then do not traverse the objects of every module loaded
    (numpy, scipy, numba, pydantic: about 0.3 s of CPU after a run, benchmarks/bench_startup.py). An exit handler, so a
    process that runs the command in-process (the tests) keeps collecting until it ends; registered once."""
    atexit.unregister(gc.freeze)
    atexit.register(gc.freeze)


@contextmanager
def start_up_uncollected() -> Iterator[Callable[[], None]]:
    """The command's start-up — imports, validation, the scene, the compiled loop's load — with the garbage collector
    off: what it makes lives to the end (modules, classes, numba's registries, the case), so collecting it is wasted
    work (0.1–0.2 s of CPU in a run of the default scene, benchmarks/bench_startup.py). Yields ``runs_begin()``, to call
    when the runs begin: every object alive moves to the permanent generation (``gc.freeze``: the runs' collections
    traverse only what the runs make) and the collector is on again. On leaving, the collector is as it was, on or off,
    with nothing left frozen by it (a process that runs the command in-process keeps collecting)."""
    enabled, frozen_before = gc.isenabled(), gc.get_freeze_count() > 0
    gc.disable()

    def runs_begin() -> None:
        if not frozen_before:
            gc.freeze()
        if enabled:
            gc.enable()

    try:
        yield runs_begin
    finally:
        if not frozen_before:
            gc.unfreeze()
        if enabled:
            gc.enable()


def _load_compiled_loop(plan, runs_begin: Callable[[], None]) -> None:
    """The last of an impact run's start-up: its compiled loop loaded (:func:`femref.run.runner.load_compiled_loop`),
    then ``runs_begin()``. A compile (the first run after an install) begins the runs first: numba's compiler leaves
    cyclic garbage that the collector must clear."""
    from femref.run import load_compiled_loop
    from femref.run.runner import compiled_loop_cached
    from femref.scene import ImpactScene

    if isinstance(plan.scene, ImpactScene):
        if not compiled_loop_cached():
            runs_begin()
        load_compiled_loop(plan.scene)
    runs_begin()


def _run_simulated(plan, output: Path, runs_begin: Callable[[], None]) -> None:
    """Run every model (femref.run.run_scene), write the results and scores, print the run table."""
    from femref.flow import run_plan

    with model_progress(Console(stderr=True)) as progress_for:
        _load_compiled_loop(plan, runs_begin)
        outcome = run_plan(plan, output, progress_for)
    print_table(run_table(outcome.run))
    finish(outcome.written, outcome.failures)


def _run_choice(plan, output: Path, runs_begin: Callable[[], None]) -> None:
    """Choose the model (femref.choice), write every run made and ``/choice``, print the ladder."""
    from femref.choice.output import choice_table
    from femref.flow import run_plan

    with model_progress(Console(stderr=True)) as progress_for:
        _load_compiled_loop(plan, runs_begin)
        try:
            choice = run_plan(plan, output, progress_for)
        except RuntimeError as error:
            fail(error, EXIT_RUN_FAILURE)
    print_table(choice_table(choice.choice))
    if not choice.choice.met:
        click.echo(f"warning: no model on the ladder is expected within {choice.choice.tolerance:g}; kept {choice.choice.chosen}, the most accurate",
                   err=True)
    finish(choice.written, [])


def _inputs(case, case_path: Path | None) -> dict[str, Path | None]:
    """The run's inputs for :func:`check_output`: CASE and every file it names (records, CSV loads, networks, calibration)."""
    from femref.cli.common import case_input_files

    return {"CASE": case_path, **case_input_files(case)}


def _run_measured(plan, output: Path, runs_begin: Callable[[], None]) -> None:
    """Every event of a measured case (femref.run.measured): write /events as each event finishes, print the event table.

    Progress: a stage while the records are read, then one per event. The events found over the work budget (exit 2)
    or a record changed since validation leave nothing under the output name."""
    from femref.case import CaseError
    from femref.cli.tables import event_table
    from femref.flow import run_plan
    from femref.sensing.recordings import RecordError

    try:
        with model_progress(Console(stderr=True), keep_finished=False) as progress_for:
            runs_begin()
            outcome = run_plan(plan, output, progress_for).measured
    except (RecordError, CaseError) as error:  # a record file changed since the case was validated; the events over the budget
        fail(error)
    print_table(event_table(outcome))
    noisy = {event.index: flag for event in outcome.events for flag in event.flags if flag.startswith("trigger in the noise")}
    if noisy:  # the first event's flag names the channels; every such event is flagged in the table and the file
        click.echo(f"warning: event(s) {', '.join(map(str, noisy))}: {next(iter(noisy.values()))}", err=True)
    for note in outcome.search.notes():  # spikes ignored, triggers outside the recorders' common span
        click.echo(f"warning: {note}", err=True)
    if not outcome.events:
        click.echo(f"warning: no event: {outcome.search.no_event_reason()}", err=True)
    finish([output], [])
