"""``MomentumMLP``: a multilayer perceptron with a unit of its own per layer, trained by back-propagation with momentum.

``Δw(k+1) = −η ∂E/∂w + μ Δw(k)``, the source study's rule (:mod:`ann.backprop` holds the arithmetic: units,
forward pass, loss and gradient, the momentum step); it keeps its loss per epoch, trains without scikit-learn,
and can continue training from a saved network (its own or an ``MLPForceRegressor``'s weights).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from ann.backprop import UNITS, initial_weights, layer_units, loss_and_gradient, momentum_step
from ann.networks.common import check_xy, convergence_warning, target_in
from ann.networks.mlp import MLPForceRegressor
from ann.networks.perceptron import hidden_layers, predict_targets, standardisation

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
        self.hidden = hidden_layers(hidden)
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
        X, y = check_xy(X, y)
        t = target_in(y, self.log_target)
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
            return standardisation(t)
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
            offset, steps = trained.target_offset_, trained.last_steps_
        else:
            offset, steps = trained.target_mean_, None
        hidden, units = tuple(W.shape[1] for W in trained.coefs_[:-1]), trained.units
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
        return predict_targets(X, self.coefs_, self.intercepts_, self.units, self.target_offset_, self.target_scale_, self.log_target)

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


__all__ = ["OUTPUT_SPAN", "MomentumMLP"]
