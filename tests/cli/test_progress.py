"""Progress of the commands that work longer than a few seconds besides the model runs (issue 18): ``femref run``
of a measured case (the records read, then each event with its estimators) and ``femref calibrate`` (each
estimator over the sweep's samples) report through the same mechanism as the model runs
(femref.cli.common.model_progress): status lines on stderr with ``femref --progress`` when stderr is not a
terminal, nothing without it, a bar per stage on a terminal."""

from __future__ import annotations

import io
import re
from pathlib import Path

import click
import pytest
from click.testing import CliRunner
from rich.console import Console

from femref.cli import main
from femref.cli.common import PROGRESS_KEY, model_progress

from femref.case.defaults import default_scene_data
from support.measured import run_calibration_sweep, yard_case_with_inverse_estimators

STATUS = re.compile(r"^(?P<stage>.+): (?P<how>running|done in \d+\.\d s|stopped after \d+\.\d s)$")


def status_lines(stderr: str) -> list[tuple[str, str]]:
    """The (stage, running | done | stopped) status lines of ``stderr``, in order."""
    found = []
    for line in stderr.splitlines():
        match = STATUS.match(line)
        if match:
            found.append((match["stage"], match["how"].split(" ")[0]))
    return found


@pytest.fixture(scope="module")
def measured_case(tmp_path_factory) -> Path:
    """cases/measured_yard.yaml (two events) reading the shipped records, with the cheap estimators only."""
    return yard_case_with_inverse_estimators(tmp_path_factory.mktemp("measured"))


def test_measured_run_shows_a_status_line_per_stage_with_progress(measured_case, tmp_path) -> None:
    """``femref --progress run measured.yaml`` with stderr piped: the records read, then each event (number and trigger
    time; the count is not known while the records stream) running and done, on stderr; the same table on stdout as
    without the flag, which shows nothing."""
    runner = CliRunner()
    quiet = runner.invoke(main, ["run", str(measured_case), "-o", str(tmp_path / "a.h5")], env={"COLUMNS": None})
    shown = runner.invoke(main, ["--progress", "run", str(measured_case), "-o", str(tmp_path / "b.h5")], env={"COLUMNS": None})
    assert quiet.exit_code == shown.exit_code == 0, shown.output
    assert status_lines(quiet.stderr) == []
    assert status_lines(shown.stderr) == [
        ("read records", "running"), ("read records", "done"),
        ("event 1 at 1.503 s", "running"), ("event 1 at 1.503 s", "done"),
        ("event 2 at 3.603 s", "running"), ("event 2 at 3.603 s", "done"),
    ], shown.stderr
    assert shown.stdout == quiet.stdout.replace("a.h5", "b.h5")


@pytest.fixture(scope="module")
def calibration_sweep(tmp_path_factory) -> tuple[Path, Path]:
    """A 20-sample fem sweep of the default scene, coarse and short (8 elements, 0.2 s): the fewest samples calibrate takes."""
    fem = {**default_scene_data()["fem"], "elements": 8}
    return run_calibration_sweep(tmp_path_factory.mktemp("calibrate"), 20, 101, 51, time={"end": 0.2}, fem=fem)


def test_calibrate_shows_a_status_line_per_estimator_with_progress(calibration_sweep, tmp_path) -> None:
    """``femref --progress calibrate``: the sweep file read, then each inverse estimator running and done, on stderr;
    nothing without the flag."""
    sweep, results = calibration_sweep
    runner = CliRunner()
    quiet = runner.invoke(main, ["calibrate", str(sweep), str(results), "-o", str(tmp_path / "a.h5")])
    shown = runner.invoke(main, ["--progress", "calibrate", str(sweep), str(results), "-o", str(tmp_path / "b.h5")])
    assert quiet.exit_code == shown.exit_code == 0, shown.output
    assert status_lines(quiet.stderr) == []
    assert status_lines(shown.stderr) == [(stage, how) for stage in ("read cal.h5", "inverse_rigid", "inverse_quasi_rigid") for how in ("running", "done")]
    assert "inverse_rigid: peak error 95 % band" in shown.stdout


def test_a_stage_ended_by_an_error_says_stopped() -> None:
    """A status line never says done for a stage an error ended: ``<stage>: stopped after …``; on a terminal a finished
    stage's bar may be hidden when the next starts (many events), and the bars go when all are done."""
    console = Console(file=io.StringIO(), width=100)
    with click.Context(main) as context:
        context.meta[PROGRESS_KEY] = True
        with pytest.raises(RuntimeError), model_progress(console) as progress_for:
            progress_for("event 1/1 at 0.100 s")
            raise RuntimeError("a record file changed")
        terminal = Console(file=io.StringIO(), width=100, force_terminal=True)
        with model_progress(terminal, keep_finished=False) as progress_for:
            for stage in ("event 1/2", "event 2/2"):
                step = progress_for(stage)
                step(1, 1)
    assert status_lines(console.file.getvalue()) == [("event 1/1 at 0.100 s", "running"), ("event 1/1 at 0.100 s", "stopped")]


@pytest.fixture
def cheap_figures(monkeypatch) -> list[str]:
    """The figure makers of femref.verification replaced by instant fakes (a few bytes of PNG each) that record
    their calls; the real figures take seconds each (tests/verification/test_verification.py draws them)."""
    import femref.verification as verification

    made: list[str] = []

    def fake(name: str):
        def make(*arguments: str):
            label = name.format(*arguments)
            made.append(label)
            return verification.Figure(label, b"\x89PNG\r\n\x1a\n" + label.encode(), {})

        return make

    for attribute, name in (("fem_convergence", "fem_convergence"), ("harmonic_against_exact", "harmonic_{}"),
                            ("quasi_rigid_epsilon", "quasi_rigid_epsilon")):
        monkeypatch.setattr(verification, attribute, fake(name))
    return made


def test_figures_shows_a_status_line_per_figure_with_progress(cheap_figures, tmp_path) -> None:
    """``femref --progress figures``: each figure running and done on stderr, in the order femref.verification makes
    them (its all_figures), each PNG written; nothing on stderr without the flag, the same files and stdout."""
    from femref.verification import all_figures

    runner = CliRunner()
    quiet = runner.invoke(main, ["figures", "-o", str(tmp_path / "a")])
    shown = runner.invoke(main, ["--progress", "figures", "-o", str(tmp_path / "b")])
    assert quiet.exit_code == shown.exit_code == 0, shown.output
    names = [figure.name for figure in all_figures()]  # the fakes: the names and order of the real figures
    assert names == ["fem_convergence", "harmonic_rod", "harmonic_beam", "quasi_rigid_epsilon"]
    assert status_lines(quiet.stderr) == []
    assert status_lines(shown.stderr) == [(f"figure {name}", how) for name in names for how in ("running", "done")], shown.stderr
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == sorted(f"{name}.png" for name in names)
    assert (tmp_path / "b" / "harmonic_beam.png").read_bytes().endswith(b"harmonic_beam")
    assert shown.stdout == quiet.stdout.replace(str(tmp_path / "a"), str(tmp_path / "b"))
