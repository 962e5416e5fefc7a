"""Save/load of pipeline + network as plain arrays: round trip, no pickle, versioning."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning
from support.ann_data import RATE, pulse_problem

import ann.storage as storage
from ann.features import FeaturePipeline, FeatureSettings
from ann.networks import MLPForceRegressor, MomentumMLP, RBFNetwork
from ann.splits import split_indices


@pytest.fixture(scope="module")
def trained():
    """Pipeline (spectrum + peak normalisation + low-pass, to exercise every setting) and small networks."""
    records, amplitude = pulse_problem(n=200, seed=2)
    train, _, test = split_indices(len(amplitude), seed=1)
    settings = FeatureSettings(length=16, rate=RATE, lowpass=120.0, spectrum=True, normalise="peak")
    pipeline = FeaturePipeline(settings).fit(records[train], RATE)
    X = pipeline.transform(records[train], RATE)
    with pytest.warns(ConvergenceWarning):  # a short run is enough to test storage
        mlp = MLPForceRegressor(hidden=(20, 5), activation="relu", seed=0, max_iter=50).fit(X, amplitude[train])
    rbf = RBFNetwork(centres=15, basis="gaussian", seed=0).fit(X, amplitude[train])
    momentum = MomentumMLP(hidden=(12, 4), activation=("step", "gaussian", "logistic"), batch_size=16, epochs=20, tol=None, seed=0, log_target=True)
    momentum.fit(X, amplitude[train])
    return pipeline, {"mlp": mlp, "rbf": rbf, "momentum_mlp": momentum}, records[test]


@pytest.mark.parametrize("kind", ["mlp", "rbf", "momentum_mlp"])
def test_round_trip_gives_identical_predictions(tmp_path, trained, kind):
    pipeline, networks, records = trained
    network = networks[kind]
    path = tmp_path / f"{kind}.npz"
    metadata = {"units": {"force": "N"}, "trained_on": "synthetic sin² pulses", "seed": 0}
    storage.save(path, pipeline, network, metadata)

    before = storage.Estimator(pipeline, network).predict(records, RATE)
    estimator, loaded_metadata = storage.load_estimator(path)
    np.testing.assert_allclose(estimator.predict(records, RATE), before, rtol=1e-12)
    assert loaded_metadata == metadata
    assert estimator.pipeline.settings == pipeline.settings
    assert type(estimator.network) is type(network)
    if kind != "rbf":
        np.testing.assert_array_equal(estimator.network.loss_curve_, network.loss_curve_)


def test_loss_curve_is_stored_per_epoch(tmp_path, trained):
    """Both MLPs save their loss per epoch (``network/loss_curve``), one value per iteration."""
    pipeline, networks, _ = trained
    for kind in ("mlp", "momentum_mlp"):
        storage.save(tmp_path / f"{kind}.npz", pipeline, networks[kind], {})
        with np.load(tmp_path / f"{kind}.npz", allow_pickle=False) as data:
            assert data["network_kind"] == kind
            assert data["network/loss_curve"].shape == (networks[kind].n_iter_,)
            assert np.all(np.isfinite(data["network/loss_curve"]))


def test_a_file_without_a_loss_curve_still_loads(tmp_path, trained):
    """Files written before the loss curve was stored load with an empty one."""
    pipeline, networks, records = trained
    path = tmp_path / "old.npz"
    storage.save(path, pipeline, networks["mlp"], {})
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files if key != "network/loss_curve"}
    np.savez(path, **arrays)
    _, network, _ = storage.load(path)
    assert network.loss_curve_.size == 0


def test_file_holds_plain_arrays_only(tmp_path, trained):
    """Every entry loads with allow_pickle=False and none is an object array or sklearn state."""
    pipeline, networks, _ = trained
    path = tmp_path / "mlp.npz"
    storage.save(path, pipeline, networks["mlp"], {})
    with np.load(path, allow_pickle=False) as data:
        assert all(data[key].dtype != object for key in data.files)
        assert int(data["format_version"]) == storage.FORMAT_VERSION
        assert {"network/coef_0", "network/intercept_2", "pipeline/mean"} <= set(data.files)
    _, network, _ = storage.load(path)
    assert not any("sklearn" in type(v).__module__ for v in vars(network).values())


def test_loaded_estimator_still_validates_input(tmp_path, trained):
    pipeline, networks, records = trained
    path = tmp_path / "rbf.npz"
    storage.save(path, pipeline, networks["rbf"], {})
    estimator, _ = storage.load_estimator(path)
    with pytest.raises(ValueError, match="expects 1000.0 Hz"):
        estimator.predict(records, 2000.0)
    with pytest.raises(ValueError, match="samples but the pipeline was fitted on 200"):
        estimator.predict(records[:, :, :-1], RATE)


def test_other_format_version_is_rejected(tmp_path, trained):
    pipeline, networks, _ = trained
    path = tmp_path / "old.npz"
    storage.save(path, pipeline, networks["rbf"], {})
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    arrays["format_version"] = np.array(storage.FORMAT_VERSION + 1)
    np.savez(path, **arrays)
    expected = f"format version {storage.FORMAT_VERSION + 1}, but this code reads version {storage.FORMAT_VERSION}"
    with pytest.raises(ValueError, match=expected):
        storage.load(path)


def test_not_a_model_file_and_bad_metadata(tmp_path, trained):
    path = tmp_path / "other.npz"
    np.savez(path, x=np.zeros(3))
    with pytest.raises(ValueError, match="not an ann model file"):
        storage.load(path)
    pipeline, networks, _ = trained
    with pytest.raises(ValueError, match="JSON-serialisable"):
        storage.save(tmp_path / "m.npz", pipeline, networks["rbf"], {"array": np.zeros(2)})


def test_round_trip_keeps_extras_and_log_target(tmp_path):
    """A pipeline with car-mass extras and a log-target network predict the same after a load."""
    records, amplitude = pulse_problem(n=60, seed=4)
    masses = np.random.default_rng(0).uniform(8e4, 1.2e5, (60, 2))
    settings = FeatureSettings(length=16, rate=RATE, normalise="channel_peak", extras=("car_mass/a", "car_mass/b"))
    pipeline = FeaturePipeline(settings).fit(records, RATE, masses)
    network = RBFNetwork(centres=10, seed=0, log_target=True).fit(pipeline.transform(records, RATE, masses), amplitude * masses[:, 1])
    storage.save(tmp_path / "net.npz", pipeline, network, {})
    estimator, _ = storage.load_estimator(tmp_path / "net.npz")
    assert estimator.pipeline.settings.extras == ("car_mass/a", "car_mass/b")
    assert estimator.network.log_target
    np.testing.assert_allclose(estimator.predict(records, RATE, masses), storage.Estimator(pipeline, network).predict(records, RATE, masses), rtol=1e-12)
    with pytest.raises(ValueError, match="needs the extras"):
        estimator.predict(records, RATE)
