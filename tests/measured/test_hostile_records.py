"""Hostile record files of a measured case (issue 33): refused at the case's ``records[i]`` before a byte too many is read.

Each probe runs ``femref run`` on a two-car case (inverse_rigid only) around one record file and must exit 2 with
``error: <case>: records[0]: <file>: <channel or dataset>: <rule>`` and write nothing. Before this work, an HDF5
dataset stored externally in /etc/passwd ran (exit 0) and its text came back in the result; external links,
virtual datasets (a missing source read as zeros), Blosc chunks and soft-link loops gave tracebacks; a FIFO
record or case file hung; /dev/zero and a 2 GB CSV ended in a MemoryError past 5 GB, a 9.9 MB gzip bomb asked
for 9.3 GiB, time stamps 1 ns apart for a GHz grid; a column named twice was read from the first one silently,
and an unbalanced quote gave a ``_csv.Error`` traceback.
"""

from __future__ import annotations

import os
import re
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.case import load_case
from femref.cli import main
from femref.sensing import record_files, recordings
from femref.sensing.record_files import MAX_RECORD_BYTES, MAX_RECORD_SAMPLES, MAX_SOFT_LINKS
from femref.sensing.quality import PLAUSIBLE_ACCELERATION
from femref.sensing.recordings import MAX_EVENT_VALUES, MAX_RECORD_RATE

G = 9.80665
RATE = 1000.0  # Hz of the probes' records
SECONDS = 3.0  # their length
HDF5_CHANNELS = {"a/front": {"dataset": "front", "unit": "m/s^2"}, "b/rear": {"dataset": "rear", "unit": "m/s^2"}}


def pulse(t: np.ndarray, start: float = 1.0, width: float = 0.1, height: float = 20.0) -> np.ndarray:
    """A half-sine acceleration pulse (m/s²) from ``start``: the one impact of every probe's record."""
    s = (t - start) / width
    return np.where((s > 0) & (s < 1), height * np.sin(np.pi * np.clip(s, 0, 1)), 0.0)


def write_case(folder: Path, record: str | Path, *, time: dict | None = None, channels: dict | None = None, events: dict | None = None) -> Path:
    """A measured case of two cars (mass and length only) reading ``record``, written to ``folder/case.yaml``."""
    data = {
        "kind": "measured",
        "records": [{"file": str(record), "time": time or {"column": "t", "unit": "s"},
                     "channels": channels or {"a/front": {"column": "front", "unit": "g"}, "b/rear": {"column": "rear", "unit": "g"}}}],
        "cars": [{"name": "a", "mass": 8.0e4, "length": 17.0, "sensors": {"front": 8.0}},
                 {"name": "b", "mass": 8.0e4, "length": 17.0, "sensors": {"rear": -8.0}}],
        "couplers": [{"between": ["a", "b"]}],
        "events": events or {"trigger": 3.0, "pre": 0.05, "post": 0.3},
        "estimators": ["inverse_rigid"],
    }
    path = folder / "case.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def csv_record(path: Path, rate: float = RATE, seconds: float = SECONDS, header: str = "t,front,rear") -> Path:
    """The pulse on car a's front, −0.8 × it on car b's rear (in g), at ``rate`` for ``seconds``."""
    t = np.arange(0.0, seconds, 1.0 / rate)
    a = pulse(t) / G
    np.savetxt(path, np.column_stack([t, a, -0.8 * a]), delimiter=",", header=header, comments="", fmt="%.10g")
    return path


def hdf5_record(path: Path, front: Callable[[h5py.File], None] | None = None) -> Path:
    """An HDF5 record at :data:`RATE` (declared): ``front`` makes its dataset ``front`` (default: the pulse), ``rear`` is zero."""
    t = np.arange(0.0, SECONDS, 1.0 / RATE)
    with h5py.File(path, "w") as h5:
        if front is None:
            h5["front"] = pulse(t)
        else:
            front(h5)
        h5["rear"] = np.zeros(t.size)
    return path


def run(case: Path, output: Path):
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(output)])
    return result


