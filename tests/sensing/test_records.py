"""Fixed-length records (femref.sensing.records) and the study's error summary, on known answers."""

from __future__ import annotations

import numpy as np
import pytest

from femref.sensing.records import fixed_length_records, record_rate, record_times
from femref.study.run import error_summary


def test_record_times_and_rate():
    """``t_k = k·end/(length − 1)``; rate ``(length − 1)/end``."""
    np.testing.assert_allclose(record_times(5, 0.4), [0.0, 0.1, 0.2, 0.3, 0.4], rtol=0, atol=1e-15)
    assert record_rate(201, 0.5) == pytest.approx(400.0, rel=1e-15)


def test_records_interpolate_linear_histories_exactly_in_probe_order():
    """A linear history is reproduced exactly at the record times; channels follow ``probes``;
    a history ending before ``end`` is held at its last value."""
    t = np.linspace(0.0, 0.5, 51)
    histories = {"a/x": 2.0 * t + 1.0, "b/y": -3.0 * t}
    records = fixed_length_records(t, histories, ["b/y", "a/x"], 6, 0.5)
    grid = record_times(6, 0.5)
    np.testing.assert_allclose(records, [-3.0 * grid, 2.0 * grid + 1.0], atol=1e-14)
    short = fixed_length_records(t[:41], {"a/x": histories["a/x"][:41]}, ["a/x"], 6, 0.5)
    assert short[0, -1] == pytest.approx(2.0 * t[40] + 1.0)


@pytest.mark.parametrize(
    ("histories", "probes", "match"),
    [
        ({"a/x": np.zeros(3)}, ["a/z"], "no acceleration history for probe 'a/z'"),
        ({"a/x": np.zeros(2)}, ["a/x"], r"shape \(2,\), expected \(3,\)"),
        ({"a/x": np.array([0.0, np.nan, 1.0])}, ["a/x"], "non-finite"),
    ],
)
def test_bad_histories(histories, probes, match):
    with pytest.raises(ValueError, match=match):
        fixed_length_records(np.array([0.0, 0.1, 0.2]), histories, probes, 4, 0.2)


def test_error_summary_known_values():
    """Errors 0.1, −0.2, 0.3, 0 of a unit reference: mean |e| 0.15, bias 0.05, p95 by linear interpolation 0.285."""
    summary = error_summary(np.array([1.1, 0.8, 1.3, 1.0]) * 2.0, np.full(4, 2.0))
    assert (summary.mean, summary.bias, summary.samples) == (pytest.approx(0.15), pytest.approx(0.05), 4)
    assert summary.p95 == pytest.approx(0.285)
    with pytest.raises(ValueError, match="matching non-empty"):
        error_summary(np.ones(2), np.ones(3))
