"""benchmarks/synthetic/day.py: a 0.2 h day written in every format reads back the same through femref's readers, and
holds what its truth says.

The impacts here come from a closed form, not the fem library (that takes minutes): a rigid pair through a
Kelvin–Voigt coupler (:func:`support.synthetic.rigid_pair`). The records are then checked against that closed form at the reference times the truth's clocks give for each recorder's
ticks (``t = (c − offset)/(1 + drift)``): what remains is the recorders' noise and offsets, so the placement, the
clocks, the restart and the units are each checked by a second path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from femref.sensing.record_files import MAX_RECORD_SAMPLES, SampleLimit, format_of, key_of, read_columns
from support.synthetic import closed_form_library, day, rigid_pair, writers

HOURS = 0.2
LIMIT = SampleLimit(MAX_RECORD_SAMPLES, "the test's limit")


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("day")
    library = closed_form_library()
    return out, day.write_day(out, HOURS, writers.FORMATS, seed=3, library=library), library


def read_file(case: dict, recorder: int, path, fmt: str) -> list[np.ndarray]:
    """A file's time and channels through femref's record reader, as the day's case names them."""
    record = case["records"][recorder]
    key = key_of(format_of(path))
    requests = [(record["time"][key], "time")] + [(channel[key], f"channel {probe}") for probe, channel in record["channels"].items()]
    options = {k: record[k] for k in ("separator", "decimal") if k in record}
    columns, _ = read_columns(path, requests, LIMIT, fmt, options)
    return columns


def test_every_format_reads_back_the_csv_values(written):
    """Each file of each format equals the CSV file it was written beside: values bit for bit, times to 1e-9 s (UFF58
    stores a start and an increment)."""
    out, truth, _ = written
    cases = {fmt: day.case_data(fmt) for fmt in writers.FORMATS}
    for k, name in enumerate(truth["files"]["csv"]):
        recorder = 0 if name.startswith("r1") else 1
        reference = read_file(cases["csv"], recorder, out / "csv" / name, "csv")
        for fmt in writers.FORMATS[1:]:
            other = read_file(cases[fmt], recorder, out / fmt / truth["files"][fmt][k], fmt)
            np.testing.assert_allclose(other[0], reference[0], rtol=0, atol=1e-9)
            for mine, theirs in zip(other[1:], reference[1:]):
                np.testing.assert_array_equal(mine, theirs)


def recorder_records(out, truth: dict, name: str) -> tuple[np.ndarray, np.ndarray]:
    """A recorder's ticks (s of its clock) and channels (m/s², rows) from its CSV files in sequence."""
    case = day.case_data("csv")
    index = [r["recorder"] for r in case["records"]].index(name)
    files = [read_file(case, index, out / "csv" / f, "csv") for f in truth["files"]["csv"] if f.startswith(name)]
    scale = day.G if truth["recorders"][name]["unit"] == "g" else 1.0
    return np.concatenate([f[0] for f in files]), np.vstack([np.concatenate([f[1 + k] for f in files]) for k in range(len(files[0]) - 1)]) * scale


def test_the_truth_places_what_the_records_hold(written):
    """The records, mapped to the reference clock by the truth's clocks, are the closed-form impacts at the truth's
    contact times plus noise (std 0.05 m/s²) and an offset — away from the joints and bursts, which hold more."""
    out, truth, library = written
    impacts_ = truth["impacts"]
    assert len(impacts_) == math.ceil(day.IMPACTS_PER_HOUR * HOURS)
    times = np.array([i["time"] for i in impacts_])
    assert np.all(np.diff(times) >= 20.0) and times.min() > 0 and times.max() < truth["seconds"]
    assert {o["kind"] for o in truth["not_impacts"]} == {"track_joint", "noise_burst"}
    for name in ("r1", "r2"):
        ticks, channels = recorder_records(out, truth, name)
        t = np.full(ticks.size, np.nan)
        for clock in truth["clocks"][name]:
            c0, c1 = clock["offset"] + (1 + clock["drift_ppm"] * 1e-6) * np.array([clock["start"], clock["end"]])
            on = (ticks >= c0 - 1e-3) & (ticks <= c1 + 1e-3)
            t[on] = (ticks[on] - clock["offset"]) / (1 + clock["drift_ppm"] * 1e-6)
        assert not np.isnan(t).any(), f"{name}: ticks outside its clocks"
        expected = np.zeros_like(channels)
        by_name = {impact.spec.name: impact for impact in library}
        for impact in impacts_:
            closed = rigid_pair(t - impact["time"], impact["speed"], impact["type"] == "coupled")
            expected += np.array([closed[p] for p in truth["recorders"][name]["probes"]])
            assert impact["library"] in by_name
        probes = truth["recorders"][name]["probes"]
        for joint in (o for o in truth["not_impacts"] if o["kind"] == "track_joint"):
            occurrence = day.Occurrence("track_joint", joint["time"], {k: joint[k] for k in ("speed", "frequency", "amplitude")})
            expected += np.array([day.joint_acceleration(occurrence, p.split("/")[0], t) for p in probes])
        quiet = np.ones(t.size, bool)
        for burst in (o for o in truth["not_impacts"] if o["kind"] == "noise_burst" and o["recorder"] == name):
            during = (t >= burst["time"]) & (t < burst["time"] + burst["duration"])
            assert during.sum() >= 50
            np.testing.assert_allclose((channels - expected)[:, during].std(axis=1), burst["level"], rtol=0.35)
            quiet &= ~during
        residual = (channels - expected)[:, quiet]
        offsets = np.array(day.RECORDERS[0 if name == "r1" else 1].offsets) * (day.G if name == "r1" else 1.0)
        np.testing.assert_allclose(residual.mean(axis=1), offsets, atol=3e-3)
        np.testing.assert_allclose(residual.std(axis=1), day.NOISE, rtol=0.03)
    ticks, _ = recorder_records(out, truth, "r2")
    gap = np.flatnonzero(np.diff(ticks) > 0.0015)
    assert gap.size == 1  # the restart: one gap, its new file on a whole second of a clock set again
    restart = truth["restart"]
    second = truth["clocks"]["r2"][1]
    assert ticks[gap[0] + 1] == math.ceil(second["offset"] + (1 + second["drift_ppm"] * 1e-6) * restart["resume"])
    assert restart["gap"] == pytest.approx(restart["resume"] - restart["stop"]) and 50.0 <= restart["gap"] <= 70.0
