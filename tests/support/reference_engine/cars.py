"""The reference steppers of the two car descriptions (:mod:`femref.impact.systems`), in Python: the oracle.

The compiled loop (:mod:`femref.impact.kernels`) steps the same descriptions with the same
arithmetic and is held to these readable steppers in the tests. Every car answers the
same two questions each step (:class:`CarModel`):

* :meth:`predict` — its end displacements and velocities at ``t_{n+1}`` as affine
  functions of its end loads ``L = (F1, F2)`` at ``t_{n+1}`` (internal axial force at
  ``−l`` and ``+l``, tension positive): ``u_end = u_free + G_u L``, ``v_end = v_free + G_v L``.
  The gains are the exact Jacobian the coupler Newton iteration needs (they are fixed
  for a fixed step, so the car's matrices are never refactorised);
* :meth:`advance` — commit the step once the coupler forces, hence ``L``, are known.

:class:`LinearCar` steps a :class:`~femref.impact.systems.SecondOrderSystem` by
generalized-α (:class:`femref.fem.transient.StepOperators`): the FEM, modal and rigid
cars. :class:`StateSpaceCar` steps a :class:`~femref.impact.systems.StateSpaceSystem`
(the quasi-rigid car).

Per step a LinearCar costs the three banded products and one pair of triangular solves
of the transient stepper, plus O(n) vector updates: with ``Z = (1−αf) S⁻¹ B`` computed
once, the new acceleration is ``a_free + Z L``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from femref.fem.banded import BandedCholesky
from femref.fem.transient import DenseCholesky, Integrator, StepOperators
from femref.impact.systems import CarSystem, SecondOrderSystem, StateSpaceSystem, car_settings_after


@dataclass(frozen=True, eq=False)
class EndPrediction:
    """End displacements (m) and velocities (m/s) at ``(−l, +l)`` after the step, affine in its end loads.

    ``displacement + displacement_gain @ L`` and ``velocity + velocity_gain @ L``; gains are
    2 × 2 (m/N, m/(s·N)), columns in the load order ``(F1, F2)``.
    """

    displacement: NDArray[np.float64]
    displacement_gain: NDArray[np.float64]
    velocity: NDArray[np.float64]
    velocity_gain: NDArray[np.float64]


@dataclass(frozen=True)
class CarEnergy:
    """Kinetic and strain energy now, and energy dissipated in the body so far (J)."""

    kinetic: float
    strain: float
    dissipated: float


@dataclass(frozen=True)
class Observation:
    """A car's sensor rows now — displacements (m or rad), velocities (m/s or rad/s: a pitch row's is the pitch
    rate), accelerations (m/s² or rad/s²) — and its energies."""

    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    energy: CarEnergy


class CarModel(Protocol):
    """What the coupled solver needs of a car, whatever its fidelity."""

    fidelity: str
    settings: dict[str, Any]
    loads: NDArray[np.float64]

    def predict(self) -> EndPrediction: ...

    def advance(self, loads: NDArray[np.float64]) -> None: ...

    def observe(self) -> Observation:
        """The sensor rows' displacements, velocities and accelerations, and the car's energies, now."""
        ...

    def momentum(self) -> float:
        """Linear momentum of the car (kg·m/s)."""
        ...

    def car_settings(self) -> dict[str, Any]:
        """The car's settings after the run (the system's, and what the run adds)."""
        ...


class LinearCar:
    """A :class:`SecondOrderSystem` stepped by generalized-α with step ``dt``.

    The car starts undeformed with DOF velocity ``velocity · t`` (t the system's
    translation) and end loads ``loads`` (consistent initial acceleration
    ``M a₀ = B L₀ − C v₀``). With αm ≠ αf the sensors report the equilibrium acceleration
    ``M⁻¹(B L − C v − K u)``: generalized-α's own ``a_n`` lags by ``(αm − αf) dt``. The
    feedthrough ``R L`` of a static correction is massless: its velocity is the backward
    difference ``R (L_{n+1} − L_n)/dt`` and it adds no acceleration. To keep the
    displacement small, after each step the rigid travel is moved from ``u`` into a
    scalar ``offset`` (``u_total = u + offset t``), so that ``K u`` and ``½ uᵀ K u`` do
    not cancel metres of travel against millimetres of deformation.
    """

    def __init__(self, system: SecondOrderSystem, integrator: Integrator, dt: float, velocity: float, loads: NDArray[np.float64]) -> None:
        self.system = system
        self.fidelity = system.fidelity
        self.dt = dt
        mass, damping, stiffness = system.mass, system.damping, system.stiffness
        sparse = sp.issparse(mass)
        self._mass, self._damping, self._stiffness = (
            (sp.dia_matrix(m) if sparse else np.asarray(m, dtype=float)) for m in (mass, damping, stiffness)
        )
        self._B, self._E, self._O = system.load_matrix, system.end_outputs, system.sensor_outputs
        self._mass_factor = BandedCholesky(sp.csr_matrix(mass)) if sparse else DenseCholesky(np.asarray(mass, dtype=float))
        self._step = StepOperators(mass, damping, stiffness, integrator, dt)
        self._alpha_f = integrator.alpha_f
        self._equilibrium_acceleration = integrator.alpha_m != integrator.alpha_f
        ndof = system.dofs
        self._Z = (1.0 - self._alpha_f) * np.column_stack([self._step.effective.solve(col.copy()) for col in self._B.T])
        self._EZ = self._E @ self._Z
        self._R_end = np.zeros((self._E.shape[0], self._B.shape[1])) if system.end_feedthrough is None else system.end_feedthrough
        self._R_sensor = system.sensor_feedthrough
        self._Q = system.feedthrough_energy
        self._displacement_gain = self._step.ca * self._EZ + self._R_end
        self._velocity_gain = self._step.cv_new * self._EZ + self._R_end / dt
        self._translation = system.translation
        self._sensor_travel = self._O @ self._translation  # what each sensor row reads of the travel: 1 axial, 0 vertical or pitch
        self._pivot = int(np.argmax(np.abs(self._translation)))
        self.offset = 0.0
        self.u = np.zeros(ndof)
        self.v = velocity * self._translation
        self.loads = np.array(loads, dtype=float)
        self._load_rate = np.zeros_like(self.loads)  # (L_{n+1} − L_n)/dt of the last step: the feedthrough's velocity
        self.a = self._equilibrium(np.zeros(ndof))
        self._dissipated = 0.0
        self._free: tuple[NDArray, NDArray, NDArray] | None = None

    def _equilibrium(self, stiffness_u: NDArray[np.float64]) -> NDArray[np.float64]:
        """``M⁻¹(B L − C v − K u)`` at the current state, given ``K u``."""
        return self._mass_factor.solve(self._B @ self.loads - self._damping @ self.v - stiffness_u)

    def predict(self) -> EndPrediction:
        # the step with the new end loads left out: S a = αf B L_n + history; the loads' part is Z L_{n+1}
        load = self._alpha_f * (self._B @ self.loads) if self._alpha_f else None
        a_free, u_free, v_free = self._step.step(self.u, self.v, self.a, load)
        self._free = (a_free, u_free, v_free)
        return EndPrediction(
            displacement=self._E @ u_free + self.offset,
            displacement_gain=self._displacement_gain,
            velocity=self._E @ v_free - self._R_end @ self.loads / self.dt,
            velocity_gain=self._velocity_gain,
        )

    def advance(self, loads: NDArray[np.float64]) -> None:
        if self._free is None:
            raise RuntimeError("advance() needs predict() first")
        a_free, u_free, v_free = self._free
        response = self._Z @ loads
        v_mid = 0.5 * self.v
        self.a = a_free + response
        self.u = u_free + self._step.ca * response
        # move the rigid travel out of u (K t = C t = 0: the dynamics are unchanged)
        shift = self.u[self._pivot] / self._translation[self._pivot]
        self.u -= shift * self._translation
        self.offset += shift
        self.v = v_free + self._step.cv_new * response
        v_mid += 0.5 * self.v
        self._dissipated += self.dt * float(v_mid @ (self._damping @ v_mid))
        new_loads = np.array(loads, dtype=float)
        self._load_rate = (new_loads - self.loads) / self.dt
        self.loads = new_loads
        self._free = None

    @property
    def end_displacement(self) -> NDArray[np.float64]:
        return self._E @ self.u + self.offset + self._R_end @ self.loads

    def observe(self) -> Observation:
        """Sensor displacements ``O u + R_s L``, velocities ``O v + R_s (L_n − L_{n−1})/dt`` (the feedthrough's
        backward difference, as at the ends) and accelerations ``O a``, and the energies, now.

        The products ``K u`` and ``C v`` serve both the equilibrium acceleration and the
        strain energy, so an output sample costs three banded products and one solve.
        """
        stiffness_u = self._stiffness @ self.u
        mass_v = self._mass @ self.v
        displacement = self._O @ self.u + self.offset * self._sensor_travel
        velocity = self._O @ self.v
        strain = 0.5 * float(self.u @ stiffness_u)
        if self._R_sensor is not None:
            displacement = displacement + self._R_sensor @ self.loads
            velocity = velocity + self._R_sensor @ self._load_rate
            strain += 0.5 * float(self.loads @ self._Q @ self.loads)
        acceleration = self.a
        if self._equilibrium_acceleration:
            acceleration = self._equilibrium(stiffness_u)
        energy = CarEnergy(0.5 * float(self.v @ mass_v), strain, self._dissipated)
        return Observation(displacement, velocity, self._O @ acceleration, energy)

    def momentum(self) -> float:
        """Linear momentum ``tᵀ M v`` (kg·m/s), t the unit translation."""
        return float(self._translation @ (self._mass @ self.v))

    def field(self) -> NDArray[np.float64]:
        """The DOF displacement vector now (m)."""
        return self.u + self.offset * self._translation

    def car_settings(self) -> dict[str, Any]:
        return dict(self.system.settings)


class StateSpaceCar:
    """A :class:`StateSpaceSystem` stepped as it is written: ``x_{n+1} = A x_n + B L_{n+1}``.

    ``predict`` is the free step ``A x_n`` read through the end maps, with the gains
    ``E B``; ``advance`` adds ``B L_{n+1}`` and books the end loads' work (trapezoidal ``L̄``)
    for the dissipated energy ``E₀ + W − T − V``. It also sums ``∫ΣL²`` and ``∫ΣL̇²``, whose
    ratio gives the load time scale ``π √(∫ΣL²/∫ΣL̇²)`` of the run (:meth:`car_settings`).
    """

    def __init__(self, system: StateSpaceSystem, velocity: float, loads: NDArray[np.float64]) -> None:
        self.system = system
        self.fidelity = system.fidelity
        self.dt = system.dt
        self.loads = np.array(loads, dtype=float)
        self.x = system.initial_state(velocity, self.loads)
        self._displacement_gain = system.end_displacement @ system.input
        self._velocity_gain = system.end_velocity @ system.input
        self._initial_energy = self._mechanical_energy()
        self._work = 0.0
        self._sum_load2 = 0.0
        self._sum_rate2 = 0.0
        self._free: NDArray[np.float64] | None = None

    def _mechanical_energy(self) -> float:
        return 0.5 * float(self.x @ self.system.kinetic_form @ self.x) + 0.5 * float(self.x @ self.system.strain_form @ self.x)

    def predict(self) -> EndPrediction:
        self._free = self.system.transition @ self.x
        return EndPrediction(
            displacement=self.system.end_displacement @ self._free,
            displacement_gain=self._displacement_gain,
            velocity=self.system.end_velocity @ self._free,
            velocity_gain=self._velocity_gain,
        )

    def advance(self, loads: NDArray[np.float64]) -> None:
        if self._free is None:
            raise RuntimeError("advance() needs predict() first")
        L0, L1 = self.loads, np.array(loads, dtype=float)
        before = self.end_displacement
        self.x = self._free + self.system.input @ L1
        self._work += float(0.5 * (L0 + L1) @ self.system.work_map @ (self.end_displacement - before))
        slope = (L1 - L0) / self.dt
        self._sum_load2 += 0.5 * self.dt * float(L0 @ L0 + L1 @ L1)
        self._sum_rate2 += self.dt * float(slope @ slope)
        self.loads = L1
        self._free = None

    @property
    def end_displacement(self) -> NDArray[np.float64]:
        return self.system.end_displacement @ self.x

    @property
    def end_velocity(self) -> NDArray[np.float64]:
        return self.system.end_velocity @ self.x

    def observe(self) -> Observation:
        kinetic = 0.5 * float(self.x @ self.system.kinetic_form @ self.x)
        strain = 0.5 * float(self.x @ self.system.strain_form @ self.x)
        energy = CarEnergy(kinetic, strain, self._initial_energy + self._work - kinetic - strain)
        system = self.system
        return Observation(system.sensor_displacement @ self.x, system.sensor_velocity @ self.x, system.sensor_acceleration @ self.x, energy)

    def momentum(self) -> float:
        return float(self.system.momentum @ self.x)

    def car_settings(self) -> dict[str, Any]:
        return car_settings_after(self.system, self._sum_load2, self._sum_rate2)


def reference_car(system: CarSystem, integrator: Integrator, dt: float, velocity: float, loads: NDArray[np.float64]) -> CarModel:
    """The Python stepper of a car description: :class:`LinearCar` or :class:`StateSpaceCar`."""
    if isinstance(system, StateSpaceSystem):
        system.check_step(dt)
        return StateSpaceCar(system, velocity, loads)
    return LinearCar(system, integrator, dt, velocity, loads)
