"""Exact solutions as a model: closed forms / transfer matrices (harmonic), inverse Laplace (transient rods)."""

from __future__ import annotations

from femref.exact import Segments, beam_harmonic, rod_harmonic, rod_transient
from femref.models.base import Progress
from femref.core.profiles import common_edges, segment_values
from femref.results import ModelResult
from femref.core.body import Body
from femref.scene.single import Scene


def segments_of(body: Body) -> Segments:
    """The piecewise-constant body as :class:`femref.exact.Segments`."""
    edges = common_edges(body.half_length, body.profiles)
    return Segments(
        edges=edges,
        mass_per_length=segment_values(body.mass_per_length, edges),
        stiffness=segment_values(body.stiffness, edges),
        viscosity=segment_values(body.viscosity, edges),
    )


class ExactModel:
    name = "exact"

    def harmonic(self, scene: Scene) -> ModelResult:
        segments = segments_of(scene.body)
        x = scene.probe_x
        result = ModelResult(self.name, settings={"segments": int(segments.edges.size - 1)})
        if scene.body.kind == "rod":
            response = rod_harmonic(segments, scene.omega, x, **scene.loads)
            outputs = {"displacement": response.displacement, "axial_force": response.axial_force}
        else:
            response = beam_harmonic(segments, scene.omega, x, **scene.loads)
            outputs = {"displacement": response.deflection}
        outputs["acceleration"] = response.acceleration
        result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
        result.set_probe_outputs(scene.probes, outputs)
        return result

    def transient(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        """Rods only (inverse Laplace of the transfer-matrix solution)."""
        segments = segments_of(scene.body)
        result = ModelResult(self.name, settings={"segments": int(segments.edges.size - 1)})
        times = scene.time_grid(scene.dt)
        response = rod_transient(segments, times, scene.probe_x, scene.loads.get("F1"), scene.loads.get("F2"))
        result.axes = {"time": times}
        result.set_probe_outputs(
            scene.probes, {"displacement": response.displacement, "acceleration": response.acceleration, "axial_force": response.axial_force}
        )
        return result


MODEL = ExactModel()
