"""Friction draft gear with hysteresis and a solid stop, tabulated as a :class:`HystereticTable`.

For ``0 ≤ δ ≤ δ_c`` (N; closure δ in m, ``δ_c`` the solid closure)::

    loading L(δ) (stiffening),    unloading U(δ) = r L(δ)

and beyond ``δ_c`` the gear is solid, both curves rising with the solid stiffness ``k_s``::

    L(δ) = L(δ_c) + k_s (δ − δ_c),    U(δ) = r L(δ_c) + k_s (δ − δ_c)

Loading curves (:class:`CubicLoading`, :class:`ExponentialLoading`) are convex with a
nondecreasing curvature; :func:`friction_gear` tabulates them (:func:`tabulation_nodes`), so
every engine that runs the table law runs this gear too, with no law code of its own
(docs/formulas.md §A6). Verified: ``tests/reduced/couplers/test_friction_gear.py`` and
``tests/impact/test_friction_gear_engines.py`` (every engine against a two-mass impact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .table import HystereticTable

#: Largest chord error of the tabulated loading curve on ``[0, δ_c]``, as a fraction of ``L(δ_c)``.
TABULATION_TOLERANCE = 1.0e-5


class LoadingCurve(Protocol):
    """A convex loading curve ``L(δ)`` (N) with ``L(0) = 0``, ``L' ≥ 0`` and a nondecreasing ``L''``."""

    def force(self, closure: float) -> float: ...

    def slope(self, closure: float) -> float: ...

    def curvature(self, closure: float) -> float: ...


@dataclass(frozen=True)
class CubicLoading:
    """``L(δ) = k1 δ + k3 δ³`` (N): ``linear_stiffness`` k1 (N/m) ≥ 0, ``cubic_stiffness`` k3 (N/m³) ≥ 0,
    not both 0. ``L' = k1 + 3 k3 δ²``, ``L'' = 6 k3 δ`` (nondecreasing for δ ≥ 0)."""

    linear_stiffness: float
    cubic_stiffness: float

    def __post_init__(self) -> None:
        _checks.non_negative("linear_stiffness", self.linear_stiffness)
        _checks.non_negative("cubic_stiffness", self.cubic_stiffness)
        if self.linear_stiffness == 0.0 and self.cubic_stiffness == 0.0:
            raise ValueError("linear_stiffness and cubic_stiffness are both 0: a gear that never pushes")

    def force(self, closure: float) -> float:
        return self.linear_stiffness * closure + self.cubic_stiffness * closure**3

    def slope(self, closure: float) -> float:
        return self.linear_stiffness + 3.0 * self.cubic_stiffness * closure**2

    def curvature(self, closure: float) -> float:
        return 6.0 * self.cubic_stiffness * closure


@dataclass(frozen=True)
class ExponentialLoading:
    """``L(δ) = a (e^{b δ} − 1)`` (N): ``amplitude`` a (N) > 0, ``rate`` b (1/m) > 0.
    ``L' = a b e^{b δ}``, ``L'' = a b² e^{b δ}`` (increasing)."""

    amplitude: float
    rate: float

    def __post_init__(self) -> None:
        _checks.positive("amplitude", self.amplitude)
        _checks.positive("rate", self.rate)

    def force(self, closure: float) -> float:
        return self.amplitude * math.expm1(self.rate * closure)

    def slope(self, closure: float) -> float:
        return self.amplitude * self.rate * math.exp(self.rate * closure)

    def curvature(self, closure: float) -> float:
        return self.amplitude * self.rate**2 * math.exp(self.rate * closure)


def tabulation_nodes(loading: LoadingCurve, solid_closure: float, tolerance: float = TABULATION_TOLERANCE) -> NDArray[np.float64]:
    """Closures ``0 = δ_0 < … < δ_m = δ_c`` (m) at which the chords of ``L`` stay within ``tolerance · L(δ_c)``.

    On a segment ``[a, b]`` the chord of a C² curve deviates from it by at most
    ``(b − a)² max|L''| / 8``; ``L''`` is nondecreasing, so its maximum is ``L''(b)``. Each
    step takes the longest ``h`` with ``h² L''(δ_i + h) = 8 tolerance L(δ_c)`` (a root of an
    increasing function, by Brent's method), the last one ends at ``δ_c``. About
    ``∫₀^{δ_c} √L'' / √(8 tolerance L(δ_c))`` nodes: at most ~230 at the default 1e-5 for
    either curve family (fewer when the linear part dominates; one segment for a linear curve).
    """
    from scipy.optimize import brentq  # scipy.optimize costs ~0.3 s to import: only a friction gear needs it

    closure_c = _checks.positive("solid_closure", solid_closure)
    tolerance = _checks.positive("tolerance", tolerance)
    bound = 8.0 * tolerance * rated_closure_force(loading, closure_c)
    nodes = [0.0]
    while nodes[-1] < closure_c:
        start = nodes[-1]
        rest = closure_c - start
        excess = lambda h: h * h * loading.curvature(start + h) - bound  # noqa: E731 — increasing in h
        if excess(rest) <= 0.0:
            nodes.append(closure_c)
            break
        step = brentq(excess, 0.0, rest, xtol=1e-12 * closure_c, rtol=1e-12)
        nodes.append(start + step if step < rest else closure_c)
    return np.array(nodes)


