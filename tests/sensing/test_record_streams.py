"""A recorder's files read as one stream (femref.sensing.recordings.RecorderReader) and its channels' quality chunk by
chunk (femref.sensing.quality): against the whole-array rules, against the same samples in one file, and the errors
a sequence of files can hold."""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from femref.sensing.quality import GAP_STEP, PLAUSIBLE_ACCELERATION, SATURATED_RUN, QualityInterval, QualityTracker
from femref.sensing.recordings import ChannelSource, RecordError, RecordFile, TimeSource, expand_files, probe_recorder, read_records


def whole_file_quality(time: np.ndarray, a: np.ndarray) -> list[QualityInterval]:
    """The rules on a whole array, as written before the stream (an independent implementation): NaN runs from the
    sample before to the sample after, steps over 1.5 median steps, runs of 3+ samples at the extreme, runs beyond
    1000 g."""
    def runs(mask: np.ndarray) -> list[tuple[int, int]]:
        edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
        return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))

    found = [QualityInterval(float(time[max(f - 1, 0)]), float(time[min(last + 1, time.size - 1)]), "gap") for f, last in runs(~np.isfinite(a))]
    steps = np.diff(time)
    found += [QualityInterval(float(time[k]), float(time[k + 1]), "gap") for k in np.flatnonzero(steps > GAP_STEP * np.median(steps))]
    magnitude = np.abs(a)
    extreme = np.nanmax(magnitude)
    found += [QualityInterval(float(time[f]), float(time[last]), "saturated") for f, last in runs(magnitude == extreme) if last - f + 1 >= SATURATED_RUN]
    found += [QualityInterval(float(time[f]), float(time[last]), "implausible") for f, last in runs(magnitude > PLAUSIBLE_ACCELERATION)]
    return sorted(found, key=lambda q: (q.start, q.reason))


def test_quality_chunk_by_chunk_is_the_whole_array_rule():
    """A channel with NaN runs (one at each end), dropped samples, clipped stretches at its extreme (a run of 2, too
    short; runs of 3 and 40), a lower flat top and implausible samples, fed in one chunk and in 40 random cuttings
    (1–700 samples, runs split across chunks): the stretches of the whole-array rule, exactly."""
    rng = np.random.default_rng(7)
    keep = np.r_[0:3000, 3004:6000]  # four samples dropped: a long step
    time = (np.arange(6000) * 1e-3)[keep]
    a = rng.normal(0.0, 1.0, time.size)
    a[:5] = a[-3:] = np.nan
    a[100:130] = np.nan
    a[500:502] = 25.0  # two samples at the extreme: not saturated
    a[800:803] = -25.0
    a[2990:3030] = 25.0  # across the dropped samples
    a[4000:4010] = 20.0  # a flat top below the extreme
    a[5000:5004] = 2.0 * PLAUSIBLE_ACCELERATION * np.sign(rng.normal(size=4))
    a[5000:5004] = np.abs(a[5000:5004])
    expected = whole_file_quality(time, a)
    assert {q.reason for q in expected} == {"gap", "saturated", "implausible"}
    step = float(np.median(np.diff(time)))
    for cutting in range(41):
        tracker = QualityTracker(1)
        if cutting == 0:
            cuts: list[int] = []
        else:
            cuts = list(np.cumsum(np.exp(rng.uniform(0.0, np.log(700.0), size=time.size)).astype(int) + 1))
        for piece in np.split(np.arange(time.size), [c for c in cuts if c < time.size]):
            tracker.feed(time[piece], a[None, piece], step)
        tracker.finish()
        assert sorted(tracker.intervals(0), key=lambda q: (q.start, q.reason)) == expected, cutting


def test_the_running_extreme_drops_the_runs_below_a_larger_value():
    """Saturated runs at 10 m/s², then a larger value: the runs are dropped, those at the new extreme kept."""
    time = np.arange(100) * 1e-3
    a = np.zeros(100)
    a[10:15] = 10.0
    tracker = QualityTracker(1)
    tracker.feed(time[:50], a[None, :50], 1e-3)
    assert [q.reason for q in tracker.intervals(0)] == ["saturated"]
    a[60:64] = -12.0
    tracker.feed(time[50:], a[None, 50:], 1e-3)
    tracker.finish()
    assert tracker.intervals(0) == [QualityInterval(time[60], time[63], "saturated")]


