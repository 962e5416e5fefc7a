"""The finite-element reference model (scikit-fem rods, Hermite beams)."""

from __future__ import annotations

import time

from femref.fem import Integrator, Operators, Stepper, assemble_beam, assemble_rod, body_nodes, harmonic_response
from femref.fem.transient import INTEGRATORS
from femref.models import Progress
from femref.results import ModelResult
from femref.scene import Body, FemSettings, Scene


def build_operators(body: Body, settings: FemSettings) -> Operators:
    """Mesh the body (nodes on every profile jump and kink) and assemble its operators."""
    nodes = body_nodes(body.half_length, settings.elements, body.jumps, settings.grading)
    if body.kind == "rod":
        return assemble_rod(nodes, settings.order, body.mass_per_length, body.stiffness, body.viscosity)
    return assemble_beam(nodes, body.mass_per_length, body.stiffness, body.viscosity)


def integrator_for(scene: Scene) -> Integrator:
    return INTEGRATORS[scene.integrator](scene.rho_inf)


class FemModel:
    name = "fem"

    def run(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        started = time.perf_counter()
        ops = build_operators(scene.body, scene.fem)
        settings = {
            "element": ops.element,
            "elements": ops.elements,
            "dofs": ops.ndof,
            "grading": scene.fem.grading,
        }
        x = scene.probe_x
        result = ModelResult(self.name, settings=settings)
        if scene.kind == "harmonic":
            response = harmonic_response(ops, scene.omega, scene.loads, x)
            settings["frequencies"] = int(scene.omega.size)
            result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
        else:
            integrator = integrator_for(scene)
            stepper = Stepper(ops, integrator, scene.dt, scene.loads)
            response = stepper.solve(
                scene.end, x, scene.output_stride, fields=scene.fem.fields, energy=True, progress=progress
            )
            settings.update(integrator=integrator.name, dt=scene.dt, steps=response.steps, factorizations=2)
            settings["energy_balance_error"] = response.energy_balance_error
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
        outputs = {"displacement": response.displacement, "acceleration": response.acceleration}
        if response.axial_force is not None:
            outputs["axial_force"] = response.axial_force
        result.set_probe_outputs(scene.probes, outputs)
        result.wall_time_s = time.perf_counter() - started
        return result
