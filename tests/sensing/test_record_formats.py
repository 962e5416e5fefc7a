"""Record readers (femref.sensing.formats) on files written by each format's own writer: Python's csv in every dialect,
h5py, asammdf (MDF.append), npTDMS (TdmsWriter) and pyuff (UFF.write_sets), each holding a known synthetic signal
read back exactly; units from the file's metadata; bad files refused naming the file and the rule."""

from __future__ import annotations

import csv
import sys
from datetime import datetime, timedelta
from pathlib import Path

import h5py
import numpy as np
import pytest

from femref.sensing import record_files
from femref.sensing.record_files import RecordError, SampleLimit, read_columns
from femref.sensing.recordings import ChannelSource, RecordFile, TimeSource, read_records

T = np.arange(2000) / 1000.0
FRONT = np.round(3.0 * np.sin(2 * np.pi * 7.0 * T) + 0.125, 6)  # 7 digits: UFF58's ASCII (12 digits) holds them exactly
REAR = np.round(-0.8 * FRONT + np.cos(T) * 1e-3, 6)
LIMIT = SampleLimit(10**6, "the test's limit")
REQUESTS = [("t", "time"), ("front", "channel a/front"), ("rear", "channel b/rear")]


def write_csv(path: Path, *, delimiter: str = ",", decimal: str = ".", bom: bool = False, quoting: int = csv.QUOTE_MINIMAL,
              iso: bool = False) -> Path:
    """T, FRONT, REAR written by Python's csv (repr: every float exactly), in the dialect asked for."""
    start = datetime(2026, 11, 27, 23, 0, 0)
    with path.open("w", newline="", encoding="utf-8-sig" if bom else "utf-8") as handle:
        writer = csv.writer(handle, delimiter=delimiter, quoting=quoting)
        writer.writerow(["t", "front", "rear"])
        for t, f, r in zip(T, FRONT, REAR):
            cells = [repr(float(v)).replace(".", decimal) for v in (t, f, r)]
            if iso:
                cells[0] = (start + timedelta(milliseconds=round(t * 1000))).isoformat(timespec="milliseconds")
            writer.writerow(cells)
    return path


@pytest.mark.parametrize("dialect", [
    {}, {"bom": True}, {"delimiter": ";", "decimal": ","}, {"delimiter": "\t"}, {"quoting": csv.QUOTE_NONNUMERIC},
    {"quoting": csv.QUOTE_ALL, "delimiter": ";", "decimal": ",", "bom": True},
], ids=["plain", "bom", "semicolon-decimal-comma", "tab", "quoted", "excel-de"])
def test_every_csv_dialect_reads_back_exactly(tmp_path, dialect):
    path = write_csv(tmp_path / "r.csv", **dialect)
    quoted = dialect.get("quoting") == csv.QUOTE_NONNUMERIC  # QUOTE_NONNUMERIC writes numbers bare: same file as plain
    assert quoted or path.read_bytes().startswith(b"\xef\xbb\xbf") == dialect.get("bom", False)
    columns, units = read_columns(path, REQUESTS, LIMIT, "csv", {"decimal": dialect.get("decimal", ".")})
    for column, truth in zip(columns, (T, FRONT, REAR)):
        np.testing.assert_array_equal(column, truth)
    assert units == [None, None, None]


def test_a_decimal_comma_in_a_comma_separated_file_is_refused(tmp_path):
    path = write_csv(tmp_path / "r.csv")
    with pytest.raises(RecordError, match=r"r\.csv: the case declares a decimal comma, and the header line is separated by commas"):
        read_columns(path, REQUESTS, LIMIT, "csv", {"decimal": ","})


def test_iso_timestamps_are_seconds_from_the_first(tmp_path):
    path = write_csv(tmp_path / "r.csv", iso=True)
    record = RecordFile(path, TimeSource(column="t", unit="iso8601"), 0.0, (ChannelSource("a/front", "front", None, "g"),))
    channel = next(iter(read_records([record]).channels.values()))
    np.testing.assert_allclose(channel.time, T, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(channel.acceleration, FRONT * 9.80665)


def test_an_unparseable_or_backward_iso_time_names_the_row(tmp_path):
    path = write_csv(tmp_path / "r.csv", iso=True)
    lines = path.read_text().splitlines()
    lines[5] = "yesterday" + lines[5][lines[5].index(","):]
    path.write_text("\n".join(lines) + "\n")
    record = RecordFile(path, TimeSource(column="t", unit="iso8601"), 0.0, (ChannelSource("a/front", "front", None, "g"),))
    with pytest.raises(RecordError, match=r"r\.csv: time \(column 't'\): row 6 is not an ISO-8601 timestamp"):
        read_records([record])
    lines = write_csv(tmp_path / "r.csv", iso=True).read_text().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordError, match=r"r\.csv: time must increase strictly; sample 6 \(t = 0\.004 s\) goes back"):
        read_records([record])


