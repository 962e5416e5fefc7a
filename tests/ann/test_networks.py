"""MLP and RBF networks on a synthetic problem with a known answer.

Problem: one-channel records a(t) = A sin²(π t / T) for t < T (zero after),
sampled at 1 kHz for 0.2 s, plus white noise of 0.01; A ~ U(1, 5), T ~ U(0.05,
0.15) s.  The target is the pulse amplitude A, a smooth function of the record
(its peak), so a working network must recover it on held-out samples.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

from ann.features import FeaturePipeline, FeatureSettings
from ann.networks import MLPForceRegressor, MomentumMLP, RBFNetwork
from ann.splits import split_indices

from support.ann_data import RATE, pulse_problem

TOLERANCE = 0.02  # mean relative error on held-out samples


@pytest.fixture(scope="module")
def features() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Train/test features of the pulse problem, scaler fitted on train only."""
    records, amplitude = pulse_problem()
    train, _, test = split_indices(len(amplitude), seed=0)
    pipeline = FeaturePipeline(FeatureSettings(length=16, rate=RATE, lowpass=100.0))
    pipeline.fit(records[train], RATE)
    return (
        pipeline.transform(records[train], RATE),
        amplitude[train],
        pipeline.transform(records[test], RATE),
        amplitude[test],
    )


def mean_relative_error(predicted: np.ndarray, exact: np.ndarray) -> float:
    return float(np.mean(np.abs(predicted - exact) / np.abs(exact)))


def test_mlp_recovers_amplitude(features):
    """Default MLP (200, 21), logistic, adam, early stopping: < 2 % on test (measured ~0.5 %)."""
    X_train, y_train, X_test, y_test = features
    net = MLPForceRegressor(seed=0).fit(X_train, y_train)
    assert net.converged_
    assert mean_relative_error(net.predict(X_test), y_test) < TOLERANCE


def test_mlp_numpy_forward_matches_sklearn(features):
    """The numpy forward pass reproduces sklearn's own prediction of the same weights."""
    from sklearn.neural_network import MLPRegressor

    X_train, y_train, X_test, _ = features
    with pytest.warns(ConvergenceWarning):
        net = MLPForceRegressor(hidden=(8,), activation="tanh", seed=3, max_iter=50).fit(X_train, y_train)
    reference = MLPRegressor(
        hidden_layer_sizes=(8,), activation="tanh", max_iter=50, random_state=3,
        early_stopping=True, validation_fraction=0.15, tol=1e-6, n_iter_no_change=30,
    )
    with pytest.warns(ConvergenceWarning):
        reference.fit(X_train, (y_train - net.target_mean_) / net.target_scale_)
    expected = reference.predict(X_test) * net.target_scale_ + net.target_mean_
    np.testing.assert_allclose(net.predict(X_test), expected, rtol=1e-12)


def test_mlp_reports_non_convergence(features):
    """A run cut short by max_iter says so: a ConvergenceWarning and converged_ False."""
    X_train, y_train, _, _ = features
    with pytest.warns(ConvergenceWarning, match="without converging"):
        net = MLPForceRegressor(hidden=(4,), early_stopping=False, max_iter=2, seed=0).fit(X_train, y_train)
    assert not net.converged_


def test_rbf_recovers_amplitude(features):
    """RBF, 40 k-means centres, multiquadric, width 4 × mean nearest-centre distance:
    < 2 % on test (measured ~0.7 %)."""
    X_train, y_train, X_test, y_test = features
    net = RBFNetwork(centres=40, basis="multiquadric", width_factor=4.0, seed=0).fit(X_train, y_train)
    assert mean_relative_error(net.predict(X_test), y_test) < TOLERANCE


def test_inverse_multiquadric_rbf_recovers_amplitude(features):
    """RBF with the inverse multiquadric basis φ(q) = 1/√(1 + q²), 40 centres, width factor 8
    (factor 4: 1.9 %, too close to the bound): < 2 % on test (measured 0.7 %)."""
    X_train, y_train, X_test, y_test = features
    net = RBFNetwork(centres=40, basis="inverse_multiquadric", width_factor=8.0, seed=0).fit(X_train, y_train)
    assert mean_relative_error(net.predict(X_test), y_test) < TOLERANCE


