"""The synthetic recordings of benchmarks/synthetic (a yard day, a fleet's month), importable by tests, and a closed-form
stand-in for their fem impacts.

benchmarks/ is not a package of the project; its ``synthetic`` generators are put on the path here.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from support.paths import REPO

if str(REPO / "benchmarks") not in sys.path:
    sys.path.insert(0, str(REPO / "benchmarks"))

from synthetic import day, fleet, impacts, writers  # noqa: E402

__all__ = ["closed_form_library", "day", "fleet", "impacts", "rigid_pair", "writers"]

M_REAR, M_FRONT, OMEGA, ZETA = 119e3, 100e3, 40.0, 0.2


def rigid_pair(t: np.ndarray, speed: float, coupled: bool) -> dict[str, np.ndarray]:
    """The pair's accelerations (m/s²) at ``t`` (s from contact): ``P = m*(ω²x + 2ζωẋ)`` over the first half period of
    ``x = v/ω_d e^{−ζωτ} sin ω_d τ``; a coupled pair is pulled back by the opposite pulse after it (no net Δv)."""
    m_star = M_REAR * M_FRONT / (M_REAR + M_FRONT)
    wd = OMEGA * math.sqrt(1.0 - ZETA**2)
    half = math.pi / wd

    def pulse(tau: np.ndarray) -> np.ndarray:
        tau = np.clip(tau, 0.0, half)
        x = speed / wd * np.exp(-ZETA * OMEGA * tau) * np.sin(wd * tau)
        rate = speed * np.exp(-ZETA * OMEGA * tau) * (np.cos(wd * tau) - ZETA * OMEGA / wd * np.sin(wd * tau))
        return np.where((tau > 0.0) & (tau < half), m_star * (OMEGA**2 * x + 2 * ZETA * OMEGA * rate), 0.0)

    force = pulse(t) - (pulse(t - half) if coupled else 0.0)
    return {probe: (-force / M_REAR if probe.startswith("car1") else force / M_FRONT) for probe in impacts.PROBES}


def closed_form_library() -> list[impacts.SimulatedImpact]:
    """Two closed-form impacts in the fem library's shape: free to roll at 2 m/s, coupled at 1.5 m/s."""
    time = np.arange(0.0, 0.5, 1e-3)
    specs = [impacts.ImpactSpec("draft_gear", 2.0), impacts.ImpactSpec("coupled", 1.5)]
    library = []
    for spec in specs:
        a = rigid_pair(time, spec.speed, spec.impact_type == "coupled")
        library.append(impacts.SimulatedImpact(spec, time, a, time, np.zeros(time.size), np.zeros(time.size)))
    return library