def test_an_iso_time_not_declared_says_how_to_declare_it(tmp_path):
    path = write_csv(tmp_path / "r.csv", iso=True)
    with pytest.raises(RecordError, match=r"row 2 is not a number .*declares unit: iso8601"):
        read_columns(path, REQUESTS, LIMIT)


def write_hdf5(path: Path) -> Path:
    with h5py.File(path, "w") as h5:
        h5["t"], h5["front"], h5["rear"] = T, FRONT, REAR
    return path


def write_mdf4(path: Path) -> Path:
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    mdf.append([Signal(FRONT, T, name="front", unit="g"), Signal(REAR, T, name="rear", unit="m/s²")])
    mdf.save(path, overwrite=True)
    return path


def write_tdms(path: Path) -> Path:
    from nptdms import ChannelObject, TdmsWriter

    with TdmsWriter(path) as writer:
        writer.write_segment([ChannelObject("rec", "t", T[:1000], {"unit_string": "s"}), ChannelObject("rec", "front", FRONT[:1000], {"unit_string": "g"}),
                              ChannelObject("rec", "rear", REAR[:1000], {"unit_string": "m/s^2"})])
        writer.write_segment([ChannelObject("rec", "t", T[1000:]), ChannelObject("rec", "front", FRONT[1000:]), ChannelObject("rec", "rear", REAR[1000:])])
    return path


def write_uff58(path: Path) -> Path:
    import pyuff

    def record(node: int, name: str, values: np.ndarray, unit: str) -> dict:
        axis = {f"{axis}_{key}": value for axis in ("abscissa", "ordinate", "orddenom", "z_axis")
                for key, value in (("spec_data_type", 0), ("len_unit_exp", 0), ("force_unit_exp", 0), ("temp_unit_exp", 0), ("axis_lab", "NONE"),
                                   ("axis_units_lab", "NONE"))}
        return axis | {"type": 58, "binary": 0, "func_type": 1, "func_id": node, "ver_num": 0, "load_case_id": 0, "id1": name, "id2": "NONE",
                       "id3": "NONE", "id4": "NONE", "id5": "NONE", "rsp_ent_name": "car", "rsp_node": node, "rsp_dir": 1, "ref_ent_name": "NONE",
                       "ref_node": 0, "ref_dir": 0, "ord_data_type": 4, "num_pts": T.size, "abscissa_spacing": 0, "abscissa_min": 0.0,
                       "abscissa_inc": 1e-3, "z_axis_value": 0.0, "n_bytes": 0, "x": T, "data": values,
                       "abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": unit}

    pyuff.UFF(str(path)).write_sets([record(1, "front", FRONT, "g"), record(2, "rear", REAR, "m/s^2")], mode="overwrite")
    return path


FILES = {  # format → (writer, the channels' references, the units the file gives)
    "hdf5": (write_hdf5, ("t", "front", "rear"), [None, None, None]),
    "mdf4": (write_mdf4, ("time", "front", "rear"), ["s", "g", "m/s²"]),
    "tdms": (write_tdms, ("rec/t", "rec/front", "rec/rear"), ["s", "g", "m/s^2"]),
    "uff58": (write_uff58, ("front", "front", "rear"), ["s", "g", "m/s^2"]),
}
SUFFIX = {"hdf5": ".h5", "mdf4": ".mf4", "tdms": ".tdms", "uff58": ".uff"}
PACKAGE = {"mdf4": "asammdf", "tdms": "nptdms", "uff58": "pyuff"}


def written(tmp_path: Path, fmt: str) -> Path:
    if fmt in PACKAGE:
        pytest.importorskip(PACKAGE[fmt])
    return FILES[fmt][0](tmp_path / f"r{SUFFIX[fmt]}")


@pytest.mark.parametrize("fmt", list(FILES))
def test_each_format_reads_back_exactly_with_its_units(tmp_path, fmt):
    path = written(tmp_path, fmt)
    _, keys, units = FILES[fmt]
    columns, found = read_columns(path, list(zip(keys, ("time", "channel a/front", "channel b/rear"))), LIMIT, fmt)
    truth = (T, FRONT, REAR)
    for column, expected in zip(columns, truth):
        np.testing.assert_array_equal(column, expected)
    assert found == units


