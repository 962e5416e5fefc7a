"""Car models stepped in time inside the coupled impact solve.

Every car model answers the same two questions each step (:class:`CarModel`):

* :meth:`predict` — its end displacements and velocities at ``t_{n+1}`` as affine
  functions of its end loads ``L = (F1, F2)`` at ``t_{n+1}`` (internal axial force at
  ``−l`` and ``+l``, tension positive): ``u_end = u_free + G_u L``, ``v_end = v_free + G_v L``.
  The gains are the exact Jacobian the coupler Newton iteration needs (they are fixed
  for a fixed step, so the car's matrices are never refactorised);
* :meth:`advance` — commit the step once the coupler forces, hence ``L``, are known.

:class:`LinearCar` is a linear second-order system ``M ü + C u̇ + K u = B L`` stepped by
generalized-α (:class:`femref.fem.transient.StepOperators`): the FEM car (banded
matrices), the modal car (a few dense modal DOFs with a static correction) and the
rigid car (one DOF) are all instances. The quasi-rigid car wraps
:class:`reduced.quasi_rigid.QuasiRigidStepper` (:mod:`femref.models.quasi_rigid`).

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


class CarModel(Protocol):
    """What the coupled solver needs of a car, whatever its fidelity."""

    fidelity: str
    settings: dict[str, Any]
    loads: NDArray[np.float64]

    def predict(self) -> EndPrediction: ...

    def advance(self, loads: NDArray[np.float64]) -> None: ...

    def observe(self) -> tuple[NDArray[np.float64], NDArray[np.float64], CarEnergy]:
        """Displacement (m) and acceleration (m/s²) at the sensors, and the car's energies, now."""
        ...

    def momentum(self) -> float:
        """Linear momentum of the car (kg·m/s)."""
        ...


