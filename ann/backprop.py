"""Back-propagation with momentum for a multilayer perceptron with a unit of its own in every layer.

The kernel of :class:`ann.networks.MomentumMLP` (docs/formulas.md §C), on plain arrays::

    forward    h_0 = x,   z_l = h_{l-1} W_l + b_l,   h_l = g_l(z_l)            (l = 1 … L; g_L linear unless given)
    loss       E = 1/(2 N m) Σ_n ‖h_L(x_n) − t_n‖² + α/(2N) Σ_l ‖W_l‖²          (N samples, m outputs)
    backward   δ_L = g_L'(z_L) ⊙ (h_L − t)/(N m),   δ_l = (δ_{l+1} W_{l+1}ᵀ) ⊙ g_l'(z_l)
               ∂E/∂W_l = h_{l-1}ᵀ δ_l + (α/N) W_l,   ∂E/∂b_l = Σ_n δ_l
    momentum   Δw(k+1) = −η ∂E/∂w + μ Δw(k),   w(k+1) = w(k) + Δw(k+1)

The momentum rule is the source study's ``Δw(k+1) = η δ o + α Δw(k)`` (its α is μ here; α is
the L2 penalty, as in scikit-learn, whose squared loss and penalty ``E`` also are). A batch
is the whole training set or a mini-batch; ``δ o`` summed over the batch is ``−∂E/∂W``.

Units (:data:`UNITS`): logistic, tanh, relu, linear, Gaussian ``e^{−z²}`` and the Heaviside
step. The step's derivative is zero almost everywhere, so back-propagation through it uses a
surrogate: the logistic's slope ``σ(z)(1 − σ(z))`` in place of ``H'(z)`` (a straight-through
estimator); the forward pass stays the exact step. Every other unit back-propagates its exact
derivative (checked against central differences in ``tests/ann/test_backprop.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def _logistic(z: Array) -> Array:
    """σ(z) = 1/(1 + e^{−z}), written (1 + tanh(z/2))/2 so that it never overflows."""
    return 0.5 * (1.0 + np.tanh(0.5 * z))


@dataclass(frozen=True)
class Unit:
    """A unit ``h = g(z)`` and the slope back-propagation uses, ``slope(z, h) = g'(z)``.

    ``exact`` is False when the slope is a surrogate (the step), not the derivative of ``g``.
    ``bounds`` is the open range of ``g`` where it is bounded on both sides (an output unit
    needs one: the target is scaled into it), else None.
    """

    name: str
    value: Callable[[Array], Array]
    slope: Callable[[Array, Array], Array]
    exact: bool = True
    bounds: tuple[float, float] | None = None


UNITS: dict[str, Unit] = {
    unit.name: unit
    for unit in (
        Unit("logistic", _logistic, lambda z, h: h * (1.0 - h), bounds=(0.0, 1.0)),
        Unit("tanh", np.tanh, lambda z, h: 1.0 - h**2, bounds=(-1.0, 1.0)),
        Unit("relu", lambda z: np.maximum(z, 0.0), lambda z, h: (z > 0.0).astype(float)),
        Unit("linear", lambda z: z, lambda z, h: np.ones_like(z)),
        Unit("gaussian", lambda z: np.exp(-(z**2)), lambda z, h: -2.0 * z * h),
        # H(z) = 1 for z ≥ 0, else 0; back-propagated with the logistic's slope (surrogate).
        Unit("step", lambda z: (z >= 0.0).astype(float), lambda z, h: _logistic(z) * (1.0 - _logistic(z)), exact=False),
    )
}

#: Units an output layer may have: linear, or bounded on both sides (the target is scaled into the range).
OUTPUT_UNITS = ("linear",) + tuple(name for name, unit in UNITS.items() if unit.bounds is not None)


def layer_units(hidden: Sequence[int], activation: str | Sequence[str]) -> tuple[str, ...]:
    """The unit of every layer of weights: the hidden layers', then the output's.

    ``activation`` is one name for every hidden layer, a list of ``len(hidden)`` names (one
    per hidden layer; the output unit is linear), or of ``len(hidden) + 1`` names, the last
    the output unit's (one of :data:`OUTPUT_UNITS`). Raises ``ValueError``.
    """
    names = (activation,) * len(hidden) if isinstance(activation, str) else tuple(activation)
    unknown = [n for n in names if n not in UNITS]
    if unknown:
        raise ValueError(f"activation must be one of {tuple(UNITS)}, got {unknown[0]!r}")
    if len(names) == len(hidden):
        names += ("linear",)
    if len(names) != len(hidden) + 1:
        raise ValueError(
            f"activation needs one name, or {len(hidden)} (one per hidden layer), or {len(hidden) + 1} "
            f"(the last for the output unit) for hidden {tuple(hidden)}, got {len(names)}"
        )
    if names[-1] not in OUTPUT_UNITS:
        raise ValueError(f"the output unit must be one of {OUTPUT_UNITS}, got {names[-1]!r}")
    return names


def initial_weights(layer_sizes: Sequence[int], rng: np.random.Generator) -> tuple[list[Array], list[Array]]:
    """Glorot-uniform weights ``W_l ~ U(−r, r)``, ``r = √(6/(n_in + n_out))``, and biases alike (seeded ``rng``)."""
    coefs, intercepts = [], []
    for n_in, n_out in zip(layer_sizes[:-1], layer_sizes[1:]):
        bound = np.sqrt(6.0 / (n_in + n_out))
        coefs.append(rng.uniform(-bound, bound, (n_in, n_out)))
        intercepts.append(rng.uniform(-bound, bound, n_out))
    return coefs, intercepts


def forward(coefs: Sequence[Array], intercepts: Sequence[Array], units: Sequence[Unit], X: Array) -> tuple[list[Array], list[Array]]:
    """``z_l = h_{l-1} W_l + b_l``, ``h_l = g_l(z_l)`` for every layer: the lists ``z`` and ``h`` (``h[0] = X``)."""
    assert len(coefs) == len(intercepts) == len(units), "one unit per layer of weights"
    z_all, h_all = [], [X]
    for W, b, unit in zip(coefs, intercepts, units):
        z = h_all[-1] @ W + b
        z_all.append(z)
        h_all.append(unit.value(z))
    return z_all, h_all


def loss_and_gradient(
    coefs: Sequence[Array], intercepts: Sequence[Array], units: Sequence[Unit], X: Array, T: Array, alpha: float
) -> tuple[float, list[Array], list[Array]]:
    """``E`` and ``(∂E/∂W_l, ∂E/∂b_l)`` by back-propagation (module docstring); ``T`` is ``(N, m)``."""
    n, m = T.shape
    z_all, h_all = forward(coefs, intercepts, units, X)
    residual = h_all[-1] - T
    loss = 0.5 * float(np.sum(residual**2)) / (n * m) + 0.5 * alpha * sum(float(np.sum(W**2)) for W in coefs) / n
    grad_coefs: list[Array] = [np.empty(0)] * len(coefs)
    grad_intercepts: list[Array] = [np.empty(0)] * len(coefs)
    delta = units[-1].slope(z_all[-1], h_all[-1]) * residual / (n * m)
    for layer in range(len(coefs) - 1, -1, -1):
        grad_coefs[layer] = h_all[layer].T @ delta + (alpha / n) * coefs[layer]
        grad_intercepts[layer] = delta.sum(axis=0)
        if layer > 0:
            delta = (delta @ coefs[layer].T) * units[layer - 1].slope(z_all[layer - 1], h_all[layer])
    return loss, grad_coefs, grad_intercepts


def momentum_step(
    weights: Sequence[Array], gradients: Sequence[Array], steps: Sequence[Array], learning_rate: float, momentum: float
) -> tuple[list[Array], list[Array]]:
    """``Δw(k+1) = −η ∂E/∂w + μ Δw(k)``, ``w(k+1) = w(k) + Δw(k+1)``: the new weights and the new steps ``Δw(k+1)``."""
    new_steps = [momentum * step - learning_rate * grad for step, grad in zip(steps, gradients)]
    return [w + step for w, step in zip(weights, new_steps)], new_steps


__all__ = ["OUTPUT_UNITS", "UNITS", "Unit", "forward", "initial_weights", "layer_units", "loss_and_gradient", "momentum_step"]
