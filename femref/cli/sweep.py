"""``femref sweep SWEEP``, ``femref study STUDY`` (docs/design.md §5, §6: runs on Dask, resumable) and
``femref calibrate SWEEP SWEEP_FILE`` (the inverse estimators' error bands from a sweep's fem records).

An output that would overwrite an input is bad input (exit 2): :func:`sweep_inputs`, :func:`study_inputs`,
:func:`study_writes`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.console import Console

from femref.cli.common import (EXIT_INTERRUPTED, EXIT_RUN_FAILURE, case_input_files, check_output, compile_notices, echo_summary, fail, model_progress, print_table,
                               sample_progress)
from femref.cli.tables import study_table

#: Failed samples listed after a sweep (the file holds every error).
SHOWN_FAILURES = 5


def sweep_inputs(sweep_path: Path, loaded, name: str = "SWEEP") -> dict[str, Path | None]:
    """The inputs of a sweep for :func:`check_output`: the sweep file, its base case file and the files the base
    case names (a sweep's samples drop its estimators, so not their networks)."""
    inputs: dict[str, Path | None] = {name: sweep_path}
    if loaded.spec.base is not None:
        inputs[f"base of {name}"] = sweep_path.parent / loaded.spec.base
    inputs.update(case_input_files(loaded.base_case, f"the base case of {name}"))
    return inputs


def study_inputs(study_path: Path, spec, study_dir: Path) -> dict[str, Path | None]:
    """The inputs of a study for :func:`check_output`: the study file, its base case file, the files the base case
    names and the saved networks its entries continue training from (``networks.<name>.mlp.initial``)."""
    from femref.case import load_case

    base = study_dir / spec.base
    inputs: dict[str, Path | None] = {"STUDY": study_path, "base of STUDY": base}
    if base.is_file():  # a missing base is the study's own error, named when it runs
        inputs.update(case_input_files(load_case(base), "the base case of STUDY"))
    for name, network in spec.networks.items():
        if getattr(network, "initial", None) is not None:
            inputs[f"networks.{name}.mlp.initial of STUDY"] = study_dir / network.initial
    return inputs


def study_writes(spec, out_dir: Path) -> list[Path]:
    """The files a study writes in ``out_dir`` (:func:`femref.study.run.run_study`): each set's sweep file, its
    samples and their ``.partial``, each trained network, ``study.h5`` and ``study.md``."""
    from reduced.signal_tools import IMPACT_KINDS

    written = []
    for name in spec.sets:
        written += [out_dir / f"{name}.sweep.yaml", out_dir / f"{name}.h5", out_dir / f"{name}.h5.partial"]
    kinds = IMPACT_KINDS if spec.impact_types else ("",)
    for source in spec.sets["train"].models if "train" in spec.sets else ():
        for name in spec.networks:
            written += [out_dir / "networks" / f"{source}_{name}{'_' + kind if kind else ''}.npz" for kind in kinds]
    return [*written, out_dir / "study.h5", out_dir / "study.md"]


@click.command("sweep")
@click.argument("sweep_path", metavar="SWEEP", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--scheduler", metavar="tcp://HOST:PORT", help="run on this Dask scheduler (default: a local cluster)")
@click.option("--workers", type=click.IntRange(min=1), help="local cluster worker processes (default: one per CPU)")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="sweep file (default: SWEEP stem + .h5, in the working folder); refused if it is SWEEP, its base case or a file that names")
@click.option("--limit", type=click.IntRange(min=0), help="run at most N samples now (the file stays .partial)")
@click.option("--retry-failed", is_flag=True, help="run the samples stored as failed again")
def sweep_command(sweep_path: Path, scheduler: str | None, workers: int | None, output: Path | None, limit: int | None, retry_failed: bool) -> None:
    """Run the samples of SWEEP not yet stored in the sweep file, on Dask; resumable (docs/design.md §6).

    Samples are stored in OUTPUT.partial as they finish, renamed to OUTPUT when all are stored;
    the same command resumes. Progress on stderr: a bar on a terminal, a line per tenth of
    the samples with femref --progress.

    Exit codes: 0 the sweep ran (failed samples are recorded in the file), 1 the sweep machinery
    failed, 2 bad input (nothing written), 130 interrupted (run again to resume).
    """
    from femref.case import CaseError
    from femref.sweep import SweepInterrupted, load_sweep, run_sweep
    from femref.sweep.store import partial_path

    if scheduler is not None and workers is not None:
        raise click.UsageError("--workers sizes the local cluster; the cluster behind --scheduler has its own workers")
    console = Console(stderr=True)
    defaulted = output is None
    try:
        loaded = load_sweep(sweep_path)
        output = output or Path(f"{sweep_path.stem}.h5")
        check_output(output, "-o", sweep_inputs(sweep_path, loaded), default=defaulted, writes=[partial_path(output)])
        with compile_notices(console), sample_progress(console) as progress:
            summary = run_sweep(loaded, output, scheduler=scheduler, workers=workers, limit=limit, retry_failed=retry_failed, progress=progress)
    except CaseError as error:
        fail(error)
    except SweepInterrupted as interrupted:
        _sweep_report(interrupted.summary)
        click.echo(f"interrupted: {interrupted.summary.run} samples stored in this call; run again to resume", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except Exception as error:  # the sweep machinery (scheduler, workers, file system), not a sample
        fail(f"sweep failed: {type(error).__name__}: {error}", EXIT_RUN_FAILURE)
    _sweep_report(summary)


def _sweep_report(summary) -> None:
    """One line of counts and speed, the first failures, and where the samples are."""
    if summary.run == 0 and summary.complete:
        failed = f" ({summary.stored_failed} failed; --retry-failed runs them again)" if summary.stored_failed else ""
        echo_summary(f"all {summary.total} samples already stored in {summary.path}{failed}")
        return
    failed = f"{summary.failed} failed" + (f" ({summary.stored_failed} stored as failed in all)" if summary.stored_failed != summary.failed else "")
    echo_summary(
        f"samples: {summary.total} total, {summary.run} run now, {summary.skipped} skipped (already stored), {failed}; "
        f"wall time {summary.wall_time_s:.1f} s, {summary.runs_per_second:.2f} runs/s"
    )
    for index, error in summary.failures[:SHOWN_FAILURES]:
        click.echo(f"  sample {index} failed: {error}", err=True)
    if summary.failed > SHOWN_FAILURES:
        click.echo(f"  … and {summary.failed - SHOWN_FAILURES} more (samples/error in the file)", err=True)
    click.echo(f"wrote {summary.path}" + ("" if summary.complete else " (incomplete: run again to resume)"))


@click.command("study")
@click.argument("study_path", metavar="STUDY", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="study folder, created in an existing folder (default: STUDY stem, in the working folder); refused if a file it writes is an input")
@click.option("--scheduler", metavar="tcp://HOST:PORT", help="run the sweeps on this Dask scheduler (default: a local cluster)")
@click.option("--workers", type=click.IntRange(min=1), help="local cluster worker processes (default: one per CPU)")
@click.option("--scale", type=click.FloatRange(min=0.0, min_open=True, max=1.0), default=1.0, help="run every set at this fraction of its samples")
def study_command(study_path: Path, out_dir: Path | None, scheduler: str | None, workers: int | None, scale: float) -> None:
    """Run the network study STUDY: sweeps, networks per training source, scores against fem (issue 5).

    Writes, in the study folder: each set's sweep (SET.sweep.yaml, SET.h5; resumable), the
    trained networks (networks/SOURCE_NAME.npz), study.h5 and study.md. Progress on stderr:
    a bar on a terminal, a line per tenth of each sweep's samples with femref --progress.

    Every network file, study.h5 and study.md is written under a temporary name and renamed
    when complete: a failure leaves none of them half-written.

    Exit codes: 0 written, 1 a failure during the study (error: study failed: …), 2 bad input
    (nothing written), 130 interrupted (the sweeps keep what they stored; run again to resume).
    """
    from femref.case import CaseError
    from femref.study.run import run_study
    from femref.study.spec import load_study
    from femref.sweep import SweepInterrupted

    if scheduler is not None and workers is not None:
        raise click.UsageError("--workers sizes the local cluster; the cluster behind --scheduler has its own workers")
    console = Console(stderr=True)
    try:
        spec, study_dir = load_study(study_path)
        if scale != 1.0:
            spec = spec.scaled(scale)
        defaulted = out_dir is None
        out_dir = out_dir or Path(study_path.stem)
        check_output(out_dir, "-o", study_inputs(study_path, spec, study_dir), folder=True, default=defaulted, writes=study_writes(spec, out_dir))
        with compile_notices(console), sample_progress(console) as progress:
            outcome = run_study(spec, study_dir, out_dir, source=str(study_path), scheduler=scheduler, workers=workers, progress=progress)
    except CaseError as error:
        fail(error)
    except (SweepInterrupted, KeyboardInterrupt):
        click.echo("interrupted: the sweeps keep what they stored; run again to resume", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except Exception as error:  # a step of the study (the sweep machinery, training, the files), not bad input
        click.echo(f"error: study failed: {type(error).__name__}: {error}", err=True)
        click.echo("the sweeps keep the samples they stored (run again to resume); no file is left half-written", err=True)
        sys.exit(EXIT_RUN_FAILURE)
    print_table(study_table(outcome))
    click.echo(f"wrote {out_dir / 'study.h5'}, {out_dir / 'study.md'} and {len(outcome.networks)} networks in {out_dir / 'networks'}")


@click.command("calibrate")
@click.argument("sweep_path", metavar="SWEEP", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("results", metavar="SWEEP_FILE", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="calibration file (default: SWEEP stem + .calibration.h5, in the working folder); refused if it is an input")
@click.option("--coupler", help="the coupler whose force is calibrated (default: the first)")
@click.option("--network", "networks", multiple=True, metavar="NAME=FILE",
              help="also calibrate a saved network, under the estimator name a measured case gives it (ann_<name>); repeatable")
def calibrate_command(sweep_path: Path, results: Path, output: Path | None, coupler: str | None, networks: tuple[str, ...]) -> None:
    """Calibrate the inverse estimators' (and saved networks') error bands on SWEEP's fem records (its file
    SWEEP_FILE, from femref sweep): the file a measured case names under calibration:.

    Needs at least 20 ok samples with a fem run. Progress on stderr: a bar per estimator on a
    terminal, a line when each starts and ends with femref --progress. The output may not be
    SWEEP, SWEEP_FILE, a --network file or SWEEP's base case.

    Exit codes: 0 written, 2 bad input (nothing written).
    """
    from femref.case import CaseError
    from femref.sensing.calibration import write_calibration
    from femref.sensing.network import AnnEstimator, NetworkFileError
    from femref.study.calibration import calibrate
    from femref.sweep import load_sweep

    loaded = []
    for entry in networks:
        name, _, file = entry.partition("=")
        if not file or not (name == "ann" or name.startswith("ann_")):
            fail(f"--network {entry}: give NAME=FILE with NAME ann or ann_<name>")
        try:
            loaded.append(AnnEstimator.load(name, file))
        except NetworkFileError as error:
            fail(f"--network {entry}: {error}")
    try:
        sweep = load_sweep(sweep_path)
    except CaseError as error:
        fail(error)
    inputs = {**sweep_inputs(sweep_path, sweep), "SWEEP_FILE": results, **{f"--network {entry}": Path(entry.partition("=")[2]) for entry in networks}}
    defaulted = output is None
    output = output or Path(f"{sweep_path.stem}.calibration.h5")
    check_output(output, "-o", inputs, default=defaulted)
    try:
        with model_progress(Console(stderr=True)) as progress_for:
            calibration = calibrate(sweep, results, coupler, loaded, progress_for=progress_for)
    except CaseError as error:
        fail(error)
    except (ValueError, OSError, KeyError, StopIteration) as error:
        fail(f"{results}: {error}")
    written = write_calibration(calibration, output)
    lo, hi = calibration.closing_speed
    for name in calibration.errors:
        e_lo, e_hi = calibration.error_band(name)
        click.echo(f"{name}: peak error 95 % band [{e_lo:+.1%}, {e_hi:+.1%}] over {calibration.errors[name].size} samples")
    chain = "unfiltered records" if calibration.lowpass is None else f"records low-passed at {calibration.lowpass:g} Hz"
    click.echo(f"valid for closing speeds {lo:.3g}–{hi:.3g} m/s, car masses "
               + ", ".join(f"{car} {a / 1e3:.0f}–{b / 1e3:.0f} t" for car, (a, b) in calibration.masses.items())
               + f", {chain} with sensor noise up to {calibration.noise[1]:.3g} m/s²")
    click.echo(f"wrote {written}")
