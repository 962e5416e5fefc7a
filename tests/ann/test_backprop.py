"""Back-propagation with momentum (ann.backprop, ann.networks.MomentumMLP) on problems with known answers.

* the analytic gradient against central differences, for every unit with an exact slope and
  for a network with a different unit per layer;
* the step unit's surrogate gradient against its defining formula, and a step network
  learning a jump;
* a linear network trained by momentum gradient descent against the least-squares solution;
* the momentum recurrence Δw(k+1) = −η ∂E/∂w + μ Δw(k), in the kernel and in the trainer;
* continuing from a saved network against training without a break.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning

import ann.storage as storage
from ann.backprop import UNITS, initial_weights, layer_units, loss_and_gradient, momentum_step
from ann.features import FeaturePipeline, FeatureSettings
from ann.networks import MLPForceRegressor, MomentumMLP

from support.ann_data import RATE, pulse_problem

EXACT_UNITS = [name for name, unit in UNITS.items() if unit.exact]


def central_difference_gradient(coefs, intercepts, units, X, T, alpha, h=1e-6):
    """∂E/∂w_i ≈ (E(w + h e_i) − E(w − h e_i)) / 2h for every weight and bias."""
    params = coefs + intercepts
    layers = len(coefs)
    gradient = []
    for p in params:
        g = np.empty_like(p)
        for index in np.ndindex(p.shape):
            saved = p[index]
            p[index] = saved + h
            plus = loss_and_gradient(params[:layers], params[layers:], units, X, T, alpha)[0]
            p[index] = saved - h
            minus = loss_and_gradient(params[:layers], params[layers:], units, X, T, alpha)[0]
            p[index] = saved
            g[index] = (plus - minus) / (2.0 * h)
        gradient.append(g)
    return gradient


def small_problem(layer_sizes, seed=0):
    rng = np.random.default_rng(seed)
    coefs, intercepts = initial_weights(layer_sizes, rng)
    X = rng.standard_normal((7, layer_sizes[0]))
    T = rng.standard_normal((7, layer_sizes[-1]))
    return coefs, intercepts, X, T


@pytest.mark.parametrize(
    "names",
    [(name, name, "linear") for name in EXACT_UNITS] + [("tanh", "gaussian", "logistic"), ("relu", "linear", "tanh")],
    ids=lambda names: "-".join(names),
)
def test_backprop_gradient_matches_central_differences(names):
    """A 3-4-3-2 network, L2 penalty α = 0.1: the back-propagated ∂E/∂w equals the central
    difference quotient (h = 1e-6; its own error ~1e-10) to 1e-6 of the largest component."""
    units = [UNITS[n] for n in names]
    coefs, intercepts, X, T = small_problem((3, 4, 3, 2))
    _, grad_coefs, grad_intercepts = loss_and_gradient(coefs, intercepts, units, X, T, alpha=0.1)
    numeric = central_difference_gradient(coefs, intercepts, units, X, T, alpha=0.1)
    analytic = np.concatenate([g.ravel() for g in grad_coefs + grad_intercepts])
    numeric = np.concatenate([g.ravel() for g in numeric])
    assert np.max(np.abs(analytic - numeric)) <= 1e-6 * np.max(np.abs(numeric))


def test_step_unit_backpropagates_the_logistic_slope():
    """Step hidden layer, linear output: the forward pass is H(z) exactly and the gradient is the
    straight-through one, ∂E/∂W_1 = Xᵀ[(δ W_2ᵀ) ⊙ σ(z)(1 − σ(z))], δ = (ŷ − t)/(N m)."""
    coefs, intercepts, X, T = small_problem((3, 5, 2), seed=4)
    _, grad_coefs, grad_intercepts = loss_and_gradient(coefs, intercepts, [UNITS["step"], UNITS["linear"]], X, T, alpha=0.0)
    z = X @ coefs[0] + intercepts[0]
    h = (z >= 0.0).astype(float)
    delta = (h @ coefs[1] + intercepts[1] - T) / T.size
    sigma = 1.0 / (1.0 + np.exp(-z))
    hidden_delta = (delta @ coefs[1].T) * sigma * (1.0 - sigma)
    np.testing.assert_allclose(grad_coefs[1], h.T @ delta, rtol=1e-12)
    np.testing.assert_allclose(grad_coefs[0], X.T @ hidden_delta, rtol=1e-12)
    np.testing.assert_allclose(grad_intercepts[0], hidden_delta.sum(axis=0), rtol=1e-12)


def test_step_network_learns_a_jump():
    """y = 1 + H(x − 0.3) on 200 points of [−1, 1], eight step units: no unit's jump x = −b/w starts
    between the two training points that bracket 0.3; the surrogate gradient moves one there (a
    fixed first layer could not fit the data), and the training loss falls by ten orders."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-1.0, 1.0, (200, 1))
    below, above = x[x < 0.3].max(), x[x >= 0.3].min()
    net = MomentumMLP(hidden=(8,), activation="step", learning_rate=0.1, momentum=0.9, epochs=2000, tol=None, seed=0)
    coefs, intercepts = initial_weights((1, 8, 1), np.random.default_rng(net.seed))
    net.fit(x, 1.0 + (x[:, 0] >= 0.3))

    def jumps_in_gap(W, b):
        jumps = -b / W[0]
        return int(np.sum((jumps > below) & (jumps <= above)))

    assert jumps_in_gap(coefs[0], intercepts[0]) == 0
    assert jumps_in_gap(net.coefs_[0], net.intercepts_[0]) >= 1
    assert net.loss_curve_[-1] < 1e-10 * net.loss_curve_[0]


