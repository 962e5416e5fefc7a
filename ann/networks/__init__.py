"""Small regression networks mapping feature vectors to coupler force.

Every network follows the estimator contract ``fit(X, y)`` / ``predict(X)`` with
explicit seeds, and predicts with plain numpy from arrays that
``ann.storage`` can save without pickle; one module each:

* ``MLPForceRegressor`` (:mod:`ann.networks.mlp`) — a multilayer perceptron trained by
  scikit-learn's ``MLPRegressor`` on a standardised target ``(y - mean) / std``; prediction is
  the numpy forward pass ``h_{l+1} = g(h_l W_l + b_l)`` (identity on the last
  layer) followed by ``y = std * h + mean``.
* ``MomentumMLP`` (:mod:`ann.networks.momentum`) — a multilayer perceptron with a unit of its own
  per layer (logistic, tanh, relu, linear, Gaussian, step; :mod:`ann.backprop`), trained
  here by back-propagation with momentum ``Δw(k+1) = −η ∂E/∂w + μ Δw(k)``, the
  source study's rule; it keeps its loss per epoch and can continue training
  from a saved network.
* ``RBFNetwork`` (:mod:`ann.networks.rbf`) — ``y(x) = sum_j w_j phi(||x - c_j|| / width) + w_0``
  with centres ``c_j`` from k-means and the weights from ridge-regularised least
  squares.

What they share is written once: the input checks, the target transforms, the training
dependency and the convergence warning in :mod:`ann.networks.common`; the two perceptrons'
layout check, standardised target and prediction (one forward pass, :func:`ann.backprop.forward`)
in :mod:`ann.networks.perceptron`. :data:`NETWORKS` maps each ``kind`` (the name a saved file
carries) to its class.

All take ``log_target``: fit ``log y`` and predict ``exp`` of the output. Peak
forces span an order of magnitude over yard speeds and car masses; in logs the
relative error is what the squared loss weighs (``Δ log P ≈ ΔP/P``), the
prediction is always positive, and ``log P = log M + log A`` is linear in the
log-amplitude features of :mod:`ann.features`.

scikit-learn is needed only to train ``MLPForceRegressor`` and ``RBFNetwork``: it is the
optional extra ``train`` (``pip install 'femref[train]'``) and is imported inside their
``fit``; importing this package, loading a saved network and predicting use numpy and scipy
only, and ``MomentumMLP`` trains without it. Training without it raises
:class:`TrainingDependencyError` (an ``ImportError``) naming the extra.
"""

from __future__ import annotations

from ann.networks.common import TRAIN_EXTRA, NetworkConvergenceWarning, TrainingDependencyError, convergence_warning
from ann.networks.mlp import ACTIVATIONS, SOLVERS, MLPForceRegressor
from ann.networks.momentum import OUTPUT_SPAN, MomentumMLP
from ann.networks.rbf import BASES, RBFNetwork

NETWORKS: dict[str, type[MLPForceRegressor | MomentumMLP | RBFNetwork]] = {
    MLPForceRegressor.kind: MLPForceRegressor,
    MomentumMLP.kind: MomentumMLP,
    RBFNetwork.kind: RBFNetwork,
}

__all__ = [
    "ACTIVATIONS",
    "BASES",
    "NETWORKS",
    "OUTPUT_SPAN",
    "SOLVERS",
    "TRAIN_EXTRA",
    "MLPForceRegressor",
    "MomentumMLP",
    "NetworkConvergenceWarning",
    "RBFNetwork",
    "TrainingDependencyError",
    "convergence_warning",
]
