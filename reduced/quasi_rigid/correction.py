"""The quasi-static creep correction shared by the rod and the beam.

A body loaded at its ends moves, to leading order, rigidly; the stress resultant that
balances that rigid inertia is linear in the end loads ``L_j(t)``:

    R₀(s, t) = Σ_j φ_j(s) L_j(t)            (rod: axial force F₀; beam: moment G₀).

Its creep strain (rod: ``u_x``; beam: curvature ``w_xx``) is, for a Prony kernel
(:mod:`.creep`), ``κ(s,t) = Σ_i k_i L_{τ_i(s)}[R₀(s,·)](t) / k(s)``, and the correction
displacement is its n-fold integral (n = 1 rod, 2 beam) with the rigid-body modes
removed in the mass inner product (``∫ m w₁ = 0``, and ``∫ m x w₁ = 0`` for the beam):

    w₁(x, t) = ∫_{−l}^{l} Kₙ(x, s) κ(s, t) ds,
    Kₙ(x, s) = (x − s)₊^{n−1}/(n−1)! − Aₙ(s)/M − [n = 2] x B(s)/J,
    Aₙ(s) = ∫_s^l m(y)(y − s)^{n−1}/(n−1)! dy,   B(s) = ∫_s^l m(y) y (y − s) dy

(the projections of the kernel's rigid content; ``A₁ = M − S₀``,
``A₂ = S₁(l) − S₁(s) − s (M − S₀(s))``, ``B = J − S₂(s) − s (S₁(l) − S₁(s))``).
Grouping equal time constants gives the separable form used by every model:

    w₁(x, t) = Σ_j Σ_g C[x, j, g] · L_{τ_g}[L_j](t),

so a probe costs one coefficient table, and time stepping costs one filter per
(load, time-constant group). Time constants that are piecewise constant on the
body's segments are grouped exactly; a continuously varying τ is represented by
barycentric interpolation in log τ on Chebyshev points (``max_tau_groups`` of them;
its error: tests/reduced/quasi_rigid/test_frequency.py).
"""

from __future__ import annotations

import sys
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .creep import CreepKernel
from .profiles import BodyQuadrature, integration_matrix, viscous_time

ShapeFunctions = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


