"""Load records (``loads.<name>: {csv: …}``) are sized before they are read: a file above
``MAX_CSV_BYTES`` is refused by ``os.stat`` without being opened, one of an estimated row count above
``MAX_CSV_ROWS`` after reading only two 64 KiB samples, and the reader counts the rows it reads anyway
(femref.core.signals). ``femref validate`` exits 2 naming ``loads.<name>.csv.path``, the rule and the size."""

from __future__ import annotations

import builtins
import re
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.cli import main
from femref.core import signals
from femref.core.signals import MAX_CSV_BYTES, MAX_CSV_ROWS, CsvTooLarge, check_csv_size, read_csv_columns

ROWS = "".join(f"{k * 1e-3:.6f},{1e5 * np.sin(k * 1e-3):.3f}\n" for k in range(8000))  # 8000 rows, ~150 kB


def _case(tmp_path: Path, csv: Path) -> Path:
    """A transient rod case loaded at F2 by the record ``csv``."""
    data = {
        "kind": "transient",
        "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9},
        "loads": {"F2": {"csv": {"path": csv.name, "time_column": "time", "value_column": "force"}}},
        "time": {"end": 0.3},
        "models": ["rigid"],
    }
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _validate(case: Path) -> tuple[object, float]:
    start = time.perf_counter()
    result = CliRunner().invoke(main, ["validate", str(case)])
    return result, time.perf_counter() - start


@pytest.fixture
def opened(monkeypatch) -> list[str]:
    """The modes in which femref.core.signals opens files (text mode means the record is being read)."""
    modes: list[str] = []

    def recording_open(file, mode="r", *args, **kwargs):
        modes.append(mode)
        return builtins.open(file, mode, *args, **kwargs)

    monkeypatch.setattr(signals, "open", recording_open, raising=False)
    return modes


def test_a_file_beyond_the_byte_limit_is_refused_without_opening_it(tmp_path, opened):
    """A 300 MiB record (sparse: a header, two rows, then truncate) exits 2 at loads.F2.csv.path, quoting both
    sizes, and is never opened: os.stat decides."""
    csv = tmp_path / "huge.csv"
    with open(csv, "w") as f:
        f.write("time,force\n0.0,0.0\n0.1,1.0\n")
        f.truncate(300 * 2**20)
    result, seconds = _validate(_case(tmp_path, csv))
    assert result.exit_code == 2, result.output
    assert "loads.F2.csv.path:" in result.output and "300 MiB" in result.output and f"{MAX_CSV_BYTES // 2**20} MiB" in result.output
    assert opened == []
    assert seconds < 1.0


def test_a_record_of_too_many_rows_is_refused_from_its_size(tmp_path, opened):
    """A 100 MiB record of ~19-byte rows (~5.4e6 rows: real rows at its start and end, a sparse middle) exits 2
    at loads.F2.csv.path with the estimate and the row limit; only the two binary samples are read."""
    csv = tmp_path / "long.csv"
    size = 100 * 2**20
    with open(csv, "w") as f:
        f.write("time,force\n" + ROWS)
        f.truncate(size - len(ROWS))
        f.seek(size - len(ROWS))
        f.write(ROWS)
    assert csv.stat().st_size == size
    result, seconds = _validate(_case(tmp_path, csv))
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    estimate = re.search(r"holds about (\S+) rows in 100 MiB", text)
    assert "loads.F2.csv.path:" in text and estimate and "at most 2e6 samples" in text, text
    assert float(estimate[1]) == pytest.approx(size / (len(ROWS) / 8000), rel=0.01)
    assert opened == ["rb"]
    assert seconds < 1.0


def test_the_reader_counts_rows_whatever_the_estimate_said(tmp_path, monkeypatch):
    """With the estimate out of the way, the reader stops at MAX_CSV_ROWS + 1 rows; exactly MAX_CSV_ROWS load."""
    monkeypatch.setattr(signals, "MAX_CSV_ROWS", 100)
    monkeypatch.setattr(signals, "check_csv_size", lambda path: 0)
    exact, over = tmp_path / "exact.csv", tmp_path / "over.csv"
    exact.write_text("time,force\n" + "".join(f"{k},{k}\n" for k in range(100)))
    over.write_text("time,force\n" + "".join(f"{k},{k}\n" for k in range(101)))
    times, _ = read_csv_columns(exact, "time", "force")
    assert times.size == 100
    with pytest.raises(CsvTooLarge, match="holds more than 100 samples"):
        read_csv_columns(over, "time", "force")


