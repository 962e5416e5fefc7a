"""Profile integrals of one body, by a Gauss–Legendre rule per panel, computed once.

A body occupies ``x ∈ [−l, l]``. Its section properties are callables of x (or
numbers): mass per length ``m`` (kg/m), stiffness ``k`` (EA in N or EI in N·m²) and
viscosity ``c`` (cA in N·s or cI in N·m²·s). Jump positions (and, duck-typed, the
``jumps``/``kinks`` attributes of profile objects such as ``femref.profiles``) split
``[−l, l]`` into segments; each segment is cut into equal panels carrying a
Gauss–Legendre rule, so no node sits on a jump and each integrand is smooth on a panel
(exponential convergence for smooth pieces; a jump *inside* a panel would drop the
rule to first order).

The cumulative mass moments ``S_p(y) = ∫_{−l}^{y} s^p m(s) ds`` (p = 0, 1, 2) at any
point come from the full panels to the left plus the integral over the partial panel
``[e_p, y]`` of the interpolant of ``s^p m`` through the panel's n nodes (exact, like the
rule, for a mass polynomial of degree ≤ n − 3 on the panel — every profile kind of
``femref.profiles``; spectrally accurate for a smooth one), so m is evaluated at the
nodes only.
"""

from __future__ import annotations

import functools
from typing import Any, Callable, Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

ProfileLike = float | Callable[[NDArray[np.float64]], ArrayLike]


