"""A resolved single-body scene: everything a model needs, as plain numbers, profiles and signals."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from femref.core.body import Body
from femref.core.timegrid import output_steps, steps_to
from femref.fem.build import FemSettings


@dataclass(frozen=True, eq=False)
class Scene:
    """One resolved harmonic or transient scene of one body: ``loads`` by name as complex amplitudes (harmonic) or
    :mod:`femref.core.signals` objects (transient); ``dt`` None when the runner is to choose it."""

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
        """``ε = (T_wave/T_load)²`` (docs/design.md §2); T_load = pulse time scale or 1/ω_max."""
        if self.kind == "harmonic":
            return float((self.body.wave_travel_time * np.max(self.omega)) ** 2)
        t_load = self.load_time_scale
        return (self.body.wave_travel_time / t_load) ** 2 if math.isfinite(t_load) else 0.0

    def facts(self) -> dict[str, float | str]:
        """The ``/scene`` attributes of the result file (docs/design.md §4); ``load_time`` (s) is the pulse time
        scale, ``1/ω_max`` for a harmonic scene, ∞ for steps."""
        load_time = 1.0 / float(np.max(self.omega)) if self.kind == "harmonic" else self.load_time_scale
        return {"kind": self.kind, "epsilon": float(self.epsilon), "wave_travel_time": self.body.wave_travel_time, "load_time": load_time}

    def time_grid(self, dt: float) -> NDArray[np.float64]:
        """Output times of a run with step ``dt`` (every ``output_stride`` steps, and the last)."""
        return dt * output_steps(steps_to(self.end, dt), self.output_stride)
