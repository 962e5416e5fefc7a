"""Every automatic time-step rule: the step a run takes when the case leaves ``time.dt`` open.

Single body (harmonic scenes have no step): every model of a transient scene runs on
the same grid, so the step is the fem mesh's,

    dt = min(T_load/100, T_h, end/20),

``T_load`` the loads' shortest time scale and ``T_h`` the period scale of the shortest
wave the mesh resolves: ``h/c_max`` for rods (``c = √(EA/m)``), ``h²·√(m/EI)`` for beams.

Impact: each model run steps at what its own cars need,

    dt = min(T_contact/100, T_h (fem cars), 4l/(k c_max)/20 (modal cars with k modes), end/20),

``T_contact`` the shortest rigid-body contact time of the couplers
(:meth:`femref.scene.ImpactScene.contact_time`): all a run of rigid and quasi-rigid cars
needs. The scores interpolate the reference onto each run's axis.

The returned rule names the candidate that won (it is recorded in the result file).
"""

from __future__ import annotations

import math

import numpy as np

from femref.core.body import Body
from femref.fem.mesh import body_nodes
from femref.scene import ImpactScene, ModelRun, Scene

GIVEN = "given in the case"


def _smallest(candidates: dict[str, float]) -> tuple[float, str]:
    value, rule = min((v, k) for k, v in candidates.items() if math.isfinite(v))
    return value, rule


def _wave_speed(body: Body, nodes: np.ndarray) -> float:
    """``c_max = max √(stiffness/m)`` over the mesh nodes (m/s for a rod; √(EI/m) for a beam)."""
    return float(np.max(np.sqrt(body.stiffness(nodes) / body.mass_per_length(nodes))))


def single_body_time_step(scene: Scene) -> tuple[float, str]:
    """The step of a transient scene: ``scene.dt`` if the case gives it, else the automatic rule (module docstring)."""
    if scene.dt is not None:
        return scene.dt, GIVEN
    body, fem = scene.body, scene.fem
    nodes = body_nodes(body.half_length, fem.elements, body.jumps, fem.grading)
    h_min = float(np.min(np.diff(nodes)))
    speed = _wave_speed(body, nodes)
    t_mesh = h_min / speed if body.kind == "rod" else h_min**2 / speed
    candidates = {"load time scale / 100": scene.load_time_scale / 100.0, "mesh wave period": t_mesh, "end time / 20": scene.end / 20.0}
    dt, rule = _smallest(candidates)
    return dt, f"automatic: {rule}"


def impact_time_step(scene: ImpactScene, run: ModelRun) -> tuple[float, str]:
    """The step of one impact run: the case's ``time.dt`` for every run, or the step its own cars need.

    A fem car adds ``T_h = h/c_max`` with ``h = 2l/elements``, the wave transit time of an
    average element: an element shortened to put a node on a profile jump resolves no
    shorter waves than its neighbours. A modal car adds a twentieth of the period of its
    highest kept mode, ``4l/(k c_max)`` for a free rod.
    """
    if scene.dt is not None:
        return scene.dt, GIVEN
    candidates = {"coupler contact time / 100": scene.contact_time() / 100.0, "end time / 20": scene.end / 20.0}
    for i, fidelity in enumerate(run.fidelity):
        if fidelity not in ("fem", "modal"):
            continue
        body = scene.cars[i].body
        speed = _wave_speed(body, body_nodes(body.half_length, scene.fem.elements, body.jumps, scene.fem.grading))
        if fidelity == "fem":
            rule, value = "mesh wave period", 2.0 * body.half_length / scene.fem.elements / speed
        else:
            rule, value = "highest modal period / 20", 4.0 * body.half_length / (scene.modal_modes * speed) / 20.0
        candidates[rule] = min(candidates.get(rule, math.inf), value)
    dt, rule = _smallest(candidates)
    return dt, f"automatic: {rule}"


__all__ = ["GIVEN", "impact_time_step", "single_body_time_step"]
