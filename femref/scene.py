"""A resolved scene: everything a model needs, as plain numbers, profiles and signals.

The case schema (:mod:`femref.case`) validates what the user wrote; :func:`scene_from_case`
turns it into this frozen object so that the models never see YAML or pydantic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from femref.profiles import Profile


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
    def profiles(self) -> tuple[Profile, Profile, Profile]:
        return (self.mass_per_length, self.stiffness, self.viscosity)

    @property
    def jumps(self) -> tuple[float, ...]:
        return tuple(sorted({j for p in self.profiles for j in (*p.jumps, *p.kinks)}))

    def quadrature(self, panels: int = 200) -> tuple[NDArray, NDArray]:
        """Gauss points and weights on ``[−l, l]``: 5 per panel, panels ending on every jump and kink
        (exact for the piecewise-polynomial profile kinds)."""
        l = self.half_length
        edges = np.unique(np.concatenate([np.linspace(-l, l, panels + 1), self.jumps]))
        edges = edges[(edges >= -l) & (edges <= l)]
        xg, wg = np.polynomial.legendre.leggauss(5)
        mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
        return (mid[:, None] + half[:, None] * xg).ravel(), (half[:, None] * wg).ravel()

    @property
    def total_mass(self) -> float:
        """``M = ∫ m dx`` (kg) by :meth:`quadrature`."""
        x, w = self.quadrature()
        return float(np.sum(w * self.mass_per_length(x)))

    def frequency_to_lambda(self, omega: NDArray) -> NDArray:
        """``λ = ω T_wave`` (DESIGN.md §2)."""
        return np.asarray(omega) * self.wave_travel_time


@dataclass(frozen=True)
class FemSettings:
    elements: int = 64
    order: int = 2
    grading: float = 1.0
    fields: bool = False
    field_stride: int = 1


@dataclass(frozen=True, eq=False)
class Scene:
    """One resolved harmonic or transient scene of one body.

    ``loads`` maps load names (F1, F2 / N1, N2, G1, G2) to complex amplitudes (harmonic)
    or :mod:`femref.signals` objects (transient). ``dt`` is None when the runner is to
    choose it.
    """

    kind: str
    body: Body
    probes: dict[str, float]
    loads: dict[str, object]
    models: tuple[str, ...]
    fem: FemSettings = field(default_factory=FemSettings)
    omega: NDArray | None = None
    end: float | None = None
    dt: float | None = None
    output_stride: int = 1
    integrator: str = "newmark"
    rho_inf: float = 1.0

    @property
    def probe_x(self) -> NDArray[np.float64]:
        return np.array(list(self.probes.values()), dtype=float)

    @property
    def load_time_scale(self) -> float:
        """Shortest time scale of the transient loads (s); ∞ for steps."""
        scales = [s.time_scale for s in self.loads.values() if hasattr(s, "time_scale")]
        return min(scales, default=math.inf)

    @property
    def epsilon(self) -> float:
        """``ε = (T_wave/T_load)²`` (DESIGN.md §2); T_load = pulse time scale or 1/ω_max."""
        if self.kind == "harmonic":
            return float((self.body.wave_travel_time * np.max(self.omega)) ** 2)
        t_load = self.load_time_scale
        return (self.body.wave_travel_time / t_load) ** 2 if math.isfinite(t_load) else 0.0

    def time_grid(self, dt: float) -> NDArray[np.float64]:
        """Output times of a run with step ``dt`` (every ``output_stride`` steps, and the last)."""
        return dt * output_steps(steps_to(self.end, dt), self.output_stride)



def steps_to(end: float, dt: float) -> int:
    """Number of steps of size ``dt`` that reach ``end`` (at least one)."""
    return max(1, int(math.ceil(end / dt - 1e-9)))


def output_steps(steps: int, stride: int) -> NDArray[np.int64]:
    """Steps ``0, stride, 2·stride, …`` and always the last one."""
    indices = np.arange(0, steps + 1, stride)
    return indices if indices[-1] == steps else np.append(indices, steps)
