"""The O(dim²)-per-step estimator: the stationary filter and smoother of :mod:`.augmented`'s model
with the initial force as a regression; its likelihoods (:func:`likelihoods`) and smoothed force
(:func:`smoothed_force`, or :func:`reference_force` for an undetectable model), for :mod:`.estimate`.

The reference recursion (:func:`.linear_gaussian.kalman_smoother`) costs O(dim³) per step. The
force estimator uses the same posterior at O(dim²) per step, exactly, by choosing the prior so
that no transient remains: ``z_0 ~ N(0, P∞ + σ_0² u uᵀ)`` with ``P∞`` the stationary predicted
covariance (the DARE solution, by the structure-preserving doubling algorithm, batched over
``q_P``), ``u`` the quasi-static state of a unit force (``e = Λ_e⁻¹ Φ_eᵀ B b``, ``ė = 0``,
``P = 1``) and ``σ_0`` the declared initial force std:
"the cars are undeformed up to what the sensors resolve in steady state, and carry an
unknown initial force in quasi-static equilibrium" (a coupler preload, or a record that
starts mid-impact). Then ``z_0 = u α + ε``, ``α ~ N(0, σ_0²)``, ``ε ~ N(0, P∞)``, and (de Jong's
augmented filter, 1991) the steady filter — gain ``K∞``, ``L = F (I − K∞ H)`` — gives
innovations ``ν∞_k = h_k α + e_k``, ``h_k = H L^k u``, ``e_k ~ N(0, S∞)`` white. So::

    ℓ = −½ [N log det S∞ + Σ ν∞ᵀ S∞⁻¹ ν∞ + log(1 + σ_0² o) − s²/(σ_0⁻² + o)] − ½ N (m log 2π + log det R)
    s = Σ h_kᵀ S∞⁻¹ ν∞_k,   o = Σ h_kᵀ S∞⁻¹ h_k,   α | y ~ N(s/(σ_0⁻² + o), 1/(σ_0⁻² + o))
    ẑ_k = ẑ∞_k + E[α|y] ψ_k,   V_k = V∞_k + Var[α|y] ψ_k ψ_kᵀ

(``ẑ∞``, ``V∞``: the stationary smoother given α = 0; ``ψ_k`` the smoothed response to a unit
α: the same smoother run with prior mean ``u`` and zero data; ``V∞_k,PP = P∞_PP − Σ_{j<N−k}
|S∞^{-1/2} H L^j P∞ e_P|²``), equal to the Joseph-form filter and smoother with the same prior
(tests). A line of ``n_c`` couplers: ``u`` becomes ``U`` (n × n_c), ``α ~ N(0, σ_0² I)``, ``h_k = H L^k U``,
``s`` a vector and ``o`` a matrix ``O``: ``log(1 + σ_0² o) → log det(I + σ_0² O)``, ``s²/(σ_0⁻² + o) →
sᵀ (I/σ_0² + O)⁻¹ s``, ``α | y ~ N((I/σ_0² + O)⁻¹ s, (I/σ_0² + O)⁻¹)``, and ``ψ_k``, ``V∞_k`` per coupler
with ``e_{P_c}``. Models that fail the detectability check have no stationary covariance; they fall back
to the reference recursion with the prior ``N(0, σ_0² u uᵀ)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .augmented import AugmentedModel
from .linear_gaussian import joseph_smoother, stationary_covariances, symmetrised, transposed

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class _Steady:
    """Stationary filter quantities, batched over G force rates (scaled, whitened)."""

    covariance: FloatArray  # P∞ (G, n, n)
    innovation_inverse: FloatArray  # S∞⁻¹ (G, m, m)
    logdet: FloatArray  # log det S∞ (G,)
    drive: FloatArray  # F K∞ (G, n, m)
    closed_loop: FloatArray  # L = F (I − K∞ H) (G, n, n)


def _steady(aug: AugmentedModel, rates: FloatArray) -> _Steady:
    f, hw = aug.transition, aug.whitened_observation
    p = stationary_covariances(f, rates[:, None, None] * aug.unit_process_covariance, hw)
    s = hw @ p @ hw.T + np.eye(hw.shape[0])
    s_inv = symmetrised(np.linalg.inv(s))
    gain = p @ hw.T @ s_inv
    return _Steady(p, s_inv, np.linalg.slogdet(s)[1], f @ gain, f - f @ gain @ hw)


def _steady_pass(steady: _Steady, hw: FloatArray, yw: FloatArray, u: FloatArray, extra: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Predicted means of the stationary filter on the data (row 0) and ``L^k u_c`` for each column of
    ``u`` (rows 1 … n_c), and ``L^k extra_c`` for each column of ``extra`` (the rows after) if given:
    ``(rows (N, G, R, n), innovations ν∞ (N, G, m))``."""
    count, n = steady.covariance.shape[:2]
    steps = yw.shape[0]
    drive = np.einsum("gnm,km->kgn", steady.drive, yw)
    lt = np.ascontiguousarray(transposed(steady.closed_loop))
    columns = [u] if extra is None else [u, extra]
    state = np.zeros((count, 1, n))
    state = np.concatenate([state] + [np.broadcast_to(c.T, (count, *c.T.shape)) for c in columns], axis=1)
    out = np.empty((steps, count, state.shape[1], n))
    if count == 1:
        s0, l0, d0 = state[0], lt[0], drive[:, 0]
        for k in range(steps):
            out[k, 0] = s0
            s0 = s0 @ l0
            s0[0] += d0[k]
    else:
        for k in range(steps):
            out[k] = state
            state = state @ lt
            state[:, 0] += drive[k]
    innovations = yw[:, None, :] - out[:, :, 0] @ hw.T
    return out, innovations


