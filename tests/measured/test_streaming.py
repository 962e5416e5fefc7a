"""Recordings streamed in bounded memory (femref.sensing.stream, .recordings, .clock): the same events and answers for
any chunking and any cutting into files, each event cut as from the records held whole, a recorder's clock drift
tracked from the impacts, memory flat in the stream's length, and an error deep in a file named where it is.

The streams are those of measured/streams.py: two recorders of two cars meeting in equal and opposite pulses.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.case import load_case
from femref.cli import main
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from femref.sensing import record_files
from femref.sensing.recordings import RecorderReader, read_records
from femref.sensing.stream import EventStream
from femref.sensing.trigger import TriggerSettings, window
from measured.streams import RATE, Restart, impact_times, write_stream


def _run(case: Path, chunk: int, monkeypatch) -> list:
    monkeypatch.setattr(record_files, "CHUNK_SAMPLES", chunk)
    return run_measured(scene_from_case(load_case(case))).events


def test_any_chunking_and_any_cutting_into_files_gives_the_same_events_records_and_answers(tmp_path, monkeypatch):
    """Ten minutes of ten impacts, in one file per recorder and in seven whose cuts fall 0.1 s after six of the
    contacts (inside the events' windows), read in chunks of 1000, 4096, 65 536 and 2^18 samples: the same windows,
    flags, records on the events' grids and peak forces, to the bit; ten events, each triggered within 30 ms of its
    contact."""
    impacts = impact_times(600.0, 10, seed=1)
    (tmp_path / "one").mkdir()
    (tmp_path / "seven").mkdir()
    one = write_stream(tmp_path / "one", 600.0, impacts, files=1)
    seven = write_stream(tmp_path / "seven", 600.0, impacts, cuts=list(impacts[1:7] + 0.1))
    assert len(list((tmp_path / "seven").glob("r1_*.h5"))) == 7
    runs = [_run(one.case, 1 << 18, monkeypatch), _run(seven.case, 1 << 18, monkeypatch), _run(one.case, 1000, monkeypatch),
            _run(seven.case, 4096, monkeypatch), _run(one.case, 65_536, monkeypatch)]
    reference = runs[0]
    assert len(reference) == 10
    np.testing.assert_allclose([e.trigger_time for e in reference], impacts, atol=0.03)
    for events in runs[1:]:
        assert [(e.start, e.end, e.trigger_time, e.flags) for e in events] == [(e.start, e.end, e.trigger_time, e.flags) for e in reference]
        for event, expected in zip(events, reference):
            assert np.array_equal(event.time, expected.time)
            assert all(np.array_equal(event.records[p], expected.records[p]) for p in expected.records)
            np.testing.assert_array_equal([e.peak for e in event.estimates], [e.peak for e in expected.estimates])


def test_each_event_is_cut_from_the_buffers_as_from_the_records_held_whole(tmp_path):
    """The stream's cut of every event (chunks of 4096 samples, seven files) against :func:`window` on the records
    read whole (the hand cut): the same samples, to the bit."""
    impacts = impact_times(300.0, 6, seed=2)
    stream = write_stream(tmp_path, 300.0, impacts, cuts=list(impacts + 0.1))
    scene = scene_from_case(load_case(stream.case))
    held = read_records(scene.records)
    cuts = list(EventStream([RecorderReader(r, 4096) for r in scene.records], TriggerSettings(3.0, 0.05, 0.5)))
    assert len(cuts) == 6
    for cut in cuts:
        t, records = window(held, cut.event)
        assert np.array_equal(t, cut.time) and all(np.array_equal(records[p], cut.records[p]) for p in records)


@pytest.fixture(scope="module")
def drifting(tmp_path_factory):
    """Two hours, 40 impacts; r2's clock 50 ppm fast, 12.3 ms ahead, restarted at 3600.15 s (0.15 s after an impact's
    contact, within its ringing) for 30 s, and back 0.25 s behind the line it ran on."""
    folder = tmp_path_factory.mktemp("drift")
    impacts = impact_times(7200.0, 40, seed=3)
    impacts[np.argmin(abs(impacts - 3600.0))] = 3600.0
    restart = Restart(3600.15, 30.0, 0.0123 - 0.25)
    stream = write_stream(folder, 7200.0, impacts, drift=50.0, offset=0.0123, restart=restart, estimate=True)
    outcome = run_measured(scene_from_case(load_case(stream.case)))
    return stream, outcome


def test_a_drifting_clock_is_tracked_from_the_impacts(drifting):
    """Every impact found once (40 events, none phantom, none missed); each event cut with r2's correction within one
    sample of the truth; the drift, once two lags of a segment are in, within 2 ppm of 50 ppm; each event's own lag
    within a sample of the truth too."""
    stream, outcome = drifting
    events = outcome.events
    assert len(events) == len(stream.impacts)
    np.testing.assert_allclose([e.trigger_time for e in events], stream.impacts, atol=0.35)
    for event in events:
        (clock,) = event.clock_corrections
        tau = event.trigger_time - clock.correction
        assert abs(clock.correction - stream.correction(tau)) < 1.0 / RATE, (event.index, clock)
        assert abs(clock.lag - stream.correction(tau)) < 1.0 / RATE, (event.index, clock)
    segments = [[e for e in events if e.trigger_time < 3600.5], [e for e in events if e.trigger_time > 3600.5]]
    for segment in segments:
        assert all(abs(e.clock_corrections[0].drift - 50.0) < 2.0 for e in segment[1:]), [e.clock_corrections[0].drift for e in segment]


def test_the_events_over_a_logger_restart_are_flagged(drifting):
    """The impact whose ringing the restart cuts is flagged with r2's gap on each of its channels; no other event is."""
    _, outcome = drifting
    flagged = [e for e in outcome.events if any(f.startswith("gap: b/") for f in e.flags)]
    assert [round(e.trigger_time) for e in flagged] == [3600]
    assert {f.split()[1] for f in flagged[0].flags if f.startswith("gap:")} == {"b/rear", "b/center", "b/front"}
    assert outcome.stream is not None and outcome.stream.gaps == 1 and outcome.stream.files == 3  # r1 in one file, r2 in two (the restart)


