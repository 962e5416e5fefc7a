"""The finite-element reference model: scikit-fem rods (P1/P2) and Hermite beams.

* single body, harmonic: one complex sparse solve per frequency, rigid modes split off
  (:func:`femref.fem.harmonic_response`);
* single body, transient: generalized-α / Newmark on ``M ü + C u̇ + K u = B f(t)``
  (:class:`femref.fem.Stepper`), energies and optional fields;
* impact car: the rod's operators as a second-order system
  (:class:`femref.impact.systems.SecondOrderSystem`) with their row bands, built once per
  geometry (a small rod straight into the bands, :func:`small_rod_system`); a car that
  bends adds Hermite beam elements on the same nodes, driven through the coupler offsets.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np
import scipy.sparse as sp

from femref.core.body import Body
from femref.fem import INTEGRATORS, Stepper, harmonic_response
from femref.fem.build import FemSettings, build_operators
from femref.fem.mesh import body_nodes
from femref.fem.operators import Operators, assemble_beam, sampling
from femref.fem.reference import assemble_bands, element_dofs
from femref.impact.systems import SecondOrderSystem
from femref.models.base import CarFidelity, Progress, Resolution, built_once
from femref.results import ModelResult
from femref.scene import Car, ImpactScene, Scene

MESH_RULE = "mesh wave transit time"
BENDING_MESH_RULE = "bending mesh transit time"
MIN_ELEMENTS = 4
"""Fewest elements per car a bench row or ladder rung uses."""
FEM_LEVELS: tuple[int, ...] = (-3, -2, -1, 0, 1)
"""Ladder rungs at ``N·2^j`` elements per car for these ``j`` (``N`` the case's ``fem.elements``)."""
ELEMENT_FACTORS: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0)
"""Bench rows at these multiples of the case's ``fem.elements``."""
DT_FACTORS: tuple[float, ...] = (2.0, 4.0)
"""Bench rows at the case's elements and these multiples of its step."""
DENSE_CAR_DOFS = 64
"""A rod car of at most this many DOFs is built with dense M, C, K (:func:`small_rod_system`); a larger one sparse."""
MATRIX_BYTES_PER_DOF = 600.0
"""Sparse M, C, K, banded factors, dense load and output maps of a mesh, per DOF."""


def transit_time(body: Body, elements: int, speed: float) -> float:
    """``T_h = h/c`` (rod) or ``h²/c`` (beam), ``h = 2l/elements``, for a wave speed ``c`` (s; :mod:`femref.run.timestep`)."""
    h = 2.0 * body.half_length / elements
    return (h if body.kind == "rod" else h * h) / speed


def loaded_bending(car: Car) -> Body | None:
    """The car's bending (a beam body) when its couplers load it — a coupler offset or slope not zero — else None: an
    unloaded beam is never excited, and the car steps as its rod alone."""
    if car.bending is None or not (any(car.coupler_offset) or any(car.coupler_slope)):
        return None
    return car.bending


def mesh_nodes(body: Body, elements: int) -> int:
    """Nodes of a mesh of ``elements`` elements with a node on every profile jump, counted without building it."""
    return int(elements) + 1 + len(body.jumps)


def rod_dofs(body: Body, elements: int, order: int) -> int:
    """DOFs of the rod mesh of order ``order`` (:func:`mesh_nodes`)."""
    return order * (mesh_nodes(body, elements) - 1) + 1


def car_dofs(car: Car, settings: FemSettings) -> tuple[int, int]:
    """``(rod, beam)`` DOFs of the car's mesh (beam 0 when the car does not bend), counted without building it."""
    beam = 2 * mesh_nodes(car.body, settings.elements) if car.bending is not None else 0
    return rod_dofs(car.body, settings.elements, settings.order), beam


def with_elements(scene: ImpactScene, elements: int) -> ImpactScene:
    """``scene`` with ``fem.elements`` per car replaced."""
    return dataclasses.replace(scene, fem=dataclasses.replace(scene.fem, elements=elements))


