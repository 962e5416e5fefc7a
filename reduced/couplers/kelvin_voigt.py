"""Kelvin-Voigt coupler: ``P = c δ + μ δ̇`` (N), a linear spring and dashpot in parallel.

:class:`KelvinVoigt` on ``p = [c, μ]``; its two-mass closed form is
:func:`reduced.rigid.kelvin_voigt_impact`. The functions are the law's arithmetic, once
(:mod:`reduced.couplers.base`).
"""

from __future__ import annotations

from dataclasses import dataclass

from reduced import _checks

from .base import PackedLaw


def piece(p, table, closure, state, strict):
    """No guards: one piece (0)."""
    return 0


def force(p, table, closure, rate, state, piece):
    """``P = c δ + μ δ̇``."""
    return p[0] * closure + p[1] * rate


def state_rate(p, table, closure, rate, state, transmitted, piece):
    """Memoryless: 0."""
    return 0.0


def tangent(p, table, closure, rate, state, transmitted, piece):
    """``∂P/∂δ = c``, ``∂P/∂δ̇ = μ``."""
    return p[0], p[1], 0.0, 0.0, 0.0, 0.0, 0.0


def stored_energy(p, table, closure, state, engaged, piece):
    """``c δ²/2`` while engaged."""
    return 0.5 * p[0] * closure**2 if engaged else 0.0


def dissipation_rate(p, table, closure, rate, state, transmitted, engaged, piece):
    """``μ δ̇²`` while engaged."""
    return p[1] * rate**2 if engaged else 0.0


@dataclass(frozen=True)
class KelvinVoigt(PackedLaw):
    """Linear spring and dashpot in parallel: ``P = c δ + μ δ̇`` (N).

    ``stiffness`` c (N/m), ``damping`` μ (N·s/m). Stored energy ``c δ²/2``, dissipation ``μ δ̇²``.
    """

    stiffness: float
    damping: float = 0.0

    def __post_init__(self) -> None:
        _checks.positive("stiffness", self.stiffness)
        _checks.non_negative("damping", self.damping)

    @property
    def reference_stiffness(self) -> float:
        return float(self.stiffness)

    def pack(self) -> tuple[list[float], list[list[float]]]:
        return [self.stiffness, self.damping], []


LAW = KelvinVoigt
NAMES = ("kelvin_voigt",)

__all__ = ["KelvinVoigt"]