def assert_refused(result, case: Path, output: Path, where: str, rule: str) -> None:
    """Exit 2, one ``error:`` line naming the case, the key path ``where`` and the rule (regexes), nothing written."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output, result.output
    assert re.search(rf"^error: {re.escape(str(case))}: {where}: {rule}", result.output, re.MULTILINE), result.output
    assert not output.exists() and not list(output.parent.glob(f".{output.name}*")), list(output.parent.iterdir())


# --- the probes: each makes a record in the folder and returns (the case's record path, its time and channels) ---


def external_storage(folder: Path) -> tuple[Path, dict, dict]:
    outside = folder.parent / "passwd"
    outside.write_bytes(b"root:x:0:0:root:/root:/bin/bash\n" * 100)
    t_size = int(SECONDS * RATE)
    record = hdf5_record(folder / "r.h5", lambda h5: h5.create_dataset("front", shape=(t_size,), dtype="f8", external=[(str(outside), 0, 8 * t_size)]))
    return record, {"rate": RATE}, HDF5_CHANNELS


def external_link(folder: Path) -> tuple[Path, dict, dict]:
    with h5py.File(folder.parent / "other.h5", "w") as h5:
        h5["x"] = pulse(np.arange(0.0, SECONDS, 1.0 / RATE))
    record = hdf5_record(folder / "r.h5", lambda h5: h5.__setitem__("front", h5py.ExternalLink(str(folder.parent / "other.h5"), "/x")))
    return record, {"rate": RATE}, HDF5_CHANNELS


def virtual_dataset(folder: Path) -> tuple[Path, dict, dict]:
    size = int(SECONDS * RATE)
    layout = h5py.VirtualLayout(shape=(size,), dtype="f8")
    layout[:] = h5py.VirtualSource(str(folder / "missing.h5"), "x", shape=(size,))
    record = hdf5_record(folder / "r.h5", lambda h5: h5.create_virtual_dataset("front", layout, fillvalue=0.0))
    return record, {"rate": RATE}, HDF5_CHANNELS


def blosc_chunks(folder: Path) -> tuple[Path, dict, dict]:
    def front(h5: h5py.File) -> None:  # filter 32001 (Blosc), no plugin: chunks written raw
        dataset = h5.create_dataset("front", shape=(int(SECONDS * RATE),), chunks=(1000,), dtype="f8", compression=32001, allow_unknown_filter=True)
        for k in range(3):
            dataset.id.write_direct_chunk((1000 * k,), b"\x00" * 64)

    return hdf5_record(folder / "r.h5", front), {"rate": RATE}, HDF5_CHANNELS


def soft_link_loop(folder: Path) -> tuple[Path, dict, dict]:
    def front(h5: h5py.File) -> None:
        h5["front"] = h5py.SoftLink("/loop")
        h5["loop"] = h5py.SoftLink("/front")

    return hdf5_record(folder / "r.h5", front), {"rate": RATE}, HDF5_CHANNELS


def gzip_bomb(folder: Path) -> tuple[Path, dict, dict]:
    """1.25e9 samples (9.3 GiB as floats) in a file of a few kB: one gzip chunk written, the rest fill value, as an (n, 1)
    dataset, which the reader holds whole (a one-dimensional one is streamed: memory bounded by the chunk)."""
    def front(h5: h5py.File) -> None:
        dataset = h5.create_dataset("front", shape=(1_250_000_000, 1), chunks=(2**20, 1), dtype="f8", compression="gzip", compression_opts=9)
        dataset[: 2**20] = np.zeros((2**20, 1))

    return hdf5_record(folder / "r.h5", front), {"rate": RATE}, HDF5_CHANNELS


def device(folder: Path) -> tuple[Path, dict, dict]:
    return Path("/dev/zero"), {"column": "t", "unit": "s"}, {}


def symlink_loop(folder: Path) -> tuple[Path, dict, dict]:
    os.symlink(folder / "two.csv", folder / "one.csv")
    os.symlink(folder / "one.csv", folder / "two.csv")
    return folder / "one.csv", {"column": "t", "unit": "s"}, {}


def uff_beyond_the_byte_limit(folder: Path) -> tuple[Path, dict, dict]:
    """A sparse UFF58 file (pyuff reads one whole) one byte past the limit: nothing on disk."""
    record = folder / "r.uff"
    with record.open("wb") as handle:
        handle.truncate(MAX_RECORD_BYTES + 1)
    return record, {"channel": "t", "unit": "s"}, {"a/front": {"channel": "front", "unit": "g"}, "b/rear": {"channel": "rear", "unit": "g"}}


def column_named_twice(folder: Path) -> tuple[Path, dict, dict]:
    t = np.arange(0.0, SECONDS, 1.0 / RATE)
    a = pulse(t) / G
    np.savetxt(folder / "r.csv", np.column_stack([t, 0.5 * a, a, -a]), delimiter=",", header="t,front,front,rear", comments="")
    return folder / "r.csv", {"column": "t", "unit": "s"}, {}


def unbalanced_quote(folder: Path) -> tuple[Path, dict, dict]:
    record = csv_record(folder / "r.csv")
    lines = record.read_text().splitlines()
    lines[100] = '"' + lines[100]  # row 101: the header is row 1
    record.write_text("\n".join(lines) + "\n")
    return record, {"column": "t", "unit": "s"}, {}


def nanosecond_stamps(folder: Path) -> tuple[Path, dict, dict]:
    """Bursts of three samples 1 ns apart every millisecond for 3 s: the median step is 1 ns, a GHz record whose event
    grid (0.6 s at 1 GHz) asked for 4.5 GiB before the rate limit."""
    t = (np.arange(0.0, SECONDS, 1.0 / RATE)[:, None] + np.arange(3) * 1e-9).ravel()
    a = pulse(t) / G
    np.savetxt(folder / "r.csv", np.column_stack([t, a, -a]), delimiter=",", header="t,front,rear", comments="", fmt="%.12f")
    return folder / "r.csv", {"column": "t", "unit": "s"}, {}


def rate_100_khz(folder: Path) -> tuple[Path, dict, dict]:
    """1.5 s at 100 kHz (a 5.7 s record at this rate needed 5.5 GB before the rate limit)."""
    return csv_record(folder / "r.csv", rate=1.0e5, seconds=1.5), {"column": "t", "unit": "s"}, {}


#: id → (probe, the key path after the case, the rule (regexes)).
HOSTILE: dict[str, tuple[Callable[[Path], tuple[Path, dict, dict]], str, str]] = {
    "hdf5 external storage": (external_storage, r"records\[0\]", r"r\.h5: channel a/front \(dataset 'front'\): /front keeps its raw data in external file\(s\) .*passwd: only data stored in this file are read \(refused unread\)"),
    "hdf5 external link": (external_link, r"records\[0\]", r"r\.h5: channel a/front \(dataset 'front'\): /front is an external link to .*other\.h5:/x; a record is read only from the file the case names"),
    "hdf5 virtual dataset": (virtual_dataset, r"records\[0\]", r"r\.h5: channel a/front \(dataset 'front'\): /front is a virtual dataset \(its data live in other files; a missing one reads as the fill value\): only data stored in this file are read \(refused unread\)"),
    "hdf5 blosc filter": (blosc_chunks, r"records\[0\]", r"r\.h5: channel a/front \(dataset 'front'\): /front is stored through chunk filter 32001 \(blosc\); femref reads only deflate \(gzip\), "),
    "hdf5 soft-link loop": (soft_link_loop, r"records\[0\]", rf"r\.h5: channel a/front \(dataset 'front'\): more than {MAX_SOFT_LINKS} soft links in a row \(a loop of soft links"),
    "hdf5 gzip bomb": (gzip_bomb, r"records\[0\]", r"r\.h5: channel a/front \(dataset 'front'\): holds 1\.25e9 samples; a column held whole holds at most 1\.68e7 samples"),
    "device /dev/zero": (device, r"records\[0\]", r"zero: is not a regular file but a character device \(/dev/zero\); a record is read only from a regular file"),
    "symlink loop": (symlink_loop, r"records\[0\]", r"one\.csv: is a loop of symbolic links"),
    "uff58 over 1 GiB": (uff_beyond_the_byte_limit, r"records\[0\]", r"r\.uff: the file holds 1024 MiB; a UFF58 record file, read whole, may hold at most 1024 MiB"),
    "column named twice": (column_named_twice, r"records\[0\]", r"r\.csv: channel a/front \(column 'front'\): the header names 2 columns 'front' \(0-based columns 1, 2\); name each column once"),
    "unbalanced quote": (unbalanced_quote, r"records\[0\]", r"r\.csv: row 101 is not valid CSV \(.*\); check its quotes"),
    "time stamps 1 ns apart": (nanosecond_stamps, r"records\[0\]", r"r\.csv: time: the median step 1e-09 s is a rate of 1e\+09 Hz, above 50000 Hz"),
    "100 kHz record": (rate_100_khz, r"records\[0\]", r"r\.csv: time: the median step 1e-05 s is a rate of 1e\+05 Hz, above 50000 Hz"),
}


@pytest.mark.parametrize(("probe", "where", "rule"), list(HOSTILE.values()), ids=list(HOSTILE))
def test_a_hostile_record_exits_2_naming_file_dataset_and_rule(tmp_path: Path, probe, where: str, rule: str) -> None:
    """Every probe is refused when the case is loaded, within a second, and nothing is written."""
    folder = tmp_path / "case"
    folder.mkdir()
    record, time_source, channels = probe(folder)
    case = write_case(folder, record, time=time_source, channels=channels or None)
    start = time.perf_counter()
    result = run(case, folder / "out.h5")
    assert time.perf_counter() - start < 2.0
    assert_refused(result, case, folder / "out.h5", where, rule)


def test_no_byte_of_a_file_outside_the_case_reaches_a_result(tmp_path: Path) -> None:
    """A marker file outside the case's folder, pointed at by a record's external storage (raw bytes), an external link
    and a virtual dataset (both to an HDF5 file holding the marker): every run is refused, and no file written in the
    folder nor any output holds the marker; the same record without a pointer runs, and its result does not hold it
    either."""
    marker = b"OUTSIDE-MARKER-7f3a" * 8  # 152 bytes = 19 float64
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.txt").write_bytes(marker * 160)
    with h5py.File(outside / "secret.h5", "w") as h5:
        h5["x"] = np.tile(np.frombuffer(marker, dtype="f8"), 160)
    size = 19 * 160
    pointers = {
        "external storage": lambda h5: h5.create_dataset("front", shape=(size,), dtype="f8", external=[(str(outside / "secret.txt"), 0, 8 * size)]),
        "external link": lambda h5: h5.__setitem__("front", h5py.ExternalLink(str(outside / "secret.h5"), "/x")),
        "virtual dataset": lambda h5: h5.create_virtual_dataset("front", _layout(outside / "secret.h5", size)),
        "none": lambda h5: h5.__setitem__("front", pulse(np.arange(size) / RATE)),
    }
    for kind, front in pointers.items():
        folder = tmp_path / kind.replace(" ", "_")
        folder.mkdir()
        with h5py.File(folder / "r.h5", "w") as h5:
            front(h5)
            h5["rear"] = np.zeros(size)
        case = write_case(folder, folder / "r.h5", time={"rate": RATE}, channels=HDF5_CHANNELS)
        result = run(case, folder / "out.h5")
        assert result.exit_code == (0 if kind == "none" else 2), (kind, result.output)
        assert "MARKER" not in result.output
        written = [path for path in folder.iterdir() if path.name not in ("r.h5", "case.yaml")]
        assert written == ([folder / "out.h5"] if kind == "none" else []), (kind, written)
        for path in folder.iterdir():
            assert marker[:16] not in path.read_bytes(), (kind, path)


def _layout(source: Path, size: int) -> h5py.VirtualLayout:
    layout = h5py.VirtualLayout(shape=(size,), dtype="f8")
    layout[:] = h5py.VirtualSource(str(source), "x", shape=(size,))
    return layout


@contextmanager
def fifo_watch(fifo: Path) -> Iterator[list[bool]]:
    """While the block runs, a thread opens ``fifo`` for writing (non-blocking) every 20 ms: that succeeds only while
    someone holds it open to read, and closing it at once gives that reader an end of file — so a reader that opened
    the FIFO is seen (the list holds True) and never hangs the test."""
    opened: list[bool] = []
    done = threading.Event()

    def watch() -> None:
        while not done.wait(0.02):
            try:
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:  # ENXIO: no reader
                continue
            opened.append(True)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    try:
        yield opened
    finally:
        done.set()
        thread.join()


def test_a_fifo_record_and_a_fifo_case_file_are_refused_unread(tmp_path: Path) -> None:
    """A FIFO (named pipe) blocks its reader until a writer comes (before: ``femref run`` hung forever): as a record and
    as the case file itself, it is refused by ``stat`` and never opened."""
    os.mkfifo(tmp_path / "r.csv")
    case = write_case(tmp_path, tmp_path / "r.csv")
    os.mkfifo(tmp_path / "fifo.yaml")
    for path, fifo, where, rule in (
        (case, tmp_path / "r.csv", r"records\[0\]", r"r\.csv: is not a regular file but a FIFO \(named pipe\) \(.*r\.csv\); a record is read only from a regular file$"),
        (tmp_path / "fifo.yaml", tmp_path / "fifo.yaml", "cannot read the case file", r"it is not a regular file but a FIFO \(named pipe\)$"),
    ):
        with fifo_watch(fifo) as opened:
            result = run(path, tmp_path / "out.h5")
        assert not opened
        assert_refused(result, path, tmp_path / "out.h5", where, rule)


def test_a_symlink_loop_case_file_is_named(tmp_path: Path) -> None:
    os.symlink(tmp_path / "b.yaml", tmp_path / "a.yaml")
    os.symlink(tmp_path / "a.yaml", tmp_path / "b.yaml")
    result = run(tmp_path / "a.yaml", tmp_path / "out.h5")
    assert_refused(result, tmp_path / "a.yaml", tmp_path / "out.h5", "cannot read the case file", r"it is a loop of symbolic links")


def test_a_declared_rate_beyond_the_limit_is_refused_before_reading(tmp_path: Path) -> None:
    """``time: {rate: 1e5}`` is refused by the schema at records[0].time.rate, the file never opened (it does not exist)."""
    case = write_case(tmp_path, tmp_path / "absent.h5", time={"rate": 1.0e5}, channels=HDF5_CHANNELS)
    result = run(case, tmp_path / "out.h5")
    assert_refused(result, case, tmp_path / "out.h5", r"records\[0\]\.time\.rate", rf"must be <= {MAX_RECORD_RATE:g}|.*less than or equal to {MAX_RECORD_RATE:g}")


def test_a_streamed_file_has_no_sample_limit_a_file_read_whole_does(tmp_path: Path, monkeypatch) -> None:
    """With the limit of columns held whole at 1000 samples, a 3000-row CSV is streamed by the run (exit 0, its impact
    found), and read whole (``read_columns``) it is refused after 1001 rows naming the limit. ``MAX_RECORD_SAMPLES``
    itself holds two hours at 1 kHz."""
    assert 2 * 3600 * 1000 <= MAX_RECORD_SAMPLES
    monkeypatch.setattr(record_files, "MAX_RECORD_SAMPLES", 1000)
    csv_record(tmp_path / "r.csv")
    case = write_case(tmp_path, tmp_path / "r.csv")
    result = run(case, tmp_path / "out.h5")
    assert result.exit_code == 0, result.output
    with h5py.File(tmp_path / "out.h5") as h5:
        assert len(h5["events"]) == 1
    with pytest.raises(record_files.RecordError, match=r"r\.csv: holds more than 1000 rows of samples; a column held whole holds at most 1000 samples"):
        record_files.read_columns(tmp_path / "r.csv", [("t", "time")], record_files.SampleLimit.whole(), "csv")


def test_an_event_grid_beyond_the_limit_names_max_window(tmp_path: Path) -> None:
    """A 20 kHz record of two channels with ``max_window: 60`` asks for (60 × 20000 + 1) × 2 = 2.4e6 values per event,
    beyond ``MAX_EVENT_VALUES``: refused at events.max_window with the longest window allowed, (2e6 / 2 − 1) / 2e4 =
    49.99995 s rounded down to the millisecond; a window of 49.999 s is accepted."""
    csv_record(tmp_path / "r.csv", rate=2.0e4, seconds=2.0)
    events = {"trigger": 3.0, "pre": 0.05, "post": 0.3, "max_window": 60.0}
    case = write_case(tmp_path, tmp_path / "r.csv", events=events)
    assert (60 * 20_000 + 1) * 2 > MAX_EVENT_VALUES >= (49.999 * 20_000 + 1) * 2
    assert_refused(run(case, tmp_path / "out.h5"), case, tmp_path / "out.h5", r"events\.max_window",
                   r"an event's grid holds max_window × rate × channels = 60 s × 2e\+04 Hz \(r\.csv\) × 2 = 2\.4e\+06 values; "
                   r"the limit is 2e\+06: give max_window \(and pre \+ post\) at most 49\.999 s")
    load_case(write_case(tmp_path, tmp_path / "r.csv", events={**events, "max_window": 49.999}))


def test_implausible_accelerations_are_flagged_per_channel(tmp_path: Path) -> None:
    """A pulse of 2000 g on car a's front (−0.8 × it on b's rear): each channel is flagged ``implausible`` over exactly
    the samples where its |a| > 1000 g (found here from the pulse's own formula), and the event carries both flags."""
    t = np.arange(0.0, SECONDS, 1.0 / RATE)
    height = 2.0 * PLAUSIBLE_ACCELERATION
    a = pulse(t, height=height)
    np.savetxt(tmp_path / "r.csv", np.column_stack([t, a / G, -0.8 * a / G]), delimiter=",", header="t,front,rear", comments="", fmt="%.17g")
    case = write_case(tmp_path, tmp_path / "r.csv")
    result = run(case, tmp_path / "out.h5")
    assert result.exit_code == 0, result.output
    flags = []
    for probe, scale in (("a/front", 1.0), ("b/rear", 0.8)):
        # |a| = scale · h · sin(π s) > bound for s in (arcsin(b / (scale h)) / π, 1 − that): the samples inside
        s_low = np.arcsin(PLAUSIBLE_ACCELERATION / (scale * height)) / np.pi
        s = (t - 1.0) / 0.1
        inside = t[(s > s_low) & (s < 1.0 - s_low)]
        flags.append(f"implausible: {probe} {inside[0]:.6g}–{inside[-1]:.6g} s")
    with h5py.File(tmp_path / "out.h5") as h5:
        assert set(flags) <= set(yaml.safe_load(h5["events/0"].attrs["flags"])), h5["events/0"].attrs["flags"]


def test_validation_reads_a_first_chunk_and_the_run_streams_the_file_once(tmp_path: Path, monkeypatch) -> None:
    """``femref run`` of a 3000-row record: validation (and the budget, for the rate of a time column) asks the file for
    one chunk of ``PROBE_SAMPLES`` rows; the run reads it once, chunk by chunk."""
    sizes: list[tuple[str, int]] = []
    real = recordings.open_columns

    def counting(path, requests, fmt="csv", options=None, size=record_files.CHUNK_SAMPLES):
        sizes.append((path.name, size))
        return real(path, requests, fmt, options, size=size)

    monkeypatch.setattr(recordings, "open_columns", counting)
    csv_record(tmp_path / "r.csv")
    assert run(write_case(tmp_path, tmp_path / "r.csv"), tmp_path / "out.h5").exit_code == 0
    probes, streamed = [s for s in sizes if s[1] == recordings.PROBE_SAMPLES], [s for s in sizes if s[1] != recordings.PROBE_SAMPLES]
    assert 1 <= len(probes) <= 2 and streamed == [("r.csv", record_files.CHUNK_SAMPLES)]


def test_numpy_and_row_by_row_readers_agree(tmp_path: Path) -> None:
    """An empty cell (a gap) sends a file to the row-by-row reader: it gives the numpy reader's values bit for bit
    everywhere else, NaN in the gap."""
    source = csv_record(tmp_path / "r.csv")
    holed = tmp_path / "h.csv"
    lines = source.read_text().splitlines()
    t, front, rear = lines[1001].split(",")
    lines[1001] = f"{t},,{rear}"
    holed.write_text("\n".join(lines) + "\n")
    channels = (recordings.ChannelSource("a/front", "front", None, "g"), recordings.ChannelSource("b/rear", "rear", None, "g"))
    clean, gap = (list(recordings.read_records([recordings.RecordFile(path, recordings.TimeSource(column="t"), 0.0, channels)]).channels.values())
                  for path in (source, holed))
    assert np.array_equal(clean[1].acceleration, gap[1].acceleration) and np.array_equal(clean[0].time, gap[0].time)
    expected = clean[0].acceleration.copy()
    expected[1000] = np.nan
    assert np.array_equal(gap[0].acceleration, expected, equal_nan=True)
    assert [q.reason for q in gap[0].quality] == ["gap"]


READ_PEAK = """
import sys, time
from pathlib import Path

def peak_kib():  # the process's own high-water mark (ru_maxrss keeps the forking parent's across exec)
    return next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:"))

from femref.sensing.recordings import ChannelSource, RecordFile, RecorderReader, TimeSource
folder = Path(sys.argv[1])
before = peak_kib()
start = time.perf_counter()
values = 0
for record in (
    RecordFile(folder / "hammer.csv", TimeSource(column="t"), 0.0, tuple(ChannelSource(f"hammer/{s}", s, None, "g") for s in ("center", "front"))),
    RecordFile(folder / "anvil.csv", TimeSource(column="t_ms", unit="ms"), 0.004, tuple(ChannelSource(f"anvil/{s}", s, None, "mm/s^2") for s in ("rear", "center", "front"))),
):
    for t, a in RecorderReader(record).chunks():
        values += a.size
seconds = time.perf_counter() - start
print(before // 1024, peak_kib() // 1024, round(seconds, 1), values)
"""


@pytest.mark.slow
def test_a_two_hour_stream_is_read_in_well_under_1_gb(tmp_path: Path) -> None:
    """Two recorders, five channels, two hours at 1 kHz (7.2e6 samples per channel, 0.46 GB of CSV) read in a subprocess
    as a measured run reads them, recorder by recorder a chunk at a time (femref.sensing.recordings.RecorderReader, with
    each chunk's quality): every value passes, and the peak resident memory (``VmHWM``, interpreter included) stays
    under 400 MiB, about what the arrays alone took when the files were held whole (7.2e6 × 7 × 8 bytes = 384 MiB; the
    whole-file reader peaked at 678 MiB, the row-by-row reader before it at 3.3 GB)."""
    import subprocess
    import sys

    samples = 2 * 3600 * 1000
    rng = np.random.default_rng(3)
    t = np.arange(samples) * 1e-3
    for name, header, scale in (("hammer.csv", "t,center,front", 1.0), ("anvil.csv", "t_ms,rear,center,front", 1e3)):
        columns = 3 if name == "hammer.csv" else 4
        with open(tmp_path / name, "w") as handle:
            handle.write(header + "\n")
            for rows in np.array_split(np.arange(samples), 36):
                block = np.column_stack([t[rows] * (1.0 if columns == 3 else 1e3), *(rng.normal(0.0, 0.01, (columns - 1, rows.size)) * scale)])
                np.savetxt(handle, block, delimiter=",", fmt=["%.3f" if columns == 3 else "%.0f"] + ["%.6g"] * (columns - 1))
    done = subprocess.run([sys.executable, "-c", READ_PEAK, str(tmp_path)], capture_output=True, text=True,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert done.returncode == 0, done.stderr
    before, peak, seconds, values = done.stdout.split()
    print(f"two-hour stream: {(tmp_path / 'hammer.csv').stat().st_size + (tmp_path / 'anvil.csv').stat().st_size} bytes of CSV, "
          f"read in {seconds} s, peak RSS {peak} MB ({before} MB before reading)")
    assert int(values) == 5 * samples
    assert int(peak) < 400
