"""The quasi-rigid model of :mod:`reduced.quasi_rigid` as a femref model.

Two-term low-frequency perturbation of the rigid-body motion (SOURCE-NOTES D, E):
harmonic scenes use the complex response, transient scenes the time-domain form with
O(1)-per-step creep filters. The ε it was computed at goes into the settings.
"""

from __future__ import annotations

import time

import numpy as np

from femref.models import Progress
from reduced.quasi_rigid import LoadHistory, QuasiRigidBeam, QuasiRigidRod
from femref.results import ModelResult
from femref.scene import Body, Scene, output_steps, steps_to


def quasi_rigid_body(body: Body) -> QuasiRigidRod | QuasiRigidBeam:
    """The body's quasi-rigid model (profiles and jumps as given)."""
    kind = QuasiRigidRod if body.kind == "rod" else QuasiRigidBeam
    return kind(body.half_length, body.mass_per_length, body.stiffness, body.viscosity, jumps=body.jumps)


class QuasiRigidModel:
    name = "quasi_rigid"

    def run(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        started = time.perf_counter()
        model = quasi_rigid_body(scene.body)
        x = scene.probe_x
        result = ModelResult(self.name)
        if scene.kind == "harmonic":
            response = model.harmonic(scene.omega, x, **scene.loads)
            result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
            result.settings = {"epsilon_max": float(np.max(response.epsilon))}
        else:
            steps = steps_to(scene.end, scene.dt)
            t_all = scene.dt * np.arange(steps + 1)
            loads = {
                name: LoadHistory(signal, lambda t, s=signal: s.derivative(t, 1), lambda t, s=signal: s.derivative(t, 2))
                for name, signal in scene.loads.items()
            }
            response = model.transient(t_all, x, **loads, load_time_scale=_finite(scene.load_time_scale))
            keep = output_steps(steps, scene.output_stride)
            response_time = t_all[keep]
            result.axes = {"time": response_time}
            result.settings = {"epsilon": float(response.epsilon), "dt": scene.dt, "load_derivatives": "analytic"}
        outputs = {"acceleration": response.acceleration, "displacement": response.displacement}
        if scene.kind == "transient":
            outputs = {name: values[keep] for name, values in outputs.items()}
        result.set_probe_outputs(scene.probes, outputs)
        result.wall_time_s = time.perf_counter() - started
        return result


def _finite(value: float) -> float | None:
    return value if np.isfinite(value) else None
