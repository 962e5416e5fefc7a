"""Standard-linear draft gear with a stroke (docs/formulas.md §A4; :class:`StandardLinearDraftGear`).

Packed ``p = [D, c, μ, stroke, c*]``; the functions are its arithmetic, once
(:mod:`reduced.couplers.base`); the piece is +1 closed in compression, −1 closed in tension, 0 open.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .base import Branch, PackedLaw, guard_sign


def guards(p, table, closure, state):
    """``x_g − stroke`` and ``x_g + stroke``: gear closure in compression and in tension."""
    return state - p[3], state + p[3]


def piece_of_signs(signs):
    """+1 closed in compression, −1 closed in tension, 0 open."""
    if signs[0] > 0:
        return 1
    if signs[1] < 0:
        return -1
    return 0


def piece(p, table, closure, state, strict):
    """The piece from the guards' signs at the state."""
    above, below = guards(p, table, closure, state)
    return piece_of_signs((guard_sign(above, strict), guard_sign(below, strict)))


def gear_spring(p, gear_compression, piece):
    """``F_g(x_g)`` and ``F_g'``: ``c x_g`` open (piece 0), ``c* x_g + (c − c*) stroke piece`` closed."""
    c, s, cs = p[1], p[3], p[4]
    if piece == 0:
        return c * gear_compression, c
    return cs * gear_compression + (c - cs) * s * piece, cs


def force(p, table, closure, rate, state, piece):
    """``P = (δ − x_g)/D``."""
    return (closure - state) / p[0]


def state_rate(p, table, closure, rate, state, transmitted, piece):
    """``ẋ_g = (P − F_g(x_g))/μ``."""
    fg, _ = gear_spring(p, state, piece)
    return (transmitted - fg) / p[2]


def tangent(p, table, closure, rate, state, transmitted, piece):
    """``∂P/∂δ = 1/D``, ``∂P/∂x_g = −1/D``, ``∂ẋ_g/∂x_g = −F_g'/μ``, ``∂ẋ_g/∂P = 1/μ``."""
    _, kg = gear_spring(p, state, piece)
    d, mu = p[0], p[2]
    return 1.0 / d, 0.0, -1.0 / d, 0.0, 0.0, -kg / mu, 1.0 / mu


def stored_energy(p, table, closure, state, engaged, piece):
    """``D P²/2`` (engaged) ``+ ∫₀^{x_g} F_g``."""
    d, c, s, cs = p[0], p[1], p[3], p[4]
    series = 0.5 * d * force(p, table, closure, 0.0, state, piece) ** 2 if engaged else 0.0
    if piece == 0:
        gear = 0.5 * c * state**2
    else:
        a = abs(state)
        gear = 0.5 * c * s**2 + 0.5 * cs * (a**2 - s**2) + (c - cs) * s * (a - s)
    return series + gear


def dissipation_rate(p, table, closure, rate, state, transmitted, engaged, piece):
    """``(P − F_g(x_g))²/μ``."""
    fg, _ = gear_spring(p, state, piece)
    return (transmitted - fg) ** 2 / p[2]