def test_linear_network_converges_to_least_squares():
    """A 3-4-1 network of linear units is the affine map x W_1 W_2 + (b_1 W_2 + b_2); momentum
    gradient descent on the squared loss (α = 0) converges to the least-squares fit of
    y = 1.5 x_1 − 2 x_2 + 0.5 x_3 + 3 + noise (numpy lstsq) to 1e-6 of its coefficients."""
    rng = np.random.default_rng(0)
    X = rng.standard_normal((60, 3))
    y = X @ np.array([1.5, -2.0, 0.5]) + 3.0 + 0.1 * rng.standard_normal(60)
    solution, *_ = np.linalg.lstsq(np.column_stack([X, np.ones(60)]), y, rcond=None)
    net = MomentumMLP(hidden=(4,), activation="linear", learning_rate=0.05, momentum=0.9, epochs=600, tol=None, seed=0).fit(X, y)
    W1, W2 = net.coefs_
    b1, b2 = net.intercepts_
    effective = np.concatenate([(W1 @ W2)[:, 0] * net.target_scale_, (b1 @ W2 + b2) * net.target_scale_ + net.target_offset_])
    assert np.max(np.abs(effective - solution)) <= 1e-6 * np.max(np.abs(solution))


def test_momentum_step_is_the_recurrence():
    """One step: Δw(k+1) = −η g + μ Δw(k) and w(k+1) = w(k) + Δw(k+1), array by array."""
    rng = np.random.default_rng(1)
    w, g, previous = (list(rng.standard_normal((3, 2, 4))) for _ in range(3))
    new_w, new_step = momentum_step(w, g, previous, learning_rate=0.3, momentum=0.7)
    for k in range(3):
        np.testing.assert_allclose(new_step[k], -0.3 * g[k] + 0.7 * previous[k], rtol=1e-15)
        np.testing.assert_allclose(new_w[k], w[k] + new_step[k], rtol=1e-15)


