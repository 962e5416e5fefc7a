"""What every network of :mod:`ann.networks` checks and transforms alike: the inputs ``X`` and targets ``y``,
the target in or out of logs, the optional training dependency and the "stopped before converging" warning.

scikit-learn is needed only to train ``MLPForceRegressor`` and ``RBFNetwork``: it is the optional extra
:data:`TRAIN_EXTRA` (``pip install 'femref[train]'``), imported through :func:`training_import` inside their
``fit``; without it training raises :class:`TrainingDependencyError` (an ``ImportError``) naming the extra.
"""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np

#: The optional extra that installs scikit-learn, the trainer of ``MLPForceRegressor`` and ``RBFNetwork``.
TRAIN_EXTRA = "train"


class TrainingDependencyError(ImportError):
    """Training asked for without scikit-learn installed: the message names the network and the extra
    ``femref[train]``; prediction from a saved network needs no scikit-learn."""


class NetworkConvergenceWarning(UserWarning):
    """A training run stopped before its tolerance was met, where scikit-learn (and its ``ConvergenceWarning``) is
    not installed; with scikit-learn, scikit-learn's ``ConvergenceWarning`` is raised (:func:`convergence_warning`)."""


def training_import(network: str, module: str, name: str) -> Any:
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


def check_xy(X: np.ndarray, y: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """``X (N, features)`` and ``y (N,)`` or ``(N, outputs)`` as float arrays, finite; ``ValueError`` otherwise."""
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


def check_features(X: np.ndarray, features: int) -> None:
    """``ValueError`` unless ``X`` has the ``features`` columns the fitted network expects."""
    if X.shape[1] != features:
        raise ValueError(f"X has {X.shape[1]} features but the network expects {features}")


def target_in(y: np.ndarray, log_target: bool) -> np.ndarray:
    """The training target: ``y`` or ``log y`` (then ``y`` must be positive)."""
    if not log_target:
        return y
    if np.any(y <= 0.0):
        raise ValueError("log_target needs positive targets (peak compression forces > 0)")
    return np.log(y)


def target_out(z: np.ndarray, log_target: bool) -> np.ndarray:
    """The prediction from the network's output ``z``: ``z``, or ``exp z`` with ``log_target``."""
    return np.exp(z) if log_target else z


__all__ = [
    "TRAIN_EXTRA",
    "NetworkConvergenceWarning",
    "TrainingDependencyError",
    "check_features",
    "check_xy",
    "convergence_warning",
    "target_in",
    "target_out",
    "training_import",
]
