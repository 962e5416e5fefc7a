"""Small regression networks mapping feature vectors to coupler force.

Both networks follow the estimator contract ``fit(X, y)`` / ``predict(X)`` with
explicit seeds, and both predict with plain numpy from arrays that
``ann.storage`` can save without pickle:

* ``MLPForceRegressor`` — a multilayer perceptron trained by scikit-learn's
  ``MLPRegressor`` on a standardised target ``(y - mean) / std``; prediction is
  the numpy forward pass ``h_{l+1} = g(h_l W_l + b_l)`` (identity on the last
  layer) followed by ``y = std * h + mean``.
* ``MomentumMLP`` — a multilayer perceptron with a unit of its own per layer
  (logistic, tanh, relu, linear, Gaussian, step; :mod:`ann.backprop`), trained
  here by back-propagation with momentum ``Δw(k+1) = −η ∂E/∂w + μ Δw(k)``, the
  source study's rule; it keeps its loss per epoch and can continue training
  from a saved network.
* ``RBFNetwork`` — ``y(x) = sum_j w_j phi(||x - c_j|| / width) + w_0`` with
  centres ``c_j`` from k-means and the weights from ridge-regularised least
  squares.

Both take ``log_target``: fit ``log y`` and predict ``exp`` of the output. Peak
forces span an order of magnitude over yard speeds and car masses; in logs the
relative error is what the squared loss weighs (``Δ log P ≈ ΔP/P``), the
prediction is always positive, and ``log P = log M + log A`` is linear in the
log-amplitude features of :mod:`ann.features`.

scikit-learn is needed only to train ``MLPForceRegressor`` and ``RBFNetwork``: it is the
optional extra ``train`` (``pip install 'femref[train]'``) and is imported inside their
``fit``; importing this module, loading a saved network and predicting use numpy and scipy
only, and ``MomentumMLP`` trains without it. Training without it raises
:class:`TrainingDependencyError` (an ``ImportError``) naming the extra.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Sequence
from typing import Any, Callable

import numpy as np
from scipy import linalg
from scipy.spatial.distance import cdist

from ann.backprop import UNITS, forward, initial_weights, layer_units, loss_and_gradient, momentum_step

ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "logistic": lambda z: 0.5 * (1.0 + np.tanh(0.5 * z)),  # = 1/(1+e^-z), overflow-free
    "relu": lambda z: np.maximum(z, 0.0),
    "tanh": np.tanh,
}
SOLVERS = ("sgd", "adam", "lbfgs")

# phi(q) with q = r / width.
BASES: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "gaussian": lambda q: np.exp(-(q**2)),
    "multiquadric": lambda q: np.sqrt(1.0 + q**2),
    "inverse_quadratic": lambda q: 1.0 / (1.0 + q**2),
    "inverse_multiquadric": lambda q: 1.0 / np.sqrt(1.0 + q**2),
}


#: The optional extra that installs scikit-learn, the trainer of ``MLPForceRegressor`` and ``RBFNetwork``.
TRAIN_EXTRA = "train"


class TrainingDependencyError(ImportError):
    """Training asked for without scikit-learn installed: the message names the network and the extra
    ``femref[train]``; prediction from a saved network needs no scikit-learn."""


class NetworkConvergenceWarning(UserWarning):
    """A training run stopped before its tolerance was met, where scikit-learn (and its ``ConvergenceWarning``) is
    not installed; with scikit-learn, scikit-learn's ``ConvergenceWarning`` is raised (:func:`convergence_warning`)."""


def _training_import(network: str, module: str, name: str) -> Any:
    """``module.name`` from scikit-learn, for training ``network``; :class:`TrainingDependencyError` when it is missing."""
    try:
        return getattr(importlib.import_module(module), name)
    except ImportError as error:
        raise TrainingDependencyError(
            f"training a {network} needs scikit-learn, an optional extra of femref: pip install 'femref[{TRAIN_EXTRA}]' "
            f"(loading a saved network and predicting with it do not need it; {error})"
        ) from error


def convergence_warning() -> type[Warning]:
    """The category of "stopped before converging" warnings: scikit-learn's ``ConvergenceWarning`` when scikit-learn is
    installed (so filters written for scikit-learn also catch ``MomentumMLP``'s), else :class:`NetworkConvergenceWarning`.
    Called only on a training path (it imports scikit-learn)."""
    try:
        from sklearn.exceptions import ConvergenceWarning
    except ImportError:
        return NetworkConvergenceWarning
    return ConvergenceWarning