@pytest.mark.parametrize("momentum", [0.0, 0.8])
def test_trainer_updates_obey_the_recurrence(momentum):
    """Full batch, two epochs from the seeded initial weights w0:
    w1 = w0 − η ∇E(w0) (Δw(0) = 0) and w2 = w1 − η ∇E(w1) + μ (w1 − w0); with μ = 0 plain
    gradient descent."""
    rng = np.random.default_rng(2)
    X, y = rng.standard_normal((30, 4)), rng.standard_normal(30)
    settings = dict(hidden=(5, 3), activation=("tanh", "gaussian"), learning_rate=0.2, momentum=momentum, tol=None, alpha=0.01, seed=7)
    one = MomentumMLP(epochs=1, **settings).fit(X, y)
    two = MomentumMLP(epochs=2, **settings).fit(X, y)
    units = [UNITS[n] for n in one.units]
    T = ((y - one.target_offset_) / one.target_scale_)[:, None]
    w0 = sum(initial_weights((4, 5, 3, 1), np.random.default_rng(7)), [])

    def gradient(w):
        _, gc, gb = loss_and_gradient(w[:3], w[3:], units, X, T, alpha=0.01)
        return gc + gb

    w1, w2 = one.coefs_ + one.intercepts_, two.coefs_ + two.intercepts_
    for a, b, g in zip(w1, w0, gradient(w0)):
        np.testing.assert_allclose(a, b - 0.2 * g, rtol=1e-12, atol=1e-15)
    for c, a, b, g in zip(w2, w1, w0, gradient(w1)):
        np.testing.assert_allclose(c, a - 0.2 * g + momentum * (a - b), rtol=1e-12, atol=1e-15)
    assert two.loss_curve_.size == 2 and two.loss_curve_[0] == one.loss_curve_[0]


def test_continuing_from_a_saved_network_is_training_without_a_break(tmp_path):
    """60 + 60 epochs across a save and a load (ann.storage, with its feature pipeline) give the
    weights and loss curve of 120 epochs in one run, mini-batches and momentum included; the
    resumed loss starts where the first run stopped and goes on falling."""
    records, amplitude = pulse_problem(n=120, seed=3)
    pipeline = FeaturePipeline(FeatureSettings(length=16, rate=RATE, lowpass=100.0)).fit(records, RATE)
    X = pipeline.transform(records, RATE)
    settings = dict(hidden=(12, 4), activation=("tanh", "tanh", "logistic"), learning_rate=0.05, momentum=0.9, batch_size=32, tol=None, seed=3, log_target=True)
    whole = MomentumMLP(epochs=120, **settings).fit(X, amplitude)
    first = MomentumMLP(epochs=60, **settings).fit(X, amplitude)
    storage.save(tmp_path / "first.npz", pipeline, first, {})
    loaded_pipeline, loaded, _ = storage.load(tmp_path / "first.npz")
    resumed = MomentumMLP(epochs=60, **settings).continue_from(loaded)
    resumed.fit(loaded_pipeline.transform(records, RATE), amplitude)
    in_memory = MomentumMLP(epochs=60, **settings).continue_from(first).fit(X, amplitude)
    for net in (resumed, in_memory):
        assert net.n_iter_ == 120
        np.testing.assert_array_equal(net.loss_curve_, whole.loss_curve_)
        for a, b in zip(net.coefs_ + net.intercepts_, whole.coefs_ + whole.intercepts_):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(resumed.predict(X), whole.predict(X))
    assert resumed.loss_curve_[60] < 0.5 * resumed.loss_curve_[0]  # not a fresh start
    assert resumed.loss_curve_[-1] < resumed.loss_curve_[59]  # still going down


def test_warm_start_continues_in_place():
    """``warm_start``: a second ``fit`` goes on from the first one's weights (epochs add up)."""
    rng = np.random.default_rng(5)
    X, y = rng.standard_normal((40, 3)), rng.standard_normal(40)
    settings = dict(hidden=(6,), activation="tanh", learning_rate=0.05, tol=None, seed=1)
    twice = MomentumMLP(epochs=20, warm_start=True, **settings)
    twice.fit(X, y).fit(X, y)
    once = MomentumMLP(epochs=40, **settings).fit(X, y)
    assert twice.n_iter_ == 40
    np.testing.assert_array_equal(twice.loss_curve_, once.loss_curve_)


def test_continuing_refuses_another_layout():
    rng = np.random.default_rng(6)
    X, y = rng.standard_normal((20, 3)), rng.uniform(1.0, 2.0, 20)
    trained = MomentumMLP(hidden=(6, 2), activation="tanh", epochs=5, tol=None).fit(X, y)
    for other in (
        MomentumMLP(hidden=(6,), activation="tanh"),
        MomentumMLP(hidden=(6, 2), activation=("tanh", "logistic")),
        MomentumMLP(hidden=(6, 2), activation="tanh", log_target=True),
    ):
        with pytest.raises(ValueError, match="cannot continue from a network with hidden layers"):
            other.continue_from(trained)
    with pytest.raises(ValueError, match="unfitted"):
        MomentumMLP(hidden=(6, 2)).continue_from(MomentumMLP(hidden=(6, 2)))
    with pytest.raises(ValueError, match="on 4 features"):
        MomentumMLP(hidden=(6, 2), activation="tanh", epochs=1).continue_from(trained).fit(rng.standard_normal((20, 4)), y)


