"""The readable impact engine, in Python: the oracle the compiled engine (:mod:`femref.impact.kernels`) is held to.

:mod:`.cars` the Python steppers of the two car descriptions, :mod:`.couplers` the coupler
iteration of one step (:class:`CouplerSolve`), :mod:`.solver` the time loop
(:func:`solve_reference`, :func:`step_reference`). Same arithmetic as the compiled engine,
operation by operation; the laws are the same functions (their dataclass methods).
"""

from .cars import CarEnergy, CarModel, EndPrediction, LinearCar, Observation, StateSpaceCar, reference_car
from .couplers import CouplerSolve, same_sign
from .solver import initial_end_loads, reference_cars, solve_reference, step_reference

__all__ = [
    "CarEnergy",
    "CarModel",
    "CouplerSolve",
    "EndPrediction",
    "LinearCar",
    "Observation",
    "StateSpaceCar",
    "initial_end_loads",
    "reference_car",
    "reference_cars",
    "same_sign",
    "solve_reference",
    "step_reference",
]
