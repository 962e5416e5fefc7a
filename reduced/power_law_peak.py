"""Peak of a power-law gear's free impact: the energy-form perturbation series in the damping.

``m* δ̈ = −N(δ) − γ(δ) δ̇``, ``N = c δⁿ + N0``, ``γ = Σ_k γ_k δ^k``, ``δ(0) = 0``, ``δ̇(0) = w``
(docs/formulas.md §A3): :func:`power_law_peak_series` gives the peak closure and force to
second order in ``ε = γ(δ₀) w / N(δ₀)``, :func:`power_law_peak_estimate` its first order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from reduced.couplers import PowerLawGear
from reduced.rigid import ImpactPair


@dataclass(frozen=True)
class PowerLawPeak:
    """Peak of a power-law gear's free impact from the energy-form series (:func:`power_law_peak_series`).

    ``closure`` δ_p (m) and ``spring_force`` N(δ_p) (N, the total coupler force: δ̇ = 0 at the peak);
    ``undamped_*`` the order-0 values; ``damping_parameter`` ε; ``closure_coefficients`` a_k of
    ``δ_p/δ₀ = Σ_k a_k ε^k`` and ``force_coefficients`` b_k of ``N(δ_p)/N(δ₀) = Σ_k b_k ε^k`` (for
    reporting); ``undamped_time_to_peak`` T₀ (s).
    """

    order: int
    closure: float
    spring_force: float
    undamped_closure: float
    undamped_force: float
    damping_parameter: float
    closure_coefficients: tuple[float, ...]
    force_coefficients: tuple[float, ...]
    undamped_time_to_peak: float


_PEAK_SERIES_NODES = 96
"""Gauss-Legendre nodes per integral of :func:`power_law_peak_series` (the integrands
are smooth in θ but for x^{n+1} at θ = 0; 96 nodes agree with 128 to 1e-14 for n = 1…3
and with nested adaptive ``quad`` of the δ-form integrals to 1e-14 of δ₀)."""


def power_law_peak_series(pair: ImpactPair, law: PowerLawGear, order: int = 2) -> PowerLawPeak:
    """Peak closure and force of a power-law gear in a free impact, to ``order`` ≤ 2 in the damping.

    ``m* δ̈ = −N(δ) − γ(δ) δ̇``, ``δ(0) = 0``, ``δ̇(0) = w > 0``, ``N = c δⁿ + N0``,
    ``γ = Σ_k γ_k δ^k`` (docs/formulas.md §A3). Energy form, with ``u(δ) = δ̇²`` on
    the compression stroke and ``Φ = c δ^{n+1}/(n+1) + N0 δ``::

        du/dδ = −2N(δ)/m* − (2/m*) γ(δ) √u,    u(0) = w²

    Small parameter. Write ``x = δ/δ₀`` with ``Φ(δ₀) = m* w²/2`` (the undamped peak),
    ``γ(δ) = γ(δ₀) ĝ(x)``, ``N(δ) = N(δ₀) ν(x)`` and ``ψ(x) = 1 − Φ(δ)/Φ(δ₀)``
    (so ``u₀ = w² ψ``). Then the damping enters only through

        ε = γ(δ₀) w / N(δ₀)

    — the dashpot force at the impact speed over the undamped peak spring force, a
    ratio of two forces and so dimensionless; every other group (n, ``N0/N(δ₀)``,
    the shape ĝ and ``κ = Φ(δ₀)/(N(δ₀) δ₀)``) is fixed by the gear's shape. (The
    source's printed series adds terms in γ of different units; scaled this way each
    order is ε^k times a pure number times δ₀.) Expanding ``u = u₀ + u₁ + u₂ + …``
    (u_k ∝ ε^k)::

        u₀ = w² − 2Φ/m*,   u₁ = −(2/m*) ∫₀^δ γ √u₀,   u₂ = −(1/m*) ∫₀^δ γ u₁/√u₀

    and the root ``u(δ_p) = 0`` about δ₀ (``u₀′ = −2N/m*``, ``u₀″ = −2N′/m*``,
    ``u₁′(δ₀) = 0``) give::

        δ_p/δ₀ = 1 − ε I₁ + ε² (I₂/(2κ) − ν′(1) I₁²/2) + O(ε³)
        I₁ = ∫₀¹ ĝ √ψ dx,   I₂ = ∫₀¹ (ĝ/√ψ) ∫₀^x ĝ √ψ dx′ dx,   ν′(1) = n c δ₀ⁿ/N(δ₀)

    The first order is ``δ₁ = δ₀ − W₁/N(δ₀)``, ``W₁ = ∫₀^{δ₀} γ √u₀ dδ`` (the dissipation
    along the undamped path); the second corrects the dissipation for the slower
    damped path (I₂ > 0 raises the peak) and the curvature of u₀. The peak force is
    ``N(δ_p)`` (δ̇ = 0 there, so no dashpot force; the maximum of the coupler force in
    time comes slightly earlier and exceeds it by O(ε²)).

    Why it is O(ε³) although u₂ has an endpoint singularity: near δ₀, ``√u₀ ≈ √(A s)``
    with ``s = δ₀ − δ``, ``A = 2N(δ₀)/m*``; u₁ − u₁(δ₀) ∝ s^{3/2}, u₂ − u₂(δ₀) ∝ s^{1/2},
    and the higher u_k ∝ s^{3/2−k} (the naive series fails for s ≲ εδ₀). These
    half-integer powers are the expansion in ε of the exact ``(δ_p − δ)^{3/2}`` term
    of u, which vanishes at the root; the root is fixed by the part analytic in δ
    (the values u_k(δ₀) and integer-power derivatives, u₁′ = u₂′ = 0 there). So the
    estimate has no ε^{5/2} term: δ_p(ε) is smooth because the peak of an ODE solution
    with a smooth right-hand side depends smoothly on its parameters.

    Quadrature: ``x = sin θ`` makes both integrands smooth on [0, π/2] —
    ``√ψ cos θ`` and ``cos θ/√ψ = √2 cos(φ/2)/√(ψ/(1 − x))`` with ``φ = π/2 − θ`` —
    with ``1 − x = 2 sin²(φ/2)`` and ``1 − x^{n+1}`` by ``expm1``/``log1p`` so that
    nothing cancels near the peak; Gauss-Legendre, the inner integral of I₂ on the
    same rule mapped to [0, θ]. ``undamped_time_to_peak`` ``T₀ = (δ₀/w) ∫₀^{π/2} cos θ/√ψ dθ``.

    Checked (tests/reduced/test_nonlinear.py): the Kelvin-Voigt case gives the Taylor series of
    the closed form; against the ODE the error falls like ε² (order 1) and ε³ (order 2).
    """
    if order not in (0, 1, 2):
        raise ValueError(f"order must be 0, 1 or 2, got {order!r}")
    w = pair.closing_speed
    if not w > 0.0:
        raise ValueError(f"closing speed must be > 0 for a peak estimate, got {w!r}")
    m = pair.reduced_mass
    energy = 0.5 * m * w * w
    c, n, n0 = law.stiffness, law.exponent, law.preload

    def phi(d: float) -> float:
        return c * d ** (n + 1.0) / (n + 1.0) + n0 * d

    upper = 1.0
    while phi(upper) < energy:
        upper *= 2.0
    d0 = brentq(lambda d: phi(d) - energy, 0.0, upper, xtol=1e-15, rtol=1e-14)
    spring0 = c * d0**n + n0
    damping0 = law.damping_at(d0)[0]
    eps = damping0 * w / spring0
    kappa = energy / (spring0 * d0)
    slope0 = n * c * d0**n / spring0  # ν′(1) = δ₀ N′(δ₀)/N(δ₀)
    curvature0 = n * (n - 1.0) * c * d0**n / spring0  # ν″(1)

    nodes, weights = np.polynomial.legendre.leggauss(_PEAK_SERIES_NODES)
    half_pi = 0.5 * math.pi

    def shape(theta: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """ĝ, √ψ cos θ and cos θ/√ψ at θ (arrays of θ's shape)."""
        half_phi = 0.5 * (half_pi - theta)
        gap = 2.0 * np.sin(half_phi) ** 2  # s/δ₀ = 1 − x
        x = 1.0 - gap
        # ψ/(1 − x) = [c δ₀^{n+1}/(n+1) (1 − x^{n+1})/(1 − x) + N0 δ₀]/Φ(δ₀)
        drop = -np.expm1((n + 1.0) * np.log1p(-gap)) / gap
        psi_over_gap = (c * d0 ** (n + 1.0) / (n + 1.0) * drop + n0 * d0) / energy
        g_hat = np.zeros_like(theta)
        for k, gk in enumerate(law.damping):
            g_hat += gk * (d0 * x) ** k
        g_hat = g_hat / damping0 if damping0 > 0.0 else g_hat
        root_psi_cos = np.sqrt(psi_over_gap * gap) * np.cos(theta)
        cos_over_root_psi = math.sqrt(2.0) * np.cos(half_phi) / np.sqrt(psi_over_gap)
        return g_hat, root_psi_cos, cos_over_root_psi

    theta = half_pi * 0.5 * (nodes + 1.0)
    quad_w = half_pi * 0.5 * weights
    g_hat, root_psi_cos, cos_over_root_psi = shape(theta)
    i1 = float(np.sum(quad_w * g_hat * root_psi_cos))
    # inner integral K(θ_j) = ∫₀^{θ_j} ĝ √ψ cos θ′ dθ′ on the rule mapped to [0, θ_j]
    inner = theta[:, None] * 0.5 * (nodes[None, :] + 1.0)
    g_in, rc_in, _ = shape(inner)
    k_inner = 0.5 * theta * np.sum(weights[None, :] * g_in * rc_in, axis=1)
    i2 = float(np.sum(quad_w * g_hat * cos_over_root_psi * k_inner))
    t0 = d0 / w * float(np.sum(quad_w * cos_over_root_psi))

    a = (1.0, -i1, i2 / (2.0 * kappa) - 0.5 * slope0 * i1 * i1)[: order + 1]
    b = (1.0, slope0 * a[1] if order >= 1 else 0.0, 0.0)[: order + 1]
    if order >= 2:
        b = (b[0], b[1], slope0 * a[2] + 0.5 * curvature0 * a[1] ** 2)
    closure = d0 * sum(ak * eps**k for k, ak in enumerate(a))
    return PowerLawPeak(
        order=order,
        closure=closure,
        spring_force=c * closure**n + n0,
        undamped_closure=d0,
        undamped_force=spring0,
        damping_parameter=eps,
        closure_coefficients=tuple(float(v) for v in a),
        force_coefficients=tuple(float(v) for v in b),
        undamped_time_to_peak=t0,
    )


def power_law_peak_estimate(pair: ImpactPair, law: PowerLawGear) -> tuple[float, float]:
    """Peak closure (m) and spring force there (N) of a power-law gear, first order in γ.

    ``δ₁ = δ₀ − W₁/N(δ₀)``, ``W₁ = ∫₀^{δ₀} γ(δ) √(w² − 2Φ(δ)/m*) dδ``, ``Φ(δ₀) = m* w²/2``
    (docs/formulas.md §A3); the spring force is ``N(δ₁)``: the order-1 :func:`power_law_peak_series`.
    """
    peak = power_law_peak_series(pair, law, order=1)
    return peak.closure, peak.spring_force


__all__ = ["PowerLawPeak", "power_law_peak_estimate", "power_law_peak_series"]