def _regression(steady: _Steady, hw: FloatArray, rows: FloatArray, innovations: FloatArray, prior: float,
                couplers: int) -> tuple[FloatArray, ...]:
    """``(ℓ_w, Σ ν S⁻¹ ν, E[α|y], Var[α|y])`` per G (whitened ℓ without constants), ``α`` the n_c initial
    forces: ``ℓ_w = −½ (N log det S∞ + log det(I + σ_0² O) + Σ ν S⁻¹ ν − sᵀ (I/σ_0² + O)⁻¹ s)``."""
    h = rows[:, :, 1 : 1 + couplers] @ hw.T  # h_k = H L^k U (N, G, n_c, m)
    weighted = np.einsum("kgi,gij->kgj", innovations, steady.innovation_inverse)
    quad0 = np.einsum("kgj,kgj->g", weighted, innovations)
    s = np.einsum("kgj,kgcj->gc", weighted, h)
    o = np.einsum("kgci,gij,kgdj->gcd", h, steady.innovation_inverse, h)
    identity = np.eye(couplers)
    info = identity / prior + o
    alpha_var = np.linalg.inv(info)
    alpha = np.einsum("gcd,gd->gc", alpha_var, s)
    quad = quad0 - np.einsum("gc,gc->g", s, alpha)
    steps = innovations.shape[0]
    ell = -0.5 * (steps * steady.logdet + np.linalg.slogdet(identity + prior * o)[1] + quad)
    return ell, quad, alpha, alpha_var


def likelihoods(aug: AugmentedModel, yw: FloatArray, rates: FloatArray, prior: float) -> tuple[FloatArray, FloatArray]:
    """Whitened log-likelihoods (no constants) and ``Σ ν S⁻¹ ν`` for each force rate."""
    hw = aug.whitened_observation
    steady = _steady(aug, rates)
    rows, innovations = _steady_pass(steady, hw, yw, aug.quasi_static_directions)
    ell, quad, _, _ = _regression(steady, hw, rows, innovations, prior, aug.couplers)
    return ell, quad


def steady_filter(aug: AugmentedModel, rate: float) -> _Steady:
    """The stationary filter of ``aug`` at one force rate, for :func:`smoothed_force` on several records."""
    return _steady(aug, np.array([rate]))


def smoothed_force(aug: AugmentedModel, yw: FloatArray, rate: float, prior: float,
                   steady: _Steady | None = None) -> tuple[FloatArray, FloatArray, float, float]:
    """Scaled smoothed forces' means and variances (N × n_c), whitened ℓ and ``Σ ν S⁻¹ ν`` (module docstring);
    ``steady``: the stationary filter at ``rate`` (:func:`steady_filter`) if already made."""
    hw, forces, nc = aug.whitened_observation, aug.force_slice, aug.couplers
    steady = _steady(aug, np.array([rate])) if steady is None else steady
    p = steady.covariance[0]
    columns = p[:, forces]  # P∞ e_{P_c}
    rows, innovations = _steady_pass(steady, hw, yw, aug.quasi_static_directions, extra=columns)
    ell, quad, alpha, alpha_var = _regression(steady, hw, rows, innovations, prior, nc)
    alpha, alpha_var = alpha[0], alpha_var[0]
    rows, nu = rows[:, 0], innovations[:, 0]
    s_inv_h = steady.innovation_inverse[0] @ hw
    h = rows[:, 1 : 1 + nc] @ hw.T  # (N, n_c, m)
    drive = np.concatenate([(nu @ s_inv_h)[:, None], -h @ s_inv_h], axis=1)  # Hᵀ S⁻¹ ν for the data and for ν = −h_c
    closed = steady.closed_loop[0]
    r = np.zeros((1 + nc, hw.shape[1]))
    adjoint = np.empty_like(drive)
    for k in range(yw.shape[0] - 1, -1, -1):
        r = drive[k] + r @ closed  # r_{k−1} = Hᵀ S⁻¹ ν_k + Lᵀ r_k
        adjoint[k] = r
    data_mean = rows[:, 0, forces] + adjoint[:, 0] @ columns
    response = rows[:, 1 : 1 + nc, forces] + adjoint[:, 1:] @ columns  # ψ_k: P_c (last axis) per unit α_d (middle axis)
    c = rows[:, 1 + nc :] @ hw.T  # H L^j P∞ e_{P_c} (N, n_c, m)
    terms = np.einsum("kci,ij,kcj->kc", c, steady.innovation_inverse[0], c)
    gathered = np.cumsum(terms, axis=0)[::-1]  # Σ_{j < N−k}
    spread = np.einsum("kdc,de,kec->kc", response, alpha_var, response)
    variance = np.maximum(np.diag(p)[forces] - gathered, 0.0) + spread
    return data_mean + response.transpose(0, 2, 1) @ alpha, variance, float(ell[0]), float(quad[0])


def reference_force(aug: AugmentedModel, yw: FloatArray, rate: float, prior: float) -> tuple[FloatArray, FloatArray, float, float]:
    """The same outputs by the Joseph-form reference, prior ``N(0, prior U Uᵀ)`` (undetectable models)."""
    u = aug.quasi_static_directions
    n, forces = u.shape[0], aug.force_slice
    out = joseph_smoother(aug.transition, aug.process_covariance(rate), aug.whitened_observation, yw, np.zeros(n), prior * (u @ u.T))
    _, _, _, _, xs, vs, _, _, logdet, quad = out
    return xs[:, forces], np.diagonal(vs[:, forces, forces], axis1=1, axis2=2), -0.5 * float(np.sum(logdet + quad)), float(np.sum(quad))


__all__: list[str] = []  # package-internal: .estimate calls it