def test_momentum_continues_a_scikit_learn_network():
    """An lbfgs-trained MLPForceRegressor handed to the momentum trainer predicts the same before
    training, and momentum training from there lowers its loss (first epoch's loss = lbfgs's end)."""
    rng = np.random.default_rng(8)
    X = rng.standard_normal((80, 3))
    y = np.sin(X[:, 0]) + X[:, 1] * X[:, 2]
    sk = MLPForceRegressor(hidden=(10,), activation="tanh", solver="lbfgs", alpha=1e-4, max_iter=30, seed=0)
    with pytest.warns(ConvergenceWarning):
        sk.fit(X, y)
    assert sk.loss_curve_.size == 0  # lbfgs records no loss per epoch
    net = MomentumMLP(hidden=(10,), activation="tanh", learning_rate=0.05, momentum=0.9, alpha=1e-4, epochs=200, tol=None).continue_from(sk)
    np.testing.assert_allclose(net.predict(X), sk.predict(X), rtol=1e-12)
    net.fit(X, y)
    assert net.loss_curve_[-1] < 0.9 * net.loss_curve_[0]


def test_bounded_output_unit_keeps_predictions_in_range():
    """A logistic output unit maps the training targets onto the middle 80 % of (0, 1): no input,
    however far out, predicts beyond min − span/8 or max + span/8 of the training targets."""
    rng = np.random.default_rng(9)
    X = rng.uniform(-1.0, 1.0, (50, 2))
    y = 10.0 + 5.0 * X[:, 0] + X[:, 1] ** 2
    net = MomentumMLP(hidden=(8,), activation=("tanh", "logistic"), learning_rate=0.1, epochs=300, tol=None).fit(X, y)
    far = 1e3 * rng.standard_normal((200, 2))
    span = y.max() - y.min()
    predicted = net.predict(far)
    assert np.all(predicted >= y.min() - span / 8 - 1e-9) and np.all(predicted <= y.max() + span / 8 + 1e-9)


def test_non_convergence_and_divergence_are_reported():
    rng = np.random.default_rng(10)
    X, y = rng.standard_normal((30, 2)), rng.standard_normal(30)
    with pytest.warns(ConvergenceWarning, match="without its loss settling"):
        net = MomentumMLP(hidden=(4,), epochs=3, tol=1e-12).fit(X, y)
    assert not net.converged_
    with pytest.raises(ValueError, match="diverged at epoch"):
        MomentumMLP(hidden=(4,), activation="linear", learning_rate=50.0, epochs=500, tol=None).fit(X, y)


@pytest.mark.parametrize(
    ("hidden", "activation", "expected"),
    [
        ((70, 5), "tanh", ("tanh", "tanh", "linear")),
        ((70, 5), ["tanh", "step"], ("tanh", "step", "linear")),
        ((70, 5), ["tanh", "tanh", "logistic"], ("tanh", "tanh", "logistic")),
    ],
)
def test_layer_units(hidden, activation, expected):
    assert layer_units(hidden, activation) == expected


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: MomentumMLP(hidden=(3, 2), activation="softplus"), "activation must be one of"),
        (lambda: MomentumMLP(hidden=(3, 2), activation=["tanh"] * 4), r"needs one name, or 2 \(one per hidden layer\), or 3"),
        (lambda: MomentumMLP(hidden=(3,), activation=["tanh", "relu"]), "output unit must be one of"),
        (lambda: MomentumMLP(momentum=1.0), "momentum must lie in"),
        (lambda: MomentumMLP(learning_rate=0.0), "learning_rate must be positive"),
        (lambda: MomentumMLP(batch_size=0), "batch_size must be"),
        (lambda: MomentumMLP(seed=-1), "seed must be"),
    ],
)
def test_bad_settings(make, match):
    with pytest.raises(ValueError, match=match):
        make()
