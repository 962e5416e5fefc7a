"""The finite-element reference model: scikit-fem rods (P1/P2) and Hermite beams.

* single body, harmonic: one complex sparse solve per frequency, rigid modes split off
  (:func:`femref.fem.harmonic_response`);
* single body, transient: generalized-α / Newmark on ``M ü + C u̇ + K u = B f(t)``
  (:class:`femref.fem.Stepper`), energies and optional fields;
* impact car: the rod's operators as a second-order system
  (:class:`femref.impact.systems.SecondOrderSystem`), built once per geometry; a car that
  bends adds Hermite beam elements on the same nodes, driven through the coupler offsets.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from femref.fem import INTEGRATORS, Stepper, harmonic_response
from femref.fem.build import FemSettings, build_operators
from femref.fem.operators import Operators, assemble_beam
from femref.impact.systems import SecondOrderSystem
from femref.models.base import Progress, built_once
from femref.results import ModelResult
from femref.scene import Car, ImpactScene, Scene


class FemModel:
    name = "fem"

    def harmonic(self, scene: Scene) -> ModelResult:
        ops = build_operators(scene.body, scene.fem)
        result = ModelResult(self.name, settings=_mesh_settings(ops, scene))
        response = harmonic_response(ops, scene.omega, scene.loads, scene.probe_x)
        result.settings["frequencies"] = int(scene.omega.size)
        result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
        _set_outputs(result, scene, response)
        return result

    def transient(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        ops = build_operators(scene.body, scene.fem)
        result = ModelResult(self.name, settings=_mesh_settings(ops, scene))
        integrator = INTEGRATORS[scene.integrator](scene.rho_inf)
        stepper = Stepper(ops, integrator, scene.dt, scene.loads)
        response = stepper.solve(scene.end, scene.probe_x, scene.output_stride, fields=scene.fem.fields, energy=True, progress=progress)
        result.settings.update(integrator=integrator.name, dt=scene.dt, steps=response.steps, factorizations=2)
        result.settings["energy_balance_error"] = response.energy_balance_error
        result.axes = {"time": response.time}
        result.energy = {
            "kinetic": response.kinetic,
            "strain": response.strain,
            "dissipated": response.dissipated,
            "external_work": response.external_work,
        }
        if response.fields is not None:
            stride = scene.fem.field_stride
            result.fields = {"x": ops.nodes, "u": response.fields[::stride], "time": response.time[::stride]}
        _set_outputs(result, scene, response)
        return result

    def car(self, car: Car, scene: ImpactScene, dt: float) -> SecondOrderSystem:
        return fem_car(car, scene.fem)


def fem_car(car: Car, settings: FemSettings) -> SecondOrderSystem:
    """The car body as scikit-fem rod elements (P1/P2), nodes on every profile jump — and, on a car that
    bends, Hermite beam elements on the same nodes (:func:`bending_system`); built once per geometry,
    sensors, offsets and mesh (:func:`femref.models.base.built_once`)."""
    bending = None if car.bending is None else car.bending.geometry
    key = ("fem", car.body.geometry, bending, car.coupler_offset, car.coupler_slope, tuple(car.sensors.values()), settings.elements,
           settings.order, settings.grading)
    return built_once(key, lambda: _fem_system(car, settings))


def car_operators(car: Car, settings: FemSettings) -> Operators:
    """The car body's assembled operators, once per geometry and mesh: the fem car and the modal car
    (which reduces them) of one body share one assembly."""
    key = ("operators", car.body.geometry, settings.elements, settings.order, settings.grading)
    return built_once(key, lambda: build_operators(car.body, settings))


def car_beam_operators(car: Car, settings: FemSettings) -> Operators:
    """The bending of a car that bends as Hermite beam operators on the nodes of its rod mesh, once per
    geometry and mesh (shared by the fem and the modal car, as :func:`car_operators`)."""
    assert car.bending is not None
    key = ("beam_operators", car.body.geometry, car.bending.geometry, settings.elements, settings.order, settings.grading)
    bending = car.bending
    return built_once(key, lambda: assemble_beam(car_operators(car, settings).nodes, bending.mass_per_length, bending.stiffness, bending.viscosity))


def _fem_system(car: Car, settings: FemSettings) -> SecondOrderSystem:
    ops = car_operators(car, settings)
    l = car.body.half_length
    outputs = ops.interpolation(np.concatenate([[-l, l], car.sensor_x])).toarray()  # the ends, then the sensors
    rod = SecondOrderSystem(
        "fem",
        ops.mass,
        ops.damping,
        ops.stiffness,
        ops.load_matrix.toarray(),
        outputs[:2],
        outputs[2:],
        translation=np.asarray(ops.rigid_modes[:, 0], dtype=float),
        settings={"element": ops.element, "elements": ops.elements, "dofs": ops.ndof, "nodes": ops.nodes},
    )
    if car.bending is None:
        return rod
    return bending_system(rod, car_beam_operators(car, settings), car.sensor_x, car.coupler_offset, car.coupler_slope)


def coupler_line(beam: Operators, offset: tuple[float, float], slope: tuple[float, float]) -> np.ndarray:
    """What the coupler line at each end reads of the beam's DOFs (2 × n_beam): ``h θ(∓l) + s w(∓l)``
    (``offset`` h below the neutral axis, ``slope`` s the coupler's inclination; docs/formulas.md §X7)."""
    l = beam.half_length
    ends = np.array([-l, l])
    rotation, deflection = beam.interpolation(ends, derivative=1).toarray(), beam.interpolation(ends, derivative=0).toarray()
    return np.array(offset)[:, None] * rotation + np.array(slope)[:, None] * deflection


def bending_system(rod: SecondOrderSystem, beam: Operators, sensor_x: np.ndarray, offset: tuple[float, float],
                   slope: tuple[float, float] = (0.0, 0.0)) -> SecondOrderSystem:
    """A car that bends: its rod and its Euler-Bernoulli beam (``beam``, DOFs ``(w, θ)`` per node) side by
    side, ``u = (u_rod, u_beam)``, joined only where the couplers act (docs/formulas.md §X7).

    A coupler acts on the coupler line, ``h`` (``offset``) below the neutral axis, where a section's
    axial displacement is ``u − z θ = u + h θ`` (Euler-Bernoulli: plane sections stay normal to the axis,
    ``θ = w'``). So the ends the couplers read and the loads they put on the car are, with the rod's
    end loads ``L = (F1, F2)`` (internal axial force at ∓l, tension positive)::

        end outputs:   u(−l) + h₁ θ(−l),   u(l) + h₂ θ(l)
        loads:         −F1 at u(−l), −h₁ F1 at θ(−l);   F2 at u(l), h₂ F2 at θ(l)

    — the beam takes the end moments ``G₁ = h₁ F1``, ``G₂ = h₂ F2`` (the beam's
    ``−G1 v'(−l) + G2 v'(l)``), and the loads are the outputs' transpose, so the coupler does
    the work ``F·Δ(u + hθ)`` and energy balances. A coupler inclined by ``s`` (``slope``, up toward
    the front) also reads ``s w`` at its end and pushes the car vertically by ``s F`` there
    (``N₁ = −s₁ F1``, ``N₂ = −s₂ F2``): its closure is the relative motion along its own line. The sensors record the rod's axial
    displacement, then the beam's ``w`` (vertical), then ``θ`` (pitch), each at every sensor.
    Zero offsets leave the beam unloaded and the rod exactly as alone.
    """
    n_rod, n_beam = rod.dofs, beam.ndof
    hooks = np.hstack([np.zeros((2, n_rod)), coupler_line(beam, offset, slope)])
    end_outputs = np.hstack([rod.end_outputs, np.zeros((2, n_beam))]) + hooks
    load_matrix = np.vstack([rod.load_matrix, np.zeros((n_beam, 2))])
    load_matrix[:, 0] -= hooks[0]
    load_matrix[:, 1] += hooks[1]
    vertical = beam.interpolation(sensor_x, derivative=0).toarray()
    pitch = beam.interpolation(sensor_x, derivative=1).toarray()
    sensors = np.vstack([
        np.hstack([rod.sensor_outputs, np.zeros((sensor_x.size, n_beam))]),
        np.hstack([np.zeros((sensor_x.size, n_rod)), vertical]),
        np.hstack([np.zeros((sensor_x.size, n_rod)), pitch]),
    ])
    settings = dict(rod.settings, dofs=n_rod + n_beam, beam_element=beam.element, coupler_offset=list(offset), coupler_slope=list(slope))
    return SecondOrderSystem(
        rod.fidelity,
        sp.block_diag([rod.mass, beam.mass], format="csr"),
        sp.block_diag([rod.damping, beam.damping], format="csr"),
        sp.block_diag([rod.stiffness, beam.stiffness], format="csr"),
        load_matrix,
        end_outputs,
        sensors,
        translation=np.concatenate([rod.translation, np.zeros(n_beam)]),
        settings=settings,
    )


def _mesh_settings(ops, scene: Scene) -> dict:
    return {"element": ops.element, "elements": ops.elements, "dofs": ops.ndof, "grading": scene.fem.grading}


def _set_outputs(result: ModelResult, scene: Scene, response) -> None:
    outputs = {"displacement": response.displacement, "acceleration": response.acceleration}
    if response.axial_force is not None:
        outputs["axial_force"] = response.axial_force
    result.set_probe_outputs(scene.probes, outputs)
