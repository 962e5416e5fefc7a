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

Verified (tests/models/test_cars.py): the frequencies equal the dense FEM eigenvalues
(1e-10) and so the exact homogeneous-rod ``nπ/(2l)·√(EA/m)`` to the mesh's h⁴ error; the
static end flexibility (kept modes + correction) is ``(l/3EA)[[−2, −1], [1, 2]]`` for a
homogeneous rod and the quasi-rigid model's elastic coefficients for a profiled one, for
any k; Q is symmetric PSD; under a smooth pulse the end displacements converge to the
FEM car's like k^−0.9 without the correction and k^−2.6 with it (elastic; with Voigt
viscosity the dropped modes' lag brings it back to k^−0.9, 20× below the uncorrected
error); momentum equals the impulse up to generalized-α's own lag term.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from femref.fem.build import FemSettings
from femref.fem.modes import free_free_modes, residual_flexibility
from femref.impact.systems import SecondOrderSystem
from femref.models.base import built_once
from femref.models.fem import car_operators
from femref.scene import Car, ImpactScene


class ModalModel:
    """Impact cars only: each car its rigid mode, ``scene.modal_modes`` elastic modes and a static correction."""

    name = "modal"

    def car(self, car: Car, scene: ImpactScene, dt: float) -> SecondOrderSystem:
        return modal_car(car, scene.fem, scene.modal_modes)


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
    key = ("modal", car.body.geometry, tuple(car.sensors.values()), settings.elements, settings.order, settings.grading, modes, static_correction)
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


def _symmetric(matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """``½(A + Aᵀ)``: a product ``Φᵀ A Φ`` of a symmetric A, its rounding asymmetry removed."""
    matrix = np.asarray(matrix, dtype=float)
    return 0.5 * (matrix + matrix.T)


def _rigid_translation(size: int, total_mass: float) -> NDArray[np.float64]:
    """Modal coordinates of a unit rigid translation: ``q_r = √M_tot`` (``φ_r = 1/√M_tot``), elastic 0."""
    translation = np.zeros(size)
    translation[0] = math.sqrt(total_mass)
    return translation
