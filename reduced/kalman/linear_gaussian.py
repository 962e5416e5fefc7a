"""Generic linear-Gaussian machinery: exact sampling of a continuous model
(:func:`van_loan_discretisation`), the reference Kalman filter and smoother (:func:`kalman_smoother`,
result :class:`GaussianSmoothing`) and the stationary covariance (:func:`stationary_covariances`).
Nothing here knows of cars; :mod:`.augmented` builds the model, :mod:`.steady` the fast estimator.

Filter and smoother. The reference (:func:`kalman_smoother`) is the textbook recursion::

    ν_k = y_k − H z⁻_k,   S_k = H P⁻_k Hᵀ + R,   K_k = P⁻_k Hᵀ S_k⁻¹
    z⁺_k = z⁻_k + K_k ν_k,  P⁺_k = (I − K_k H) P⁻_k (I − K_k H)ᵀ + K_k R K_kᵀ   (Joseph form)
    z⁻_{k+1} = F z⁺_k,      P⁻_{k+1} = F P⁺_k Fᵀ + Q                             (symmetrised)

with the Rauch–Tung–Striebel posterior in its Bryson–Frazier/de Jong form (no inverse of
``P⁻``, which is nearly singular for an undeformed start)::

    r_{k−1} = Hᵀ S_k⁻¹ ν_k + L_kᵀ r_k,   N_{k−1} = Hᵀ S_k⁻¹ H + L_kᵀ N_k L_k,   L_k = F (I − K_k H)
    ẑ_k = z⁻_k + P⁻_k r_{k−1},            V_k = P⁻_k − P⁻_k N_{k−1} P⁻_k,       r_{N−1} = N_{N−1} = 0

:func:`symmetrised`, :func:`transposed`, :func:`joseph_smoother` (the recursion on whitened outputs)
and :func:`stationary_covariances` are shared within the package and not re-exported by it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import expm

from reduced import _checks

FloatArray = NDArray[np.float64]


def transposed(a: FloatArray) -> FloatArray:
    """``Aᵀ`` of each matrix of a batch (the last two axes swapped)."""
    return np.swapaxes(a, -1, -2)


def symmetrised(a: FloatArray) -> FloatArray:
    """``½ (A + Aᵀ)`` of each matrix of a batch."""
    return 0.5 * (a + transposed(a))


def van_loan_discretisation(
    system_matrix: ArrayLike, noise_input: ArrayLike, noise_intensity: ArrayLike, step: float
) -> tuple[FloatArray, FloatArray]:
    """``(F, Q)`` of ``ż = A z + G w``, ``E[w(t) w(s)ᵀ] = Q_c δ(t − s)``, sampled exactly at step ``h``.

    ``expm([[−A, G Q_c Gᵀ], [0, Aᵀ]] h) = [[·, E12], [0, E22]]``; ``F = E22ᵀ = e^{Ah}``,
    ``Q = F E12 = ∫₀ʰ e^{Aτ} G Q_c Gᵀ e^{Aᵀτ} dτ`` (Van Loan 1978), symmetrised.
    ``noise_input`` is n × p (a 1-D array is one column), ``noise_intensity`` p × p (a
    scalar for p = 1).
    """
    a = np.atleast_2d(np.asarray(system_matrix, dtype=float))
    n = a.shape[0]
    if a.shape != (n, n) or not np.all(np.isfinite(a)):
        raise ValueError(f"system_matrix must be a finite square matrix, got shape {a.shape}")
    g = np.asarray(noise_input, dtype=float)
    g = g.reshape(n, -1) if g.ndim <= 1 else g
    qc = np.atleast_2d(np.asarray(noise_intensity, dtype=float))
    if g.shape[0] != n or qc.shape != (g.shape[1], g.shape[1]):
        raise ValueError(f"noise_input must be {n} × p and noise_intensity p × p; got {g.shape} and {qc.shape}")
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(qc))):
        raise ValueError("noise_input and noise_intensity must be finite")
    h = _checks.sample_step("step", step)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n] = -a
    block[:n, n:] = g @ qc @ g.T
    block[n:, n:] = a.T
    e = expm(block * h)
    transition = np.ascontiguousarray(e[n:, n:].T)
    return transition, symmetrised(transition @ e[:n, n:])


@dataclass(frozen=True, eq=False)
class GaussianSmoothing:
    """Filter and smoother output of :func:`kalman_smoother` (N steps, n states, m outputs).

    ``predicted_*`` are ``z⁻_k``, ``P⁻_k`` (given y_0 … y_{k−1}), ``filtered_*`` ``z⁺_k``,
    ``P⁺_k`` (given y_0 … y_k), ``smoothed_*`` given all N samples; ``gain`` is ``K_k``
    (n × m), ``innovation`` ``ν_k``; ``log_likelihood`` ``−½ Σ (m log 2π + log det S_k +
    ν_kᵀ S_k⁻¹ ν_k)``; ``nis`` the mean of ``ν_kᵀ S_k⁻¹ ν_k / m``.
    """

    predicted_mean: FloatArray
    predicted_covariance: FloatArray
    filtered_mean: FloatArray
    filtered_covariance: FloatArray
    smoothed_mean: FloatArray
    smoothed_covariance: FloatArray
    gain: FloatArray
    innovation: FloatArray
    log_likelihood: float
    nis: float


def joseph_smoother(
    transition: FloatArray,
    process: FloatArray,
    observation: FloatArray,
    measurements: FloatArray,
    initial_mean: FloatArray,
    initial_covariance: FloatArray,
) -> tuple[FloatArray, ...]:
    """Reference filter + smoother on whitened outputs (R = I); module docstring, first display.

    Returns ``(z⁻, P⁻, z⁺, P⁺, ẑ, V, K, ν, log det S, ν S⁻¹ ν)`` per step (whitened ``K``, ``ν``, ``S``).
    """
    f, q, hm, y = transition, process, observation, measurements
    steps, m = y.shape
    n = f.shape[0]
    eye_n, eye_m = np.eye(n), np.eye(m)
    xp, pp = np.empty((steps, n)), np.empty((steps, n, n))
    xf, pf = np.empty((steps, n)), np.empty((steps, n, n))
    gains, nus = np.empty((steps, n, m)), np.empty((steps, m))
    s_inv_all, logdet, quad = np.empty((steps, m, m)), np.empty(steps), np.empty(steps)
    x, p = initial_mean.copy(), symmetrised(initial_covariance)
    for k in range(steps):
        xp[k], pp[k] = x, p
        pht = p @ hm.T
        s = hm @ pht + eye_m
        s_inv = symmetrised(np.linalg.inv(s))
        gain = pht @ s_inv
        nu = y[k] - hm @ x
        gains[k], nus[k], s_inv_all[k] = gain, nu, s_inv
        logdet[k] = np.linalg.slogdet(s)[1]
        quad[k] = nu @ s_inv @ nu
        a = eye_n - gain @ hm
        xf[k] = x + gain @ nu
        pf[k] = symmetrised(a @ p @ a.T + gain @ gain.T)
        x, p = f @ xf[k], symmetrised(f @ pf[k] @ f.T + q)
    r, info = np.zeros(n), np.zeros((n, n))
    xs, vs = np.empty((steps, n)), np.empty((steps, n, n))
    for k in range(steps - 1, -1, -1):
        ell = f @ (eye_n - gains[k] @ hm)
        weighted = hm.T @ s_inv_all[k]
        r = weighted @ nus[k] + ell.T @ r
        info = symmetrised(weighted @ hm + ell.T @ info @ ell)
        xs[k] = xp[k] + pp[k] @ r
        vs[k] = symmetrised(pp[k] - pp[k] @ info @ pp[k])
    return xp, pp, xf, pf, xs, vs, gains, nus, logdet, quad


def _whitening(noise_covariance: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """``(W, L, log det R)`` with ``R = L Lᵀ``, ``W = L⁻¹``."""
    try:
        chol = np.linalg.cholesky(noise_covariance)
    except np.linalg.LinAlgError:
        raise ValueError("noise_covariance must be symmetric positive definite") from None
    return np.linalg.inv(chol), chol, 2.0 * float(np.sum(np.log(np.diag(chol))))


def kalman_smoother(
    transition: ArrayLike,
    process_covariance: ArrayLike,
    observation: ArrayLike,
    noise_covariance: ArrayLike,
    initial_mean: ArrayLike,
    initial_covariance: ArrayLike,
    measurements: ArrayLike,
) -> GaussianSmoothing:
    """Kalman filter and RTS smoother of ``z_{k+1} = F z_k + w_k``, ``y_k = H z_k + v_k``.

    ``w_k ~ N(0, Q)``, ``v_k ~ N(0, R)``, ``z_0 ~ N(m_0, P_0)``; ``measurements`` is N × m (or
    N for m = 1). The time-varying recursion with the Joseph-form update and de Jong's form
    of the RTS smoother (module docstring), O(n³) per step, all covariances returned.
    """
    f = np.atleast_2d(np.asarray(transition, dtype=float))
    n = f.shape[0]
    q = np.atleast_2d(np.asarray(process_covariance, dtype=float))
    hm = np.atleast_2d(np.asarray(observation, dtype=float))
    r = np.atleast_2d(np.asarray(noise_covariance, dtype=float))
    y = np.asarray(measurements, dtype=float)
    y = y.reshape(-1, 1) if y.ndim == 1 else y
    m = hm.shape[0]
    x0 = np.asarray(initial_mean, dtype=float).reshape(-1)
    p0 = np.atleast_2d(np.asarray(initial_covariance, dtype=float))
    if (
        f.shape != (n, n)
        or q.shape != (n, n)
        or hm.shape != (m, n)
        or r.shape != (m, m)
        or x0.shape != (n,)
        or p0.shape != (n, n)
        or y.ndim != 2
        or y.shape[1] != m
        or y.shape[0] < 1
    ):
        raise ValueError(f"inconsistent shapes: F {f.shape}, Q {q.shape}, H {hm.shape}, R {r.shape}, m0 {x0.shape}, P0 {p0.shape}, y {y.shape}")
    for name, arr in (("transition", f), ("process_covariance", q), ("observation", hm), ("noise_covariance", r), ("initial_mean", x0), ("initial_covariance", p0), ("measurements", y)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains non-finite values")
    w, chol, logdet_r = _whitening(r)
    xp, pp, xf, pf, xs, vs, gains, nus, logdet, quad = joseph_smoother(f, q, w @ hm, y @ w.T, x0, p0)
    steps = y.shape[0]
    ell = -0.5 * (float(np.sum(logdet + quad)) + steps * (m * math.log(2.0 * math.pi) + logdet_r))
    return GaussianSmoothing(
        predicted_mean=xp,
        predicted_covariance=pp,
        filtered_mean=xf,
        filtered_covariance=pf,
        smoothed_mean=xs,
        smoothed_covariance=vs,
        gain=gains @ w,
        innovation=nus @ chol.T,
        log_likelihood=ell,
        nis=float(np.sum(quad)) / (steps * m),
    )


def stationary_covariances(transition: FloatArray, process: FloatArray, observation: FloatArray) -> FloatArray:
    """Stabilising solutions ``P∞`` of ``P = F P Fᵀ − F P Hᵀ (H P Hᵀ + I)⁻¹ H P Fᵀ + Q``, batched over Q.

    Structure-preserving doubling (Chu, Fan & Lin 2005) for ``X = Aᵀ X (I + G X)⁻¹ A + Q``
    with ``A = Fᵀ``, ``G = Hᵀ H``: ``A ← A W⁻¹ A``, ``G ← G + A W⁻¹ G Aᵀ``,
    ``X ← X + Aᵀ X W⁻¹ A``, ``W = I + G X``; ``X`` after k doublings is the Riccati
    iterate after 2^k steps, the error falls like ``ρ(L)^{2^{k+1}}``.
    """
    count, n = process.shape[0], transition.shape[0]
    a = np.broadcast_to(transition.T, (count, n, n)).copy()
    g = np.broadcast_to(observation.T @ observation, (count, n, n)).copy()
    x = symmetrised(process.copy())
    eye = np.eye(n)
    for _ in range(64):
        z = np.linalg.solve(eye + g @ x, np.concatenate([a, g], axis=2))
        wa, wg = z[..., :n], z[..., n:]
        x = symmetrised(x + transposed(a) @ x @ wa)
        g = symmetrised(g + a @ wg @ transposed(a))
        a = a @ wa
        if not np.all(np.isfinite(x)):
            break
        if np.max(np.abs(a)) <= 1e-9:
            return x
    raise ArithmeticError("no stationary covariance: the model is not detectable")


__all__ = [
    "GaussianSmoothing",
    "kalman_smoother",
    "van_loan_discretisation",
]
