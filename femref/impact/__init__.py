"""Coupled time stepping of impacts: cars in a line, stepped together, Newton on the coupler forces.

Receives cars already built at their fidelities (:mod:`femref.models`) as linear systems
(:mod:`.systems`) and never builds them: :func:`~.solver.solve_impact` is the time loop, run
compiled (:mod:`.kernels`), held by the tests to ``tests/support/reference_engine``.
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