class CreepCorrection:
    """Coefficients ``C[x, j, g]`` and time constants ``τ_g`` of the correction ``w₁``.

    ``shapes(s, S)`` returns ``φ_j(s)`` on a new last axis from positions ``s`` and the
    cumulative moments ``S = (S₀, S₁, S₂)(s)`` on the last axis. ``order`` is 1 (rod)
    or 2 (beam). ``psi_at_nodes`` is ``ψ_{j,g} = φ_j λ_g / k`` (:meth:`_psi`, the creep strain
    per unit filtered load: ``∂C/∂x`` of the rod) at the quadrature nodes, ``(P, n, J, G)``;
    the integrals over whole panels are its Gauss sums, those over the partial panel
    ``[e_p, x]`` the integral of its interpolant through the panel's nodes (:meth:`coefficients`).
    """

    def __init__(
        self,
        quadrature: BodyQuadrature,
        order: int,
        shapes: ShapeFunctions,
        kernel: CreepKernel,
        *,
        max_tau_groups: int = 24,
    ) -> None:
        if order not in (1, 2):
            raise ValueError("order must be 1 (rod) or 2 (beam)")
        if max_tau_groups < 2:
            raise ValueError("max_tau_groups must be ≥ 2")
        self.quadrature = q = quadrature
        self.order = order
        self.shapes = shapes
        self.kernel = kernel
        weights, taus = kernel.time_constants(q.viscous_time)             # (P, n, I)
        self._choose_groups(taus, max_tau_groups)
        lam = self._sum_over_terms(weights, self._membership(taus))      # (P, n, G)

        psi = self._psi(q.nodes, q.node_moments, q.stiffness, lam)      # (P, n, J, G)
        # keep only the groups that carry weight somewhere (τ = 0 and τ = ∞ are often empty)
        G = lam.shape[-1]
        self._keep = (psi != 0.0).reshape(-1, G).any(axis=0)
        if self.interpolated:
            self._keep[1:-1] = True
        self.tau_groups = self.tau_groups[self._keep]
        psi = psi[..., self._keep]
        self.psi_at_nodes = psi
        self._panel_group_weights = lam[:, 0, self._keep]                # (P, G): λ_g on each panel when exact
        self._cum0 = _cumulative_panels(q.weights, psi)
        M, S1l, J = q.total_mass, q.first_moment, q.second_moment
        s, S = q.nodes, q.node_moments
        if order == 1:
            a = M - S[..., 0]
            self._proj0 = q.integrate(a[..., None, None] * psi) / M
        else:
            self._cum1 = _cumulative_panels(q.weights * q.nodes, psi)
            a = (S1l - S[..., 1]) - s * (M - S[..., 0])
            b = (J - S[..., 2]) - s * (S1l - S[..., 1])
            self._proj0 = q.integrate(a[..., None, None] * psi) / M
            self._proj1 = q.integrate(b[..., None, None] * psi) / J
        self.n_loads = psi.shape[2]
        # compliance share of each group, ∫ Σ_i k_i ℓ_g(τ_i)/k dx ÷ ∫ dx/k (for ε and the creep factor)
        self.group_compliance = q.integrate(lam[..., self._keep] / q.stiffness[..., None]) / q.compliance

    # -- time-constant groups -------------------------------------------------------
    def _choose_groups(self, taus: NDArray[np.float64], max_groups: int) -> None:
        """The groups for the time constants ``taus`` at the nodes, ``(P, n, I)``."""
        q = self.quadrature
        positive = taus[(taus > 0.0) & np.isfinite(taus)]
        distinct = _distinct(positive)
        self.interpolated = distinct.size > 1 and not (distinct.size <= max_groups and _piecewise_constant(taus, q.panel_segment))
        if self.interpolated:
            lo, hi = np.log(positive.min()), np.log(positive.max())
            k = np.arange(max_groups)
            nodes = 0.5 * (lo + hi) - 0.5 * (hi - lo) * np.cos(np.pi * k / (max_groups - 1))
            self._log_nodes = nodes
            bary = (-1.0) ** k
            bary[[0, -1]] *= 0.5
            self._bary = bary
            finite = np.exp(nodes)
        else:
            finite = distinct
            # a time constant's group: 0 for τ = 0, the nearest in log τ (below the geometric mean of two
            # neighbours, the lower), the last for τ = ∞: its index among these edges
            middle = np.sqrt(finite[1:] * finite[:-1])
            self._group_edges = np.array([0.0, *middle, sys.float_info.max]) if finite.size else np.zeros(1)
        self._all_groups = np.concatenate([[0.0], finite, [np.inf]])  # group 0: τ = 0, last: τ = ∞
        self.tau_groups = self._all_groups

    def _membership(self, taus: NDArray[np.float64]) -> NDArray[np.float64]:
        """Weights ``ℓ_g(τ)`` of each time constant on the groups, shape ``(..., G)``."""
        G = self._all_groups.size
        if not self.interpolated:  # each τ wholly in its group (:meth:`_choose_groups`)
            return (np.searchsorted(self._group_edges, taus)[..., None] == np.arange(G)).astype(float)
        out = np.zeros((*taus.shape, G))
        zero = taus == 0.0
        inf = np.isinf(taus)
        mid = ~(zero | inf)
        out[zero, 0] = 1.0
        out[inf, G - 1] = 1.0
        t = taus[mid]
        if t.size:
            v = np.log(t)[:, None]
            diff = v - self._log_nodes
            exact = diff == 0.0
            with np.errstate(divide="ignore", invalid="ignore"):
                terms = self._bary / diff
                ell = terms / terms.sum(axis=1, keepdims=True)
            rows = np.any(exact, axis=1)
            ell[rows] = exact[rows].astype(float)
            out[mid, 1 : G - 1] = ell
        return out

    @staticmethod
    def _sum_over_terms(weights: NDArray[np.float64], membership: NDArray[np.float64]) -> NDArray[np.float64]:
        """``λ_g = Σ_i k_i ℓ_g(τ_i)`` from the kernel's weights ``(..., I)`` and the membership ``(..., I, G)``."""
        return np.matmul(weights[..., None, :], membership)[..., 0, :]

    def _group_weights(self, tau: NDArray[np.float64]) -> NDArray[np.float64]:
        """``λ_g = Σ_i k_i ℓ_g(τ_i)`` at points of viscous time ``τ = c/k``, shape ``(..., G)``."""
        weights, taus = self.kernel.time_constants(tau)                   # (..., I)
        return self._sum_over_terms(weights, self._membership(taus))

    def _psi(self, s, S, stiffness, lam) -> NDArray[np.float64]:
        """``ψ_{j,g}(s) = φ_j(s)/k(s) · λ_g(s)`` (:meth:`_group_weights`) with shape ``(..., J, G)``."""
        phi = self.shapes(s, S)                                           # (..., J)
        return (phi / stiffness[..., None])[..., :, None] * lam[..., None, :]

    def _psi_at(self, s: NDArray[np.float64], S: NDArray[np.float64], panel: NDArray[np.intp]) -> NDArray[np.float64]:
        """ψ of the kept groups at positions s, with the moments S there and the panel of each (shaped like s).

        Time constants grouped exactly are constant on each segment, so λ_g is the panel's
        (its nodes'); interpolated ones are evaluated at s.
        """
        q = self.quadrature
        stiffness = q.stiffness_function(s)
        if self.interpolated:
            lam = self._group_weights(viscous_time(stiffness, q.viscosity_function(s)))[..., self._keep]
        else:
            lam = self._panel_group_weights[panel]
        return self._psi(s, S, stiffness, lam)

    # -- coefficients ----------------------------------------------------------------
    def coefficients(self, x: ArrayLike, derivative: int = 0) -> NDArray[np.float64]:
        """``C[x, j, g]``: the correction displacement at x per unit filtered load ``L_{τ_g}[L_j]``.

        ``derivative = 1`` gives ``∂C/∂x`` (rod: the strain per unit load; beam: the
        section rotation), from ``∂Kₙ/∂x`` (no numerical differentiation). The partial panel
        ``[e_p, x]`` integrates the interpolant of ψ through the panel's nodes
        (:meth:`BodyQuadrature.interpolant_rule`: no evaluation off the nodes, exact where ψ is a
        polynomial of degree below n on the panel) when the time constants are grouped exactly (λ_g
        constant on each panel); interpolated groups (λ_g of degree up to ``max_tau_groups`` in log τ)
        take the Gauss rule mapped onto it with ψ evaluated there (:meth:`BodyQuadrature.partial_rule`).
        """
        if derivative not in (0, 1):
            raise ValueError("derivative must be 0 or 1")
        q = self.quadrature
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if self.order == 1 and derivative == 1:
            return self._psi_at(x, q.moments(x), q.panel_of(x))
        if not self.interpolated:
            p, weights = q.interpolant_rule(x)
            return self._from_rule(x, derivative, p, q.nodes[p], weights, self.psi_at_nodes[p])
        p, points, weights = q.partial_rule(x)
        psi = self._psi_at(points, q.moments(points), np.broadcast_to(p[:, None], points.shape))
        return self._from_rule(x, derivative, p, points, weights, psi)

    def node_coefficients(self) -> NDArray[np.float64]:
        """:meth:`coefficients` at the quadrature nodes, ``(P·n, J, G)`` in the order of ``nodes.ravel()``: with
        exact groups the interpolant rule at the nodes themselves is ``h Q[k]`` (:func:`.profiles.integration_matrix`),
        one table per order."""
        q = self.quadrature
        if self.interpolated:
            return self.coefficients(q.nodes.ravel())
        P, n = q.nodes.shape
        psi = self.psi_at_nodes
        if self.order == 1:  # the rule's weights per panel times ψ there, without repeating ψ per node
            partial = q.half_widths[:, None, None] * (integration_matrix(n) @ psi.reshape(P, n, -1))
            return (partial.reshape(psi.shape) + (self._cum0[:-1, None] - self._proj0)).reshape(P * n, *psi.shape[2:])
        p = np.repeat(np.arange(P), n)
        weights = (q.half_widths[:, None, None] * integration_matrix(n)).reshape(P * n, n)
        return self._from_rule(q.nodes.ravel(), 0, p, q.nodes[p], weights, psi[p])

    def _from_rule(self, x: NDArray[np.float64], derivative: int, p: NDArray[np.intp], nodes: NDArray[np.float64],
                   weights: NDArray[np.float64], psi: NDArray[np.float64]) -> NDArray[np.float64]:
        """C (or its x-derivative) at x from a rule for ``∫_{e_p}^{x}`` over each point's partial panel
        (panel p, nodes and weights ``(X, n)``, ψ there ``(X, n, J, G)``) and the full panels left of it."""
        xb = x[:, None, None]
        if self.order == 1 or derivative == 1:
            partial = np.matmul(weights[:, None, :], psi.reshape(*weights.shape, -1)).reshape(x.size, *psi.shape[2:])
            return self._cum0[p] + partial - (self._proj0 if self.order == 1 else self._proj1)
        full = xb * self._cum0[p] - self._cum1[p]
        partial = np.einsum("xn,xnjg->xjg", weights * (x[:, None] - nodes), psi)
        return full + partial - self._proj0 - xb * self._proj1


