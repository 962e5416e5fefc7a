"""Every automatic time-step rule: the step a run takes when the case leaves ``time.dt`` open (docs/design.md §4.1,
"Time steps": the reasons and measurements behind each rule).

One mesh rule serves both: ``T_h``, the wave transit time of an average element (:func:`mesh_transit_time`),
``h/c_max`` for a rod (``c = √(EA/m)``) and ``h²/c_max`` for a beam (``c = √(EI/m)``), with ``h = 2l/elements``
and ``c_max`` the largest wave speed at the mesh nodes (a shorter element resolves no shorter waves).

Single body (every model of a transient scene on one grid; ``T_load`` the loads' shortest time scale)::

    dt = min(T_load/100, T_h, end/20)

Impact (each model run at what its own cars need)::

    dt = min(T_contact/100, end/20, 1/(4 f_c s), the candidates of each car's fidelity)

``T_contact`` the couplers' shortest rigid-body contact time (:meth:`femref.scene.ImpactScene.contact_time`);
``1/(4 f_c s)`` keeps a measurement low-pass of corner ``f_c`` an octave below the Nyquist frequency of the stored
samples, every ``s = time.output_stride``-th step (:data:`LOWPASS_RULE`); a fidelity's candidates are its module's
(:meth:`femref.models.base.CarFidelity.step_candidates`: a fem car's ``T_h`` and, when its couplers bend it, its
Hermite mesh's bending transit time ``T_h,b = h²/c_b,max``, docs/formulas.md §X8; a modal car's ``4l/(k c_max)/20``
of ``k`` modes). The returned rule names the candidate that won (it is recorded in the result file).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from femref.core.body import Body
from femref.fem.build import FemSettings
from femref.fem.mesh import body_nodes
from femref.models import CAR_FIDELITIES
from femref.models.base import Resolution
from femref.models.fem import MESH_RULE, transit_time
from femref.scene import ImpactScene, ModelRun, Scene

GIVEN = "given in the case"
LOWPASS_RULE = "measurement low-pass: 1/(4 corner × output_stride)"


def smallest_candidate(candidates: dict[str, float]) -> tuple[float, str]:
    """The smallest finite candidate step and its rule."""
    return min((v, k) for k, v in candidates.items() if math.isfinite(v))


def _wave_speed(body: Body, fem: FemSettings) -> float:
    """``c_max = max √(stiffness/m)`` over the mesh nodes (m/s for a rod; m²/s, √(EI/m), for a beam)."""
    nodes = body_nodes(body.half_length, fem.elements, body.jumps, fem.grading)
    return float(np.max(np.sqrt(body.stiffness(nodes) / body.mass_per_length(nodes))))


def mesh_transit_time(body: Body, fem: FemSettings) -> float:
    """``T_h = h/c_max`` (rod) or ``h²/c_max`` (beam), ``h = 2l/elements`` (s; module docstring)."""
    return transit_time(body, fem.elements, _wave_speed(body, fem))


def single_body_candidates(scene: Scene, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
    """The automatic rule's candidate steps of a transient scene (module docstring) on ``elements`` elements, the
    wave speed of a body given by ``speed`` (the mesh nodes' here; sampled without a mesh by femref.run.budget)."""
    return {"load time scale / 100": scene.load_time_scale / 100.0, MESH_RULE: transit_time(scene.body, elements, speed(scene.body)),
            "end time / 20": scene.end / 20.0}


def single_body_time_step(scene: Scene) -> tuple[float, str]:
    """The step of a transient scene: ``scene.dt`` if the case gives it, else the automatic rule (module docstring)."""
    if scene.dt is not None:
        return scene.dt, GIVEN
    dt, rule = smallest_candidate(single_body_candidates(scene, scene.fem.elements, lambda body: _wave_speed(body, scene.fem)))
    return dt, f"automatic: {rule}"


def impact_candidates(scene: ImpactScene, run: ModelRun, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
    """The automatic rule's candidate steps of one impact run (module docstring) on ``elements`` elements per meshed
    car, the wave speed of a body given by ``speed``: each car adds its fidelity's candidates, the smallest of a rule
    kept; a measurement low-pass of corner ``f_c`` adds ``1/(4 f_c output_stride)``."""
    candidates = {"coupler contact time / 100": scene.contact_time() / 100.0, "end time / 20": scene.end / 20.0}
    if scene.measurement is not None and scene.measurement.lowpass is not None:
        candidates[LOWPASS_RULE] = 1.0 / (4.0 * scene.measurement.lowpass * scene.output_stride)
    for car, fidelity in zip(scene.cars, run.fidelity):
        for rule, value in CAR_FIDELITIES[fidelity].step_candidates(car, scene, elements, speed).items():
            candidates[rule] = min(candidates.get(rule, math.inf), value)
    return candidates


def impact_time_step(scene: ImpactScene, run: ModelRun) -> tuple[float, str]:
    """The step of one impact run: the case's ``time.dt`` for every run, or the step its own cars need
    (:func:`impact_candidates` on the fem mesh)."""
    if scene.dt is not None:
        return scene.dt, GIVEN
    dt, rule = smallest_candidate(impact_candidates(scene, run, scene.fem.elements, lambda body: _wave_speed(body, scene.fem)))
    return dt, f"automatic: {rule}"


StepRule = Callable[[ImpactScene, ModelRun], tuple[float, str]]
"""A run's step and its rule: :func:`impact_time_step` (on the mesh), or the budget's prediction."""


def uniform_run(fidelity: str, scene: ImpactScene, name: str | None = None) -> ModelRun:
    """The run of ``scene`` with every car at ``fidelity``, named ``name`` (default the fidelity)."""
    return ModelRun(name or fidelity, (fidelity,) * len(scene.cars))


def resolution_step(fidelity: str, resolution: Resolution, step: StepRule = impact_time_step) -> tuple[float, str]:
    """The step of a fidelity's resolution (a ladder rung, a bench row) and its rule: ``step`` of its
    ``step_scene`` (default its scene) × ``scale[0]/scale[1]``, the rule read through its ``rule``."""
    base = resolution.step_scene or resolution.scene
    dt, rule = step(base, uniform_run(fidelity, base))
    return dt * resolution.scale[0] / resolution.scale[1], resolution.rule.format(rule=rule)


__all__ = ["GIVEN", "LOWPASS_RULE", "StepRule", "impact_candidates", "impact_time_step", "mesh_transit_time", "resolution_step", "single_body_candidates",
           "single_body_time_step", "smallest_candidate", "uniform_run"]
