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

    dt = min(T_contact/100, T_h (fem cars), T_h,b (fem cars whose couplers bend them), 4l/(k c_max)/20 (modal cars with k modes),
             end/20, 1/(4 f_c s) (a measurement low-pass)),

``T_contact`` the shortest rigid-body contact time of the couplers
(:meth:`femref.scene.ImpactScene.contact_time`): all a run of rigid and quasi-rigid cars
needs. The scores interpolate the reference onto each run's axis.

A measurement chain's anti-alias low-pass (corner ``f_c``) runs on the model's stored samples, every
``s = time.output_stride``-th step (:func:`femref.sensing.measurement.measure`), and needs ``f_c``
below their Nyquist frequency ``1/(2 dt s)``; the rule keeps it an octave below (:data:`LOWPASS_RULE`).
A soft coupler (a contact time of seconds) otherwise gives a rigid run ``end/20`` — 25 ms for a 0.5 s
impact, a Nyquist frequency of 20 Hz under a 100 Hz filter. A step the case gives must keep ``f_c`` below
that Nyquist frequency (a case error otherwise: ``femref.case.impact``).

A fem car that bends also steps within its Hermite mesh's bending transit time
``T_h,b = h²/c_b,max`` (``c_b = √(EI/m)``: :data:`BENDING_MESH_RULE`) when its couplers load the
beam (an offset or a slope: :func:`loaded_bending`). A coupler force that jumps
at contact (a damper met at the closing speed) puts a step end moment ``h ΔP`` on the beam, whose
modal force ``h ΔP φ_n'(±l)`` grows with the mode number: every mode of the mesh is driven. The
generalized-α error of that response grows with the mesh's highest bending frequency
(``ω_max ∝ c_b/h²``): measured on two bending cars against their exact modal solution it is
``≈ C N³ dt²`` on ``N`` elements (peak coupler force and centre vertical acceleration alike;
the force's constant within 25 % over a hundredfold Voigt viscosity), so the axial rule ``dt ∝ h`` lets it grow like ``N`` — doubling at
each refinement — while ``dt ∝ h²`` makes it fall like ``1/N`` (docs/formulas.md §X8).

The returned rule names the candidate that won (it is recorded in the result file).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from femref.core.body import Body
from femref.fem.build import FemSettings
from femref.fem.mesh import body_nodes
from femref.scene import Car, ImpactScene, ModelRun, Scene

GIVEN = "given in the case"
MESH_RULE = "mesh wave transit time"
BENDING_MESH_RULE = "bending mesh transit time"
LOWPASS_RULE = "measurement low-pass: 1/(4 corner × output_stride)"


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


def loaded_bending(car: Car) -> Body | None:
    """The car's bending (a beam body) when its couplers load it — a coupler offset or slope not zero — else None: an
    unloaded beam is never excited, and the car steps as its rod alone."""
    if car.bending is None or not (any(car.coupler_offset) or any(car.coupler_slope)):
        return None
    return car.bending


def impact_candidates(scene: ImpactScene, run: ModelRun, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
    """The automatic rule's candidate steps of one impact run (module docstring) on ``elements`` elements per fem or
    modal car, the wave speed of a body given by ``speed``: a fem car adds its mesh transit time — and, when it bends,
    its beam's, ``h²/c_b,max`` (``speed`` of the car's bending, a beam body) — a modal car a twentieth of the period
    of its highest kept mode, ``4l/(k c_max)`` for a free rod; a measurement low-pass of corner ``f_c`` adds
    ``1/(4 f_c output_stride)``."""
    candidates = {"coupler contact time / 100": scene.contact_time() / 100.0, "end time / 20": scene.end / 20.0}
    if scene.measurement is not None and scene.measurement.lowpass is not None:
        candidates[LOWPASS_RULE] = 1.0 / (4.0 * scene.measurement.lowpass * scene.output_stride)

    def add(rule: str, value: float) -> None:
        candidates[rule] = min(candidates.get(rule, math.inf), value)

    for car, fidelity in zip(scene.cars, run.fidelity):
        if fidelity == "fem":
            add(MESH_RULE, transit_time(car.body, elements, speed(car.body)))
            bending = loaded_bending(car)
            if bending is not None:
                add(BENDING_MESH_RULE, transit_time(bending, elements, speed(bending)))
        elif fidelity == "modal":
            add("highest modal period / 20", 4.0 * car.body.half_length / (scene.modal_modes * speed(car.body)) / 20.0)
    return candidates


def impact_time_step(scene: ImpactScene, run: ModelRun) -> tuple[float, str]:
    """The step of one impact run: the case's ``time.dt`` for every run, or the step its own cars need
    (:func:`impact_candidates` on the fem mesh)."""
    if scene.dt is not None:
        return scene.dt, GIVEN
    dt, rule = smallest_candidate(impact_candidates(scene, run, scene.fem.elements, lambda body: _wave_speed(body, scene.fem)))
    return dt, f"automatic: {rule}"


__all__ = ["BENDING_MESH_RULE", "GIVEN", "LOWPASS_RULE", "MESH_RULE", "impact_candidates", "impact_time_step", "loaded_bending", "mesh_transit_time",
           "single_body_candidates", "single_body_time_step", "smallest_candidate", "transit_time"]
