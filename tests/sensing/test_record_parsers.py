"""The CSV reader's C parsers (pandas', numpy's) against Python's rule for a cell, ``csv`` + ``float`` (and
``datetime.fromisoformat`` for an ISO-8601 time), written out here independently of femref: the same values bit for
bit in every dialect, whatever the chunk size, and the row-by-row reader's error (file, row, column) for every cell
Python refuses."""

from __future__ import annotations

import csv
import math
import os
import random
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from femref.sensing.formats import delimited
from femref.sensing.formats.delimited import PARSERS, Reader
from femref.sensing.record_files import RecordError

ROWS = 600
DIALECTS = {
    "comma": {"delimiter": ","},
    "semicolon": {"delimiter": ";"},
    "tab": {"delimiter": "\t"},
    "decimal_comma": {"delimiter": ";", "decimal": ","},
    "quoted": {"delimiter": ",", "quoting": csv.QUOTE_ALL},
    "iso8601": {"delimiter": ",", "iso": True},
    "bom": {"delimiter": ",", "bom": True},
    "crlf": {"delimiter": ",", "terminator": "\r\n"},
}


def hard_numbers(count: int, seed: int) -> list[str]:
    """Numbers as text that test rounding: shortest reprs, 17–40 significant digits (between two doubles), subnormals,
    huge and tiny exponents, signed zeros and infinities."""
    rng = random.Random(seed)
    cells = []
    for k in range(count):
        kind = k % 5
        if kind == 0:
            cells.append(repr(rng.uniform(-50.0, 50.0)))
        elif kind == 1:
            digits = "".join(rng.choice("0123456789") for _ in range(rng.randint(17, 40)))
            cells.append(f"{rng.choice('+-')}{digits[0]}.{digits[1:]}e{rng.randint(-330, 308)}")
        elif kind == 2:
            value = np.frombuffer(rng.randbytes(8), dtype=np.float64)[0]
            cells.append(repr(float(value)) if math.isfinite(value) else "-0.0")
        elif kind == 3:
            cells.append(rng.choice(["0", "-0", "1e-320", "5e-324", "1.7976931348623157e308", "inf", "-Infinity", "1e400", ".5", "5.", "+7"]))
        else:
            cells.append(f"{rng.randint(-10**6, 10**6)}.{rng.randint(0, 10**9):09d}")
    return cells


def write_record(path: Path, dialect: str, rows: int = ROWS, seed: int = 1) -> list[list[str]]:
    """A time column and two channels of ``hard_numbers`` written by Python's csv in ``dialect``; the cells as written."""
    style = DIALECTS[dialect]
    decimal = style.get("decimal", ".")
    start = datetime(2026, 3, 1, 23, 59, 59, 500000)
    table = []
    for k, (a, b) in enumerate(zip(hard_numbers(rows, seed), hard_numbers(rows, seed + 1))):
        time = (start + timedelta(microseconds=1000 * k + k % 7)).isoformat() if style.get("iso") else repr(k / 1000.0).replace(".", decimal)
        table.append([time, a.replace(".", decimal), b.replace(".", decimal)])
    with path.open("w", newline="", encoding="utf-8-sig" if style.get("bom") else "utf-8") as handle:
        writer = csv.writer(handle, delimiter=style["delimiter"], quoting=style.get("quoting", csv.QUOTE_MINIMAL),
                            lineterminator=style.get("terminator", "\n"))
        writer.writerow(["t", "front", "rear"])
        writer.writerows(table)
    return table


def python_columns(table: list[list[str]], decimal: str, iso: bool) -> list[np.ndarray]:
    """Python's reading of the cells: ``float`` (a decimal comma as a point), ``fromisoformat`` in s from the first."""
    if iso:
        stamps = [datetime.fromisoformat(row[0]) for row in table]
        time = [(stamp - stamps[0]).total_seconds() for stamp in stamps]
    else:
        time = [float(row[0].replace(decimal, ".")) for row in table]
    return [np.array(time)] + [np.array([float(row[k].replace(decimal, ".")) for row in table]) for k in (1, 2)]