MEMORY = """
import sys
from pathlib import Path
from femref.case import load_case
from femref.events import event_file
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
scene = scene_from_case(load_case(Path(sys.argv[1])))
with event_file(Path(sys.argv[2]), {}) as write:
    outcome = run_measured(scene, sink=write)
peak = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:"))
print(len(outcome.events), peak // 1024)
"""


@pytest.mark.parametrize("lengths", [(0.25, 1.0), pytest.param((0.5, 2.0), marks=pytest.mark.slow)], ids=["quarter-to-1h", "half-to-2h"])
def test_memory_does_not_grow_with_the_streams_length(tmp_path, lengths):
    """The same stream (an impact every 3 min, drift estimated) over 0.25 h and 1 h (0.5 h and 2 h: slow), each run in
    a fresh process writing its event file: the peak resident memory (VmHWM) differs by less than 50 MB. Records held
    whole would differ by ~150 MB over the 0.75 h between the quick pair (7 columns of the two recorders × 1 kHz × 8 bytes)."""
    peaks = []
    for hours in lengths:
        folder = tmp_path / f"{hours}h"
        folder.mkdir()
        duration = hours * 3600.0
        stream = write_stream(folder, duration, impact_times(duration, int(duration / 180), seed=4), files=int(hours * 2), drift=50.0,
                              estimate=True)
        done = subprocess.run([sys.executable, "-c", MEMORY, str(stream.case), str(folder / "out.h5")], capture_output=True, text=True,
                              check=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
        count, peak = map(int, done.stdout.split())
        assert count == int(duration / 180)
        peaks.append(peak)
    assert abs(peaks[1] - peaks[0]) < 50, peaks


def test_a_record_error_deep_in_the_fifth_of_seven_files_names_it_and_writes_nothing(tmp_path):
    """Seven CSV files per recorder; in r1's fifth, the time of sample 6001 (beyond what validation reads) goes back to
    sample 5999's: ``femref run`` exits 2 naming the file, the sample and the rule, and writes nothing."""
    stream = write_stream(tmp_path, 70.0, impact_times(70.0, 1, seed=5), files=7, fmt="csv")
    path = tmp_path / "r1_04.csv"
    lines = path.read_text().splitlines()
    lines[6001] = lines[5999].split(",", 1)[0] + "," + lines[6001].split(",", 1)[1]
    path.write_text("\n".join(lines) + "\n")
    result = CliRunner().invoke(main, ["run", str(stream.case), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 2, result.output
    assert "r1_04.csv: time must increase strictly; sample 6001 (t = " in result.output and "goes back" in result.output, result.output
    assert not (tmp_path / "out.h5").exists() and not list(tmp_path.glob(".out.h5*"))


def test_each_events_clock_is_in_the_event_file_the_table_and_the_report(drifting, tmp_path):
    """The clock of each event (correction, drift, lag, residual) written to its group ``clock/r2`` as computed, named
    in the console table's notes and in the report."""
    import h5py
    from rich.console import Console

    from femref.cli.tables import event_table
    from support.measured import write_events

    _, outcome = drifting
    path = write_events(tmp_path / "events.h5", {"cars": ["a", "b"], "couplers": ["c1"], "estimators": ["inverse_rigid"]}, outcome.events[:3])
    with h5py.File(path) as h5:
        for event in outcome.events[:3]:
            attrs = h5[f"events/{event.index}/clock/r2"].attrs
            (clock,) = event.clock_corrections
            assert [attrs[k] for k in ("correction", "drift", "lag", "residual")] == [clock.correction, clock.drift, clock.lag, clock.residual]
    console = Console(width=400, record=True)
    console.print(event_table(outcome))
    assert console.export_text().count("clock r2: correction ") == len(outcome.events)
    result = CliRunner().invoke(main, ["report", str(path), "-o", str(tmp_path / "report.html")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "report.html").read_text().count("clock r2: correction ") == 3


@pytest.mark.parametrize(("change", "where", "rule"), [
    (lambda r: r[0].update(files=["nothing_*.h5"]), r"records\.0\.files\.0", "the glob matches no file"),
    (lambda r: r[0].update(file="r1_00.h5"), r"records\.0\.file", "give exactly one of file"),
    (lambda r: r[0].update(clock_drift="estimate"), r"records\.0\.clock_drift", "the first recorder is the reference"),
    (lambda r: r[1].update(recorder="r1"), r"records\.1\.recorder", "records[0] has the same name"),
])
def test_a_recorders_files_and_clock_keys_are_checked(tmp_path, change, where, rule):
    """A glob matching nothing, ``file`` beside ``files``, the reference recorder's clock estimated, two recorders of
    one name: exit 2 naming the key and the rule."""
    stream = write_stream(tmp_path, 60.0, impact_times(60.0, 1, seed=6))
    data = yaml.safe_load(stream.case.read_text())
    change(data["records"])
    stream.case.write_text(yaml.safe_dump(data, sort_keys=False))
    result = CliRunner().invoke(main, ["run", str(stream.case), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 2, result.output
    assert rule in result.output and re.search(where, result.output.replace("[", ".").replace("]", "")), result.output
