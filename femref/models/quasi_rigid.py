"""The quasi-rigid model of :mod:`reduced.quasi_rigid` as a femref model.

Two-term low-frequency perturbation of the rigid-body motion (docs/formulas.md §D, E):
harmonic scenes use the complex response, transient scenes the time-domain form with
O(1)-per-step creep filters. The ε it was computed at goes into the settings.

In an impact the car is the displacement-form stepper of :mod:`reduced.quasi_rigid.coupled`
(:class:`QuasiRigidCar`): its displacement is its rigid-body motion plus the creep deformation under the
inertia-balanced end loads (:mod:`reduced.quasi_rigid.coupled`),

    u(x, t) = q(t) + Σ_j Σ_g C[x, j, g] y_{g,j}(t),   M q̈ = F2 − F1,   τ_g ẏ + y = L_j,

stepped exactly for end loads linear within a step, so its end displacement and
velocity after a step are affine in the new loads — the prediction the coupled
solver's Newton iteration needs. The car starts undeformed at its rigid velocity
(``initial_shape="undeformed"``), whatever its initial end loads: an impact's coupler
force may jump at contact, and the deformation under it then develops through the
creep filters (an elastic car takes it within the first step).

Verified (tests/models/test_cars.py): ``predict`` is the exact affine map of ``advance``;
against the FEM car under a smooth pulse the end displacements differ by O(ε²) of the
rigid displacement (3.4e-5 at ε = 0.01, 2.4e-6 at 0.0025: slope 1.93); momentum equals
the impulse to 1e-12; a car 10⁴ times stiffer agrees with the FEM, modal and rigid cars
to 1e-6; the Voigt car's dissipated energy is within 3 % of the FEM car's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.core.body import Body
from femref.core.timegrid import output_steps, steps_to
from femref.fem import Integrator
from femref.impact.cars import CarEnergy, EndPrediction
from femref.models.base import Progress
from femref.results import ModelResult
from femref.scene import Car, ImpactScene, Scene
from reduced.quasi_rigid import LoadHistory, QuasiRigidBeam, QuasiRigidRod, QuasiRigidStepper


def quasi_rigid_body(body: Body) -> QuasiRigidRod | QuasiRigidBeam:
    """The body's quasi-rigid model (profiles and jumps as given)."""
    kind = QuasiRigidRod if body.kind == "rod" else QuasiRigidBeam
    return kind(body.half_length, body.mass_per_length, body.stiffness, body.viscosity, jumps=body.jumps)


