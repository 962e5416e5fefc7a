"""Every table ``femref`` prints fits 80 columns without cutting a figure (issue 31): the legend, titles and words of
text wrap; a table too wide is split into panels of whole columns that repeat the row's name.

Each test runs a case in-process, checks that figures computed here from the outcome's own data are cells of the
table, then prints the table as the CLI does at ``COLUMNS=80`` (support.tables): no line over 80 characters and every
figure of every cell, title and legend a whole word of the output.
"""

from __future__ import annotations

import numpy as np
import pytest
from rich.table import Table

from femref.api import run_case
from femref.case.defaults import default_scene_data
from femref.choice.output import choice_table
from femref.cli.tables import event_table, fit, natural_width, run_table

from support.paths import CASES
from support.tables import assert_echoed_whole, assert_printed_whole

WIDTH = 80


def cells(table: Table, header: str) -> list[str]:
    """The cells of the column named ``header``."""
    (column,) = [c for c in table.columns if c.header == header]
    return [str(cell) for cell in column.cells]


@pytest.fixture(scope="module")
def impact_outcome():
    """The default scene on a coarse mesh, every model and both inverse estimators: the widest run table."""
    data = default_scene_data()
    data["fem"]["elements"] = 8
    return run_case(data)


def test_impact_run_table(impact_outcome, monkeypatch, capsys) -> None:
    """Peak coupler force (kN, one decimal) and wall time (ms) of every model, from its histories, are whole at 80."""
    table = run_table(impact_outcome)
    peaks = cells(table, "P peak kN")
    for result in impact_outcome.results:
        peak = max(float(np.max(out["force"] if "force" in out else out["peak_force"])) for out in result.couplers.values())
        assert any(cell.startswith(f"{peak / 1e3:.1f} @") for cell in peaks), (result.model, peaks)
        assert f"{result.wall_time_s * 1e3:.1f}" in cells(table, "wall ms")
    assert natural_width(table) > WIDTH  # the point of the test: it does not fit as it is
    text = assert_printed_whole(table, WIDTH, monkeypatch, capsys)
    for result in impact_outcome.results:  # each model's name leads a row of every panel
        assert sum(line.split()[0] == result.model for line in text.splitlines() if line.strip()) >= 2, text


def test_single_body_run_table(monkeypatch, capsys) -> None:
    """A rod's harmonic run: peak |a| of every model from its probes, whole at 80."""
    outcome = run_case(CASES / "rod_harmonic.yaml")
    table = run_table(outcome)
    for result in outcome.results:
        peak = max(float(np.max(np.abs(out["acceleration"]))) for out in result.probes.values())
        assert any(cell.startswith(f"{peak:.4g} @") for cell in cells(table, "|a| peak")), result.model
    assert_printed_whole(table, WIDTH, monkeypatch, capsys)


def test_choice_table(monkeypatch, capsys) -> None:
    """The ladder of ``--tolerance 0.01``: each rung's predicted cost (ms) is whole at 80."""
    data = default_scene_data()
    data["fem"]["elements"] = 8
    choice = run_case(data, tolerance=0.01)
    table = choice_table(choice)
    assert cells(table, "predicted cost") == [f"{row.rung.cost * 1e-3:.1f} ms" for row in choice.rows]
    assert_printed_whole(table, WIDTH, monkeypatch, capsys)


def test_measured_event_table(monkeypatch, capsys) -> None:
    """The yard case's events: trigger time and every estimator's peak (kN) from the estimates, whole at 80; the
    figures columns and the estimators' columns fall into two panels, each led by the event's number."""
    outcome = run_case(CASES / "measured_yard.yaml")
    table = event_table(outcome)
    assert [c for c in cells(table, "t trigger s") if c] == [f"{event.trigger_time:.4f}" for event in outcome.events]
    assert [c for c in cells(table, "peak kN") if c] == [f"{e.peak[0] / 1e3:.1f}" for event in outcome.events for e in event.estimates]
    text = assert_printed_whole(table, WIDTH, monkeypatch, capsys)
    assert text.count("event ") >= 2


def test_fit_splits_into_panels_of_whole_columns(monkeypatch, capsys) -> None:
    """A table of twelve 9-digit columns keyed by two text columns: within 60 columns each panel repeats the two keys,
    holds whole columns in order, and leaves out a row blank in all its columns; the legend comes once, at the end."""
    table = Table(title="wide", caption="legend: " + "every column explained at length " * 4)
    table.add_column("name")
    table.add_column("status")
    for k in range(12):
        table.add_column(f"x{k}", justify="right", no_wrap=True)
    table.add_row("alpha", "ok", *(f"{k:09d}" for k in range(12)))
    table.add_row("", "", *([""] * 6), *(f"{k:09d}" for k in range(100, 106)))
    parts = fit(table, 60)
    panels = [p for p in parts if isinstance(p, Table)]
    assert len(panels) >= 3 and parts[-1].plain.startswith("legend:")
    headers = [[c.header for c in panel.columns] for panel in panels]
    assert all(h[:2] == ["name", "status"] for h in headers)
    assert [x for h in headers for x in h[2:]] == [f"x{k}" for k in range(12)]
    assert all(natural_width(panel) <= 60 for panel in panels)
    assert panels[0].row_count == 1 and panels[-1].row_count == 2  # the second row is blank in x0..x5
    assert_printed_whole(table, 60, monkeypatch, capsys)


def test_a_table_that_fits_is_left_as_it_is_and_one_too_wide_without_a_column_to_split_off_loses_its_frame() -> None:
    table = Table()
    table.add_column("a")
    table.add_row("1")
    assert fit(table, WIDTH) == [table]
    table.add_row("x" * 100)
    (compact,) = fit(table, WIDTH)
    assert compact.row_count == 2 and not compact.show_edge


def test_summary_lines_wrap_at_spaces(monkeypatch, capsys) -> None:
    """The sweep's and the fleet's summary lines (femref.cli.common.echo_summary) wrap at spaces at 80, every figure
    whole; piped without COLUMNS a line stays one line."""
    line = ("samples: 1000 total, 996 run now, 4 skipped (already stored), 0 failed; wall time 12.3 s, 81.23 runs/s; "
            "throughput: 0.52 events/s, 12.75 MB/s of record files, 1.23e+05 samples/s; wall time 4321.0 s")
    text = assert_echoed_whole(line, WIDTH, monkeypatch, capsys)
    assert len(text.splitlines()) > 1
    monkeypatch.delenv("COLUMNS")
    assert_echoed_whole(line, 10_000, monkeypatch, capsys)  # COLUMNS=10000: one line
    monkeypatch.delenv("COLUMNS")
    from femref.cli.common import echo_summary

    echo_summary(line)
    assert capsys.readouterr().out == line + "\n"