class LinearCar:
    """``M ü + C u̇ + K u = B L`` with outputs, stepped by generalized-α with step ``dt``.

    ``load_matrix`` B (ndof × 2) maps ``(F1, F2)`` to generalized forces;
    ``end_outputs`` (2 × ndof) and ``sensor_outputs`` (S × ndof) read displacements.
    Optional ``feedthrough`` is a static correction (modal truncation): outputs gain
    ``R L`` instantly — ``end_feedthrough`` (2 × 2), ``sensor_feedthrough`` (S × 2), with
    strain energy ``½ Lᵀ Q L`` (``feedthrough_energy`` Q); its velocity is the backward
    difference ``R (L_{n+1} − L_n)/dt`` and it adds no acceleration (it is massless).

    The car starts undeformed with DOF velocity ``velocity`` and end loads ``loads``
    (consistent initial acceleration ``M a₀ = B L₀ − C v₀``). With αm ≠ αf the sensors
    report the equilibrium acceleration ``M⁻¹(B L − C v − K u)``: generalized-α's own
    ``a_n`` lags by ``(αm − αf) dt``. ``translation`` t is the DOF vector of a unit rigid
    translation (``K t = C t = 0``, every output row reads 1 from it), for :meth:`momentum`
    and to keep the displacement small: after each step the rigid travel is moved from
    ``u`` into a scalar ``offset`` (``u_total = u + offset t``), so that ``K u`` and
    ``½ uᵀ K u`` do not cancel metres of travel against millimetres of deformation.
    """

    def __init__(
        self,
        fidelity: str,
        mass: Any,
        damping: Any,
        stiffness: Any,
        load_matrix: Any,
        end_outputs: Any,
        sensor_outputs: Any,
        integrator: Integrator,
        dt: float,
        velocity: NDArray[np.float64],
        loads: NDArray[np.float64],
        *,
        end_feedthrough: NDArray[np.float64] | None = None,
        sensor_feedthrough: NDArray[np.float64] | None = None,
        feedthrough_energy: NDArray[np.float64] | None = None,
        translation: NDArray[np.float64] | None = None,
        settings: dict[str, Any] | None = None,
    ) -> None:
        self.fidelity = fidelity
        self.settings = dict(settings or {})
        self.dt = dt
        sparse = sp.issparse(mass)
        self._mass, self._damping, self._stiffness = (
            (sp.dia_matrix(m) if sparse else np.asarray(m, dtype=float)) for m in (mass, damping, stiffness)
        )
        # the load and output maps have 2 columns / a few rows: dense is cheapest to apply
        self._B, self._E, self._O = (self._dense(m) for m in (load_matrix, end_outputs, sensor_outputs))
        self._mass_factor = BandedCholesky(sp.csr_matrix(mass)) if sparse else DenseCholesky(np.asarray(mass, dtype=float))
        self._step = StepOperators(mass, damping, stiffness, integrator, dt)
        self._alpha_f = integrator.alpha_f
        self._equilibrium_acceleration = integrator.alpha_m != integrator.alpha_f
        ndof = self._mass.shape[0]
        self._Z = (1.0 - self._alpha_f) * np.column_stack([self._step.effective.solve(col.copy()) for col in self._B.T])
        self._EZ = self._E @ self._Z
        self._R_end = np.zeros((2, 2)) if end_feedthrough is None else np.asarray(end_feedthrough, dtype=float)
        self._R_sensor = None if sensor_feedthrough is None else np.asarray(sensor_feedthrough, dtype=float)
        self._Q = None if feedthrough_energy is None else np.asarray(feedthrough_energy, dtype=float)
        self._displacement_gain = self._step.ca * self._EZ + self._R_end
        self._velocity_gain = self._step.cv_new * self._EZ + self._R_end / dt
        self._translation = None if translation is None else np.asarray(translation, dtype=float)
        self._pivot = None if translation is None else int(np.argmax(np.abs(self._translation)))
        self.offset = 0.0
        self.u = np.zeros(ndof)
        self.v = np.array(velocity, dtype=float)
        self.loads = np.array(loads, dtype=float)
        self.a = self._equilibrium(np.zeros(ndof))
        self._dissipated = 0.0
        self._free: tuple[NDArray, NDArray, NDArray] | None = None

    @staticmethod
    def _dense(matrix: Any) -> NDArray[np.float64]:
        return matrix.toarray() if sp.issparse(matrix) else np.asarray(matrix, dtype=float)

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
        if self._pivot is not None:  # move the rigid travel out of u (K t = C t = 0: the dynamics are unchanged)
            shift = self.u[self._pivot] / self._translation[self._pivot]
            self.u -= shift * self._translation
            self.offset += shift
        self.v = v_free + self._step.cv_new * response
        v_mid += 0.5 * self.v
        self._dissipated += self.dt * float(v_mid @ (self._damping @ v_mid))
        self.loads = np.array(loads, dtype=float)
        self._free = None

    @property
    def end_displacement(self) -> NDArray[np.float64]:
        return self._E @ self.u + self.offset + self._R_end @ self.loads

    @property
    def end_velocity(self) -> NDArray[np.float64]:
        return self._E @ self.v

    def observe(self) -> tuple[NDArray[np.float64], NDArray[np.float64], CarEnergy]:
        """Sensor displacements (m) and accelerations (m/s²), and the energies, now.

        The products ``K u`` and ``C v`` serve both the equilibrium acceleration and the
        strain energy, so an output sample costs three banded products and one solve.
        """
        stiffness_u = self._stiffness @ self.u
        mass_v = self._mass @ self.v
        displacement = self._O @ self.u + self.offset
        strain = 0.5 * float(self.u @ stiffness_u)
        if self._R_sensor is not None:
            displacement = displacement + self._R_sensor @ self.loads
            strain += 0.5 * float(self.loads @ self._Q @ self.loads)
        acceleration = self.a
        if self._equilibrium_acceleration:
            acceleration = self._equilibrium(stiffness_u)
        return displacement, self._O @ acceleration, CarEnergy(0.5 * float(self.v @ mass_v), strain, self._dissipated)

    def momentum(self) -> float:
        """Linear momentum ``tᵀ M v`` (kg·m/s), t the unit translation."""
        if self._translation is None:
            raise ValueError(f"the {self.fidelity} car was built without its translation vector")
        return float(self._translation @ (self._mass @ self.v))

    def field(self) -> NDArray[np.float64]:
        """The DOF displacement vector now (m)."""
        return self.u if self._translation is None else self.u + self.offset * self._translation