def test_rows_growing_longer_down_the_file_are_not_refused_for_the_short_first_ones(tmp_path, monkeypatch):
    """The estimate takes the longer bytes per row of the first and the last sample: a record of 6000 rows whose
    first rows are short ("1,0") is estimated at about its true length and loads."""
    monkeypatch.setattr(signals, "MAX_CSV_ROWS", 10_000)
    monkeypatch.setattr(signals, "_SAMPLE_BYTES", 1024)
    csv = tmp_path / "growing.csv"
    short = [f"{k},0\n" for k in range(1, 10)]
    long = [f"{k * 1.0e-3 + 1.0:.9f},{123456.789012 + k:.6f}\n" for k in range(6000 - len(short))]
    csv.write_text("time,force\n" + "".join(short + long))
    head_only = csv.stat().st_size / (len("time,force\n" + "".join(short)) / (1 + len(short)))
    assert head_only > 10_000  # the first lines alone would have refused it
    assert 5000 < check_csv_size(csv) < 7000
    assert read_csv_columns(csv, "time", "force")[0].size == 6000


def test_the_estimate_is_close_for_an_even_record(tmp_path):
    """8000 rows of a regular record: the estimate lies within 5 % of the true count (the header counts too)."""
    csv = tmp_path / "even.csv"
    csv.write_text("time,force\n" + ROWS)
    assert abs(check_csv_size(csv) - 8001) < 0.05 * 8001


def test_the_row_limit_holds_a_30_minute_record_at_1_khz():
    """The documented reason for the limit: 30 min at 1 kHz (1.8e6 samples) fits, and the byte limit holds
    such a record even with long rows (256 MiB / 1.8e6 ≈ 149 bytes per row)."""
    assert 30 * 60 * 1000 <= MAX_CSV_ROWS
    assert MAX_CSV_BYTES / (30 * 60 * 1000) > 100


def test_a_device_is_refused_without_reading_it(tmp_path):
    """``path: /dev/zero`` (no size, no end, no line break) is refused at loads.F2.csv.path, not read forever."""
    case = _case(tmp_path, tmp_path / "x.csv")
    case.write_text(case.read_text().replace("path: x.csv", "path: /dev/zero"))
    result, seconds = _validate(case)
    assert result.exit_code == 2 and "loads.F2.csv.path:" in result.output and "is not a regular file" in result.output, result.output
    assert seconds < 1.0


# --- a record is read once per run ---------------------------------------------------------------------------


@pytest.fixture
def reads(monkeypatch) -> list[Path]:
    """The files femref.core.signals.read_csv_columns reads (validation and Tabulated.from_csv both call it)."""
    read: list[Path] = []
    real = signals.read_csv_columns

    def counting(path, *args, **kwargs):
        read.append(Path(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(signals, "read_csv_columns", counting)
    return read


def test_a_run_reads_its_load_record_once(tmp_path, reads):
    """``femref run`` of a transient case with a CSV load reads the record once: validation keeps the samples (not in
    the resolved case) and the run builds the load from them; the result holds the same load as a fresh read."""
    import h5py

    csv = tmp_path / "force.csv"
    csv.write_text("time,force\n" + ROWS)
    result = CliRunner().invoke(main, ["run", str(_case(tmp_path, csv)), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 0, result.output
    assert reads == [csv]
    with h5py.File(tmp_path / "out.h5") as h5:
        resolved = yaml.safe_load(h5.attrs["case_yaml"])
    assert resolved["loads"]["F2"] == {"csv": {"path": str(csv), "time_column": "time", "value_column": "force"}}  # no samples


def test_a_record_changed_since_validation_is_read_again(tmp_path, reads):
    """The load is built from what validation read while the file's size and mtime are unchanged; a record changed
    since (another size or st_mtime_ns) is read again, so the run uses the file as it is."""
    import os

    from femref.case import load_case
    from femref.core.signals import Tabulated

    csv = tmp_path / "force.csv"
    csv.write_text("time,force\n" + ROWS)
    case = load_case(_case(tmp_path, csv))
    spec = case.loads.F2
    first = spec.build()
    assert isinstance(first, Tabulated) and reads == [csv]
    assert case == load_case(_case(tmp_path, csv))  # cases compare as before (the kept samples compare by value)
    reads.clear()
    csv.write_text("time,force\n0.0,0.0\n0.1,2.0e5\n0.2,0.0\n")
    stamp = os.stat(csv)
    os.utime(csv, ns=(stamp.st_atime_ns, stamp.st_mtime_ns + 1_000_000))
    changed = spec.build()
    assert reads == [csv] and changed.values.tolist() == [0.0, 2.0e5, 0.0]
    np.testing.assert_array_equal(first.times[:3], [0.0, 1e-3, 2e-3])