@pytest.mark.parametrize("fmt", ["mdf4", "tdms", "uff58"])
def test_the_files_unit_is_taken_and_a_declared_one_must_agree(tmp_path, fmt):
    path = written(tmp_path, fmt)
    _, keys, _ = FILES[fmt]
    record = RecordFile(path, TimeSource(channel=keys[0]), 0.0, (ChannelSource("a/front", None, None, None, channel=keys[1]),))
    np.testing.assert_allclose(next(iter(read_records([record]).channels.values())).acceleration, FRONT * 9.80665, rtol=1e-12, atol=1e-11)
    record = RecordFile(path, TimeSource(channel=keys[0]), 0.0, (ChannelSource("a/front", None, None, "m/s^2", channel=keys[1]),))
    with pytest.raises(RecordError, match=r"channel a/front: the case declares unit 'm/s\^2', the file gives 'g'; they must agree"):
        read_records([record])


@pytest.mark.parametrize("fmt", ["mdf4", "tdms", "uff58"])
def test_a_missing_channel_names_the_file_and_its_channels(tmp_path, fmt):
    path = written(tmp_path, fmt)
    with pytest.raises(RecordError, match=rf"r{SUFFIX[fmt]}: channel a/x \(channel 'nope'\): no such (channel|record) \(.*front"):
        read_columns(path, [("nope", "channel a/x")], LIMIT, fmt)


@pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")  # no traceback from a half-built object either
@pytest.mark.parametrize("fmt", list(FILES))
@pytest.mark.parametrize("damage", ["truncated", "garbage"])
def test_a_corrupt_file_is_a_record_error_naming_the_file(tmp_path, fmt, damage):
    path = written(tmp_path, fmt)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2] if damage == "truncated" else b"\x00\x17garbage" * 50)
    _, keys, _ = FILES[fmt]
    with pytest.raises(RecordError, match=rf"^r{SUFFIX[fmt]}: "):
        read_columns(path, list(zip(keys, ("time", "channel a/front", "channel b/rear"))), LIMIT, fmt)


@pytest.mark.parametrize("fmt", list(FILES))
def test_a_sample_count_beyond_the_limit_is_refused_before_a_sample_is_read(tmp_path, fmt, monkeypatch):
    path = written(tmp_path, fmt)
    _, keys, _ = FILES[fmt]
    opened = []
    real = record_files.open_reader

    def spying(*args):
        reader = real(*args)
        opened.append(reader)
        monkeypatch.setattr(reader, "chunks", lambda size: pytest.fail("data read before the bound was checked"))
        return reader

    monkeypatch.setattr(record_files, "open_reader", spying)
    with pytest.raises(RecordError, match=r"holds 2000 samples; the test's limit"):
        read_columns(path, list(zip(keys, ("time", "channel a/front", "channel b/rear"))), SampleLimit(1999, "the test's limit"), fmt)
    assert opened


def test_a_tdms_index_beside_the_file_is_not_read(tmp_path):
    path = written(tmp_path, "tdms")
    index = tmp_path / "r.tdms_index"
    index.write_bytes(b"TDSh" + b"\xff" * 200)  # npTDMS would read its segments' metadata from this
    columns, _ = read_columns(path, [("rec/front", "channel a/front")], LIMIT, "tdms")
    np.testing.assert_array_equal(columns[0], FRONT)


@pytest.mark.parametrize("fmt", ["mdf4", "tdms", "uff58"])
def test_without_its_package_a_format_names_the_extra(tmp_path, fmt, monkeypatch):
    path = written(tmp_path, fmt)
    monkeypatch.setitem(sys.modules, PACKAGE[fmt], None)  # import raises ImportError
    with pytest.raises(RecordError, match=rf"r{SUFFIX[fmt]}: reading {fmt.upper()} files needs the package {PACKAGE[fmt]}: pip install 'femref\[formats\]'"):
        read_columns(path, [("front", "channel a/front")], LIMIT, fmt)


