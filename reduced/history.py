"""The time history of a two-car impact, shared by the rigid closed forms and the ODE driver.

The hammer car (1) strikes the anvil car (2); ``x1``, ``x2`` are their displacements
(m), ``x = x2 − x1`` the relative displacement (negative while the coupler is
compressed) and ``P`` the coupler force (N, compression positive; the force on the
hammer is ``−P``, on the anvil ``+P``). :func:`reduced.rigid.kelvin_voigt_impact` and
:func:`reduced.rigid.kelvin_voigt_perturbation` return a :class:`TwoMassHistory`;
:func:`reduced.nonlinear.simulate_impact` returns its subclass
:class:`reduced.nonlinear.ImpactSimulation` (coupler state, energies, events, solver
status).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, eq=False)
class TwoMassHistory:
    """Time histories of a two-car impact (SI units, arrays of the shape of ``time``).

    ``relative_displacement`` is ``x = x2 − x1`` (m), ``coupler_force`` is positive in
    compression (N). ``separation_time`` (s) is the first separation of a
    compression-only contact that opened, else None. ``model`` names the model that
    produced it.
    """

    time: NDArray[np.float64]
    relative_displacement: NDArray[np.float64]
    relative_velocity: NDArray[np.float64]
    relative_acceleration: NDArray[np.float64]
    hammer_displacement: NDArray[np.float64]
    hammer_velocity: NDArray[np.float64]
    hammer_acceleration: NDArray[np.float64]
    anvil_displacement: NDArray[np.float64]
    anvil_velocity: NDArray[np.float64]
    anvil_acceleration: NDArray[np.float64]
    coupler_force: NDArray[np.float64]
    separation_time: float | None
    model: str


__all__ = ["TwoMassHistory"]
