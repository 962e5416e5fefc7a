"""A resolved body: a free rod or beam on ``x ∈ [−l, l]`` with its section-property profiles.

The case (:mod:`femref.case`) validates what the user wrote; the scene builder turns a
body spec into this frozen object, which every model, the FEM assembly and the exact
solutions read.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from femref.core.profiles import Profile
from femref.core.quadrature import gauss_legendre


@dataclass(frozen=True, eq=False)
class Body:
    """A free rod or beam on ``x ∈ [−l, l]`` with its section-property profiles.

    ``stiffness`` is EA (rod) or EI (beam); ``viscosity`` is cA or cI.
    ``wave_travel_time`` is ``T_wave = l√(m/EA)`` (rod) or ``l²√(m/EI)`` (beam) with the
    body's mean properties (s), the time unit of λ and ε.
    """

    kind: str
    half_length: float
    mass_per_length: Profile
    stiffness: Profile
    viscosity: Profile
    wave_travel_time: float

    @property
    def geometry(self) -> tuple:
        """Everything the body's models are built from, as a value (equal bodies give equal keys):
        the key under which built operators, modes and coefficients are reused."""
        return (self.kind, self.half_length, self.mass_per_length, self.stiffness, self.viscosity)

    @property
    def profiles(self) -> tuple[Profile, Profile, Profile]:
        return (self.mass_per_length, self.stiffness, self.viscosity)

    @property
    def jumps(self) -> tuple[float, ...]:
        return tuple(sorted({j for p in self.profiles for j in (*p.jumps, *p.kinks)}))

    def quadrature(self, panels: int = 200) -> tuple[NDArray, NDArray]:
        """Gauss points and weights on ``[−l, l]``: 5 per panel, panels ending on every jump and kink
        (exact for the piecewise-polynomial profile kinds)."""
        l = self.half_length
        jumps = self.jumps
        edges = np.linspace(-l, l, panels + 1)  # sorted and distinct: merged with the jumps only where there are any
        if jumps:
            edges = np.unique(np.concatenate([edges, jumps]))
            edges = edges[(edges >= -l) & (edges <= l)]
        xg, wg = gauss_legendre(5)
        mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
        return (mid[:, None] + half[:, None] * xg).ravel(), (half[:, None] * wg).ravel()

    @functools.cached_property
    def total_mass(self) -> float:
        """``M = ∫ m dx`` (kg) by :meth:`quadrature`."""
        x, w = self.quadrature()
        return float(np.sum(w * self.mass_per_length(x)))

    def frequency_to_lambda(self, omega: NDArray) -> NDArray:
        """``λ = ω T_wave`` (docs/design.md §2)."""
        return np.asarray(omega) * self.wave_travel_time
