"""``femref validate [CASE]`` and ``femref run [CASE] [-o FILE] [--tolerance T]`` (docs/design.md §5).

``run`` runs every model of the case (:func:`femref.run.run_scene`), writes the result
file atomically with the scene's facts and scores, prints the summary and exits 1 when
a model failed (its message says where). A measured case runs its estimators on every
event of its records instead (:func:`femref.run.measured.run_measured`) and writes ``/events``. With a tolerance it climbs the ladder of impact
models instead (:mod:`femref.choice`) and keeps the cheapest expected within it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.console import Console

from femref.cli.common import EXIT_BAD_INPUT, EXIT_RUN_FAILURE, check_output, finish, load_case_or_default, model_progress, print_table, source_name
from femref.cli.tables import run_table


@click.command("validate")
@click.argument("case_path", metavar="[CASE]", required=False, type=click.Path(dir_okay=False, path_type=Path))
def validate_command(case_path: Path | None) -> None:
    """Check CASE (no CASE: the built-in default scene) and print the resolved case (every default filled in).

    Files the case names (records, CSV loads, network and calibration files) are read and checked too.

    Exit codes: 0 valid, 2 not (the message names the key path and the rule).
    """
    from femref.case import CaseError, resolved_yaml

    try:
        case, _ = load_case_or_default(case_path)
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
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
    from femref.case import CaseError, resolved_yaml
    from femref.case.inputs import field_models
    from femref.results import field_file_paths, write_results
    from femref.run import run_scene
    from femref.choice import check_ladder_budget
    from femref.run.budget import check_budget
    from femref.scene.build import scene_from_case

    console = Console(stderr=True)
    try:
        case, base_dir = load_case_or_default(case_path)
        case = _with_tolerance(case, tolerance, source_name(case_path))
        scene = scene_from_case(case, base_dir)
        # Once per command, before any work (femref.run.budget; FEMREF_BUDGET raises it): the runs and the reference's
        # self-check, or with a tolerance every rung of the ladder it may climb; run_scene and choose_model are told.
        if case.kind == "impact" and getattr(case, "tolerance", None) is not None:
            check_ladder_budget(scene, source_name(case_path))
        else:
            check_budget(scene, source_name(case_path))
    except CaseError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    defaulted = output is None
    output = output or Path(f"{case_path.stem if case_path else 'default'}.h5")
    check_output(output, "-o", _inputs(case, case_path), default=defaulted, writes=field_file_paths(output, field_models(case)))
    if case.kind == "measured":
        _run_measured(case, scene, output, source_name(case_path))
        return
    if getattr(case, "tolerance", None) is not None:
        _run_choice(case, scene, output, console)
        return

    with model_progress(console) as progress_for:
        outcome = run_scene(scene, progress_for, budget_checked=True)
    written = write_results(output, resolved_yaml(case), outcome.results, outcome.scores, scene=scene.facts())
    print_table(run_table(outcome))
    finish(written, [(f"model {failed.model}", failed.message) for failed in outcome.failed])


def _with_tolerance(case, tolerance: float | None, source: str):
    """The case with ``--tolerance`` in its ``tolerance.value`` (kept in the resolved case of the result file)."""
    from femref.case import CaseError, Problem
    from femref.case.runs import ToleranceSpec

    if tolerance is None:
        return case
    if case.kind != "impact":
        rule = "--tolerance: model choice serves impact cases (the ladder of impact models)"
        raise CaseError(Problem(("kind",), rule, case.kind), source)
    spec = ToleranceSpec(value=tolerance) if case.tolerance is None else ToleranceSpec(value=tolerance, output=case.tolerance.output)
    return case.model_copy(update={"tolerance": spec})


def _run_choice(case, scene, output: Path, console: Console) -> None:
    """Choose the model (femref.choice), write every run made and ``/choice``, print the ladder."""
    from femref.case import resolved_yaml
    from femref.choice import choose_model, run_rung
    from femref.choice.output import choice_table, write_choice
    from femref.results import write_results

    if scene.estimators or scene.networks:
        click.echo("note: with a tolerance the estimators are not run (they read the records of the models list's fem run)", err=True)
    with model_progress(console) as progress_for:
        try:
            choice = choose_model(scene, case.tolerance.value, case.tolerance.output, runner=lambda rung: run_rung(rung, progress_for(rung.label)),
                                  budget_checked=True)
        except RuntimeError as error:
            click.echo(f"error: {error}", err=True)
            sys.exit(EXIT_RUN_FAILURE)
    written = write_results(output, resolved_yaml(case), choice.results, extra=lambda h5: write_choice(h5, choice), scene=scene.facts())
    print_table(choice_table(choice))
    if not choice.met:
        click.echo(f"warning: no model on the ladder is expected within {choice.tolerance:g}; kept {choice.chosen}, the most accurate", err=True)
    finish(written, [])


def _inputs(case, case_path: Path | None) -> dict[str, Path | None]:
    """The run's inputs for :func:`check_output`: CASE and every file it names (records, CSV loads, networks, calibration)."""
    from femref.cli.common import case_input_files

    return {"CASE": case_path, **case_input_files(case)}


def _run_measured(case, scene, output: Path, source: str = "<case>") -> None:
    """Every event of a measured case (femref.run.measured): write /events as each event finishes, print the event table.

    Progress as for the models of a run (:func:`model_progress`): a stage while the records are read,
    then one per event (its classification, estimators and networks the steps of its bar). The events go
    into the output's temporary as they finish (:func:`femref.events.event_file`), renamed to the output when
    the last is in; the events found over the work budget (exit 2) or a record changed since validation leave
    nothing under the output name."""
    from femref.case import CaseError, resolved_yaml
    from femref.cli.tables import event_table
    from femref.events import event_file
    from femref.run.measured import run_measured
    from femref.sensing.recordings import RecordError

    facts = {"cars": [car.name for car in scene.cars], "couplers": [c.name for c in scene.couplers], "estimators": list(scene.estimators)}
    try:
        with event_file(output, facts, resolved_yaml(case)) as write, model_progress(Console(stderr=True), keep_finished=False) as progress_for:
            outcome = run_measured(scene, progress_for, sink=write, source=source)
    except (RecordError, CaseError) as error:  # a record file changed since the case was validated; the events over the budget
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    print_table(event_table(outcome))
    noisy = {event.index: flag for event in outcome.events for flag in event.flags if flag.startswith("trigger in the noise")}
    if noisy:  # the first event's flag names the channels; every such event is flagged in the table and the file
        click.echo(f"warning: event(s) {', '.join(map(str, noisy))}: {next(iter(noisy.values()))}", err=True)
    for note in outcome.search.notes():  # spikes ignored, triggers outside the recorders' common span
        click.echo(f"warning: {note}", err=True)
    if not outcome.events:
        click.echo(f"warning: no event: {outcome.search.no_event_reason()}", err=True)
    finish([output], [])
