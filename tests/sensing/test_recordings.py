"""Measured record files: units, clocks and rates, quality marks, and an error naming file, channel and rule for each bad file."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from femref.sensing.trigger import window
from support.measured import find_events
from femref.sensing.recordings import ChannelSource, RecordError, RecordFile, TimeSource, read_records

G = 9.80665


def pulse(t: np.ndarray, start: float, width: float = 0.1, height: float = 20.0) -> np.ndarray:
    """A half-sine acceleration pulse (m/s²) from ``start``."""
    s = (t - start) / width
    return np.where((s > 0) & (s < 1), height * np.sin(np.pi * np.clip(s, 0, 1)), 0.0)


def csv_file(path: Path, columns: dict[str, np.ndarray]) -> Path:
    np.savetxt(path, np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns), comments="")
    return path


def one(path: Path, *channels: ChannelSource, time: TimeSource | None = None, offset: float = 0.0) -> RecordFile:
    return RecordFile(path, time or TimeSource(column="t"), offset, channels)


def test_units_clocks_and_rates_are_read_into_si(tmp_path):
    """A CSV in g with a time column in ms, an HDF5 file in mm/s² at its own rate and clock: both give the
    pulse in m/s² at its absolute time (1e-12), each at its own rate."""
    t1 = np.arange(0, 2000) * 0.5  # ms, 2 kHz
    a = pulse(t1 * 1e-3, 0.4)
    csv_file(tmp_path / "a.csv", {"t": t1, "acc": a / G})
    t2 = np.arange(0, 1000) * 1e-3  # s, 1 kHz, clock 0.25 s behind
    with h5py.File(tmp_path / "b.h5", "w") as h5:
        h5["accel/rear"] = pulse(t2 + 0.25, 0.4) * 1e3
    recordings = read_records([
        one(tmp_path / "a.csv", ChannelSource("hammer/front", "acc", None, "g"), time=TimeSource(column="t", unit="ms")),
        RecordFile(tmp_path / "b.h5", TimeSource(rate=1000.0, start=0.0), 0.25, (ChannelSource("anvil/rear", None, "accel/rear", "mm/s^2"),)),
    ])
    front, rear = recordings.channels["hammer/front"], recordings.channels["anvil/rear"]
    np.testing.assert_allclose(front.acceleration, pulse(t1 * 1e-3, 0.4), rtol=0, atol=1e-12)
    np.testing.assert_allclose(rear.time, t2 + 0.25, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rear.acceleration, pulse(rear.time, 0.4), rtol=0, atol=1e-12)
    assert front.rate == pytest.approx(2000.0) and rear.rate == 1000.0
    assert front.quality == () and rear.quality == ()


@pytest.mark.parametrize(
    "columns, channel, time, match",
    [
        ({"t": [0, 1, 2], "a": [0, 1, 2]}, ChannelSource("c/s", "b", None, "g"), None, r"x\.csv: channel c/s \(column 'b'\): no such column \(columns: t, a\)"),
        ({"t": [0, 1, 2], "a": [0, 1, 2]}, ChannelSource("c/s", 5, None, "g"), None, r"channel c/s \(column 5\): no such column; the file has 2 columns"),
        ({"t": [0, 1, 2], "a": [0, 1, 2]}, ChannelSource("c/s", "a", None, "furlong/s^2"), None, r"channel c/s: unknown unit 'furlong/s\^2'; units: m/s\^2, g, mm/s\^2"),
        ({"t": [0, 1, 1, 2], "a": [0, 1, 2, 3]}, ChannelSource("c/s", "a", None, "g"), None, r"time must increase strictly; sample 3 \(t = 1 s\) is duplicated"),
        ({"t": [0, 2, 1, 3], "a": [0, 1, 2, 3]}, ChannelSource("c/s", "a", None, "g"), None, r"sample 3 \(t = 1 s\) goes back"),
        ({"t": [0, 1, 2], "a": [np.nan, np.nan, np.nan]}, ChannelSource("c/s", "a", None, "g"), None, r"channel c/s: no finite value"),
        ({"t": [0, np.nan, 2], "a": [0, 1, 2]}, ChannelSource("c/s", "a", None, "g"), None, r"time: sample 2 is not a finite number"),
        ({"t": [0, 1, 2], "a": [0, 1, 2]}, ChannelSource("c/s", "a", None, "g"), TimeSource(column="t", unit="min"), r"time: unknown unit 'min'"),
    ],
)
def test_a_bad_record_names_file_channel_and_rule(tmp_path, columns, channel, time, match):
    csv_file(tmp_path / "x.csv", {k: np.asarray(v, dtype=float) for k, v in columns.items()})
    with pytest.raises(RecordError, match=match):
        read_records([one(tmp_path / "x.csv", channel, time=time)])


def test_missing_files_text_cells_short_files_and_probes_recorded_twice(tmp_path):
    with pytest.raises(RecordError, match=r"nope\.csv: file not found"):
        read_records([one(tmp_path / "nope.csv", ChannelSource("c/s", "a", None, "g"))])
    (tmp_path / "x.csv").write_text("t,a\n0,1\n1,two\n2,3\n")
    with pytest.raises(RecordError, match=r"x\.csv: channel c/s \(column 'a'\): row 3 is not a number \('two'\)"):
        read_records([one(tmp_path / "x.csv", ChannelSource("c/s", "a", None, "g"))])
    (tmp_path / "y.csv").write_text("t,a\n0,1\n")
    with pytest.raises(RecordError, match=r"y\.csv: needs a header row and at least two rows of samples"):
        read_records([one(tmp_path / "y.csv", ChannelSource("c/s", "a", None, "g"))])
    csv_file(tmp_path / "z.csv", {"t": np.arange(3.0), "a": np.zeros(3)})
    with pytest.raises(RecordError, match=r"z\.csv: channel c/s: also recorded in z\.csv"):
        read_records([one(tmp_path / "z.csv", ChannelSource("c/s", "a", None, "g")), one(tmp_path / "z.csv", ChannelSource("c/s", "a", None, "g"))])
    with h5py.File(tmp_path / "w.h5", "w") as h5:
        h5["a"] = np.zeros((3, 2))
    with pytest.raises(RecordError, match=r"w\.h5: channel c/s \(dataset 'b'\): no such dataset"):
        read_records([RecordFile(tmp_path / "w.h5", TimeSource(rate=100.0), 0.0, (ChannelSource("c/s", None, "b", "g"),))])
    with pytest.raises(RecordError, match=r"must be one-dimensional, has shape \(3, 2\)"):
        read_records([RecordFile(tmp_path / "w.h5", TimeSource(rate=100.0), 0.0, (ChannelSource("c/s", None, "a", "g"),))])


def test_clipping_and_gaps_are_marked_not_refused(tmp_path):
    """A half-sine clipped at 80 % of its height is saturated over the clipped stretch; the unclipped one is
    not; a NaN run and a dropped stretch of samples are gaps."""
    t = np.arange(0, 1.0, 1e-3)
    a = pulse(t, 0.3)
    clipped = np.minimum(a, 16.0)
    holed = a.copy()
    holed[100:110] = np.nan
    keep = np.r_[0:500, 520:t.size]
    csv_file(tmp_path / "c.csv", {"t": t, "clean": a, "clipped": clipped, "holed": holed})
    csv_file(tmp_path / "d.csv", {"t": t[keep], "a": a[keep]})
    recordings = read_records([
        one(tmp_path / "c.csv", *(ChannelSource(f"car/{name}", name, None, "m/s^2") for name in ("clean", "clipped", "holed"))),
        one(tmp_path / "d.csv", ChannelSource("other/a", "a", None, "m/s^2")),
    ])
    assert recordings.channels["car/clean"].quality == ()
    (saturated,) = recordings.channels["car/clipped"].quality
    over = t[clipped >= 16.0]
    assert saturated.reason == "saturated" and saturated.start == pytest.approx(over[0]) and saturated.end == pytest.approx(over[-1])
    (gap,) = recordings.channels["car/holed"].quality
    assert gap.reason == "gap" and gap.start == pytest.approx(t[99]) and gap.end == pytest.approx(t[110])
    (dropped,) = recordings.channels["other/a"].quality
    assert dropped.reason == "gap" and dropped.start == pytest.approx(t[499]) and dropped.end == pytest.approx(t[520])


def test_a_stream_with_three_impacts_gives_three_events(tmp_path):
    """Pulses 2 s apart on one car, seen 5 ms later on the other (slower recorder, offset clock): three
    events, triggered within one sample of where the first channel crosses the level; a quiet stream none;
    an event over a clipped stretch is flagged; a window cut by the record's end is truncated, one longer than the
    impacts' spacing is cut short where the next event's window starts."""
    t = np.arange(0, 7.0, 5e-4)
    starts = (1.0, 3.0, 5.0)
    a = sum(pulse(t, s) for s in starts)
    t2 = np.arange(0, 7.0, 1e-3)
    b = sum(pulse(t2, s + 0.005) for s in starts)
    b = np.minimum(b, 18.0)  # the slower recorder clips
    csv_file(tmp_path / "a.csv", {"t": t, "a": a})
    csv_file(tmp_path / "b.csv", {"t": t2 - 0.01, "b": b})
    recordings = read_records([
        one(tmp_path / "a.csv", ChannelSource("hammer/x", "a", None, "m/s^2")),
        one(tmp_path / "b.csv", ChannelSource("anvil/y", "b", None, "m/s^2"), offset=0.01),
    ])
    events = find_events(recordings, trigger=5.0, pre=0.05, post=0.5)
    level_time = [s + 0.1 * np.arcsin(0.25) / np.pi for s in starts]  # 20 sin(π s/0.1) = 5
    assert [e.trigger_probe for e in events] == ["hammer/x"] * 3
    np.testing.assert_allclose([e.trigger_time for e in events], level_time, atol=5e-4)
    assert all(any(f.startswith("saturated: anvil/y") for f in e.flags) for e in events)
    assert find_events(recordings, trigger=25.0, pre=0.05, post=0.5) == []
    late = find_events(recordings, trigger=5.0, pre=0.05, post=3.0)  # windows longer than the impacts' spacing
    assert len(late) == 3 and "truncated" in late[2].flags and "truncated" not in late[0].flags
    assert [e.end for e in late[:2]] == pytest.approx([t - 0.05 for t in level_time[1:]], abs=5e-4)  # cut short at the next pre


def test_window_puts_two_rates_on_one_grid(tmp_path):
    t1, t2 = np.arange(0, 1.0, 5e-4), np.arange(0, 1.0, 2e-3)
    smooth = lambda t: np.sin(2 * np.pi * 3.0 * t)  # noqa: E731
    csv_file(tmp_path / "a.csv", {"t": t1, "a": 10 * smooth(t1)})
    csv_file(tmp_path / "b.csv", {"t": t2, "b": 10 * smooth(t2)})
    recordings = read_records([one(tmp_path / "a.csv", ChannelSource("p/a", "a", None, "m/s^2")), one(tmp_path / "b.csv", ChannelSource("q/b", "b", None, "m/s^2"))])
    (event,) = find_events(recordings, trigger=9.0, pre=0.05, post=0.9)
    t, records = window(recordings, event)
    assert np.allclose(np.diff(t), 5e-4) and t[0] == pytest.approx(event.start)
    np.testing.assert_allclose(records["p/a"], 10 * smooth(t), atol=1e-9)
    np.testing.assert_allclose(records["q/b"], 10 * smooth(t), atol=10 * (2 * np.pi * 3.0) ** 2 * 2e-3**2 / 8 * 1.01)
