"""Coupled time stepping of impacts: cars in a line, stepped together, Newton on the coupler forces.

Receives cars already built at their fidelities (:mod:`femref.models`) and never builds
them: :mod:`.cars` is what a car must answer each step (and the generic linear car),
:mod:`.couplers` the coupler unknowns of a step, :mod:`.solver` the time loop with its
status.
"""

from femref.impact.cars import CarEnergy, CarModel, EndPrediction, LinearCar
from femref.impact.couplers import CouplerConvergenceError, CouplerSolve
from femref.impact.solver import ImpactResponse, initial_end_loads, solve_impact

__all__ = [
    "CarEnergy",
    "CarModel",
    "CouplerConvergenceError",
    "CouplerSolve",
    "EndPrediction",
    "ImpactResponse",
    "LinearCar",
    "initial_end_loads",
    "solve_impact",
]
