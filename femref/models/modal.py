"""The modal car: rigid mode, the lowest free-free elastic modes, and a static correction.

The standard reduction of a structural model (modal truncation with the
mode-acceleration / residual-flexibility correction, e.g. Craig & Kurdila,
*Fundamentals of Structural Dynamics*). From the car's FEM
operators ``M ü + C u̇ + K u = B L`` keep ``Φ = [φ_r, φ_1 … φ_k]`` (``Φᵀ M Φ = I``,
``φ_r = 1/√M_tot`` the rigid translation, ``K φ_i = ω_i² M φ_i``) and write
``u = Φ q + R L``:

    q̈ + Φᵀ C Φ q̇ + diag(0, ω_1², …, ω_k²) q = Φᵀ B L,

    R = G_e B − Σ_{i ≤ k} φ_i φ_iᵀ B / ω_i²,      G_e = Πᵀ K⁺ Π,  Π = I − M φ_r φ_rᵀ,

``G_e`` the inertia-relief elastic flexibility (the load balanced by rigid-body inertia,
the displacement M-orthogonal to the rigid mode), so ``R`` is the quasi-static
response of the dropped modes, ``Σ_{i > k} φ_i φ_iᵀ B / ω_i²``. The outputs gain the
massless ``R L`` at once (the feedthrough of :class:`~femref.impact.systems.SecondOrderSystem`); its strain
energy is ``½ Lᵀ Q L`` with ``Q = Bᵀ R`` (``uᵀ K u`` of ``u = R L``, since ``R`` is a sum
of ``φφᵀ/ω²`` over M-orthonormal modes), symmetric positive semidefinite.

The modal damping ``Φᵀ C Φ`` is kept full: a Voigt viscosity that varies along the car
couples the modes. The static correction is elastic: the dropped modes' viscous lag
(``τ L̇`` for a Voigt body) is not represented.

Verified (tests/models/test_cars.py): the frequencies, the static end flexibility for any k,
Q symmetric PSD, the convergence to the FEM car with the mode count (faster with the
correction), momentum.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from femref.core.body import Body
from femref.fem.build import FemSettings
from femref.fem.mesh import body_nodes
from femref.fem.modes import free_free_modes, residual_flexibility
from femref.impact.systems import SecondOrderSystem
from femref.models.base import CarFidelity, Resolution, built_once
from femref.models.fem import MATRIX_BYTES_PER_DOF, car_beam_operators, car_dofs, car_operators, coupler_line
from femref.scene import Car, ImpactScene

MODE_COUNTS: tuple[int, ...] = (1, 2, 4, 8, 16)
"""Elastic modes per car of the ladder rungs and bench rows (those the mesh holds: :func:`at_mode_counts`)."""


def at_mode_counts(scene: ImpactScene, candidates: tuple[int, ...], ndof: int | None = None) -> list[Resolution]:
    """``modal_k<k>``, ``scene`` at ``k`` modes, for the ``k`` among ``candidates`` that every car's fem mesh holds
    (``1 ≤ k ≤ ndof − 2``, ``ndof`` the smallest car's DOFs: given, or counted on the meshes), ascending."""
    if ndof is None:
        ndof = min(
            (body_nodes(car.body.half_length, scene.fem.elements, car.body.jumps, scene.fem.grading).size - 1) * scene.fem.order + 1
            for car in scene.cars
        )
    modes = sorted(k for k in set(candidates) if 1 <= k <= ndof - 2)
    return [Resolution(f"modal_k{k}", dataclasses.replace(scene, modal_modes=k), "modes", k) for k in modes]


class ModalModel(CarFidelity):
    """Impact cars only: each car its rigid mode, ``scene.modal_modes`` elastic modes and a static correction."""

    name = "modal"
    setup_us = (8930.0, 23.5, 303.3)
    """Set-up of a two-car run, µs: ``s₀ + s₁·N + s₂·k`` (:meth:`cost_regressors`)."""
    step_us = (2.258, 0.03005)
    """One step of a two-car run, µs: ``t₀ + t₁·(k+1)²``."""

    def car(self, car: Car, scene: ImpactScene, dt: float) -> SecondOrderSystem:
        return modal_car(car, scene.fem, scene.modal_modes)

    def step_candidates(self, car: Car, scene: ImpactScene, elements: int, speed: Callable[[Body], float]) -> dict[str, float]:
        """A twentieth of the period of the highest kept mode, ``4l/(k c_max)`` for a free rod of ``k`` modes."""
        return {"highest modal period / 20": 4.0 * car.body.half_length / (scene.modal_modes * speed(car.body)) / 20.0}

    def cost_regressors(self, car: Car, scene: ImpactScene) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """``x_setup = (1, N, k)``: the case's mesh of ``N`` elements assembled, then the eigen-solve of ``k`` modes,
        the static correction and packing; ``x_step = (1, (k+1)²)``: dense ``(k+1)``-DOF cars."""
        k = scene.modal_modes
        return (1.0, scene.fem.elements, k), (1.0, (k + 1) ** 2)

    def matrices(self, car: Car, scene: ImpactScene) -> tuple[float, int, bool]:
        """Its mesh's matrices and, for a car that bends, the four dense n × n matrices of its beam's ``n`` DOFs'
        eigenproblem."""
        rod, beam = car_dofs(car, scene.fem)
        return MATRIX_BYTES_PER_DOF * (rod + beam) + 32.0 * beam**2, 0, True

    def rungs(self, scene: ImpactScene, mesh_dofs: int | None) -> list[Resolution]:
        """At :data:`MODE_COUNTS` that the case's mesh holds, each at its own step."""
        return at_mode_counts(scene, MODE_COUNTS, mesh_dofs)

    def bench(self, scene: ImpactScene) -> list[Resolution]:
        """At :data:`MODE_COUNTS` and the case's ``modal.modes`` that its mesh holds, each at its own step."""
        return at_mode_counts(scene, (*MODE_COUNTS, scene.modal_modes))


MODEL = ModalModel()


def modal_car(car: Car, settings: FemSettings, modes: int, *, static_correction: bool = True) -> SecondOrderSystem:
    """The car as its rigid mode plus ``modes`` elastic modes (and the static correction) of its FEM mesh.

    Modal DOFs ``q`` (rigid first): mass I, stiffness ``diag(0, ω²)``, damping ``Φᵀ C Φ``
    (full), loads ``Φᵀ B``, outputs ``Φ`` at ``±l`` and at the sensors, feedthrough
    ``R`` (module docstring) unless ``static_correction`` is False. The unit translation
    is ``q_r = √M_tot`` (so a car at ``v₀`` has ``q̇_r = v₀ √M_tot``, elastic modes at rest);
    momentum ``√M_tot q̇_r`` (the elastic modes are M-orthogonal to the translation and
    carry none). Built once per geometry, sensors, mesh and mode count.
    """
    if car.body.kind != "rod":
        raise ValueError(f"a modal car is a rod, got a {car.body.kind}")
    bending = None if car.bending is None else car.bending.geometry
    key = ("modal", car.body.geometry, bending, car.coupler_offset, car.coupler_slope, tuple(car.sensors.values()), settings.elements, settings.order,
           settings.grading, modes, static_correction)
    if car.bending is not None:
        return built_once(key, lambda: _bending_modal_system(car, settings, modes, static_correction))
    return built_once(key, lambda: _modal_system(car, settings, modes, static_correction))


def _modal_system(car: Car, settings: FemSettings, modes: int, static_correction: bool) -> SecondOrderSystem:
    ops = car_operators(car, settings)
    phi, omega2 = free_free_modes(ops, modes, car.body.wave_travel_time)
    l = car.body.half_length
    outputs = ops.interpolation(np.concatenate([[-l, l], car.sensor_x]))  # the ends, then the sensors
    at_outputs = np.asarray(outputs @ phi)
    feedthrough = {}
    if static_correction:
        R = residual_flexibility(ops, phi, omega2)
        R_outputs = np.asarray(outputs @ R)
        feedthrough = dict(
            end_feedthrough=R_outputs[:2],
            sensor_feedthrough=R_outputs[2:],
            feedthrough_energy=_symmetric(ops.load_matrix.T @ R),
        )
    frequencies = np.sqrt(np.maximum(omega2[1:], 0.0)) / (2.0 * math.pi)
    return SecondOrderSystem(
        "modal",
        np.eye(phi.shape[1]),
        _symmetric(phi.T @ (ops.damping @ phi)),
        np.diag(omega2),
        phi.T @ ops.load_matrix.toarray(),
        at_outputs[:2],
        at_outputs[2:],
        translation=_rigid_translation(phi.shape[1], ops.total_mass),
        **feedthrough,
        settings={
            "modes": modes,
            "frequencies_hz": [float(f) for f in frequencies],
            "static_correction": static_correction,
            "element": ops.element,
            "elements": ops.elements,
        },
    )


def _bending_modal_system(car: Car, settings: FemSettings, modes: int, static_correction: bool) -> SecondOrderSystem:
    """A car that bends, reduced: the rod's modal car (above) beside the beam's heave and pitch and its
    ``modes`` lowest elastic bending modes, with the beam's own static correction, joined at the coupler
    line as the fem car is (:func:`femref.models.fem.bending_system`)::

        q = (q_rod, q_beam),   q̈_b + Φ_bᵀ C_b Φ_b q̇_b + diag(0, 0, ω_b²) q_b = Φ_bᵀ B_b L,
        u_beam = Φ_b q_b + R_b L,   R_b = Σ_{dropped bending modes} φ φᵀ B_b / ω²

    ``B_b`` are the end moments and vertical forces of the loads (``−h₁`` at ``θ(−l)`` and ``−s₁`` at ``w(−l)``
    for F1, ``h₂`` at ``θ(l)`` and ``s₂`` at ``w(l)`` for F2). The
    beam's modes come from the dense generalised eigenproblem of its Hermite mesh (all of them, so the
    residual flexibility is the exact sum over the dropped ones; its two zero eigenvalues are the rigid
    heave and pitch). Sensors: the rod's rows, then ``w`` and ``θ`` rows.
    """
    rod = _modal_system(car, settings, modes, static_correction)
    beam = car_beam_operators(car, settings)
    omega2, phi = scipy.linalg.eigh(beam.stiffness.toarray(), beam.mass.toarray())
    omega2[:2] = 0.0  # heave and pitch
    keep = min(2 + modes, omega2.size)
    x = car.sensor_x
    hooks = coupler_line(beam, car.coupler_offset, car.coupler_slope)  # (2, n_beam): h θ + s w at the ends
    beam_loads = np.column_stack([-hooks[0], hooks[1]])  # columns F1, F2
    beam_outputs = np.vstack([hooks, beam.sampling(x, 0), beam.sampling(x, 1)])
    kept = phi[:, :keep]
    modal_outputs = beam_outputs @ kept
    n_rod, n_beam, S = rod.dofs, keep, x.size
    end_rod, sensor_rod = rod.end_outputs, rod.sensor_outputs
    feedthrough = {}
    if static_correction:
        dropped = phi[:, keep:]
        residual = dropped @ ((dropped.T @ beam_loads) / omega2[keep:, None])
        beam_feedthrough = beam_outputs @ residual
        feedthrough = dict(
            end_feedthrough=rod.end_feedthrough + beam_feedthrough[:2],
            sensor_feedthrough=np.vstack([rod.sensor_feedthrough, beam_feedthrough[2:]]),
            feedthrough_energy=rod.feedthrough_energy + _symmetric(beam_loads.T @ residual),
        )
    damping = np.zeros((n_rod + n_beam, n_rod + n_beam))
    damping[:n_rod, :n_rod] = rod.damping
    damping[n_rod:, n_rod:] = _symmetric(kept.T @ (beam.damping @ kept))
    bending_hz = np.sqrt(omega2[2:keep]) / (2.0 * math.pi)
    return SecondOrderSystem(
        "modal",
        np.eye(n_rod + n_beam),
        damping,
        np.diag(np.concatenate([np.diag(rod.stiffness), omega2[:keep]])),
        np.vstack([rod.load_matrix, kept.T @ beam_loads]),
        np.hstack([end_rod, modal_outputs[:2]]),
        np.vstack([
            np.hstack([sensor_rod, np.zeros((S, n_beam))]),
            np.hstack([np.zeros((2 * S, n_rod)), modal_outputs[2:]]),
        ]),
        translation=np.concatenate([rod.translation, np.zeros(n_beam)]),
        **feedthrough,
        settings=dict(rod.settings, bending_modes=keep - 2, bending_frequencies_hz=[float(f) for f in bending_hz],
                      coupler_offset=list(car.coupler_offset)),
    )


def _symmetric(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """``½(A + Aᵀ)``: a product ``Φᵀ A Φ`` of a symmetric A, its rounding asymmetry removed."""
    matrix = np.asarray(matrix, dtype=float)
    return 0.5 * (matrix + matrix.T)


def _rigid_translation(size: int, total_mass: float) -> NDArray[np.float64]:
    """Modal coordinates of a unit rigid translation: ``q_r = √M_tot`` (``φ_r = 1/√M_tot``), elastic 0."""
    translation = np.zeros(size)
    translation[0] = math.sqrt(total_mass)
    return translation
