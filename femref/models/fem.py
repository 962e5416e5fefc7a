"""The finite-element reference model: scikit-fem rods (P1/P2) and Hermite beams.

* single body, harmonic: one complex sparse solve per frequency, rigid modes split off
  (:func:`femref.fem.harmonic_response`);
* single body, transient: generalized-α / Newmark on ``M ü + C u̇ + K u = B f(t)``
  (:class:`femref.fem.Stepper`), energies and optional fields;
* impact car: the rod's operators as a second-order system
  (:class:`femref.impact.systems.SecondOrderSystem`), built once per geometry.
"""

from __future__ import annotations

import numpy as np

from femref.fem import INTEGRATORS, Stepper, harmonic_response
from femref.fem.build import FemSettings, build_operators
from femref.fem.operators import Operators
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
    """The car body as scikit-fem rod elements (P1/P2), nodes on every profile jump; built once per
    geometry, sensors and mesh (:func:`femref.models.base.built_once`)."""
    key = ("fem", car.body.geometry, tuple(car.sensors.values()), settings.elements, settings.order, settings.grading)
    return built_once(key, lambda: _fem_system(car, settings))


def car_operators(car: Car, settings: FemSettings) -> Operators:
    """The car body's assembled operators, once per geometry and mesh: the fem car and the modal car
    (which reduces them) of one body share one assembly."""
    key = ("operators", car.body.geometry, settings.elements, settings.order, settings.grading)
    return built_once(key, lambda: build_operators(car.body, settings))


def _fem_system(car: Car, settings: FemSettings) -> SecondOrderSystem:
    ops = car_operators(car, settings)
    l = car.body.half_length
    outputs = ops.interpolation(np.concatenate([[-l, l], car.sensor_x])).toarray()  # the ends, then the sensors
    return SecondOrderSystem(
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


def _mesh_settings(ops, scene: Scene) -> dict:
    return {"element": ops.element, "elements": ops.elements, "dofs": ops.ndof, "grading": scene.fem.grading}


def _set_outputs(result: ModelResult, scene: Scene, response) -> None:
    outputs = {"displacement": response.displacement, "acceleration": response.acceleration}
    if response.axial_force is not None:
        outputs["axial_force"] = response.axial_force
    result.set_probe_outputs(scene.probes, outputs)