@dataclass(frozen=True)
class StandardLinearDraftGear(PackedLaw):
    """Standard-linear draft gear with a stroke (docs/formulas.md §A4).

    Two linear springs ``c1``, ``c2`` (car body and coupler compliance, in series:
    ``D = 1/c1 + 1/c2``) carry the coupler force to the gear element, a spring
    ``F_g(x_g)`` in parallel with a dashpot μ. The state is the gear compression
    ``x_g`` (m)::

        P     = (δ − x_g)/D                         (series springs)
        μ ẋ_g = P − F_g(x_g)                         (gear element; P transmitted)
        F_g   = c x_g                               |x_g| ≤ stroke (gear open)
              = c* x_g + (c − c*) stroke sgn(x_g)   |x_g| > stroke (gear closed, solid)

    The series springs make the gear equation first order in ``x_g`` (the printed
    source carries ``x_g'`` in the state; it is not independent). Guards
    ``x_g ∓ stroke`` mark closure. Stored energy ``D P²/2 + ∫₀^{x_g} F_g``,
    dissipation ``μ ẋ_g² = (P − F_g)²/μ``.

    Tangent: ``∂P/∂δ = 1/D``, ``∂P/∂x_g = −1/D``, ``∂ẋ_g/∂P = 1/μ``,
    ``∂ẋ_g/∂x_g = −F_g'(x_g)/μ``. Requires ``μ > 0`` (rate-independent gears need a
    different state law). Units: stiffnesses N/m, μ N·s/m, stroke m.

    Signed state (``signed_state = True``). The gear pack sits between two followers: buff
    pushes the front follower back, draft pulls the rear one forward through the yoke, and
    the pack is *compressed* in both; ``x_g > 0`` is a buff compression, ``x_g < 0`` a draft
    one. ``F_g`` is odd, so the law is odd under ``(δ, x_g, P) → (−δ, −x_g, −P)``: the open
    gear's relaxation commutes with the mirror ``x_g → −x_g`` and its energy is even. A pack
    still compressed from buff when the yoke picks it up in draft is the mirrored state
    (:meth:`reduced.couplers.Coupling.state_mirrored`; :meth:`mirror_state` is the map).
    With the pack compression ``a = |x_g|``, a bilateral contact with slack ``s_c``, ``s_t``
    and the sided state is the system (continuous in δ and a; the independent check of
    ``tests/reduced/test_gear_sides.py``)::

        P = max(0, (δ − s_c − a)/D) + min(0, (δ + s_t + a)/D),    μ ȧ = |P| − F_g(a)
    """

    series_stiffness_1: float
    series_stiffness_2: float
    gear_stiffness: float
    gear_damping: float
    stroke: float
    solid_stiffness: float

    state_size: ClassVar[int] = 1
    signed_state: ClassVar[bool] = True
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = (
        ("gear_closed", "gear_reopened"),
        ("gear_reopened_tension", "gear_closed_tension"),
    )

    def __post_init__(self) -> None:
        _checks.positive("series_stiffness_1", self.series_stiffness_1)
        _checks.positive("series_stiffness_2", self.series_stiffness_2)
        _checks.positive("gear_stiffness", self.gear_stiffness)
        _checks.positive("gear_damping", self.gear_damping)
        _checks.positive("stroke", self.stroke)
        _checks.positive("solid_stiffness", self.solid_stiffness)

    @classmethod
    def m901e_like(
        cls,
        *,
        series_stiffness: float = 4.0e8,
        gear_damping: float = 5.0e5,
        solid_stiffness: float = 2.0e8,
    ) -> StandardLinearDraftGear:
        """A Group-J (M-901E class) gear, linearised (docs/design.md §8).

        ``c = 2.52 MN / 74 mm = 34 MN/m`` (secant to the rating point), stroke 82.5 mm
        (the gear travel), solid stiffness ``c* = 200 MN/m`` (the published friction
        gear's solid stiffness); ``c1 = c2 = series_stiffness`` (car body and coupler),
        ``μ = gear_damping`` (0.2 of critical for the 119 t / 100 t pair). With the
        source study's pair it closes at 3.58 m/s (8 mph) under 3.68 MN, not at 2.68 m/s
        (80.7 mm). One gear: two cars' gears in series act as ``c/2`` with twice the stroke.
        """
        return cls(
            series_stiffness_1=series_stiffness,
            series_stiffness_2=series_stiffness,
            gear_stiffness=2.52e6 / 0.074,
            gear_damping=gear_damping,
            stroke=0.0825,
            solid_stiffness=solid_stiffness,
        )

    @property
    def series_compliance(self) -> float:
        """``D = 1/c1 + 1/c2`` (m/N)."""
        return 1.0 / self.series_stiffness_1 + 1.0 / self.series_stiffness_2

    @property
    def reference_stiffness(self) -> float:
        """Static stiffness of the open gear with the series springs (N/m)."""
        return 1.0 / (self.series_compliance + 1.0 / self.gear_stiffness)

    def pack(self) -> tuple[list[float], list[list[float]]]:
        return [self.series_compliance, self.gear_stiffness, self.gear_damping, self.stroke, self.solid_stiffness], []

    def mirror_state(self, state: NDArray[np.float64]) -> NDArray[np.float64]:
        """The same pack compression on the other side: ``x_g → −x_g`` (``|x_g|`` and ``∫₀^{x_g} F_g`` kept)."""
        return -np.asarray(state, dtype=float)

    def gear_spring(self, gear_compression: float, branch: Branch | None = None) -> tuple[float, float]:
        """``F_g(x_g)`` (N) and ``F_g'(x_g)`` (N/m) on the (frozen) piece."""
        p, table = self.packed
        return gear_spring(p, gear_compression, self._piece(p, table, 0.0, float(gear_compression), branch))


LAW = StandardLinearDraftGear
NAMES = ("standard_linear", "draft_gear")

__all__ = ["StandardLinearDraftGear"]
