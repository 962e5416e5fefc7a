"""Small regression networks mapping feature vectors to coupler force.

Every network follows the estimator contract ``fit(X, y)`` / ``predict(X)`` with
explicit seeds, and predicts with plain numpy from arrays that
``ann.storage`` can save without pickle; one module each (:mod:`ann.networks.mlp`,
:mod:`ann.networks.momentum`, :mod:`ann.networks.rbf`), what they share in
:mod:`ann.networks.common` and :mod:`ann.networks.perceptron`. :data:`NETWORKS` maps each
``kind`` (the name a saved file carries) to its class.

All take ``log_target``: fit ``log y`` and predict ``exp`` of the output. Peak
forces span an order of magnitude over yard speeds and car masses; in logs the
relative error is what the squared loss weighs (``Δ log P ≈ ΔP/P``), the
prediction is always positive, and ``log P = log M + log A`` is linear in the
log-amplitude features of :mod:`ann.features`.

scikit-learn is needed only to train ``MLPForceRegressor`` and ``RBFNetwork``
(:mod:`ann.networks.common`); loading a saved network and predicting use numpy and scipy only.
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