def rated_closure_force(loading: LoadingCurve, solid_closure: float) -> float:
    """``L(δ_c)`` (N): the force at which the gear closes solid (its rated closure force; ValueError unless finite)."""
    closure_c = _checks.positive("solid_closure", solid_closure)
    try:
        rated = float(loading.force(closure_c))
    except OverflowError:
        rated = math.inf
    if not math.isfinite(rated):
        raise ValueError(f"the loading curve overflows at the solid closure {closure_c:g} m: L(δ_c) is not finite")
    return rated


def friction_gear(
    loading: LoadingCurve,
    *,
    unloading_ratio: float,
    solid_closure: float,
    solid_stiffness: float,
    damping: float = 0.0,
    switch_velocity: float = HystereticTable.switch_velocity,
    tolerance: float = TABULATION_TOLERANCE,
) -> HystereticTable:
    """The friction gear of the module docstring as a :class:`HystereticTable` (forces N, closures m).

    ``unloading_ratio`` r in [0, 1] (friction gears 0.3–0.5, polymer-like gears near 1 with
    a ``damping`` c_v in N·s/m), ``solid_closure`` δ_c (m, > 0, typically 0.06–0.09),
    ``solid_stiffness`` k_s (N/m, at least ``L'(δ_c)``: the stop stiffens the gear; real gears
    20–50× that), ``switch_velocity`` v_s (m/s, > 0).

    The table: :func:`tabulation_nodes` on ``[0, δ_c]``, then one node on the solid line at
    ``δ_c + L(δ_c)/k_s`` (loading force ``2 L(δ_c)``), beyond which the table law's last slope
    keeps the solid part exact; ``reference_stiffness`` is the loading secant there.

    Energy: a slow cycle to ``δ_m ≤ δ_c`` dissipates the loop area ``(1 − r) ∫₀^{δ_m} L``;
    beyond ``δ_c`` the solid part is elastic (``L − U = (1 − r) L(δ_c)`` stays constant), so
    the area grows by ``(1 − r) L(δ_c) (δ_m − δ_c)``.
    """
    ratio = _checks.finite("unloading_ratio", unloading_ratio)
    if not 0.0 <= ratio <= 1.0:
        raise ValueError(f"unloading_ratio must be in [0, 1] (0 <= unloading <= loading), got {ratio!r}")
    closure_c = _checks.positive("solid_closure", solid_closure)
    stiffness_s = _checks.positive("solid_stiffness", solid_stiffness)
    rated_closure_force(loading, closure_c)  # ValueError if the curve overflows before δ_c
    slope_c = loading.slope(closure_c)
    if stiffness_s < slope_c:
        raise ValueError(
            f"solid_stiffness must be at least the loading slope at the solid closure, L'({closure_c:g} m) = {slope_c:.6g} N/m "
            f"(the solid stop stiffens the gear), got {stiffness_s!r}"
        )
    nodes = tabulation_nodes(loading, closure_c, tolerance)
    loading_force = np.array([loading.force(x) for x in nodes])
    unloading_force = ratio * loading_force
    rated, unloading_c = float(loading_force[-1]), float(unloading_force[-1])
    unloading_solid = unloading_c + rated  # both curves rise by L(δ_c) on the solid segment;
    while unloading_solid - unloading_c > rated:  # rounding must not make U's last slope exceed L's (2L − L = L exactly)
        unloading_solid = float(np.nextafter(unloading_solid, -np.inf))
    closure = (*nodes.tolist(), closure_c + rated / stiffness_s)
    loading_table = (*loading_force.tolist(), 2.0 * rated)
    unloading_table = (*unloading_force.tolist(), unloading_solid)
    return HystereticTable(closure, loading_table, unloading_table, damping=damping, switch_velocity=switch_velocity)


__all__ = [
    "CubicLoading",
    "ExponentialLoading",
    "LoadingCurve",
    "TABULATION_TOLERANCE",
    "friction_gear",
    "rated_closure_force",
    "tabulation_nodes",
]
