"""The report's pure helpers, on synthetic input with known answers: the robust y-range, the elastic
displacement, the path hiding and the grouping of score names."""

from pathlib import Path

import numpy as np
import pytest

from femref.report.field_map import elastic_displacement
from femref.report.figures import LIMIT_MARGIN, robust_limits
from femref.report.html import MetricName, hide_local_paths, item_columns, metric_columns


def test_a_brief_spike_does_not_set_the_range():
    """Reference 10 sin(2πt) on 400 samples; the other model follows it but spikes to +270 and −190 m/s² over
    3 samples. The range is the reference's 0.5–99.5 % quantiles (≈ ±10) widened by the margin: the spike is out."""
    t = np.linspace(0.0, 1.0, 400)
    reference = 10.0 * np.sin(2.0 * np.pi * t)
    spiking = reference.copy()
    spiking[5:8] = [270.0, -190.0, 120.0]
    lo, hi = robust_limits(reference, [spiking])
    q_lo, q_hi = np.quantile(reference, [0.005, 0.995])
    assert lo == pytest.approx(q_lo - LIMIT_MARGIN * (q_hi - q_lo))
    assert hi == pytest.approx(q_hi + LIMIT_MARGIN * (q_hi - q_lo))
    assert hi < 14.0 and lo > -14.0


def test_a_model_whose_bulk_differs_stays_inside():
    """A model at +50 throughout (its bulk, not a spike) widens the range to show it."""
    reference = np.sin(np.linspace(0.0, 6.0, 200))
    offset = reference + 50.0
    lo, hi = robust_limits(reference, [offset])
    assert lo < -0.9 and hi > np.quantile(offset, 0.95)


def test_no_reference_leaves_the_range_to_the_plot():
    assert robust_limits(None, [np.ones(3)]) is None
    assert robust_limits(np.array([np.nan]), []) is None
    lo, hi = robust_limits(np.zeros(10), [])  # a flat reference still gets a range around it
    assert lo < 0.0 < hi


def test_elastic_displacement_removes_the_rigid_translation():
    """u(x, t) = a(t) + b(t)·x on x ∈ [−8, 8] (uniform): the length-weighted mean is a(t), the elastic part b(t)·x."""
    x = np.linspace(-8.0, 8.0, 17)
    a = np.array([0.0, 0.01, 0.03])
    b = np.array([0.0, 1e-4, -2e-4])
    u = a[:, None] + b[:, None] * x[None, :]
    elastic, translation = elastic_displacement(x, u)
    assert translation == pytest.approx(a, abs=1e-15)
    assert elastic == pytest.approx(b[:, None] * x[None, :], abs=1e-15)


def test_elastic_displacement_rejects_a_field_that_does_not_fit():
    with pytest.raises(ValueError, match="expected"):
        elastic_displacement(np.arange(3.0), np.zeros((2, 4)))
    with pytest.raises(ValueError, match="no length"):
        elastic_displacement(np.zeros(2), np.zeros((2, 2)))


def test_local_paths_are_hidden():
    """Below the result folder a path is shown relative to it, elsewhere by its name; units stay as they are."""
    folder = Path("/srv/runs/yard")
    text = "network: /home/me/cases/networks/fem_mlp.npz\nrecords: {a: /srv/runs/yard/data/a.csv}\nviscosity: 2 N·s/m\n"
    assert hide_local_paths(text, folder) == "network: fem_mlp.npz\nrecords: {a: data/a.csv}\nviscosity: 2 N·s/m\n"


def test_score_names_are_grouped_by_item():
    """``<quantity>_<statistic>_error_<item>``: aggregates (item ``max``) in the summary, per-item errors grouped
    by coupler, then probe."""
    assert MetricName.parse("coupler_force_peak_time_error_c1") == MetricName("coupler_force_peak_time_error_c1", "coupler_force", "peak_time", "c1")
    assert MetricName.parse("measured_acceleration_rms_error_max").label() == "measured acceleration rms error (worst probe)"
    assert MetricName.parse("wall_time_s").label() == "wall time"
    scores = {
        "rigid": {
            "reference": "fem", "wall_time_s": 0.1, "speedup": 2.0, "undefined": "",
            "acceleration_rms_error_a/x": 0.1, "acceleration_peak_error_a/x": 0.2, "acceleration_rms_error_max": 0.1,
            "coupler_force_peak_error_c1": 0.01, "coupler_force_rms_error_c1": 0.02, "coupler_force_peak_error_max": 0.01,
            "measured_acceleration_rms_error_a/x": 0.3,
        }
    }
    assert metric_columns(scores) == ["reference", "wall_time_s", "speedup", "coupler_force_peak_error_max", "acceleration_rms_error_max"]
    assert item_columns(scores) == {
        "c1": ["coupler_force_peak_error_c1", "coupler_force_rms_error_c1"],
        "a/x": ["acceleration_peak_error_a/x", "acceleration_rms_error_a/x", "measured_acceleration_rms_error_a/x"],
    }


def test_the_self_check_is_a_sentence_not_score_columns():
    """A fem run that checked itself (femref.run.runner.check_reference keys): no reference_* or self_check column in
    the summary or per-item tables; one sentence with the warning, the runs, 'at least' for a lower bound and the
    estimate per coupler; the other models' scores are untouched; in-range scores are labelled as such."""
    from femref.report.html import _self_check_notes

    scores = {
        "fem": {"reference": "fem at dt/2, dt/4", "self_check": "fem at dt/2, dt/4", "reference_warning": "time.dt = 0.013 s is coarse",
                "reference_error_estimate": 0.379, "reference_error_basis": "c1: lower bound", "reference_error_bound": "lower",
                "reference_observed_order": -0.49, "reference_error_estimate_c1": 0.379, "reference_error_estimate_c2": 0.1,
                "reference_observed_order_c1": -0.49, "self_check_wall_time_s": 0.5, "wall_time_s": 0.5},
        "rigid": {"reference": "fem", "wall_time_s": 0.01, "coupler_force_peak_error_c1": 0.02, "coupler_force_peak_error_max": 0.02,
                  "acceleration_rms_in_range_error_max": 0.3},
    }
    columns = metric_columns(scores)
    assert columns == ["reference", "wall_time_s", "coupler_force_peak_error_max", "acceleration_rms_in_range_error_max"]
    assert item_columns(scores) == {"c1": ["coupler_force_peak_error_c1"]}
    (note,) = _self_check_notes(scores)
    assert "fem checked itself" in note and "time.dt = 0.013 s is coarse" in note and "at least 37.9 %" in note
    assert "c1 37.9 %, c2 10 %" in note and "0.5 s" in note
    assert MetricName.parse("acceleration_rms_in_range_error_max").label() == "acceleration rms error in range (worst probe)"
