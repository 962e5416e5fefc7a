"""A toy car fidelity: the car as two lumped masses, half its mass at each end, joined by its static axial
stiffness ``k = 1/∫ dx/EA`` (a Voigt dashpot ``(C/K) = cA/EA`` at its mean), a second-order system
``M ü + C u̇ + K u = B L``:

    M = (m_tot/2) I,   K = k [[1, −1], [−1, 1]],   C = τ K,   ends read u₁, u₂, a sensor at x reads the two linearly.

Its own step candidate is a twentieth of the period of its one elastic mode, ``2π √(m_tot/(4k))``.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from femref.core.body import Body
from femref.impact.systems import SecondOrderSystem
from femref.models.base import CarFidelity
from femref.scene import Car, ImpactScene


def _stiffness(body: Body) -> tuple[float, float, float]:
    """``(m_tot, k, τ)``: total mass, static axial stiffness ``1/∫ dx/EA`` and the mean ``cA/EA``."""
    x, w = body.quadrature()
    flexibility = float(np.sum(w / body.stiffness(x)))
    tau = float(np.sum(w * body.viscosity(x) / body.stiffness(x))) / (2.0 * body.half_length)
    return float(np.sum(w * body.mass_per_length(x))), 1.0 / flexibility, tau


class RigidLumpedModel(CarFidelity):
    """Impact cars only: two lumped masses joined by the car's static stiffness (module docstring)."""

    name = "rigid_lumped"
    setup_us = (900.0,)
    step_us = (2.5,)

    def car(self, car: Car, scene: ImpactScene, dt: float) -> SecondOrderSystem:
        if car.bending is not None:
            raise ValueError("a lumped car does not bend")
        mass, k, tau = _stiffness(car.body)
        stiffness = k * np.array([[1.0, -1.0], [-1.0, 1.0]])
        l = car.body.half_length
        share = (car.sensor_x + l) / (2.0 * l)
        return SecondOrderSystem("rigid_lumped", 0.5 * mass * np.eye(2), tau * stiffness, stiffness, np.array([[-1.0, 0.0], [0.0, 1.0]]), np.eye(2),
                                 np.column_stack([1.0 - share, share]), translation=np.ones(2), settings={"dofs": 2, "stiffness": k})

    def step_candidates(self, car: Car, scene: ImpactScene, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
        mass, k, _ = _stiffness(car.body)
        return {"lumped mode period / 20": 2.0 * math.pi * math.sqrt(mass / (4.0 * k)) / 20.0}


MODEL = RigidLumpedModel()
