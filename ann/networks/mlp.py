"""``MLPForceRegressor``: a multilayer perceptron trained by scikit-learn, predicting with numpy.

``MLPRegressor`` (the optional extra ``femref[train]``) trains it on a standardised target
``(t - mean) / std``; prediction is the numpy forward pass ``h_{l+1} = g(h_l W_l + b_l)`` (identity on the
last layer) followed by ``y = std * h + mean`` (:func:`ann.networks.perceptron.predict_targets`, the pass
``MomentumMLP`` predicts with too).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np

from ann.backprop import UNITS
from ann.networks.common import check_xy, target_in, training_import
from ann.networks.perceptron import hidden_layers, predict_targets, standardisation

#: The hidden units scikit-learn trains: ``g(z)`` of each (the units of :data:`ann.backprop.UNITS` by those names).
ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {name: UNITS[name].value for name in ("logistic", "relu", "tanh")}
SOLVERS = ("sgd", "adam", "lbfgs")


class MLPForceRegressor:
    """Multilayer perceptron for force regression (scikit-learn training, numpy prediction).

    After ``fit``: ``coefs_``, ``intercepts_``, ``target_mean_``, ``target_scale_``, ``n_iter_``,
    ``loss_curve_`` (empty for ``lbfgs``, which records none) and ``converged_``, False when training
    stopped at ``max_iter`` without meeting its tolerance (a ``ConvergenceWarning`` is then raised too).

    ``tol`` and ``n_iter_no_change`` are tighter than scikit-learn's defaults (1e-4, 10): on a synthetic
    sin² pulse problem those stopped the default network at ~4.5 % mean error, these reach ~0.5 %.

    Solvers: ``"sgd"`` (back-propagation with ``momentum``, the source study's rule), ``"adam"``,
    ``"lbfgs"`` (full batch, no early stopping: ``alpha`` does the regularising).
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
        self.hidden = hidden_layers(hidden)
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
        MLPRegressor = training_import("MLPForceRegressor", "sklearn.neural_network", "MLPRegressor")
        ConvergenceWarning = training_import("MLPForceRegressor", "sklearn.exceptions", "ConvergenceWarning")
        X, y = check_xy(X, y)
        y = target_in(y, self.log_target)
        self.target_mean_, self.target_scale_ = standardisation(y)
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

    @property
    def units(self) -> tuple[str, ...]:
        """The unit of every layer of weights, as :attr:`MomentumMLP.units`: ``activation`` on the hidden layers, linear
        on the output (scikit-learn's layout; the layers of the fitted weights once fitted)."""
        layers = len(self.coefs_) if self.coefs_ is not None else len(self.hidden) + 1
        return (self.activation,) * (layers - 1) + ("linear",)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Forces for features ``X``: the numpy forward pass of the stored weights."""
        if self.coefs_ is None:
            raise ValueError("MLPForceRegressor.predict called before fit")
        return predict_targets(X, self.coefs_, self.intercepts_, self.units, self.target_mean_, self.target_scale_, self.log_target)

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


__all__ = ["ACTIVATIONS", "SOLVERS", "MLPForceRegressor"]
