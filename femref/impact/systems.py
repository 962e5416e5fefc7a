"""What a car is to the impact solver: a linear system driven by its end loads.

A model builds a car (:mod:`femref.models`) as one of two descriptions, plain arrays with
no factorisation and no state, so that building is cheap and both steppers — the
readable reference (``tests/support/reference_engine``) and the compiled loop
(:mod:`femref.impact.kernels`) — start from the same numbers:

* :class:`SecondOrderSystem` (stepped by generalized-α): the FEM, modal and rigid cars;
* :class:`StateSpaceSystem` (a discrete-time system of a fixed step): the quasi-rigid car.

``L`` is the car's end-load vector (rod: ``(F1, F2)``, internal axial force at ``−l`` and
``+l``, tension positive); the end outputs are what the couplers read (rod: the
displacements at ``−l`` and ``+l``). Sensor outputs are displacements (and, for the
state-space car, velocities and accelerations) at the sensor positions: a second-order car's
sensor velocities are ``O u̇`` (plus ``R_s L̇``). :func:`car_settings_after` reports a car's
settings after a run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, eq=False)
class SecondOrderSystem:
    """``M ü + C u̇ + K u = B L``; end outputs ``E u + R_e L``, sensor outputs ``O u + R_s L``.

    ``mass``, ``damping``, ``stiffness`` (n × n; scipy sparse for a FEM car, dense numpy
    for a small FEM rod and a few modal or rigid DOFs), ``load_matrix`` B (n × J), ``end_outputs`` E (Y × n),
    ``sensor_outputs`` O (S × n), all dense but M, C, K. ``translation`` t is the DOF vector
    of a unit rigid translation (``K t = C t = 0``; every end output reads 1 from it, a sensor
    row 1 if axial and 0 if vertical or pitch on a car that bends): the car starts undeformed
    at ``velocity · t``. The optional static correction (modal
    truncation) is massless: ``end_feedthrough`` R_e (Y × J), ``sensor_feedthrough`` R_s
    (S × J), strain energy ``½ Lᵀ Q L`` (``feedthrough_energy`` Q, J × J). ``bands``, when the
    builder has them (a fem rod), is ``(p, M, C, K)`` as row bands ``A[i, i + k − p]`` at ``[k, i]``:
    what the packing takes as they are.
    """

    fidelity: str
    mass: Any
    damping: Any
    stiffness: Any
    load_matrix: NDArray[np.float64]
    end_outputs: NDArray[np.float64]
    sensor_outputs: NDArray[np.float64]
    translation: NDArray[np.float64]
    end_feedthrough: NDArray[np.float64] | None = None
    sensor_feedthrough: NDArray[np.float64] | None = None
    feedthrough_energy: NDArray[np.float64] | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    bands: tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None

    @property
    def dofs(self) -> int:
        return int(self.mass.shape[0])


@dataclass(frozen=True, eq=False)
class StateSpaceSystem:
    """``x_{n+1} = A x_n + B L_{n+1}`` for one fixed step ``dt`` (s), outputs linear in x.

    ``end_displacement`` and ``end_velocity`` (Y × n) give the end outputs and their rates,
    ``sensor_displacement``, ``sensor_velocity`` and ``sensor_acceleration`` (S × n) the sensors. The state starts at ``velocity · velocity_state + load_state @ L₀``.

    Energy: kinetic ``½ xᵀ T x`` and strain ``½ xᵀ V x`` (``kinetic_form`` T,
    ``strain_form`` V), and — the model having no dissipation of its own to book —
    ``dissipated = E₀ + W − T − V`` with ``W = Σ_steps L̄ᵀ (work_map Δy)`` the work of the
    end loads on the end outputs (``L̄`` the step-mean loads, ``work_map`` J × Y). Momentum
    ``momentum @ x`` (kg·m/s). ``settings_of_time_scale`` maps the load time scale seen in
    the run, ``π √(∫ΣL²/∫ΣL̇²)`` (s), to settings recorded after it (the quasi-rigid ε).
    """

    fidelity: str
    dt: float
    transition: NDArray[np.float64]
    input: NDArray[np.float64]
    end_displacement: NDArray[np.float64]
    end_velocity: NDArray[np.float64]
    sensor_displacement: NDArray[np.float64]
    sensor_velocity: NDArray[np.float64]
    sensor_acceleration: NDArray[np.float64]
    velocity_state: NDArray[np.float64]
    load_state: NDArray[np.float64]
    kinetic_form: NDArray[np.float64]
    strain_form: NDArray[np.float64]
    work_map: NDArray[np.float64]
    momentum: NDArray[np.float64]
    settings: dict[str, Any] = field(default_factory=dict)
    settings_of_time_scale: Callable[[float], dict[str, Any]] | None = None

    def check_step(self, dt: float) -> None:
        """ValueError unless ``dt`` is the step the system was built for (its A and B hold only there)."""
        if self.dt != dt:
            raise ValueError(f"the {self.fidelity} car was built for dt = {self.dt:g} s, not {dt:g} s")

    def initial_state(self, velocity: float, loads: NDArray[np.float64]) -> NDArray[np.float64]:
        """``x₀ = velocity · velocity_state + load_state @ L₀``."""
        return velocity * self.velocity_state + self.load_state @ np.asarray(loads, dtype=float)


CarSystem = SecondOrderSystem | StateSpaceSystem


def car_settings_after(system: CarSystem, sum_load2: float, sum_rate2: float) -> dict[str, Any]:
    """The system's settings plus what its ``settings_of_time_scale`` makes of the run's load time
    scale ``π √(∫ΣL²/∫ΣL̇²)`` (∞ while the loads have not changed)."""
    settings = dict(system.settings)
    hook = getattr(system, "settings_of_time_scale", None)
    if hook is not None:
        scale = math.inf if sum_rate2 == 0.0 else math.pi * math.sqrt(sum_load2 / sum_rate2)
        settings.update(hook(scale))
    return settings


__all__ = ["CarSystem", "SecondOrderSystem", "StateSpaceSystem", "car_settings_after"]