def uff58_record(values: np.ndarray, precision: int, spacing: int) -> dict:
    """A pyuff dataset-58 record of ``values`` at 1 kHz from 0.25 s (``precision`` 2 single, 4 double; ``spacing`` 1 even)."""
    axis = {f"{axis}_{key}": value for axis in ("abscissa", "ordinate", "orddenom", "z_axis")
            for key, value in (("spec_data_type", 0), ("len_unit_exp", 0), ("force_unit_exp", 0), ("temp_unit_exp", 0), ("axis_lab", "NONE"),
                               ("axis_units_lab", "NONE"))}
    return axis | {"type": 58, "binary": 0, "func_type": 1, "func_id": 1, "ver_num": 0, "load_case_id": 0, "id1": "front", "id2": "NONE",
                   "id3": "NONE", "id4": "NONE", "id5": "NONE", "rsp_ent_name": "car", "rsp_node": 1, "rsp_dir": 1, "ref_ent_name": "NONE",
                   "ref_node": 0, "ref_dir": 0, "ord_data_type": precision, "num_pts": values.size, "abscissa_spacing": spacing,
                   "abscissa_min": 0.25, "abscissa_inc": 1e-3, "z_axis_value": 0.0, "n_bytes": 0, "x": 0.25 + np.arange(values.size) * 1e-3,
                   "data": values, "abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": "g"}


@pytest.mark.parametrize("precision", [2, 4], ids=["single 6E13.5", "double 4E20.12"])
def test_uff58_ascii_records_are_read_as_pyuff_reads_them(tmp_path, precision):
    """An ASCII UFF58 record written by pyuff in single and in double precision (2000 and 1999 points: a full and a
    partial last line): the reader's numpy conversion of its fields and of its abscissa equals pyuff's own reading,
    to the bit; a record it cannot take that way (uneven abscissa) is left to pyuff."""
    pyuff = pytest.importorskip("pyuff")
    from femref.sensing.formats.uff58 import Reader

    for points in (2000, 1999):
        path = tmp_path / f"r{points}.uff"
        pyuff.UFF(str(path)).write_sets([uff58_record(FRONT[:points] * (1 + 1e-7 * np.arange(points)), precision, 1)], mode="overwrite")
        reader = Reader(path)
        ((number, _),) = reader.headers.values()
        truth = reader.uff.read_sets(number)
        for field in ("data", "x"):
            fast = reader.ascii_column(number, field)
            assert fast is not None and np.array_equal(fast, np.asarray(truth[field], dtype=float)), (points, field)
    pyuff.UFF(str(tmp_path / "u.uff")).write_sets([uff58_record(FRONT[:100], 4, 0)], mode="overwrite")
    reader = Reader(tmp_path / "u.uff")
    assert reader.ascii_column(next(iter(reader.headers.values()))[0], "data") is None


@pytest.mark.parametrize("scan_bytes", [97, 1000, 1 << 24])
def test_uff58_records_are_found_as_pyuff_finds_them_a_piece_at_a_time(tmp_path, monkeypatch, scan_bytes):
    """The reader finds a file's records by a scan a piece at a time (femref.sensing.formats.uff58._ScannedUFF): for pieces
    of 97 and 1000 bytes (every tag near a piece's edge somewhere) and one piece, the record bounds, types and formats
    equal those of pyuff's own scan of the whole file (three records, single and double precision, and a dataset 151
    header before them), and the channels read back."""
    pyuff = pytest.importorskip("pyuff")
    from femref.sensing.formats import uff58

    path = tmp_path / "three.uff"
    header = {"type": 151, "model_name": "car", "description": "femref test", "db_app": "femref", "date_db_created": "", "time_db_created": "",
              "version_db1": "0", "version_db2": "0", "file_type": "0", "date_db_saved": "", "time_db_saved": "", "program": "femref",
              "date_db_written": "", "time_db_written": ""}
    records = [uff58_record(FRONT[:1999], 2, 1), uff58_record(REAR[:2000], 4, 1), uff58_record(FRONT[:5], 2, 1)]
    for k, record in enumerate(records):
        record["id1"] = f"channel {k}"
    pyuff.UFF(str(path)).write_sets([header, *records], mode="overwrite")
    monkeypatch.setattr(uff58, "SCAN_BYTES", scan_bytes)
    mine, theirs = uff58._ScannedUFF(str(path)), pyuff.UFF(str(path))
    np.testing.assert_array_equal(np.asarray(mine._block_ind), np.asarray(theirs._block_ind))
    np.testing.assert_array_equal(mine._set_types, theirs._set_types)
    np.testing.assert_array_equal(mine._set_formats, theirs._set_formats)
    assert list(mine._set_types) == [151, 58, 58, 58]
    with uff58.Reader(path) as reader:
        reader.select([("channel 1", "channel rear")])
        np.testing.assert_array_equal(np.concatenate([chunk[0] for chunk in reader.chunks(512)]), np.asarray(theirs.read_sets(2)["data"], dtype=float))
