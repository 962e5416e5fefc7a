"""Feature pipeline: layout, scaler fitted on training data only, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from ann.features import FeaturePipeline, FeatureSettings

RATE = 500.0  # Hz


def records(n: int = 6, channels: int = 2, samples: int = 50, seed: int = 0, offset: float = 0.0) -> np.ndarray:
    return offset + np.random.default_rng(seed).standard_normal((n, channels, samples))


def test_feature_count_for_each_option():
    """Time samples C·L, plus C·(L//2+1) spectrum magnitudes, plus 1 peak when normalising."""
    x = records()
    for spectrum, normalise, count in [(False, "none", 2 * 8), (True, "none", 2 * 8 + 2 * 5), (True, "peak", 1 + 2 * 8 + 2 * 5)]:
        settings = FeatureSettings(length=8, rate=RATE, lowpass=100.0, spectrum=spectrum, normalise=normalise)
        assert FeaturePipeline(settings).fit_transform(x, RATE).shape == (6, count)


def test_training_features_are_standardised():
    f = FeaturePipeline(FeatureSettings(length=10, rate=RATE)).fit_transform(records(n=40), RATE)
    np.testing.assert_allclose(f.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(f.std(axis=0), 1.0, rtol=1e-12)


def test_scaler_uses_training_statistics_only():
    """Test records shifted by +3 keep the shift after transform: the scaler is not refitted.

    Exact answer: with no filtering and length = samples, the raw features are the
    samples themselves, so transform(test) = (test - mean_train) / std_train.
    """
    train, test = records(n=30, samples=12, seed=1), records(n=10, samples=12, seed=2, offset=3.0)
    pipeline = FeaturePipeline(FeatureSettings(length=12, rate=RATE)).fit(train, RATE)
    flat_train = train.reshape(30, -1)
    expected = (test.reshape(10, -1) - flat_train.mean(axis=0)) / flat_train.std(axis=0)
    np.testing.assert_allclose(pipeline.transform(test, RATE), expected, rtol=1e-12)
    assert pipeline.transform(test, RATE).mean() > 2.0


def test_peak_normalisation_separates_shape_and_amplitude():
    """Scaling a record by 2 doubles the peak feature and leaves the shape features unchanged."""
    x = records(n=1)
    pipeline = FeaturePipeline(FeatureSettings(length=8, rate=RATE, normalise="peak")).fit(np.concatenate([x, 2 * x]), RATE)
    raw = pipeline.transform(np.concatenate([x, 2 * x]), RATE) * pipeline.scale_ + pipeline.mean_
    np.testing.assert_allclose(raw[1, 0], 2 * raw[0, 0], rtol=1e-12)
    np.testing.assert_allclose(raw[1, 1:], raw[0, 1:], rtol=1e-12)


def test_linear_resampling_keeps_a_ramp():
    """A linear ramp resampled linearly is the same ramp on the coarser grid."""
    ramp = np.linspace(0.0, 1.0, 41)[None, None, :]
    settings = FeatureSettings(length=5, rate=RATE)
    pipeline = FeaturePipeline(settings).fit(np.concatenate([ramp, 2 * ramp]), RATE)
    raw = pipeline.transform(ramp, RATE) * pipeline.scale_ + pipeline.mean_
    np.testing.assert_allclose(raw[0], [0.0, 0.25, 0.5, 0.75, 1.0], atol=1e-12)


def fitted() -> FeaturePipeline:
    return FeaturePipeline(FeatureSettings(length=8, rate=RATE)).fit(records(), RATE)


def test_wrong_rate_is_rejected():
    with pytest.raises(ValueError, match=r"sampled at 1000.0 Hz but the pipeline expects 500.0 Hz"):
        fitted().transform(records(), 1000.0)
    with pytest.raises(ValueError, match="expects 500.0 Hz"):
        FeaturePipeline(FeatureSettings(length=8, rate=RATE)).fit(records(), 250.0)


def test_wrong_length_is_rejected():
    with pytest.raises(ValueError, match="records have 49 samples but the pipeline was fitted on 50"):
        fitted().transform(records(samples=49), RATE)
    with pytest.raises(ValueError, match="3 channels but the pipeline was fitted on 2"):
        fitted().transform(records(channels=3), RATE)
    with pytest.raises(ValueError, match=r"shape \(N, channels, samples\)"):
        fitted().transform(np.zeros((4, 50)), RATE)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_records_are_rejected(bad):
    x = records()
    x[2, 1, 7] = bad
    with pytest.raises(ValueError, match=r"NaN/inf values \(first at record 2, channel 1, sample 7\)"):
        fitted().transform(x, RATE)
    with pytest.raises(ValueError, match="NaN/inf"):
        FeaturePipeline(FeatureSettings(length=8, rate=RATE)).fit(x, RATE)


def test_transform_before_fit_is_rejected():
    with pytest.raises(ValueError, match="before fit"):
        FeaturePipeline(FeatureSettings(length=8, rate=RATE)).transform(records(), RATE)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"length": 1}, "length must be an integer >= 2"),
        ({"rate": 0.0}, "rate must be a positive"),
        ({"lowpass": 300.0}, r"lowpass must lie in \(0, rate/2 = 250\) Hz"),
        ({"normalise": "rms"}, "normalise must be one of"),
    ],
)
def test_bad_settings(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FeatureSettings(**{"length": 8, "rate": RATE, **kwargs})


def test_channel_peak_normalisation_gives_log_amplitudes():
    """Scaling channel 1 by 3 shifts its log-peak feature by log 3; shapes and channel 0 are unchanged."""
    x = records(n=1, channels=2, samples=8)
    scaled = x.copy()
    scaled[:, 1] *= 3.0
    pipeline = FeaturePipeline(FeatureSettings(length=8, rate=RATE, normalise="channel_peak")).fit(np.concatenate([x, scaled]), RATE)
    raw = pipeline.transform(np.concatenate([x, scaled]), RATE) * pipeline.scale_ + pipeline.mean_
    np.testing.assert_allclose(raw[0, :2], np.log(np.abs(x[0]).max(axis=1)), rtol=1e-12)
    np.testing.assert_allclose(raw[1, 1] - raw[0, 1], np.log(3.0), rtol=1e-12)
    np.testing.assert_allclose(raw[1, [0, *range(2, raw.shape[1])]], raw[0, [0, *range(2, raw.shape[1])]], atol=1e-12)
    np.testing.assert_allclose(np.abs(raw[0, 2:]).reshape(2, 8).max(axis=1), 1.0, rtol=1e-12)


def test_extras_enter_as_logarithms_after_the_records():
    x = records(n=3, channels=1, samples=6)
    masses = np.array([[1.0e5, 9.0e4], [1.2e5, 1.0e5], [8.0e4, 1.1e5]])
    settings = FeatureSettings(length=6, rate=RATE, extras=("car_mass/hammer", "car_mass/anvil"))
    pipeline = FeaturePipeline(settings).fit(x, RATE, masses)
    raw = pipeline.transform(x, RATE, masses) * pipeline.scale_ + pipeline.mean_
    np.testing.assert_allclose(raw[:, -2:], np.log(masses), rtol=1e-12)
    assert raw.shape == (3, 6 + 2)


@pytest.mark.parametrize(
    "extras, match",
    [
        (None, "needs the extras car_mass/a"),
        (np.ones((3, 2)), r"shape \(3, 1\)"),
        (np.array([[1.0], [0.0], [2.0]]), "finite and positive"),
        (np.array([[1.0], [np.nan], [2.0]]), "finite and positive"),
    ],
)
def test_bad_extras(extras, match):
    x = records(n=3, channels=1, samples=6)
    pipeline = FeaturePipeline(FeatureSettings(length=6, rate=RATE, extras=("car_mass/a",))).fit(x, RATE, np.ones((3, 1)))
    with pytest.raises(ValueError, match=match):
        pipeline.transform(x, RATE, extras)


def test_extras_refused_when_the_pipeline_takes_none():
    x = records(n=3, channels=1, samples=6)
    with pytest.raises(ValueError, match="takes none"):
        FeaturePipeline(FeatureSettings(length=6, rate=RATE)).fit(x, RATE, np.ones((3, 1)))
    with pytest.raises(ValueError, match="distinct non-empty names"):
        FeatureSettings(length=6, rate=RATE, extras=("m", "m"))