def as_callable(profile: ProfileLike, name: str) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """A vectorised callable for a number or a callable profile (broadcast to the input's shape)."""
    if callable(profile):
        def evaluate(x: NDArray[np.float64]) -> NDArray[np.float64]:
            values = np.array(profile(x), dtype=float)
            return values if values.shape == np.shape(x) else np.broadcast_to(values, np.shape(x)).copy()
        return evaluate
    try:
        value = float(profile)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or a callable of x, got {type(profile).__name__}") from None

    def constant(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.full(np.shape(x), value)
    return constant


@functools.cache
def _jacobi_eigensystem(points: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre nodes ``ξᵢ``, weights ``wᵢ`` and ``Pₖ(ξᵢ)`` (k < n) from one symmetric eigensolve (Golub–Welsch).

    The Jacobi matrix of the orthonormal Legendre polynomials ``p̂ₖ = √(k + ½) Pₖ`` (off-diagonal ``k/√(4k² − 1)``) has
    the nodes as eigenvalues; its normalised eigenvector ``v`` of ``ξᵢ`` is ``(p̂ₖ(ξᵢ))ₖ`` scaled, so ``wᵢ = 2 v₀ᵢ²``
    and ``Pₖ(ξᵢ) = vₖᵢ/(v₀ᵢ √(2k + 1))``. Nodes made antisymmetric, weights symmetric and summing to 2. Read-only.
    """
    k = np.arange(1.0, points)
    nodes, vectors = np.linalg.eigh(np.diag(k / np.sqrt(4.0 * k * k - 1.0), -1))
    legendre = (vectors / vectors[0]).T / np.sqrt(2.0 * np.arange(points) + 1.0)
    weights = 2.0 * vectors[0] ** 2
    nodes, weights = 0.5 * (nodes - nodes[::-1]), 0.5 * (weights + weights[::-1])
    weights *= 2.0 / weights.sum()
    for array in (nodes, weights, legendre):
        array.flags.writeable = False
    return nodes, weights, legendre


def gauss_legendre(points: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nodes ``ξ`` and weights of the ``points``-point Gauss–Legendre rule ``∫_{−1}^{1} f ≈ Σ wᵢ f(ξᵢ)``
    (:func:`_jacobi_eigensystem`: once per order; read-only, shared)."""
    nodes, weights, _ = _jacobi_eigensystem(points)
    return nodes, weights


@functools.cache
def _antiderivative_table(points: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The n + 1 Gauss–Legendre points ``ζᵢ`` of order n + 1, their barycentric weights ``(−1)ⁱ √((1 − ζᵢ²) ωᵢ)``
    (ωᵢ the rule's weights) and ``Aⱼ(ζᵢ)`` (once per order; read-only).

    ``ℓⱼ = wⱼ Σ_{m<n} (m + ½) Pₘ(ξⱼ) Pₘ`` (the rule integrates ``ℓⱼ Pₘ`` exactly) and
    ``∫_{−1}^{η} Pₘ = (P_{m+1} − P_{m−1})(η)/(2m + 1)`` (``η + 1`` for m = 0) give
    ``Aⱼ(η) = wⱼ [(η + 1)/2 + Σ_{1≤m<n} Pₘ(ξⱼ) (P_{m+1} − P_{m−1})(η)/2]``, a polynomial of degree n; the Legendre
    values at both sets of points come with their rules (:func:`_jacobi_eigensystem`).
    """
    _, wi, at_nodes = _jacobi_eigensystem(points)
    zeta, omega, at_zeta = _jacobi_eigensystem(points + 1)
    bary = (-1.0) ** np.arange(points + 1) * np.sqrt((1.0 - zeta * zeta) * omega)
    integrals = np.concatenate([at_zeta[:, 1:2] + 1.0, at_zeta[:, 2:] - at_zeta[:, :-2]], axis=1)
    values = 0.5 * (integrals @ at_nodes.T) * wi
    bary.flags.writeable = values.flags.writeable = False
    return zeta, bary, values


def lagrange_antiderivatives(eta: ArrayLike, points: int) -> NDArray[np.float64]:
    """``Aⱼ(η) = ∫_{−1}^{η} ℓⱼ(ξ) dξ`` for the Lagrange basis ``ℓⱼ`` on the ``points`` Gauss nodes, on a new last axis.

    ``Aⱼ(1) = wⱼ``; ``Σⱼ Aⱼ(η) f(ξⱼ)`` integrates the interpolant of f. A polynomial of degree
    n, evaluated by the barycentric formula on the n + 1 Gauss–Legendre points of order n + 1 (stable, no
    recurrence per point; values there from :func:`_antiderivative_table`).
    """
    zeta, bary, values = _antiderivative_table(points)
    difference = np.asarray(eta, dtype=float)[..., None] - zeta
    exact = difference == 0.0
    if not exact.any():
        terms = bary / difference
        return (terms / terms.sum(axis=-1, keepdims=True)) @ values
    with np.errstate(divide="ignore", invalid="ignore"):  # η on a point: the formula's 0/0 is replaced below
        terms = bary / difference
        interpolation = terms / terms.sum(axis=-1, keepdims=True)
    rows = np.any(exact, axis=-1)
    interpolation[rows] = exact[rows]
    return interpolation @ values


@functools.cache
def integration_matrix(points: int) -> NDArray[np.float64]:
    """``Q[k, j] = Aⱼ(ξₖ)`` (:func:`lagrange_antiderivatives` at the nodes themselves, once per order):
    ``Σⱼ Q[k, j] f(ξⱼ) = ∫_{−1}^{ξₖ} f̃``. Read-only."""
    matrix = lagrange_antiderivatives(gauss_legendre(points)[0], points)
    matrix.flags.writeable = False
    return matrix


GAUSS_POINTS = 16
"""The Gauss–Legendre rule's points per panel of a body's quadrature unless told otherwise."""

# The default order's tables (its rule, its antiderivatives' and the order above's) are one constant per process,
# whatever the body or the scene: made at import, not by the first body built (~0.3 ms, most of it the process's first
# eigensolve).
integration_matrix(GAUSS_POINTS)


def _check_profile(name: str, values: NDArray[np.float64], positive: bool) -> None:
    """Raise unless the values are finite and > 0 (``positive``) or ≥ 0, ∞ allowed (a viscosity)."""
    low = values.min()  # NaN if any is NaN
    if (low > 0.0 and values.max() < np.inf) if positive else low >= 0.0:
        return
    if np.any(np.isnan(values)) or (positive and not np.all(np.isfinite(values))):
        raise ValueError(f"{name} must be finite along the body")
    raise ValueError(f"{name} must be {'> 0' if positive else '≥ 0'} along the body")


def viscous_time(stiffness: NDArray[np.float64], viscosity: NDArray[np.float64]) -> NDArray[np.float64]:
    """``τ = c/k`` (s), 0 where ``c = 0`` (elastic, whatever k)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(viscosity == 0.0, 0.0, viscosity / stiffness)


def declared_breakpoints(profiles: Iterable[Any]) -> list[float]:
    """Jump and kink positions that profile objects declare (``.jumps``, ``.kinks``), if any."""
    points: list[float] = []
    for p in profiles:
        for attribute in ("jumps", "kinks"):
            points.extend(float(v) for v in getattr(p, attribute, ()) or ())
    return points


class BodyQuadrature:
    """Composite Gauss–Legendre rule on ``[−l, l]`` with the section properties at its nodes.

    Attributes (arrays of shape ``(P, n)`` over P panels and n nodes each):
    ``nodes``, ``weights``, ``mass``, ``stiffness``, ``viscosity``, ``viscous_time``;
    ``node_moments`` ``(P, n, 3)``, the moments at the nodes (:meth:`moments`); ``half_widths`` ``(P,)``,
    the panels' half-widths. Scalars:
    ``total_mass`` ``M = S₀(l)``, ``first_moment`` ``S₁(l)``, ``second_moment``
    ``J = S₂(l)`` (about x = 0), ``mean_mass`` ``M/2l``, ``mean_compliance``
    ``⟨1/k⟩ = (1/2l)∫ dx/k`` (``compliance`` ``∫ dx/k``) and ``mean_viscous_time`` ``∫(c/k)/k dx / ∫ dx/k``.
    """

    def __init__(
        self,
        half_length: float,
        mass_per_length: ProfileLike,
        stiffness: ProfileLike,
        viscosity: ProfileLike = 0.0,
        jumps: Iterable[float] = (),
        *,
        gauss_points: int = GAUSS_POINTS,
        panels_per_segment: int = 4,
    ) -> None:
        l = float(half_length)
        if not (np.isfinite(l) and l > 0.0):
            raise ValueError(f"half_length must be finite and > 0, got {half_length}")
        if gauss_points < 2 or panels_per_segment < 1:
            raise ValueError("gauss_points must be ≥ 2 and panels_per_segment ≥ 1")
        self.half_length = l
        self.mass_function = as_callable(mass_per_length, "mass_per_length")
        self.stiffness_function = as_callable(stiffness, "stiffness")
        self.viscosity_function = as_callable(viscosity, "viscosity")

        inner = [float(p) for p in [*jumps, *declared_breakpoints((mass_per_length, stiffness, viscosity))]]
        inner = sorted({p for p in inner if -l * (1 - 1e-12) < p < l * (1 - 1e-12)})
        edges = [-l, *inner, l]
        if any(right - left <= 1e-12 * l for left, right in zip(edges[:-1], edges[1:])):
            edges = np.unique(np.round(np.array(edges) / (1e-12 * l)) * (1e-12 * l)).tolist()
        self.segment_edges = segment_edges = np.array(edges)
        segments = segment_edges.size - 1
        a = segment_edges[:-1, None]
        panel_edges = np.empty(segments * panels_per_segment + 1)
        panel_edges[:-1] = (a + (segment_edges[1:, None] - a) * (np.arange(panels_per_segment) / panels_per_segment)).ravel()
        panel_edges[-1] = l
        self.panel_edges = panel_edges
        self.panel_segment = np.arange(segments).repeat(panels_per_segment)

        xi, wi = gauss_legendre(gauss_points)
        self._xi, self._wi = xi, wi
        a, b = panel_edges[:-1, None], panel_edges[1:, None]
        half = 0.5 * (b - a)
        self.half_widths = half[:, 0]
        self.nodes = s = (0.5 * (a + b)) + half * xi
        self.weights = half * wi
        self._flat_weights = self.weights.ravel()

        self.mass = m = self.mass_function(s)
        self.stiffness = k = self.stiffness_function(s)
        self.viscosity = c = self.viscosity_function(s)
        _check_profile("mass_per_length", m, positive=True)
        _check_profile("stiffness", k, positive=True)
        _check_profile("viscosity", c, positive=False)

        # (1, s, s²) m at the nodes, (P, n, 3): the integrands of the moments
        density = np.empty((*s.shape, 3))
        density[..., 0] = m
        np.multiply(m, s, out=density[..., 1])
        np.multiply(density[..., 1], s, out=density[..., 2])
        self._moment_density = density
        self._cumulative = cumulative = np.zeros((s.shape[0] + 1, 3))
        np.cumsum(np.matmul(self.weights[:, None, :], density)[:, 0], axis=0, out=cumulative[1:])
        self.total_mass, self.first_moment, self.second_moment = cumulative[-1].tolist()
        # the moments at the nodes, :meth:`interpolant_rule` at the nodes themselves
        self.node_moments = cumulative[:-1, None] + half[..., None] * (integration_matrix(gauss_points) @ density)

        self.viscous_time = c / k  # = viscous_time(k, c): k is finite and > 0, so c = 0 gives 0
        self.compliance = compliance = float(self._flat_weights @ (1.0 / k).ravel())
        self.mean_mass = self.total_mass / (2.0 * l)
        self.mean_compliance = compliance / (2.0 * l)

    @functools.cached_property
    def mean_viscous_time(self) -> float:
        """``∫(c/k)/k dx / ∫ dx/k`` (s; ∞ where any c is)."""
        tau = self.viscous_time
        if np.isinf(tau).any():
            return float(np.inf)
        return float(self.integrate(tau / self.stiffness)) / self.compliance

    def integrate(self, values_at_nodes: NDArray[np.float64]) -> Any:
        """``∫_{−l}^{l} f dx`` from values at :attr:`nodes` (leading axes ``(P, n)``)."""
        values = np.asarray(values_at_nodes)
        return (self._flat_weights @ values.reshape(self._flat_weights.size, -1)).reshape(values.shape[2:])

    def panel_of(self, y: NDArray[np.float64]) -> NDArray[np.intp]:
        """Index of the panel holding each point (the right one on an edge, the last one for y = l)."""
        return np.searchsorted(self.panel_edges[1:-1], y, side="right")

    def _checked_panel(self, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        y = np.asarray(y, dtype=float)
        l = self.half_length
        if (np.abs(y) > l * (1 + 1e-12)).any():
            raise ValueError(f"positions must lie in [−l, l] = [{-l}, {l}]")
        return y, self.panel_of(y)

    def partial_rule(self, y: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
        """Panel index, nodes and weights of the rule on ``[e_p, y]`` for each point y: ``(…), (…, n), (…, n)``."""
        y, p = self._checked_panel(y)
        start = self.panel_edges[p]
        half = 0.5 * (y - start)
        nodes = (start + half)[..., None] + half[..., None] * self._xi
        return p, nodes, half[..., None] * self._wi

    def interpolant_rule(self, y: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Panel index p of each point y and weights ``h Aⱼ(η)`` on that panel's nodes ``nodes[p]``: ``(…), (…, n)``.

        ``Σⱼ h Aⱼ(η) f(sⱼ) = ∫_{e_p}^{y} f̃`` with f̃ the interpolant of f through the panel's nodes
        (half-width h, y at the local coordinate η; :func:`lagrange_antiderivatives`): exact for f
        polynomial of degree < n on the panel, and f is wanted at the nodes only.
        """
        y, p = self._checked_panel(y)
        half = self.half_widths[p]
        eta = (y - self.panel_edges[p]) / half - 1.0
        return p, half[..., None] * lagrange_antiderivatives(eta, self._xi.size)

    def moments(self, y: ArrayLike) -> NDArray[np.float64]:
        """``(S₀, S₁, S₂)(y) = ∫_{−l}^{y} (1, s, s²) m(s) ds`` on the last axis: the full panels to the left
        plus :meth:`interpolant_rule` on ``[e_p, y]``."""
        p, weights = self.interpolant_rule(y)
        return self._cumulative[p] + np.einsum("...j,...jk->...k", weights, self._moment_density[p])

    def is_even(self, rtol: float = 1e-9) -> bool:
        """Whether the mass, stiffness and viscosity are even in x (checked at the nodes)."""
        mirrored = -self.nodes
        return all(
            np.allclose(f(mirrored), values, rtol=rtol, atol=0.0)
            for f, values in ((self.mass_function, self.mass), (self.stiffness_function, self.stiffness),
                              (self.viscosity_function, self.viscosity))
        )