def csv(path: Path, t: np.ndarray, a: np.ndarray, header: str = "t,a") -> Path:
    np.savetxt(path, np.column_stack([t, a]), delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def recorder(*paths: Path, time: TimeSource | None = None, drift: float | str = 0.0) -> RecordFile:
    return RecordFile(paths[0], time or TimeSource(column="t"), 0.0, (ChannelSource("c/s", "a", None, "m/s^2"),), files=tuple(paths), clock_drift=drift)


def test_files_in_sequence_read_as_the_one_file_they_were_cut_from(tmp_path):
    """A stream cut into five CSV files (a glob, sorted by name) reads as the one file: the same times, samples and
    quality (the NaN run across a cut one gap), read in chunks of 333 samples; with a rate, files are contiguous."""
    rng = np.random.default_rng(1)
    t = np.arange(5000) * 1e-3
    a = rng.normal(size=t.size)
    a[1995:2010] = np.nan
    csv(tmp_path / "whole.csv", t, a)
    for k, piece in enumerate(np.split(np.arange(t.size), [1000, 2000, 3000, 4000])):
        csv(tmp_path / f"part_{k}.csv", t[piece], a[piece])
    parts = expand_files(["part_*.csv"], tmp_path)
    assert [p.name for p in parts] == [f"part_{k}.csv" for k in range(5)]
    whole = read_records([recorder(tmp_path / "whole.csv")]).channels["c/s"]
    cut = read_records([recorder(*parts)], chunk=333).channels["c/s"]
    assert np.array_equal(whole.time, cut.time) and np.array_equal(whole.acceleration, cut.acceleration, equal_nan=True)
    assert whole.quality == cut.quality and [q.reason for q in cut.quality] == ["gap"] and whole.rate == cut.rate
    rated = read_records([recorder(*parts, time=TimeSource(rate=1000.0, start=2.0))]).channels["c/s"]
    np.testing.assert_array_equal(rated.time, 2.0 + np.arange(5000) / 1000.0)


def test_a_gap_between_files_is_a_gap_and_time_going_back_names_both_files(tmp_path):
    """A logger restart (2 s missing between two files) is a gap of every channel; a second file that starts before
    the first ends is refused naming both."""
    t = np.arange(1000) * 1e-3
    first, second = csv(tmp_path / "a.csv", t, np.zeros(1000)), csv(tmp_path / "b.csv", t + 3.0, np.zeros(1000))
    channel = read_records([recorder(first, second)]).channels["c/s"]
    assert [(q.start, q.end, q.reason) for q in channel.quality] == [(0.999, 3.0, "gap")]
    csv(tmp_path / "b.csv", t + 0.5, np.zeros(1000))
    with pytest.raises(RecordError, match=r"b\.csv: time goes back from file a\.csv to file b\.csv: its first sample t = 0\.5 s is not after the last of a\.csv"):
        read_records([recorder(first, second)])


def test_a_declared_drift_is_removed_and_iso_stamps_count_from_the_first_file(tmp_path):
    """``clock_drift: 100`` ppm: the times less 1e-4 × (t − t_first); ISO-8601 stamps in two files: seconds from the
    first file's first stamp; the probe reads the rate and span from the files' starts."""
    t = 10.0 + np.arange(2000) * 1e-3
    csv(tmp_path / "r.csv", t, np.zeros(2000))
    drifted = read_records([recorder(tmp_path / "r.csv", drift=100.0)]).channels["c/s"]
    np.testing.assert_allclose(drifted.time, t - 1e-4 * (t - 10.0), rtol=0, atol=1e-12)
    start = datetime(2026, 11, 27, 23, 59, 59)
    for k in range(2):
        stamps = [(start + timedelta(milliseconds=1000 * k + m)).isoformat(timespec="milliseconds") for m in range(1000)]
        (tmp_path / f"iso_{k}.csv").write_text("t,a\n" + "".join(f"{s},0.0\n" for s in stamps))
    iso = recorder(*expand_files(["iso_*.csv"], tmp_path), time=TimeSource(column="t", unit="iso8601"))
    np.testing.assert_allclose(read_records([iso]).channels["c/s"].time, np.arange(2000) * 1e-3, rtol=0, atol=1e-9)
    head = probe_recorder(iso)
    assert head.rate == pytest.approx(1000.0) and head.first_time == 0.0 and head.last_time == pytest.approx(1.999)
