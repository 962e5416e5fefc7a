"""What the two multilayer perceptrons (``MLPForceRegressor``, ``MomentumMLP``) share, written once.

* the layout check of ``hidden`` (:func:`hidden_layers`);
* the standardised target ``u = (t − mean)/scale``, ``scale = std`` (1 where ``std`` is 0) (:func:`standardisation`);
* the prediction (:func:`predict_targets`): the forward pass of :func:`ann.backprop.forward`,
  ``h_0 = x``, ``h_l = g_l(h_{l-1} W_l + b_l)``, then ``y = scale · h_L + offset`` (``exp`` of it with
  ``log_target``). ``MLPForceRegressor`` passes scikit-learn's layout, ``activation`` on every hidden layer
  and a linear output unit; ``MomentumMLP`` its own unit per layer.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ann.backprop import UNITS, forward
from ann.networks.common import check_features, check_xy, target_out


def hidden_layers(hidden: Sequence[int]) -> tuple[int, ...]:
    """``hidden`` as a tuple of positive integer layer sizes; ``ValueError`` when empty or not such sizes."""
    if not hidden or any(int(h) != h or h < 1 for h in hidden):
        raise ValueError(f"hidden must be a non-empty tuple of positive layer sizes, got {hidden!r}")
    return tuple(int(h) for h in hidden)


def standardisation(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(mean, scale)`` of ``u = (t − mean)/scale`` per output: ``scale`` the standard deviation, 1 where it is 0."""
    std = t.std(axis=0)
    return t.mean(axis=0), np.where(std > 0, std, 1.0)


def predict_targets(
    X: np.ndarray,
    coefs: Sequence[np.ndarray],
    intercepts: Sequence[np.ndarray],
    units: Sequence[str],
    offset: np.ndarray,
    scale: np.ndarray,
    log_target: bool,
) -> np.ndarray:
    """``y = scale · h_L(X) + offset`` (``exp`` of it with ``log_target``) for features ``X (N, features)``.

    ``h_L`` is the forward pass through ``coefs``/``intercepts`` with the unit of :data:`ann.backprop.UNITS` named
    in ``units`` per layer; a scalar ``offset`` (one output) gives ``y (N,)``, else ``(N, outputs)``.
    """
    X, _ = check_xy(X)
    check_features(X, coefs[0].shape[0])
    h = forward(coefs, intercepts, [UNITS[name] for name in units], X)[1][-1]
    if np.ndim(offset) == 0:
        h = h[:, 0]
    return target_out(h * scale + offset, log_target)


__all__ = ["hidden_layers", "predict_targets", "standardisation"]
