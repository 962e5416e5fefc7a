"""A summary table as the CLI prints it at a given width, and the check that it fits without cutting a figure."""

from __future__ import annotations

from collections import Counter

from rich.cells import cell_len
from rich.table import Table
from rich.text import Text

from femref.cli.common import echo_summary, print_table


def figures(text: str) -> Counter:
    """The words of ``text`` (split at white space) that hold a digit, counted."""
    return Counter(word for word in text.split() if any(ch.isdigit() for ch in word))


def table_figures(table: Table) -> Counter:
    """Every figure of ``table``'s cells, title and legend: what the printed table must show whole."""
    parts = [table.title, table.caption, *(cell for column in table.columns for cell in column.cells)]
    return sum((figures(Text.from_markup(part).plain) for part in parts if isinstance(part, str)), Counter())


def assert_printed_whole(table: Table, width: int, monkeypatch, capsys) -> str:
    """Print ``table`` as ``femref`` does with ``COLUMNS=width``: no line wider than ``width``, and every figure of
    its cells, title and legend a whole word of the output (a folded number would be two words). Returns the text."""
    monkeypatch.setenv("COLUMNS", str(width))
    capsys.readouterr()
    print_table(table)
    text = capsys.readouterr().out
    assert max(cell_len(line) for line in text.splitlines()) <= width, text
    missing = table_figures(table) - figures(text)
    assert not missing, (missing, text)
    return text


def assert_echoed_whole(line: str, width: int, monkeypatch, capsys) -> str:
    """:func:`femref.cli.common.echo_summary` of ``line`` with ``COLUMNS=width``: within the width, every figure whole."""
    monkeypatch.setenv("COLUMNS", str(width))
    capsys.readouterr()
    echo_summary(line)
    text = capsys.readouterr().out
    assert max(cell_len(row) for row in text.splitlines()) <= width, text
    assert not figures(line) - figures(text), text
    return text