class FemModel(CarFidelity):
    name = "fem"
    setup_us = (5090.0, 8.671)
    """Set-up of a two-car run, µs: ``s₀ + s₁·n`` (:meth:`cost_regressors`)."""
    step_us = (3.042, 0.3329)
    """One step of a two-car run, µs: ``t₀ + t₁·n``."""

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

    def step_candidates(self, car: Car, scene: ImpactScene, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
        """The mesh transit time of the car's rod on ``elements`` elements and, when its couplers bend it, its beam's,
        ``h²/c_b,max`` (:func:`loaded_bending`)."""
        candidates = {MESH_RULE: transit_time(car.body, elements, speed(car.body))}
        bending = loaded_bending(car)
        if bending is not None:
            candidates[BENDING_MESH_RULE] = transit_time(bending, elements, speed(bending))
        return candidates

    def cost_regressors(self, car: Car, scene: ImpactScene) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """``x_setup = x_step = (1, n)``: banded cars of ``n`` elements (the case's ``fem.elements``)."""
        return (1.0, scene.fem.elements), (1.0, scene.fem.elements)

    def matrices(self, car: Car, scene: ImpactScene) -> tuple[float, int, bool]:
        """Its mesh's matrices (:data:`MATRIX_BYTES_PER_DOF`), every DOF stepped."""
        dofs = sum(car_dofs(car, scene.fem))
        return MATRIX_BYTES_PER_DOF * dofs, dofs, True

    def rungs(self, scene: ImpactScene, mesh_dofs: int | None) -> list[Resolution]:
        """``fem_n<n>`` for ``n = N·2^j`` (:data:`FEM_LEVELS`, at least :data:`MIN_ELEMENTS`), refined **jointly in
        space and time**: the coarsest at its automatic step ``dt₀`` (or the case's ``time.dt``), level ``n`` at
        ``dt₀·n₀/n``. Refining the mesh alone would leave the time error of a step set by the contact time
        untouched, and Richardson between two levels would then see no change."""
        elements = sorted({max(MIN_ELEMENTS, round(scene.fem.elements * 2.0**j)) for j in FEM_LEVELS})
        n0, coarsest = elements[0], with_elements(scene, elements[0])
        return [Resolution(f"fem_n{n}", with_elements(scene, n), "elements", n, coarsest, (n0, n),
                           "{rule}" if n == n0 else f"{{rule}} at {n0} elements, × {n0}/{n}") for n in elements]

    def bench(self, scene: ImpactScene) -> list[Resolution]:
        """At ``N`` (the case's ``fem.elements``) and ``max(MIN_ELEMENTS, round(N f))`` elements for ``f`` in
        :data:`ELEMENT_FACTORS`, each at its own step, and at ``N`` at :data:`DT_FACTORS` × that step."""
        n = scene.fem.elements
        counts = sorted({n, *(max(MIN_ELEMENTS, round(n * f)) for f in ELEMENT_FACTORS)})
        rows = [Resolution(f"fem_n{e}", with_elements(scene, e), "elements", e) for e in counts]
        return rows + [Resolution(f"fem_dt{f:g}", with_elements(scene, n), "dt_factor", f, scale=(f, 1.0), rule=f"{f:g} × ({{rule}})")
                       for f in DT_FACTORS]


MODEL = FemModel()


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
    if car.bending is None and rod_dofs(car.body, settings.elements, settings.order) <= DENSE_CAR_DOFS:
        return small_rod_system(car, settings)
    ops = car_operators(car, settings)
    l = car.body.half_length
    outputs = ops.sampling(np.concatenate([[-l, l], car.sensor_x]))  # the ends, then the sensors
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
        bands=ops.bands,
    )
    if car.bending is None:
        return rod
    return bending_system(rod, car_beam_operators(car, settings), car.sensor_x, car.coupler_offset, car.coupler_slope)


def small_rod_system(car: Car, settings: FemSettings) -> SecondOrderSystem:
    """A rod car of at most :data:`DENSE_CAR_DOFS` DOFs assembled straight into its row bands
    (:func:`femref.fem.reference.assemble_bands`: the numbers of :func:`car_operators`' matrices to the bit), its
    M, C, K dense from them: no sparse matrix, no sparsity pattern, which cost a small car more than its arithmetic."""
    body = car.body
    element = {1: "P1", 2: "P2"}.get(settings.order)
    if element is None:
        raise ValueError(f"rod elements are P1 or P2, got order {settings.order}")
    nodes = body_nodes(body.half_length, settings.elements, body.jumps, settings.grading)
    p, (mass, stiffness, damping) = assemble_bands(element, nodes, ((body.mass_per_length, 0), (body.stiffness, 1), (body.viscosity, 1)),
                                                   settings.order + 2)
    n = mass.shape[1]
    dofs = element_dofs(element, nodes.size - 1)
    load_matrix = np.zeros((n, 2))
    load_matrix[0, 0], load_matrix[n - 1, 1] = -1.0, 1.0  # −F1 at u(−l), F2 at u(l) (femref.fem.operators.assemble_rod)
    l = body.half_length
    outputs = sampling(element, nodes, dofs, n, np.concatenate([[-l, l], car.sensor_x]))  # the ends, then the sensors
    return SecondOrderSystem(
        "fem",
        *dense_of_bands([mass, damping, stiffness], p),
        load_matrix,
        outputs[:2],
        outputs[2:],
        translation=np.ones(n),
        settings={"element": element, "elements": nodes.size - 1, "dofs": n, "nodes": nodes},
        bands=(p, mass, damping, stiffness),
    )


def dense_of_bands(bands: list[np.ndarray], p: int) -> list[np.ndarray]:
    """The n × n matrices of row bands ``bands[m][k, i] = A_m[i, i + k − p]`` (one index for all)."""
    n = bands[0].shape[1]
    row = np.broadcast_to(np.arange(n), (2 * p + 1, n))
    column = row + np.arange(-p, p + 1)[:, None]
    inside = (column >= 0) & (column < n)
    row, column = row[inside], column[inside]
    dense = []
    for band in bands:
        matrix = np.zeros((n, n))
        matrix[row, column] = band[inside]
        dense.append(matrix)
    return dense


def coupler_line(beam: Operators, offset: tuple[float, float], slope: tuple[float, float]) -> np.ndarray:
    """What the coupler line at each end reads of the beam's DOFs (2 × n_beam): ``h θ(∓l) + s w(∓l)``
    (``offset`` h below the neutral axis, ``slope`` s the coupler's inclination; docs/formulas.md §X7)."""
    l = beam.half_length
    ends = np.array([-l, l])
    rotation, deflection = beam.sampling(ends, derivative=1), beam.sampling(ends, derivative=0)
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
    vertical = beam.sampling(sensor_x, derivative=0)
    pitch = beam.sampling(sensor_x, derivative=1)
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
