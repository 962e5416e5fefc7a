"""Power-law gear: ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``, ``γ(δ) = Σ_k γ_k |δ|^k`` (N).

:class:`PowerLawGear` on ``p = [c, n, N0, K, γ_0, …, γ_{K−1}]``: preload ``N0`` and
closure-dependent damping ``γ`` (docs/formulas.md §A3); the functions are its arithmetic,
once (:mod:`reduced.couplers.base`). One guard, ``δ`` itself: the piece is the side
``σ = ±1``. :func:`reduced.power_law_peak.power_law_peak_series` estimates its peak closure
and force in a free impact to second order in the damping.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from reduced import _checks

from .base import PackedLaw, guard_sign


def guards(p, table, closure, state):
    """The closure: the preload's jump."""
    return (closure,)


def piece_of_signs(signs):
    """The side ``σ``: the guard's sign."""
    return signs[0]


def piece(p, table, closure, state, strict):
    """The side ``σ = ±1`` of ``δ``."""
    return piece_of_signs((guard_sign(closure, strict),))


def gamma(p, closure):
    """``γ(δ) = Σ_k γ_k |δ|^k`` and ``dγ/dδ``."""
    a = abs(closure)
    g = 0.0
    dg = 0.0
    for k in range(int(p[3])):
        gk = p[4 + k]
        g += gk * a ** float(k)
        if k >= 1:
            dg += float(k) * gk * a ** float(k - 1)
    return g, dg * (1.0 if closure >= 0.0 else -1.0)


def force(p, table, closure, rate, state, piece):
    """``P = σ (c |δ|ⁿ + N0) + γ(δ) δ̇`` on the side ``σ = piece``."""
    g, _ = gamma(p, closure)
    return piece * (p[0] * abs(closure) ** p[1] + p[2]) + g * rate


def state_rate(p, table, closure, rate, state, transmitted, piece):
    """Memoryless: 0."""
    return 0.0


def tangent(p, table, closure, rate, state, transmitted, piece):
    """``∂P/∂δ = n c |δ|^{n−1} + γ'(δ) δ̇``, ``∂P/∂δ̇ = γ(δ)``."""
    g, dg = gamma(p, closure)
    a = abs(closure)
    spring = p[1] * p[0] * a ** (p[1] - 1.0)
    return spring + dg * rate, g, 0.0, 0.0, 0.0, 0.0, 0.0


def stored_energy(p, table, closure, state, engaged, piece):
    """``c |δ|^{n+1}/(n+1) + N0 |δ|`` while engaged."""
    if not engaged:
        return 0.0
    a = abs(closure)
    return p[0] * a ** (p[1] + 1.0) / (p[1] + 1.0) + p[2] * a


def dissipation_rate(p, table, closure, rate, state, transmitted, engaged, piece):
    """``γ(δ) δ̇²`` while engaged."""
    return gamma(p, closure)[0] * rate**2 if engaged else 0.0


@dataclass(frozen=True)
class PowerLawGear(PackedLaw):
    """Power-law gear with preload and closure-dependent damping (docs/formulas.md §A3).

    ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``, ``γ(δ) = Σ_k γ_k |δ|^k`` (N).

    ``stiffness`` c (N/mⁿ), ``exponent`` n ≥ 1 (n < 1 has infinite stiffness at
    δ = 0, which no Newton iteration or stiff solver can use), ``preload`` N0 (N,
    the initial tightening: the force jumps to ±N0 as δ passes 0), ``damping``
    (γ_0 in N·s/m, γ_1 in N·s/m², …). With n = 1, N0 = 0, γ = (μ,) it is :class:`KelvinVoigt`.

    Stored energy ``c|δ|^{n+1}/(n+1) + N0|δ|``; dissipation ``γ(δ) δ̇²``; tangent
    ``∂P/∂δ = n c |δ|^{n−1} + γ'(δ) δ̇``, ``∂P/∂δ̇ = γ(δ)``. One guard, ``δ`` itself
    (the preload jump; with compression-only contact the contact guard covers it).
    """

    stiffness: float
    exponent: float = 1.0
    preload: float = 0.0
    damping: tuple[float, ...] = (0.0,)

    guard_events: ClassVar[tuple[tuple[str, str], ...]] = (("closure_turns_compressive", "closure_turns_tensile"),)

    def __post_init__(self) -> None:
        _checks.positive("stiffness", self.stiffness)
        n = _checks.finite("exponent", self.exponent)
        if n < 1.0:
            raise ValueError(f"exponent must be >= 1 (infinite stiffness at zero closure otherwise), got {n!r}")
        _checks.non_negative("preload", self.preload)
        if len(self.damping) == 0:
            raise ValueError("damping needs at least one coefficient (gamma_0)")
        for k, g in enumerate(self.damping):
            _checks.non_negative(f"damping[{k}]", g)
        object.__setattr__(self, "damping", tuple(float(g) for g in self.damping))

    @classmethod
    def m901e_like(cls, damping: float = 5.0e5) -> PowerLawGear:
        """A Group-J (M-901E class) gear as ``P = c δ²``: 2.52 MN at the 74 mm rating travel.

        ``c = 2.52e6/0.074² ≈ 4.6e8 N/m²`` gives 3.1 MN and 86 kJ at the 82.5 mm
        travel (data sheet: 3.82 MN near 80 mm, capacity 62–71 kJ; docs/design.md §8).
        ``damping`` γ_0 (N·s/m) stands in for the gear friction.
        """
        return cls(stiffness=2.52e6 / 0.074**2, exponent=2.0, preload=0.0, damping=(damping,))

    @property
    def reference_stiffness(self) -> float:
        """Secant stiffness at 10 mm closure (N/m), for time scales only."""
        return float(self.stiffness * 0.01 ** (self.exponent - 1.0) + self.preload / 0.01)

    def damping_at(self, closure: float) -> tuple[float, float]:
        """``γ(δ)`` and ``dγ/dδ``."""
        return gamma(self.packed[0], closure)

    def pack(self) -> tuple[list[float], list[list[float]]]:
        return [self.stiffness, self.exponent, self.preload, float(len(self.damping)), *self.damping], []


LAW = PowerLawGear
NAMES = ("power_law",)

__all__ = ["PowerLawGear"]