def _check_xy(X: np.ndarray, y: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    X = np.asarray(X, dtype=float)
    if X.ndim != 2:
        raise ValueError(f"X must have shape (N, features), got {X.shape}")
    if not np.isfinite(X).all():
        raise ValueError("X contains NaN/inf values")
    if y is None:
        return X, None
    y = np.asarray(y, dtype=float)
    if y.ndim not in (1, 2) or y.shape[0] != X.shape[0]:
        raise ValueError(f"y must have shape (N,) or (N, outputs) with N = {X.shape[0]}, got {y.shape}")
    if not np.isfinite(y).all():
        raise ValueError("y contains NaN/inf values")
    return X, y


def _target_in(y: np.ndarray, log_target: bool) -> np.ndarray:
    """The training target: ``y`` or ``log y`` (then ``y`` must be positive)."""
    if not log_target:
        return y
    if np.any(y <= 0.0):
        raise ValueError("log_target needs positive targets (peak compression forces > 0)")
    return np.log(y)


def _target_out(z: np.ndarray, log_target: bool) -> np.ndarray:
    return np.exp(z) if log_target else z


class MLPForceRegressor:
    """Multilayer perceptron for force regression (scikit-learn training, numpy prediction).

    After ``fit``: ``coefs_``, ``intercepts_`` (the layer weights), ``target_mean_``,
    ``target_scale_``, ``n_iter_``, ``loss_curve_`` (scikit-learn's training loss per
    epoch for ``sgd`` and ``adam``; empty for ``lbfgs``, which records none), and
    ``converged_`` — False when training
    stopped at ``max_iter`` without meeting its tolerance; a
    ``ConvergenceWarning`` is then also raised, so a short run never passes
    unnoticed.

    ``tol`` and ``n_iter_no_change`` are tighter than scikit-learn's defaults
    (1e-4, 10): on a synthetic sin² pulse problem those stopped the default
    (200, 21) logistic network at ~4.5 % mean error, these reach ~0.5 %.
    With ``early_stopping`` the weights of the best validation epoch are kept.

    Solvers: ``"sgd"`` (back-propagation with ``momentum``, the source study's
    rule), ``"adam"`` (adaptive), ``"lbfgs"`` (quasi-Newton on the full batch:
    on a few thousand samples it converges in a few hundred iterations, where the
    stochastic solvers wander; it has no early stopping, so ``alpha`` does the
    regularising).
    """

    kind = "mlp"

    def __init__(
        self,
        hidden: tuple[int, ...] = (200, 21),
        activation: str = "logistic",
        solver: str = "adam",
        momentum: float = 0.9,
        learning_rate: float = 1e-3,
        early_stopping: bool = True,
        validation_fraction: float = 0.15,
        max_iter: int = 2000,
        seed: int | None = 0,
        alpha: float = 1e-4,
        tol: float = 1e-6,
        n_iter_no_change: int = 30,
        log_target: bool = False,
    ) -> None:
        if activation not in ACTIVATIONS:
            raise ValueError(f"activation must be one of {tuple(ACTIVATIONS)}, got {activation!r}")
        if solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
        if not hidden or any(int(h) != h or h < 1 for h in hidden):
            raise ValueError(f"hidden must be a non-empty tuple of positive layer sizes, got {hidden!r}")
        self.hidden = tuple(int(h) for h in hidden)
        self.activation = activation
        self.solver = solver
        self.momentum = momentum
        self.learning_rate = learning_rate
        self.early_stopping = early_stopping
        self.validation_fraction = validation_fraction
        self.max_iter = max_iter
        self.seed = seed
        self.alpha = alpha
        self.tol = tol
        self.n_iter_no_change = n_iter_no_change
        self.log_target = log_target
        self.coefs_: list[np.ndarray] | None = None
        self.intercepts_: list[np.ndarray] | None = None
        self.target_mean_: np.ndarray | None = None
        self.target_scale_: np.ndarray | None = None
        self.n_iter_: int = 0
        self.converged_: bool = False
        self.loss_curve_: np.ndarray = np.empty(0)

    def fit(self, X: np.ndarray, y: np.ndarray) -> MLPForceRegressor:
        """Train on features ``X (N, features)`` and forces ``y (N,)`` or ``(N, outputs)`` (scikit-learn's ``MLPRegressor``:
        :class:`TrainingDependencyError` without the extra ``femref[train]``)."""
        MLPRegressor = _training_import("MLPForceRegressor", "sklearn.neural_network", "MLPRegressor")
        ConvergenceWarning = _training_import("MLPForceRegressor", "sklearn.exceptions", "ConvergenceWarning")
        X, y = _check_xy(X, y)
        y = _target_in(y, self.log_target)
        self.target_mean_ = y.mean(axis=0)
        std = y.std(axis=0)
        self.target_scale_ = np.where(std > 0, std, 1.0)
        model = MLPRegressor(
            hidden_layer_sizes=self.hidden,
            activation=self.activation,
            solver=self.solver,
            momentum=self.momentum,
            learning_rate_init=self.learning_rate,
            early_stopping=self.early_stopping,
            validation_fraction=self.validation_fraction,
            max_iter=self.max_iter,
            alpha=self.alpha,
            tol=self.tol,
            n_iter_no_change=self.n_iter_no_change,
            random_state=self.seed,
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            model.fit(X, (y - self.target_mean_) / self.target_scale_)
        self.converged_ = not any(issubclass(w.category, ConvergenceWarning) for w in caught)
        self.n_iter_ = int(model.n_iter_)
        self.loss_curve_ = np.asarray(getattr(model, "loss_curve_", ()), dtype=float)  # lbfgs keeps none
        self.coefs_ = [np.array(c) for c in model.coefs_]
        self.intercepts_ = [np.array(b) for b in model.intercepts_]
        if not self.converged_:
            warnings.warn(
                f"MLPForceRegressor stopped at max_iter={self.max_iter} without converging "
                f"({self.n_iter_} iterations); check converged_ before trusting it",
                ConvergenceWarning,
                stacklevel=2,
            )
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Forces for features ``X``: the numpy forward pass of the stored weights."""
        if self.coefs_ is None:
            raise ValueError("MLPForceRegressor.predict called before fit")
        X, _ = _check_xy(X)
        if X.shape[1] != self.coefs_[0].shape[0]:
            raise ValueError(f"X has {X.shape[1]} features but the network expects {self.coefs_[0].shape[0]}")
        g = ACTIVATIONS[self.activation]
        h = X
        for W, b in zip(self.coefs_[:-1], self.intercepts_[:-1]):
            h = g(h @ W + b)
        out = h @ self.coefs_[-1] + self.intercepts_[-1]
        if np.ndim(self.target_mean_) == 0:
            out = out[:, 0]
        return _target_out(out * self.target_scale_ + self.target_mean_, self.log_target)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Weights and target scaling as plain arrays (no sklearn object)."""
        if self.coefs_ is None:
            raise ValueError("cannot store an unfitted MLPForceRegressor")
        arrays: dict[str, np.ndarray] = {
            "activation": np.array(self.activation),
            "layers": np.array(len(self.coefs_), dtype=np.int64),
            "target_mean": np.asarray(self.target_mean_),
            "target_scale": np.asarray(self.target_scale_),
            "n_iter": np.array(self.n_iter_, dtype=np.int64),
            "converged": np.array(self.converged_, dtype=bool),
            "log_target": np.array(self.log_target, dtype=bool),
            "loss_curve": np.asarray(self.loss_curve_, dtype=float),
        }
        for i, (W, b) in enumerate(zip(self.coefs_, self.intercepts_)):
            arrays[f"coef_{i}"] = W
            arrays[f"intercept_{i}"] = b
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> MLPForceRegressor:
        """Rebuild a trained network from ``to_arrays`` output."""
        layers = int(arrays["layers"])
        coefs = [np.asarray(arrays[f"coef_{i}"], dtype=float) for i in range(layers)]
        net = cls(
            hidden=tuple(W.shape[1] for W in coefs[:-1]) or (1,),
            activation=str(arrays["activation"]),
            log_target=bool(arrays.get("log_target", False)),
        )
        net.coefs_ = coefs
        net.intercepts_ = [np.asarray(arrays[f"intercept_{i}"], dtype=float) for i in range(layers)]
        net.target_mean_ = np.asarray(arrays["target_mean"], dtype=float)
        net.target_scale_ = np.asarray(arrays["target_scale"], dtype=float)
        net.n_iter_ = int(arrays["n_iter"])
        net.converged_ = bool(arrays["converged"])
        net.loss_curve_ = np.asarray(arrays.get("loss_curve", np.empty(0)), dtype=float)  # files before the loss curve have none
        return net


#: Share of a bounded output unit's range that the training targets span: (1 − OUTPUT_SPAN)/2 of
#: the range is left free at each end, where the unit saturates and its slope vanishes.
OUTPUT_SPAN = 0.8


class MomentumMLP:
    """Multilayer perceptron ``h_l = g_l(h_{l-1} W_l + b_l)`` trained by back-propagation with momentum.

    ``Δw(k+1) = −η ∂E/∂w + μ Δw(k)``, ``w(k+1) = w(k) + Δw(k+1)`` with ``η = learning_rate``,
    ``μ = momentum`` and ``E`` the squared loss plus ``alpha`` times the L2 penalty
    (:mod:`ann.backprop`, docs/formulas.md §C); one update per batch, ``batch_size`` samples
    (None: the whole training set, so one update per epoch). Each layer has its own unit
    (:func:`ann.backprop.layer_units`): logistic, tanh, relu, linear, Gaussian ``e^{−z²}`` or the Heaviside
    step (its forward pass exact, back-propagated with the logistic's slope as a surrogate),
    e.g. ``hidden=(70, 5), activation=("tanh", "tanh", "logistic")``, the source study's
    300-70-5-1 network with a logistic output unit.

    The target (``log y`` with ``log_target``) is scaled ``u = (y − offset)/scale``: standardised
    for a linear output unit; for a bounded one (logistic, tanh) mapped onto the middle
    :data:`OUTPUT_SPAN` of its range, so that a prediction never leaves the range of the
    training targets by more than a tenth of it either way.

    Seeded: the initial weights from ``default_rng(seed)``; epoch ``k``'s mini-batch order
    from ``default_rng([seed, k])`` (the whole set is used in order), so training for
    ``n + n`` epochs, even across a save and a load, is training for ``2n``.

    Stopping: after ``epochs`` epochs of this call, or when the epoch loss has not fallen
    by more than ``tol`` below its best for ``n_iter_no_change`` epochs (``converged_`` True;
    ``tol=None`` trains for exactly ``epochs`` and counts that as converged). A call that
    ends at ``epochs`` with ``tol`` unmet sets ``converged_`` False and warns
    (``ConvergenceWarning``); a loss that becomes infinite raises ``ValueError``.

    After ``fit``: ``coefs_``, ``intercepts_``, ``last_steps_`` (the last ``Δw``, weights then
    biases, the momentum carried into the next update), ``target_offset_``, ``target_scale_``,
    ``n_iter_`` (epochs of every call so far), ``loss_curve_`` (``E`` per epoch, the mean of
    its batches' losses, as scikit-learn records it) and ``converged_``.

    Continuing: with ``warm_start`` a fitted network's ``fit`` goes on from its weights, steps,
    target scaling and epoch count; :meth:`continue_from` takes them from another trained
    network of the same layout (e.g. one loaded from a file) into these training settings.
    """

    kind = "momentum_mlp"

    def __init__(
        self,
        hidden: tuple[int, ...] = (200, 21),
        activation: str | Sequence[str] = "logistic",
        learning_rate: float = 0.01,
        momentum: float = 0.9,
        epochs: int = 2000,
        batch_size: int | None = None,
        alpha: float = 0.0,
        tol: float | None = 1e-7,
        n_iter_no_change: int = 50,
        seed: int = 0,
        log_target: bool = False,
        warm_start: bool = False,
    ) -> None:
        if not hidden or any(int(h) != h or h < 1 for h in hidden):
            raise ValueError(f"hidden must be a non-empty tuple of positive layer sizes, got {hidden!r}")
        self.hidden = tuple(int(h) for h in hidden)
        self.units = layer_units(self.hidden, activation)
        if not (np.isfinite(learning_rate) and learning_rate > 0):
            raise ValueError(f"learning_rate must be positive, got {learning_rate!r}")
        if not (0.0 <= momentum < 1.0):
            raise ValueError(f"momentum must lie in [0, 1), got {momentum!r}")
        if int(epochs) != epochs or epochs < 1:
            raise ValueError(f"epochs must be an integer >= 1, got {epochs!r}")
        if batch_size is not None and (int(batch_size) != batch_size or batch_size < 1):
            raise ValueError(f"batch_size must be None (the whole set) or an integer >= 1, got {batch_size!r}")
        if not (alpha >= 0):
            raise ValueError(f"alpha must be >= 0, got {alpha!r}")
        if tol is not None and not (tol >= 0):
            raise ValueError(f"tol must be None or >= 0, got {tol!r}")
        if int(n_iter_no_change) != n_iter_no_change or n_iter_no_change < 1:
            raise ValueError(f"n_iter_no_change must be an integer >= 1, got {n_iter_no_change!r}")
        if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
            raise ValueError(f"seed must be an integer >= 0 (training is always seeded), got {seed!r}")
        self.activation = activation
        self.learning_rate = float(learning_rate)
        self.momentum = float(momentum)
        self.epochs = int(epochs)
        self.batch_size = None if batch_size is None else int(batch_size)
        self.alpha = float(alpha)
        self.tol = None if tol is None else float(tol)
        self.n_iter_no_change = int(n_iter_no_change)
        self.seed = int(seed)
        self.log_target = log_target
        self.warm_start = warm_start
        self.coefs_: list[np.ndarray] | None = None
        self.intercepts_: list[np.ndarray] | None = None
        self.last_steps_: list[np.ndarray] | None = None
        self.target_offset_: np.ndarray | None = None
        self.target_scale_: np.ndarray | None = None
        self.n_iter_: int = 0
        self.loss_curve_: np.ndarray = np.empty(0)
        self.converged_: bool = False

    # ------------------------------------------------------------------ training

    def fit(self, X: np.ndarray, y: np.ndarray) -> MomentumMLP:
        """Train on features ``X (N, features)`` and targets ``y (N,)`` or ``(N, outputs)`` (class docstring)."""
        X, y = _check_xy(X, y)
        t = _target_in(y, self.log_target)
        T = t.reshape(t.shape[0], -1)
        if self.warm_start and self.coefs_ is not None:
            if X.shape[1] != self.coefs_[0].shape[0] or T.shape[1] != self.coefs_[-1].shape[1]:
                raise ValueError(
                    f"cannot continue training a {self.layout()} network on {X.shape[1]} features and {T.shape[1]} outputs"
                )
        else:
            self.target_offset_, self.target_scale_ = self._target_scaling(t)
            self.coefs_, self.intercepts_ = initial_weights((X.shape[1], *self.hidden, T.shape[1]), np.random.default_rng(self.seed))
            self.last_steps_ = [np.zeros_like(w) for w in self.coefs_ + self.intercepts_]
            self.n_iter_, self.loss_curve_ = 0, np.empty(0)
        U = (T - np.reshape(self.target_offset_, -1)) / np.reshape(self.target_scale_, -1)
        units = [UNITS[name] for name in self.units]
        layers = len(self.coefs_)
        weights, steps = self.coefs_ + self.intercepts_, self.last_steps_
        n = X.shape[0]
        batch = n if self.batch_size is None else min(self.batch_size, n)
        best = float(self.loss_curve_[-1]) if self.loss_curve_.size else np.inf
        stalled, converged = 0, self.tol is None
        losses: list[float] = []
        with np.errstate(over="ignore", invalid="ignore"):  # a diverging run is caught by its loss below
            for epoch in range(self.n_iter_, self.n_iter_ + self.epochs):
                order = np.arange(n) if batch == n else np.random.default_rng([self.seed, epoch]).permutation(n)
                total = 0.0
                for start in range(0, n, batch):
                    rows = order[start : start + batch]
                    loss, grad_coefs, grad_intercepts = loss_and_gradient(weights[:layers], weights[layers:], units, X[rows], U[rows], self.alpha)
                    weights, steps = momentum_step(weights, grad_coefs + grad_intercepts, steps, self.learning_rate, self.momentum)
                    total += loss * rows.size
                losses.append(total / n)
                if not np.isfinite(losses[-1]):
                    raise ValueError(
                        f"MomentumMLP diverged at epoch {epoch + 1} (loss {losses[-1]}); lower learning_rate ({self.learning_rate:g}) or momentum"
                    )
                if self.tol is not None:
                    stalled = stalled + 1 if losses[-1] > best - self.tol else 0
                    best = min(best, losses[-1])
                    if stalled >= self.n_iter_no_change:
                        converged = True
                        break
        self.coefs_, self.intercepts_, self.last_steps_ = weights[:layers], weights[layers:], steps
        self.n_iter_ += len(losses)
        self.loss_curve_ = np.concatenate([self.loss_curve_, losses])
        self.converged_ = converged
        if not converged:
            warnings.warn(
                f"MomentumMLP stopped after {self.epochs} epochs without its loss settling (tol={self.tol:g}); "
                "check converged_ before trusting it",
                convergence_warning(),
                stacklevel=2,
            )
        return self

    def _target_scaling(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(offset, scale)`` of ``u = (t − offset)/scale``: standardisation, or the bounded output unit's middle span."""
        bounds = UNITS[self.units[-1]].bounds
        if bounds is None:
            std = t.std(axis=0)
            return t.mean(axis=0), np.where(std > 0, std, 1.0)
        low, high = bounds
        t_min, t_max = t.min(axis=0), t.max(axis=0)
        scale = np.where(t_max > t_min, (t_max - t_min) / (OUTPUT_SPAN * (high - low)), 1.0)
        return t_min - scale * (low + 0.5 * (1.0 - OUTPUT_SPAN) * (high - low)), scale

    def continue_from(self, trained: MomentumMLP | MLPForceRegressor) -> MomentumMLP:
        """Take the weights, target scaling, epoch count and loss curve of ``trained`` (and its last
        steps ``Δw``; zero for an :class:`MLPForceRegressor`); the next ``fit`` continues from them
        with this network's training settings.

        Raises ``ValueError`` when ``trained`` is unfitted or is laid out otherwise (hidden layers,
        units, ``log_target``).
        """
        if not isinstance(trained, (MomentumMLP, MLPForceRegressor)):
            raise ValueError(f"cannot continue from a {getattr(trained, 'kind', type(trained).__name__)} network: only a multilayer perceptron's weights carry over")
        if trained.coefs_ is None:
            raise ValueError("cannot continue from an unfitted network")
        if isinstance(trained, MomentumMLP):
            units, offset, steps = trained.units, trained.target_offset_, trained.last_steps_
        else:
            units, offset, steps = (trained.activation,) * (len(trained.coefs_) - 1) + ("linear",), trained.target_mean_, None
        hidden = tuple(W.shape[1] for W in trained.coefs_[:-1])
        if (hidden, units, bool(trained.log_target)) != (self.hidden, self.units, bool(self.log_target)):
            raise ValueError(
                f"cannot continue from a network with hidden layers {hidden}, units {units} and log_target {bool(trained.log_target)}: "
                f"this one has hidden layers {self.hidden}, units {self.units} and log_target {bool(self.log_target)}"
            )
        self.coefs_ = [np.array(W, dtype=float) for W in trained.coefs_]
        self.intercepts_ = [np.array(b, dtype=float) for b in trained.intercepts_]
        self.last_steps_ = [np.array(s, dtype=float) for s in steps] if steps is not None else [np.zeros_like(w) for w in self.coefs_ + self.intercepts_]
        self.target_offset_, self.target_scale_ = np.array(offset, dtype=float), np.array(trained.target_scale_, dtype=float)
        self.n_iter_, self.loss_curve_ = int(trained.n_iter_), np.array(trained.loss_curve_, dtype=float)
        self.converged_ = bool(trained.converged_)
        self.warm_start = True
        return self

    def layout(self) -> str:
        """``"30-70-5-1 (tanh, tanh, logistic)"``: the layer sizes and their units (inputs shown once fitted)."""
        sizes = ([str(self.coefs_[0].shape[0])] if self.coefs_ is not None else ["?"]) + [str(h) for h in self.hidden]
        sizes.append(str(self.coefs_[-1].shape[1]) if self.coefs_ is not None else "?")
        return f"{'-'.join(sizes)} ({', '.join(self.units)})"

    # ------------------------------------------------------------------ prediction and storage

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Targets for features ``X``: the forward pass, ``y = scale · h_L + offset`` (``exp`` of it with ``log_target``)."""
        if self.coefs_ is None:
            raise ValueError("MomentumMLP.predict called before fit")
        X, _ = _check_xy(X)
        if X.shape[1] != self.coefs_[0].shape[0]:
            raise ValueError(f"X has {X.shape[1]} features but the network expects {self.coefs_[0].shape[0]}")
        h = forward(self.coefs_, self.intercepts_, [UNITS[name] for name in self.units], X)[1][-1]
        if np.ndim(self.target_offset_) == 0:
            h = h[:, 0]
        return _target_out(h * self.target_scale_ + self.target_offset_, self.log_target)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Weights, last steps, target scaling, loss curve and training settings as plain arrays."""
        if self.coefs_ is None:
            raise ValueError("cannot store an unfitted MomentumMLP")
        arrays: dict[str, np.ndarray] = {
            "units": np.array(self.units),
            "layers": np.array(len(self.coefs_), dtype=np.int64),
            "target_offset": np.asarray(self.target_offset_, dtype=float),
            "target_scale": np.asarray(self.target_scale_, dtype=float),
            "n_iter": np.array(self.n_iter_, dtype=np.int64),
            "converged": np.array(self.converged_, dtype=bool),
            "log_target": np.array(self.log_target, dtype=bool),
            "loss_curve": np.asarray(self.loss_curve_, dtype=float),
            "learning_rate": np.array(self.learning_rate),
            "momentum": np.array(self.momentum),
            "epochs": np.array(self.epochs, dtype=np.int64),
            "batch_size": np.array(0 if self.batch_size is None else self.batch_size, dtype=np.int64),  # 0: the whole set
            "alpha": np.array(self.alpha),
            "tol": np.array(np.nan if self.tol is None else self.tol),  # NaN: none
            "n_iter_no_change": np.array(self.n_iter_no_change, dtype=np.int64),
            "seed": np.array(self.seed, dtype=np.int64),
        }
        layers = len(self.coefs_)
        for i, (W, b) in enumerate(zip(self.coefs_, self.intercepts_)):
            arrays[f"coef_{i}"] = W
            arrays[f"intercept_{i}"] = b
            arrays[f"last_step_coef_{i}"] = self.last_steps_[i]
            arrays[f"last_step_intercept_{i}"] = self.last_steps_[layers + i]
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> MomentumMLP:
        """Rebuild a trained network, with its training settings, from ``to_arrays`` output."""
        layers = int(arrays["layers"])
        coefs = [np.asarray(arrays[f"coef_{i}"], dtype=float) for i in range(layers)]
        tol, batch_size = float(arrays["tol"]), int(arrays["batch_size"])
        net = cls(
            hidden=tuple(W.shape[1] for W in coefs[:-1]),
            activation=[str(u) for u in arrays["units"]],
            learning_rate=float(arrays["learning_rate"]),
            momentum=float(arrays["momentum"]),
            epochs=int(arrays["epochs"]),
            batch_size=batch_size or None,
            alpha=float(arrays["alpha"]),
            tol=None if np.isnan(tol) else tol,
            n_iter_no_change=int(arrays["n_iter_no_change"]),
            seed=int(arrays["seed"]),
            log_target=bool(arrays["log_target"]),
        )
        net.coefs_ = coefs
        net.intercepts_ = [np.asarray(arrays[f"intercept_{i}"], dtype=float) for i in range(layers)]
        net.last_steps_ = [np.asarray(arrays[f"last_step_coef_{i}"], dtype=float) for i in range(layers)] + [
            np.asarray(arrays[f"last_step_intercept_{i}"], dtype=float) for i in range(layers)
        ]
        net.target_offset_ = np.asarray(arrays["target_offset"], dtype=float)
        net.target_scale_ = np.asarray(arrays["target_scale"], dtype=float)
        net.n_iter_ = int(arrays["n_iter"])
        net.loss_curve_ = np.asarray(arrays["loss_curve"], dtype=float)
        net.converged_ = bool(arrays["converged"])
        return net


class RBFNetwork:
    """Radial-basis-function network ``y(x) = sum_j w_j phi(||x - c_j|| / width) + w_0``.

    Centres ``c_j``: k-means cluster centres of the training features (seeded).
    Width: ``"nearest"`` takes ``width_factor`` times the mean distance from each
    centre to its nearest other centre (so neighbouring bases overlap); a float
    sets it directly. The default factor 4 is measured: factor 1 left 13–16 %
    mean error on the synthetic pulse problem (4: 0.5–1.7 %), and the network
    study chose 8 over 2 and 4 (:mod:`femref.study`); in tens of feature
    dimensions the nearest centre is far, and narrow bases leave gaps.  Weights: least squares on the augmented system
    ``[Phi; sqrt(ridge) I] w = [y; 0]``, i.e. ``(Phi^T Phi + ridge I) w = Phi^T y``
    without forming the normal equations (better conditioned).
    """

    kind = "rbf"

    def __init__(
        self,
        centres: int = 20,
        basis: str = "gaussian",
        width: str | float = "nearest",
        width_factor: float = 4.0,
        ridge: float = 1e-8,
        seed: int | None = 0,
        log_target: bool = False,
    ) -> None:
        if int(centres) != centres or centres < 2:
            raise ValueError(f"centres must be an integer >= 2, got {centres!r}")
        if basis not in BASES:
            raise ValueError(f"basis must be one of {tuple(BASES)}, got {basis!r}")
        if isinstance(width, str):
            if width != "nearest":
                raise ValueError(f"width must be 'nearest' or a positive number, got {width!r}")
        elif not (np.isfinite(width) and width > 0):
            raise ValueError(f"width must be 'nearest' or a positive number, got {width!r}")
        if not (width_factor > 0):
            raise ValueError(f"width_factor must be positive, got {width_factor!r}")
        if not (ridge >= 0):
            raise ValueError(f"ridge must be >= 0, got {ridge!r}")
        self.centres = int(centres)
        self.basis = basis
        self.width = width
        self.width_factor = width_factor
        self.ridge = ridge
        self.seed = seed
        self.log_target = log_target
        self.centres_: np.ndarray | None = None
        self.width_: float | None = None
        self.weights_: np.ndarray | None = None

    def fit(self, X: np.ndarray, y: np.ndarray) -> RBFNetwork:
        """Place centres (scikit-learn's ``KMeans``: :class:`TrainingDependencyError` without the extra
        ``femref[train]``), choose the width, solve for the output weights."""
        KMeans = _training_import("RBFNetwork", "sklearn.cluster", "KMeans")
        X, y = _check_xy(X, y)
        y = _target_in(y, self.log_target)
        if X.shape[0] < self.centres:
            raise ValueError(f"{X.shape[0]} training samples are fewer than the {self.centres} centres")
        kmeans = KMeans(n_clusters=self.centres, n_init=10, random_state=self.seed).fit(X)
        self.centres_ = np.array(kmeans.cluster_centers_)
        if self.width == "nearest":
            d = cdist(self.centres_, self.centres_)
            np.fill_diagonal(d, np.inf)
            self.width_ = float(self.width_factor * d.min(axis=1).mean())
            if not self.width_ > 0:
                raise ValueError("k-means returned coincident centres; use fewer centres or a fixed width")
        else:
            self.width_ = float(self.width)
        Phi = self._design(X)
        n = Phi.shape[1]
        A = np.vstack([Phi, np.sqrt(self.ridge) * np.eye(n)])
        rhs = np.concatenate([y, np.zeros((n,) + y.shape[1:])])
        self.weights_, *_ = linalg.lstsq(A, rhs)
        return self

    def _design(self, X: np.ndarray) -> np.ndarray:
        """``[phi(||x - c_1||/w), ..., phi(||x - c_k||/w), 1]`` for each row x."""
        q = cdist(X, self.centres_) / self.width_
        return np.hstack([BASES[self.basis](q), np.ones((X.shape[0], 1))])

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Forces for features ``X``."""
        if self.weights_ is None:
            raise ValueError("RBFNetwork.predict called before fit")
        X, _ = _check_xy(X)
        if X.shape[1] != self.centres_.shape[1]:
            raise ValueError(f"X has {X.shape[1]} features but the network expects {self.centres_.shape[1]}")
        return _target_out(self._design(X) @ self.weights_, self.log_target)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Centres, width, basis and weights as plain arrays."""
        if self.weights_ is None:
            raise ValueError("cannot store an unfitted RBFNetwork")
        return {
            "basis": np.array(self.basis),
            "centres": self.centres_,
            "width": np.array(self.width_, dtype=float),
            "weights": self.weights_,
            "log_target": np.array(self.log_target, dtype=bool),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> RBFNetwork:
        """Rebuild a trained network from ``to_arrays`` output."""
        centres = np.asarray(arrays["centres"], dtype=float)
        width = float(arrays["width"])
        net = cls(centres=centres.shape[0], basis=str(arrays["basis"]), width=width, log_target=bool(arrays.get("log_target", False)))
        net.centres_ = centres
        net.width_ = width
        net.weights_ = np.asarray(arrays["weights"], dtype=float)
        return net


NETWORKS: dict[str, type[MLPForceRegressor] | type[MomentumMLP] | type[RBFNetwork]] = {
    MLPForceRegressor.kind: MLPForceRegressor,
    MomentumMLP.kind: MomentumMLP,
    RBFNetwork.kind: RBFNetwork,
}