def _cumulative_panels(weights: NDArray[np.float64], values: NDArray[np.float64]) -> NDArray[np.float64]:
    """``Σ`` of ``weights · values`` over the panels left of each panel edge, ``(P + 1, …)``: the full panels of ``∫_{−l}^{x}``."""
    P, n = weights.shape
    cumulative = np.zeros((P + 1, *values.shape[2:]))
    panels = np.matmul(weights[:, None, :], values.reshape(P, n, -1))
    np.cumsum(panels.reshape(P, *values.shape[2:]), axis=0, out=cumulative[1:])
    return cumulative


def _piecewise_constant(values: NDArray[np.float64], panel_segment: NDArray[np.intp], rtol: float = 1e-10) -> bool:
    """Whether every node's values ``(P, n, …)`` equal its segment's first node's within ``rtol`` (equal infinities too)."""
    first = values[np.searchsorted(panel_segment, panel_segment), :1]  # each panel's segment's first panel's first node
    with np.errstate(invalid="ignore"):  # ∞ − ∞
        close = (values == first) | (np.abs(values - first) <= rtol * np.abs(first))
    return bool(np.all(close))


def _distinct(values: NDArray[np.float64], rtol: float = 1e-10) -> NDArray[np.float64]:
    """Sorted distinct values, merging those within a relative tolerance."""
    if values.size == 0:
        return np.zeros(0)
    low, high = values.min(), values.max()
    if high - low <= rtol * low:  # one value (every node's, often): the sort below would merge them all
        return np.array([low])
    v = np.sort(values.ravel())
    keep = np.concatenate([[True], np.diff(v) > rtol * v[1:]])
    return v[keep]