class QuasiRigidModel:
    name = "quasi_rigid"

    def harmonic(self, scene: Scene) -> ModelResult:
        response = quasi_rigid_body(scene.body).harmonic(scene.omega, scene.probe_x, **scene.loads)
        result = ModelResult(self.name, settings={"epsilon_max": float(np.max(response.epsilon))})
        result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
        result.set_probe_outputs(scene.probes, {"acceleration": response.acceleration, "displacement": response.displacement})
        return result

    def transient(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        steps = steps_to(scene.end, scene.dt)
        t_all = scene.dt * np.arange(steps + 1)
        loads = {
            name: LoadHistory(signal, lambda t, s=signal: s.derivative(t, 1), lambda t, s=signal: s.derivative(t, 2))
            for name, signal in scene.loads.items()
        }
        response = quasi_rigid_body(scene.body).transient(t_all, scene.probe_x, **loads, load_time_scale=_finite(scene.load_time_scale))
        keep = output_steps(steps, scene.output_stride)
        result = ModelResult(self.name, settings={"epsilon": float(response.epsilon), "dt": scene.dt, "load_derivatives": "analytic"})
        result.axes = {"time": t_all[keep]}
        result.set_probe_outputs(scene.probes, {"acceleration": response.acceleration[keep], "displacement": response.displacement[keep]})
        return result

    def car(self, car: Car, scene: ImpactScene, integrator: Integrator, dt: float, loads: NDArray[np.float64]) -> "QuasiRigidCar":
        """The car as a quasi-rigid rod, undeformed at its initial velocity, sensors as probes (``integrator`` unused:
        the creep filters are stepped exactly)."""
        return quasi_rigid_car(car, dt, loads)


def _finite(value: float) -> float | None:
    return value if np.isfinite(value) else None


class QuasiRigidCar:
    """A car rod as the two-term quasi-rigid model, stepped with a fixed ``dt`` (s).

    The quasi-rigid model is asymptotic (in ``ε = (T_wave/T_load)²``) and has no exact
    energy identity. :meth:`observe` therefore reports kinetic ``½∫ m v² dx`` and strain
    ``½∫ EA u_x² dx`` (Gauss quadrature of the body) and defines

        dissipated = T₀ + W − T − V,   W = Σ_steps L̄ · (−Δu(−l), +Δu(+l)),

    the work done on the body by its end loads (trapezoidal ``L̄``; internal end forces,
    tension positive: ``−F1`` acts at ``−l``, ``+F2`` at ``+l``) less the change of
    mechanical energy. For a Voigt car it approximates the viscous dissipation; for an
    elastic car it measures the model's energy error (small, either sign): the correction's
    own kinetic energy, O(ε) of the strain energy, is not balanced by the model.
    """

    fidelity = "quasi_rigid"

    def __init__(self, rod: QuasiRigidRod, dt: float, velocity: float, sensor_x: NDArray[np.float64],
                 loads: NDArray[np.float64]) -> None:
        if not dt > 0.0:
            raise ValueError(f"the time step must be positive, got {dt}")
        self.dt = float(dt)
        self.rod = rod
        self.stepper = QuasiRigidStepper(rod, sensor_x, initial_loads=np.asarray(loads, dtype=float),
                                         initial_rigid_velocity=velocity, initial_shape="undeformed")
        self._kinetic_form, self._kinetic_cross, self._strain_form = _energy_forms(rod)
        self._initial_energy = 0.5 * rod.mass * float(velocity) ** 2
        self._work = 0.0
        self._end_displacement = self.stepper.end_displacement

    @property
    def loads(self) -> NDArray[np.float64]:
        """The current end loads ``(F1, F2)`` (N)."""
        return self.stepper.loads

    @property
    def settings(self) -> dict[str, Any]:
        """``epsilon`` at the load time scale seen so far (so: final after the run), the filter ``tau_groups`` (s)."""
        return {"epsilon": self.stepper.epsilon, "tau_groups": [float(t) for t in self.rod.tau_groups]}

    def predict(self) -> EndPrediction:
        """End displacement and velocity after the step, affine in its end loads (the stepper's ends rows)."""
        p = self.stepper.predict(self.dt)
        return EndPrediction(
            displacement=p.displacement[:2],
            displacement_gain=p.displacement_gain[:2],
            velocity=p.velocity[:2],
            velocity_gain=p.velocity_gain[:2],
        )

    def advance(self, loads: NDArray[np.float64]) -> None:
        """Step with end loads ``loads`` at the new time (linear within the step); add their work."""
        L0, u0 = self.stepper.loads, self._end_displacement
        L1 = np.asarray(loads, dtype=float)
        self.stepper.step(self.dt, *L1)
        self._end_displacement = self.stepper.end_displacement
        du = self._end_displacement - u0
        mean = 0.5 * (L0 + L1)
        self._work += float(-mean[0] * du[0] + mean[1] * du[1])

    @property
    def end_displacement(self) -> NDArray[np.float64]:
        return self._end_displacement.copy()

    @property
    def end_velocity(self) -> NDArray[np.float64]:
        return self.stepper.end_velocity

    def observe(self) -> tuple[NDArray[np.float64], NDArray[np.float64], CarEnergy]:
        """Displacement (m) and acceleration (m/s²) at the sensors, and the energies (J), now.

        ``T = ½ M q̇² + q̇ (∫ m C) z + ½ zᵀ (∫ m C Cᵀ) z`` and ``V = ½ yᵀ (∫ EA C' C'ᵀ) y`` with
        the stepper's filtered loads ``(y, z)`` (:attr:`QuasiRigidStepper.correction_loads`):
        the quadrature of ``½∫ m v²`` and ``½∫ EA u_x²`` done once, as small Gram matrices,
        at construction (the cross term is zero up to quadrature rounding: ``∫ m C dx = 0``).
        """
        y, z = (state.ravel() for state in self.stepper.correction_loads)
        rigid = float(self.stepper.rigid_velocity[0])
        kinetic = 0.5 * self.rod.mass * rigid**2 + rigid * float(self._kinetic_cross @ z)
        kinetic += 0.5 * float(z @ self._kinetic_form @ z)
        strain = 0.5 * float(y @ self._strain_form @ y)
        energy = CarEnergy(kinetic, strain, self._initial_energy + self._work - kinetic - strain)
        return self.stepper.displacement[2:], self.stepper.acceleration[2:], energy

    def momentum(self) -> float:
        """``∫ m v dx = M q̇`` (kg·m/s): the creep correction carries no momentum (``∫ m C dx = 0``)."""
        return float(self.rod.mass * self.stepper.rigid_velocity[0])


def _energy_forms(rod: QuasiRigidRod) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(∫ m C Cᵀ, ∫ m C, ∫ EA C' C'ᵀ)`` over the body's Gauss rule; C flattened as ``(g, j)``.

    ``C[x, j, g]`` (:meth:`QuasiRigidRod.coefficients`) and its x-derivative, the strain per
    unit filtered load, at the quadrature nodes (panels end on every profile jump).
    """
    q = rod.quadrature
    x = q.nodes.ravel()

    def flat(table: NDArray[np.float64]) -> NDArray[np.float64]:
        return table.transpose(0, 2, 1).reshape(x.size, -1)

    C, D = flat(rod.coefficients(x)), flat(rod.coefficients(x, derivative=1))
    mass, stiffness = (q.weights * q.mass).ravel(), (q.weights * q.stiffness).ravel()
    return C.T @ (mass[:, None] * C), mass @ C, D.T @ (stiffness[:, None] * D)


def quasi_rigid_rod(car: Car) -> QuasiRigidRod:
    """The car's body as a :class:`QuasiRigidRod` (profiles and jumps as given)."""
    if car.body.kind != "rod":
        raise ValueError(f"a quasi-rigid car is a rod, got a {car.body.kind}")
    return quasi_rigid_body(car.body)


def quasi_rigid_car(car: Car, dt: float, loads: NDArray[np.float64]) -> QuasiRigidCar:
    """The car as a quasi-rigid rod, undeformed at its initial velocity, sensors as probes."""
    return QuasiRigidCar(quasi_rigid_rod(car), dt, car.velocity, car.sensor_x, loads)
