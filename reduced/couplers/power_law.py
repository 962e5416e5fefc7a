"""Power-law gear: ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``, ``γ(δ) = Σ_k γ_k |δ|^k`` (N).

:class:`PowerLawGear`: preload ``N0`` and closure-dependent damping ``γ``
(docs/formulas.md §A3); :func:`reduced.power_law_peak.power_law_peak_series` estimates its peak
closure and force in a free impact to second order in the damping.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .base import Branch, CouplerTangent, select_branch


@dataclass(frozen=True)
class PowerLawGear:
    """Power-law gear with preload and closure-dependent damping (docs/formulas.md §A3).

    ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``, ``γ(δ) = Σ_k γ_k |δ|^k`` (N).

    ``stiffness`` c (N/mⁿ), ``exponent`` n ≥ 1 (n < 1 has infinite stiffness at
    δ = 0, which no Newton iteration or stiff solver can use), ``preload`` N0 (N,
    the initial tightening: the force jumps to ±N0 as δ passes 0), ``damping``
    (γ_0 in N·s/m, γ_1 in N·s/m², …). With n = 1, N0 = 0, γ = (μ,) it is
    :class:`KelvinVoigt` (the ODE driver reproduces the closed form to 3e-11).

    Stored energy ``c|δ|^{n+1}/(n+1) + N0|δ|``; dissipation ``γ(δ) δ̇²``; tangent
    ``∂P/∂δ = n c |δ|^{n−1} + γ'(δ) δ̇``, ``∂P/∂δ̇ = γ(δ)``. One guard, ``δ`` itself
    (the preload jump; with compression-only contact the contact guard covers it).
    """

    stiffness: float
    exponent: float = 1.0
    preload: float = 0.0
    damping: tuple[float, ...] = (0.0,)

    state_size: ClassVar[int] = 0
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
        a = abs(closure)
        g = 0.0
        dg = 0.0
        for k, gk in enumerate(self.damping):
            g += gk * a**k
            if k >= 1:
                dg += k * gk * a ** (k - 1)
        return g, dg * (1.0 if closure >= 0.0 else -1.0)

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(0)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([closure])

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        (side,) = select_branch(self.guards(closure, closure_rate, state), branch)
        g, _ = self.damping_at(closure)
        return side * (self.stiffness * abs(closure) ** self.exponent + self.preload) + g * closure_rate

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        return np.zeros(0)

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        g, dg = self.damping_at(closure)
        a = abs(closure)
        spring = self.exponent * self.stiffness * a ** (self.exponent - 1.0)
        return CouplerTangent(float(spring + dg * closure_rate), float(g))

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        if not engaged:
            return 0.0
        a = abs(closure)
        return self.stiffness * a ** (self.exponent + 1.0) / (self.exponent + 1.0) + self.preload * a

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float:
        return self.damping_at(closure)[0] * closure_rate**2 if engaged else 0.0


__all__ = ["PowerLawGear"]
