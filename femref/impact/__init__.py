"""Coupled time stepping of impacts: cars in a line, stepped together, Newton on the coupler forces.

Receives cars already built at their fidelities (:mod:`femref.models`) as linear systems
(:mod:`.systems`) and never builds them: :func:`~.solver.solve_impact` is the time loop, returning an
:class:`~.response.ImpactResponse` with its status, run compiled (:mod:`.kernels`: the cars, the
coupler iteration and the loop in numba; :mod:`.couplers` its limits, tolerances and failures).
The readable twin the tests hold it to is ``tests/support/reference_engine``.
"""

from femref.impact.couplers import CouplerConvergenceError
from femref.impact.response import ImpactResponse
from femref.impact.solver import solve_impact
from femref.impact.systems import CarSystem, SecondOrderSystem, StateSpaceSystem

__all__ = [
    "CarSystem",
    "CouplerConvergenceError",
    "ImpactResponse",
    "SecondOrderSystem",
    "StateSpaceSystem",
    "solve_impact",
]