def read(path: Path, parser: str, size: int, **options) -> list[np.ndarray]:
    """Every selected column of ``path`` joined over its chunks of ``size`` lines, through ``parser``."""
    reader = Reader(path, parser=parser, **options)
    reader.select([("front", "channel a/front"), ("rear", "channel b/rear"), ("t", "time")])
    parts = list(reader.chunks(size))
    return [np.concatenate([chunk[k] for chunk in parts]) for k in range(3)]


@pytest.mark.parametrize("parser", PARSERS)
@pytest.mark.parametrize("dialect", DIALECTS)
def test_every_parser_gives_pythons_values_bit_for_bit(tmp_path, monkeypatch, dialect, parser):
    """Every chunk of a clean file is taken by the C parser (none read again row by row; numpy's takes no ISO-8601
    time), and every value is Python's."""
    style = DIALECTS[dialect]
    again = []
    by_rows = Reader._by_rows
    monkeypatch.setattr(Reader, "_by_rows", lambda self, lines, before: again.append(before) or by_rows(self, lines, before))
    table = write_record(tmp_path / "r.csv", dialect)
    expected = python_columns(table, style.get("decimal", "."), bool(style.get("iso")))
    options = {"decimal": style.get("decimal", ".")} | ({"timestamps": "t"} if style.get("iso") else {})
    for size in (7, 256, 10_000):
        front, rear, time = read(tmp_path / "r.csv", parser, size, **options)
        for got, want in zip((time, front, rear), expected):
            assert got.tobytes() == want.tobytes(), (dialect, parser, size)
    assert again == [] or parser == "rows" or (parser == "numpy" and style.get("iso")), again


HOSTILE = ["", "nan", " NaN ", "-nan", "NA", "null", "0x10", "1e", "1.5.2", " 1.5", "1.5 ", "True", "1_000", "١", "+1", "1d5", "--1",
           "in", "infinit", "e5", ".", "-", "1..5", '"1.5"x', '"1.5', "1.5\"", "#N/A", "\ufeff1.5"]