@pytest.mark.parametrize(
    ("activation", "tolerance"),
    [(("tanh", "tanh", "logistic"), 0.08), ("gaussian", 0.04), ("step", 0.15)],
    ids=["tanh-tanh-logistic", "gaussian", "step"],
)
def test_momentum_mlp_recovers_amplitude(features, activation, tolerance):
    """Back-propagation with momentum (η = 0.05, μ = 0.9, batches of 32, 500 epochs), 20-5 hidden
    units: the study's tanh/tanh/logistic layout (logistic output unit; measured 5.0 %), Gaussian
    units (1.7 %) and step units (a piecewise-constant fit, 9.9 %) learn the pulse amplitude."""
    X_train, y_train, X_test, y_test = features
    net = MomentumMLP(hidden=(20, 5), activation=activation, learning_rate=0.05, momentum=0.9, epochs=500, batch_size=32, tol=None, seed=0)
    net.fit(X_train, y_train)
    assert mean_relative_error(net.predict(X_test), y_test) < tolerance


@pytest.mark.parametrize("basis", ["gaussian", "multiquadric", "inverse_quadratic", "inverse_multiquadric"])
def test_rbf_interpolates_with_centres_at_data(basis):
    """With as many centres as distinct points and no ridge, least squares interpolates: y(x_i) = y_i."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-1.0, 1.0, (12, 2))
    y = np.sin(3 * X[:, 0]) + X[:, 1] ** 2
    net = RBFNetwork(centres=12, basis=basis, ridge=0.0, seed=0).fit(X, y)
    np.testing.assert_allclose(net.predict(X), y, atol=1e-8)


def test_rbf_fixed_width_and_reproducible(features):
    """A float width is used as given; the same seed gives the same network."""
    X_train, y_train, X_test, _ = features
    a = RBFNetwork(centres=10, width=3.0, seed=5).fit(X_train, y_train)
    b = RBFNetwork(centres=10, width=3.0, seed=5).fit(X_train, y_train)
    assert a.width_ == 3.0
    np.testing.assert_array_equal(a.predict(X_test), b.predict(X_test))


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: MLPForceRegressor(activation="softplus"), "activation must be one of"),
        (lambda: MLPForceRegressor(solver="newton"), "solver must be one of"),
        (lambda: MLPForceRegressor(hidden=()), "hidden must be"),
        (lambda: RBFNetwork(basis="cubic"), "basis must be one of"),
        (lambda: RBFNetwork(width="widest"), "width must be 'nearest'"),
        (lambda: RBFNetwork(width=-1.0), "width must be 'nearest'"),
        (lambda: RBFNetwork(centres=1), "centres must be"),
    ],
)
def test_bad_settings(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_predict_before_fit_and_bad_data():
    with pytest.raises(ValueError, match="before fit"):
        MLPForceRegressor().predict(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="before fit"):
        RBFNetwork().predict(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="NaN"):
        RBFNetwork(centres=2).fit(np.array([[0.0], [np.nan], [1.0]]), np.zeros(3))
    with pytest.raises(ValueError, match="fewer than"):
        RBFNetwork(centres=5).fit(np.zeros((3, 1)), np.zeros(3))


@pytest.mark.parametrize(
    "make",
    [
        lambda: RBFNetwork(centres=40, basis="gaussian", width_factor=4.0, ridge=1e-10, seed=0, log_target=True),
        lambda: MLPForceRegressor(hidden=(10,), activation="tanh", solver="lbfgs", alpha=1e-6, max_iter=3000, seed=0, log_target=True),
        lambda: MomentumMLP(hidden=(10,), activation="tanh", learning_rate=0.05, momentum=0.9, epochs=3000, tol=None, seed=0, log_target=True),
    ],
)
def test_log_target_learns_a_product_law(make):
    """``y = M · A`` over a decade of each: linear in logs, so a log-target network recovers it.

    The features are ``log M`` and ``log A`` (as the channel-peak pipeline gives them);
    held-out relative error under 1 %, and every prediction positive.
    """
    rng = np.random.default_rng(3)
    mass, amplitude = 10 ** rng.uniform(4.0, 5.0, 300), 10 ** rng.uniform(0.0, 1.0, 300)
    X, y = np.log(np.column_stack([mass, amplitude])), mass * amplitude
    X = (X - X[:200].mean(axis=0)) / X[:200].std(axis=0)
    net = make().fit(X[:200], y[:200])
    predicted = net.predict(X[200:])
    assert np.all(predicted > 0.0)
    assert mean_relative_error(predicted, y[200:]) < 0.01


def test_log_target_needs_positive_forces():
    X = np.random.default_rng(0).standard_normal((20, 2))
    for net in (RBFNetwork(centres=5, log_target=True), MLPForceRegressor(hidden=(3,), log_target=True)):
        with pytest.raises(ValueError, match="positive targets"):
            net.fit(X, np.linspace(-1.0, 1.0, 20))
