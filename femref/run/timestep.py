"""Every automatic time-step rule: the step a run takes when the case leaves ``time.dt`` open.

One mesh rule serves both: ``T_h``, the wave transit time of an average element
(:func:`mesh_transit_time`), ``h/c_max`` for a rod (``c = √(EA/m)``) and ``h²/c_max`` for a
beam (``c = √(EI/m)``, so ``h²·√(m/EI)``), with ``h = 2l/elements`` and ``c_max`` the
largest wave speed at the mesh nodes. An element shortened to put a node on a profile
jump, or by grading toward the ends, resolves no shorter waves than its neighbours: the
shortest element would only cost steps.

Single body (harmonic scenes have no step): every model of a transient scene runs on
the same grid, so the step is the fem mesh's,

    dt = min(T_load/100, T_h, end/20),

``T_load`` the loads' shortest time scale.

Impact: each model run steps at what its own cars need,

    dt = min(T_contact/100, T_h (fem cars), 4l/(k c_max)/20 (modal cars with k modes), end/20),

``T_contact`` the shortest rigid-body contact time of the couplers
(:meth:`femref.scene.ImpactScene.contact_time`): all a run of rigid and quasi-rigid cars
needs. The scores interpolate the reference onto each run's axis.

The returned rule names the candidate that won (it is recorded in the result file).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from femref.core.body import Body
from femref.fem.build import FemSettings
from femref.fem.mesh import body_nodes
from femref.scene import ImpactScene, ModelRun, Scene

GIVEN = "given in the case"
MESH_RULE = "mesh wave transit time"


def smallest_candidate(candidates: dict[str, float]) -> tuple[float, str]:
    """The smallest finite candidate step and its rule."""
    value, rule = min((v, k) for k, v in candidates.items() if math.isfinite(v))
    return value, rule


def _wave_speed(body: Body, fem: FemSettings) -> float:
    """``c_max = max √(stiffness/m)`` over the mesh nodes (m/s for a rod; m²/s, √(EI/m), for a beam)."""
    nodes = body_nodes(body.half_length, fem.elements, body.jumps, fem.grading)
    return float(np.max(np.sqrt(body.stiffness(nodes) / body.mass_per_length(nodes))))


def transit_time(body: Body, elements: int, speed: float) -> float:
    """``T_h = h/c`` (rod) or ``h²/c`` (beam), ``h = 2l/elements``, for a wave speed ``c`` (s; module docstring)."""
    h = 2.0 * body.half_length / elements
    return (h if body.kind == "rod" else h * h) / speed


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
    """The automatic rule's candidate steps of one impact run (module docstring) on ``elements`` elements per fem or
    modal car, the wave speed of a body given by ``speed``: a fem car adds its mesh transit time, a modal car a
    twentieth of the period of its highest kept mode, ``4l/(k c_max)`` for a free rod."""
    candidates = {"coupler contact time / 100": scene.contact_time() / 100.0, "end time / 20": scene.end / 20.0}
    for i, fidelity in enumerate(run.fidelity):
        if fidelity not in ("fem", "modal"):
            continue
        body = scene.cars[i].body
        if fidelity == "fem":
            rule, value = MESH_RULE, transit_time(body, elements, speed(body))
        else:
            rule, value = "highest modal period / 20", 4.0 * body.half_length / (scene.modal_modes * speed(body)) / 20.0
        candidates[rule] = min(candidates.get(rule, math.inf), value)
    return candidates


def impact_time_step(scene: ImpactScene, run: ModelRun) -> tuple[float, str]:
    """The step of one impact run: the case's ``time.dt`` for every run, or the step its own cars need
    (:func:`impact_candidates` on the fem mesh)."""
    if scene.dt is not None:
        return scene.dt, GIVEN
    dt, rule = smallest_candidate(impact_candidates(scene, run, scene.fem.elements, lambda body: _wave_speed(body, scene.fem)))
    return dt, f"automatic: {rule}"


__all__ = ["GIVEN", "MESH_RULE", "impact_candidates", "impact_time_step", "mesh_transit_time", "single_body_candidates", "single_body_time_step",
           "smallest_candidate", "transit_time"]