@pytest.mark.parametrize("parser", ["pandas", "numpy"])
@pytest.mark.parametrize("cell", HOSTILE)
def test_a_hostile_cell_reads_as_python_reads_it_or_gives_its_error(tmp_path, cell, parser):
    """A cell in row 301 of 600: the value Python's rule gives it (a gap for empty or ``nan``), or the row-by-row
    reader's error naming the file, the row and the column."""
    write_record(tmp_path / "r.csv", "comma")
    lines = (tmp_path / "r.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    t, _, rear = lines[301].rstrip("\n").split(",")
    lines[301] = f"{t},{cell},{rear}\n"
    (tmp_path / "h.csv").write_text("".join(lines), encoding="utf-8")

    def outcome(parser: str):
        try:
            return read(tmp_path / "h.csv", parser, 256)
        except RecordError as error:
            return str(error)

    rows, fast = outcome("rows"), outcome(parser)
    if isinstance(rows, str):
        assert fast == rows and "h.csv" in rows
    else:
        assert not isinstance(fast, str), fast
        assert all(a.tobytes() == b.tobytes() for a, b in zip(fast, rows))
        stripped = cell.strip()
        assert math.isnan(rows[0][300]) if stripped.lower() in ("", "nan", "-nan") else rows[0][300] == float(stripped.strip('"'))


@pytest.mark.parametrize("shape", ["blank line", "line of blanks", "short row", "long row", "lone cr line ends", "bad stamp"])
def test_odd_rows_read_as_the_row_by_row_reader_reads_them(tmp_path, shape):
    """Rows the C parsers read otherwise than Python's csv (a line of blanks is a row of gaps to it, a longer row
    keeps its first cells, a lone ``\\r`` ends a line) give the row-by-row reader's values or error."""
    table = write_record(tmp_path / "r.csv", "iso8601" if shape == "bad stamp" else "comma")
    lines = ["t,front,rear"] + [",".join(row) for row in table]
    if shape == "blank line":
        lines.insert(200, "")
    elif shape == "line of blanks":
        lines.insert(200, "   ")
    elif shape == "short row":
        lines[200] = lines[200].rsplit(",", 1)[0]
    elif shape == "long row":
        lines[200] += ",9.5"
    elif shape == "bad stamp":
        lines[200] = "2026-03-01 25:00:00" + lines[200][lines[200].index(","):]
    text = ("\r" if shape == "lone cr line ends" else "\n").join(lines) + "\n"
    (tmp_path / "odd.csv").write_text(text, encoding="utf-8", newline="")
    options = {"timestamps": "t"} if shape == "bad stamp" else {}
    found = {}
    for parser in PARSERS:
        try:
            found[parser] = read(tmp_path / "odd.csv", parser, 64, **options)
        except RecordError as error:
            found[parser] = str(error)
    if shape == "bad stamp":
        assert found["pandas"] == found["rows"] and "row 201" in found["rows"] and "ISO-8601" in found["rows"]
        return
    for parser in ("pandas", "numpy"):
        assert all(a.tobytes() == b.tobytes() for a, b in zip(found[parser], found["rows"])), parser


def test_the_parser_goes_by_the_files_size_unless_pandas_is_loaded(tmp_path, monkeypatch):
    """Below :data:`PANDAS_BYTES` and without pandas imported a file goes to numpy's parser; at it, to pandas'."""
    write_record(tmp_path / "r.csv", "comma", rows=50)
    seen = []
    monkeypatch.setattr(Reader, "_by_numpy", lambda self, lines: seen.append("numpy"))
    monkeypatch.setattr(Reader, "_by_pandas", lambda self, data, rows, before: seen.append("pandas"))
    monkeypatch.delitem(delimited.sys.modules, "pandas", raising=False)
    read(tmp_path / "r.csv", None, 1000)
    monkeypatch.setattr(delimited, "PANDAS_BYTES", (tmp_path / "r.csv").stat().st_size)
    read(tmp_path / "r.csv", None, 1000)
    assert seen == ["numpy", "pandas"]


def test_an_unknown_parser_is_refused(tmp_path):
    write_record(tmp_path / "r.csv", "comma", rows=5)
    with pytest.raises(ValueError, match="parser 'fast'"):
        Reader(tmp_path / "r.csv", parser="fast")


def test_chunks_hold_at_most_their_lines_whatever_the_bytes(tmp_path, monkeypatch):
    """pandas' pieces are cut at line ends, at most ``size`` lines and about :data:`BLOCK_BYTES`; a line longer than
    a block is read whole."""
    write_record(tmp_path / "r.csv", "comma", rows=300)
    monkeypatch.setattr(delimited, "BLOCK_BYTES", 100)  # shorter than a row of three 40-digit numbers: rows read whole
    reader = Reader(tmp_path / "r.csv", parser="pandas")
    reader.select([("front", "f"), ("t", "t")])
    sizes = [chunk[0].size for chunk in reader.chunks(32)]
    assert sum(sizes) == 300 and max(sizes) <= 32
    expected = read(tmp_path / "r.csv", "rows", 1000)
    got = read(tmp_path / "r.csv", "pandas", 32)
    assert all(a.tobytes() == b.tobytes() for a, b in zip(got, expected))


def test_a_files_line_count_is_kept_for_the_file_as_it_is(tmp_path):
    """Validation and the run count a file's lines once; a file changed (size, or content and modification time) or
    replaced is counted again."""
    path = tmp_path / "r.csv"
    write_record(path, "comma", rows=40)

    def samples() -> int:
        reader = Reader(path)
        return reader.select([("front", "f")])[0].samples

    assert samples() == 40 and samples() == 40
    with path.open("a") as handle:
        handle.write("0.5,1,2\n")
    assert samples() == 41
    text = path.read_text()
    stamp = path.stat().st_mtime_ns
    path.write_text(text[:-8] + "0.5\n1,2\n")  # the same size, a line more, a later modification time
    os.utime(path, ns=(stamp + 10**9, stamp + 10**9))
    assert samples() == 42
    replaced = tmp_path / "other.csv"
    replaced.write_text(text[:text.index("\n") + 1] + "0,1,2\n" * 10)
    stamp = path.stat().st_mtime_ns
    replaced.replace(path)
    os.utime(path, ns=(stamp, stamp))  # same modification time, another file (inode) and size
    assert samples() == 10
