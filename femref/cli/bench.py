"""``femref bench [CASE] [-o FILE] [--repeats N] [--plot PNG]``: the speed–accuracy trade of one impact scene.

docs/design.md §7 (:mod:`femref.bench`). Impact cases only: a single-body case costs one banded solve per
step or frequency; the trade worth measuring is the impact models'.
"""

from __future__ import annotations

from pathlib import Path

import click
from rich.console import Console

from femref.cli.common import (EXIT_RUN_FAILURE, case_input_files, check_output, configuration_progress, echo_summary, fail, finish,
                               load_case_or_default, print_table)
from femref.cli.tables import bench_table

IMPACT_ONLY = "femref bench serves impact cases"


@click.command("bench")
@click.argument("case_path", metavar="[CASE]", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="bench table (default: CASE stem + _bench.h5, in the working folder); refused if it is CASE or a file CASE names")
@click.option("--repeats", type=click.IntRange(min=1), default=3, show_default=True, help="timed runs per configuration (the median is kept)")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False, path_type=Path), help="write the Pareto plot (PNG) here (not an input, not -o)")
def bench_command(case_path: Path | None, output: Path | None, repeats: int, plot_path: Path | None) -> None:
    """Time and score every model of CASE at several resolutions against the finest fem; table + Pareto plot.

    No CASE: the built-in default scene. Impact cases only. Progress on stderr: a bar on a
    terminal, a line per configuration with femref --progress.

    Exit codes: 0 written, 1 a configuration failed (the table says which and why) or the
    reference failed (nothing written), 2 bad input (nothing written).
    """
    from femref.bench.output import plot_pareto, write_bench_table
    from femref.case import CaseError, resolved_yaml
    from femref.case.defaults import DEFAULT_SCENE_SOURCE
    from femref.bench.run import ReferenceFailed, run_bench
    from femref.scene.build import scene_from_case

    try:
        case, base_dir = load_case_or_default(case_path)
        if case.kind != "impact":
            raise CaseError.at("kind", f"{IMPACT_ONLY}; this is a {case.kind} case", source=str(case_path))
        scene = scene_from_case(case, base_dir)
    except CaseError as error:
        fail(error)
    defaulted = output is None
    output = output or Path(f"{case_path.stem if case_path else 'default'}_bench.h5")
    inputs = {"CASE": case_path, **case_input_files(case)}
    check_output(output, "-o", inputs, default=defaulted)
    if plot_path is not None:
        check_output(plot_path, "--plot", {**inputs, "-o": output})

    try:
        with configuration_progress(Console(stderr=True)) as progress:
            outcome = run_bench(scene, repeats, progress)
    except ReferenceFailed as error:
        fail(error, EXIT_RUN_FAILURE)
    written = [write_bench_table(output, resolved_yaml(case), outcome)]
    if plot_path is not None:
        name = case_path.name if case_path else DEFAULT_SCENE_SOURCE
        written.append(plot_pareto(plot_path, outcome, title=f"femref bench {name}: peak coupler force error vs wall time"))
    print_table(bench_table(outcome))
    echo_summary("Pareto-optimal (fastest first): " + ", ".join(row.configuration.label for row in outcome.pareto_rows))
    for note in outcome.notes:
        echo_summary(f"note: {note}")
    finish(written, [(f"configuration {row.configuration.label}", row.message) for row in outcome.failed])
