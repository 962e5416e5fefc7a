"""Kelvin-Voigt coupler: ``P = c δ + μ δ̇`` (N), a linear spring and dashpot in parallel.

:class:`KelvinVoigt`; its two-mass closed form is :func:`reduced.rigid.kelvin_voigt_impact`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .base import Branch, CouplerTangent


@dataclass(frozen=True)
class KelvinVoigt:
    """Linear spring and dashpot in parallel: ``P = c δ + μ δ̇`` (N).

    ``stiffness`` c (N/m), ``damping`` μ (N·s/m). Stored energy ``c δ²/2``, dissipation
    ``μ δ̇²``. Tangent: ``∂P/∂δ = c``, ``∂P/∂δ̇ = μ``. Its two-mass closed form is
    :func:`reduced.rigid.kelvin_voigt_impact`; the ODE driver reproduces it to 3e-11
    of the peaks (``tests/reduced/test_nonlinear.py``).
    """

    stiffness: float
    damping: float = 0.0

    state_size: ClassVar[int] = 0
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = ()

    def __post_init__(self) -> None:
        _checks.positive("stiffness", self.stiffness)
        _checks.non_negative("damping", self.damping)

    @classmethod
    def design_example(cls) -> KelvinVoigt:
        """The coupler of the example impact case (docs/design.md §3): 4e7 N/m, 3e5 N·s/m."""
        return cls(stiffness=4.0e7, damping=3.0e5)

    @property
    def reference_stiffness(self) -> float:
        return float(self.stiffness)

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(0)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.zeros(0)

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        return self.stiffness * closure + self.damping * closure_rate

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        return np.zeros(0)

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        return CouplerTangent(float(self.stiffness), float(self.damping))

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        return 0.5 * self.stiffness * closure**2 if engaged else 0.0

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float:
        return self.damping * closure_rate**2 if engaged else 0.0


__all__ = ["KelvinVoigt"]
