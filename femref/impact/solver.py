"""Coupled time stepping of an impact: cars stepped implicitly, Newton on the coupler forces.

:func:`solve_impact` receives the cars as the linear systems their models built
(:mod:`femref.impact.systems`, :mod:`femref.models`) and steps them from contact (t = 0) to
the scene's end: each step every car predicts its end motion, the coupler iteration finds
the coupler forces, and each car advances with its final end loads. The car matrices are
factorised once; a step costs each car its banded products and triangular solves, plus a
Newton iteration on n_c + n_s unknowns.

The loop is compiled (:mod:`femref.impact.kernels`: no Python work per step). Like
``scipy.integrate.solve_ivp``, the result carries a ``status`` (0 reached the end, −1 a step
failed) and a ``message``: a step whose coupler iteration does not converge ends the run
there, with the histories up to the failing step and NaN after.

Energy bookkeeping at the output steps: kinetic, strain and body-dissipated energy of
the cars; stored and dissipated energy of the couplers; and the work the cars did on the
couplers (``coupler_work``). With average acceleration and Kelvin–Voigt couplers the
identity is exact while the contact mode holds, so the balance error
(:func:`femref.impact.response.energy_balance_error`: ``ΔE = W``) measures round-off and
the contact-change steps only; the cars alone balance the coupler forces' work to
round-off with average acceleration whatever the laws.
"""

from __future__ import annotations

from typing import Callable

from femref.fem import INTEGRATORS
from femref.impact.response import ImpactResponse
from femref.impact.systems import CarSystem
from femref.scene import ImpactScene


def solve_impact(
    scene: ImpactScene,
    systems: list[CarSystem],
    dt: float,
    progress: Callable[[int, int], None] | None = None,
) -> ImpactResponse:
    """Step the cars ``systems`` (line order) from contact (t = 0) to ``scene.end`` at step ``dt``;
    a step that fails ends the run with ``status = −1`` (module docstring)."""
    from femref.impact.kernels.loop import solve_compiled  # numba only where an impact is stepped

    return solve_compiled(scene, systems, INTEGRATORS[scene.integrator](scene.rho_inf), dt, progress)


__all__ = ["solve_impact"]
