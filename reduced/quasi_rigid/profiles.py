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
point come from the full panels to the left plus the rule mapped onto the partial
panel ``[e_p, y]``.
"""

from __future__ import annotations

from typing import Any, Callable, Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

ProfileLike = float | Callable[[NDArray[np.float64]], ArrayLike]


def as_callable(profile: ProfileLike, name: str) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """A vectorised callable for a number or a callable profile (broadcast to the input's shape)."""
    if callable(profile):
        def evaluate(x: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.broadcast_to(np.asarray(profile(x), dtype=float), np.shape(x)).astype(float)
        return evaluate
    try:
        value = float(profile)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or a callable of x, got {type(profile).__name__}") from None

    def constant(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.full(np.shape(x), value)
    return constant


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
    ``nodes``, ``weights``, ``mass``, ``stiffness``, ``viscosity``. Scalars:
    ``total_mass`` ``M = S₀(l)``, ``first_moment`` ``S₁(l)``, ``second_moment``
    ``J = S₂(l)`` (about x = 0), ``mean_mass`` ``M/2l``, ``mean_compliance``
    ``⟨1/k⟩ = (1/2l)∫ dx/k`` and ``mean_viscous_time`` ``∫(c/k)/k dx / ∫ dx/k``.
    """

    def __init__(
        self,
        half_length: float,
        mass_per_length: ProfileLike,
        stiffness: ProfileLike,
        viscosity: ProfileLike = 0.0,
        jumps: Iterable[float] = (),
        *,
        gauss_points: int = 16,
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
        segment_edges = np.array([-l, *inner, l])
        if np.any(np.diff(segment_edges) <= 1e-12 * l):
            segment_edges = np.unique(np.round(segment_edges / (1e-12 * l)) * (1e-12 * l))
        self.segment_edges = segment_edges
        panel_edges = [segment_edges[0]]
        for a, b in zip(segment_edges[:-1], segment_edges[1:]):
            panel_edges.extend(np.linspace(a, b, panels_per_segment + 1)[1:])
        self.panel_edges = np.asarray(panel_edges)
        self.panel_segment = np.repeat(np.arange(segment_edges.size - 1), panels_per_segment)

        xi, wi = np.polynomial.legendre.leggauss(gauss_points)
        self._xi, self._wi = xi, wi
        a, b = self.panel_edges[:-1], self.panel_edges[1:]
        half = 0.5 * (b - a)
        self.nodes = (0.5 * (a + b))[:, None] + half[:, None] * xi
        self.weights = half[:, None] * wi

        self.mass = self.mass_function(self.nodes)
        self.stiffness = self.stiffness_function(self.nodes)
        self.viscosity = self.viscosity_function(self.nodes)
        for name, values, positive in (("mass_per_length", self.mass, True), ("stiffness", self.stiffness, True),
                                       ("viscosity", self.viscosity, False)):
            if np.any(np.isnan(values)) or (name != "viscosity" and not np.all(np.isfinite(values))):
                raise ValueError(f"{name} must be finite along the body")
            if (positive and np.any(values <= 0.0)) or np.any(values < 0.0):
                raise ValueError(f"{name} must be {'> 0' if positive else '≥ 0'} along the body")

        powers = self.nodes[..., None] ** np.arange(3)                  # (P, n, 3)
        panel_moments = np.einsum("pn,pn,pnk->pk", self.weights, self.mass, powers)
        self._cumulative = np.vstack([np.zeros(3), np.cumsum(panel_moments, axis=0)])
        self.total_mass, self.first_moment, self.second_moment = (float(v) for v in self._cumulative[-1])
        self.node_moments = self.moments(self.nodes)                     # (P, n, 3)

        with np.errstate(divide="ignore", invalid="ignore"):
            tau = np.where(self.viscosity == 0.0, 0.0, self.viscosity / self.stiffness)
        self.viscous_time = tau
        compliance = self.integrate(1.0 / self.stiffness)
        self.mean_mass = self.total_mass / (2.0 * l)
        self.mean_compliance = compliance / (2.0 * l)
        if np.any(np.isinf(tau)):
            self.mean_viscous_time = float(np.inf)
        else:
            self.mean_viscous_time = self.integrate(tau / self.stiffness) / compliance

    def integrate(self, values_at_nodes: NDArray[np.float64]) -> Any:
        """``∫_{−l}^{l} f dx`` from values at :attr:`nodes` (leading axes ``(P, n)``)."""
        return np.tensordot(self.weights, values_at_nodes, axes=([0, 1], [0, 1]))

    def panel_of(self, y: NDArray[np.float64]) -> NDArray[np.intp]:
        """Index of the panel holding each point (the last panel for y = l)."""
        return np.clip(np.searchsorted(self.panel_edges, y, side="right") - 1, 0, self.panel_edges.size - 2)

    def partial_rule(self, y: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
        """Panel index, nodes and weights of the rule on ``[e_p, y]`` for each point y: ``(…), (…, n), (…, n)``."""
        y = np.asarray(y, dtype=float)
        l = self.half_length
        if np.any(np.abs(y) > l * (1 + 1e-12)):
            raise ValueError(f"positions must lie in [−l, l] = [{-l}, {l}]")
        p = self.panel_of(y)
        start = self.panel_edges[p]
        half = 0.5 * (y - start)
        nodes = (start + half)[..., None] + half[..., None] * self._xi
        return p, nodes, half[..., None] * self._wi

    def moments(self, y: ArrayLike) -> NDArray[np.float64]:
        """``(S₀, S₁, S₂)(y) = ∫_{−l}^{y} (1, s, s²) m(s) ds`` on the last axis."""
        p, nodes, weights = self.partial_rule(y)
        partial = np.einsum("...n,...n,...nk->...k", weights, self.mass_function(nodes), nodes[..., None] ** np.arange(3))
        return self._cumulative[p] + partial

    def is_even(self, rtol: float = 1e-9) -> bool:
        """Whether the mass, stiffness and viscosity are even in x (checked at the nodes)."""
        mirrored = -self.nodes
        return all(
            np.allclose(f(mirrored), values, rtol=rtol, atol=0.0)
            for f, values in ((self.mass_function, self.mass), (self.stiffness_function, self.stiffness),
                              (self.viscosity_function, self.viscosity))
        )
