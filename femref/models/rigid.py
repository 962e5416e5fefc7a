"""Rigid-body model: a free body under end loads, or a car as a point mass in an impact.

The body moves as a rigid body: ``u(x, t) = q₀(t) + (x − x_c) q₁(t)`` (beam) with the
generalised accelerations ``(ΦᵀMΦ) α = Φᵀ f``:

* rod: ``M a = F2 − F1``, and the internal force is the inertia-balanced
  ``F0(x) = F1 + (F2 − F1) ∫_{−l}^{x} m dx / M``;
* beam: ``[M, S; S, J₀] [a_v; Ω] = [N1 − N2; G2 − G1 − l(N1 + N2)]`` about ``x = 0`` with
  ``S = ∫ x m dx`` and ``J₀ = ∫ x² m dx`` (S = 0 for even profiles: the laws of docs/design.md §2).

Integrals by Gauss quadrature between the profiles' jumps (exact for the profile kinds).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from femref.core.body import Body
from femref.core.timegrid import output_steps, steps_to
from femref.impact.systems import SecondOrderSystem
from femref.models.base import CarFidelity, Progress, built_once
from femref.results import ModelResult
from femref.scene import Car, ImpactScene, Scene


def rigid_accelerations(body: Body, loads: NDArray, x: NDArray) -> NDArray:
    """Accelerations at ``x`` for end loads ``loads[..., j]`` in the order F1, F2 (rod) or N1, N2, G1, G2."""
    xq, wq = body.quadrature()
    m = body.mass_per_length(xq)
    if body.kind == "rod":
        return np.repeat(((loads[..., 1] - loads[..., 0]) / np.sum(wq * m))[..., None], np.size(x), axis=-1)
    l = body.half_length
    mass = np.array([[np.sum(wq * m), np.sum(wq * m * xq)], [np.sum(wq * m * xq), np.sum(wq * m * xq * xq)]])
    n1, n2, g1, g2 = (loads[..., k] for k in range(4))
    generalized = np.stack([n1 - n2, g2 - g1 - l * (n1 + n2)], axis=-1)
    av, omega = np.moveaxis(np.linalg.solve(mass, generalized[..., None])[..., 0], -1, 0)
    return av[..., None] + omega[..., None] * np.asarray(x)


def inertia_balanced_force(body: Body, loads: NDArray, x: NDArray) -> NDArray:
    """Rod internal force of rigid motion ``F0(x) = F1 + (F2 − F1) ∫_{−l}^x m / M`` (tension positive)."""
    xq, wq = body.quadrature()
    order = np.argsort(xq)
    cumulative = np.concatenate([[0.0], np.cumsum((wq * body.mass_per_length(xq))[order])])
    positions = np.concatenate([[-body.half_length], xq[order]])
    fraction = np.interp(x, positions, cumulative) / cumulative[-1]
    return loads[..., :1] + (loads[..., 1:2] - loads[..., :1]) * fraction


class RigidModel(CarFidelity):
    name = "rigid"
    expansion_order = 0
    setup_us = (1268.0,)
    """Set-up of a two-car run, µs (:meth:`femref.models.base.CarFidelity.cost`)."""
    step_us = (1.868,)
    """One step of a two-car run, µs."""

    def harmonic(self, scene: Scene) -> ModelResult:
        x = scene.probe_x
        loads = np.array([[complex(scene.loads.get(n, 0.0)) for n in _load_names(scene.body)]])
        accel = np.repeat(rigid_accelerations(scene.body, loads, x), scene.omega.size, axis=0)
        displacement = -accel / scene.omega[:, None] ** 2
        force = inertia_balanced_force(scene.body, np.repeat(loads, scene.omega.size, axis=0), x)
        result = ModelResult(self.name)
        result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
        return _with_outputs(result, scene, accel, displacement, force)

    def transient(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        from scipy.integrate import cumulative_trapezoid  # scipy.integrate costs ~0.3 s to import: an impact's rigid car needs none

        x = scene.probe_x
        steps = steps_to(scene.end, scene.dt)
        t_all = scene.dt * np.arange(steps + 1)
        loads = np.stack([scene.loads[n](t_all) if n in scene.loads else np.zeros_like(t_all) for n in _load_names(scene.body)], axis=-1)
        accel_all = rigid_accelerations(scene.body, loads, x)
        velocity = cumulative_trapezoid(accel_all, t_all, axis=0, initial=0.0)
        displacement_all = cumulative_trapezoid(velocity, t_all, axis=0, initial=0.0)
        keep = output_steps(steps, scene.output_stride)
        result = ModelResult(self.name, settings={"dt": scene.dt, "integration": "trapezoidal (displacement from acceleration)"})
        result.axes = {"time": t_all[keep]}
        return _with_outputs(result, scene, accel_all[keep], displacement_all[keep], inertia_balanced_force(scene.body, loads[keep], x))

    def car(self, car: Car, scene: ImpactScene, dt: float) -> SecondOrderSystem:
        return rigid_car(car)


MODEL = RigidModel()


def rigid_car(car: Car) -> SecondOrderSystem:
    """The car as a point mass: ``M ü = F2 − F1``, every point moving together; a car that bends as a rigid
    body that also heaves and pitches (:func:`rigid_pitching_system`)."""
    if car.bending is not None:
        key = ("rigid", car.body.geometry, car.coupler_offset, car.coupler_slope, tuple(car.sensors.values()))
        return built_once(key, lambda: rigid_pitching_system(car.body, car.sensor_x, car.coupler_offset, car.coupler_slope))
    return built_once(("rigid", car.body.geometry, len(car.sensors)), lambda: _rigid_system(car.mass, len(car.sensors)))


def rigid_pitching_system(body: Body, sensor_x: NDArray, offset: tuple[float, float], slope: tuple[float, float] = (0.0, 0.0)) -> SecondOrderSystem:
    """A rigid car that moves along the line, heaves and pitches: DOFs ``(x, z, θ)`` (θ about the body's
    centre ``x = 0``, positive when the front rises), so a point at ``x`` moves ``(x_c, z + x θ)``::

        M = [[m, 0, 0], [0, m, S], [0, S, J]],   m = ∫ m dx,  S = ∫ m x dx,  J = ∫ m x² dx,   K = C = 0

    The couplers act ``h`` (``offset``) below the neutral axis, as on the fem car
    (:func:`femref.models.fem.bending_system`): end outputs ``x_c + h θ + s w(∓l)`` with ``w(∓l) = z ∓ l θ``
    (``s`` the inclination of the coupler there), loads their transpose: ``M ẍ = F2 − F1``,
    ``m z̈ + S θ̈ = s₂ F2 − s₁ F1`` and ``S z̈ + J θ̈ = h₂ F2 − h₁ F1 + l (s₁ F1 + s₂ F2)``. Sensors: axial ``x_c``,
    vertical ``z + x θ``, pitch ``θ``. The rigid limit of the bending fem car (its rigid modes).
    """
    x, w = body.quadrature()
    m = w * body.mass_per_length(x)
    mass, first, second = float(np.sum(m)), float(np.sum(m * x)), float(np.sum(m * x * x))
    (h1, h2), (s1, s2) = offset, slope
    n = np.asarray(sensor_x, dtype=float).size
    l = body.half_length
    ends = np.array([[1.0, s1, h1 - s1 * l], [1.0, s2, h2 + s2 * l]])
    sensors = np.vstack([
        np.column_stack([np.ones(n), np.zeros(n), np.zeros(n)]),
        np.column_stack([np.zeros(n), np.ones(n), sensor_x]),
        np.column_stack([np.zeros(n), np.zeros(n), np.ones(n)]),
    ])
    return SecondOrderSystem(
        "rigid",
        np.array([[mass, 0.0, 0.0], [0.0, mass, first], [0.0, first, second]]),
        np.zeros((3, 3)),
        np.zeros((3, 3)),
        np.column_stack([-ends[0], ends[1]]),
        ends,
        sensors,
        translation=np.array([1.0, 0.0, 0.0]),
        settings={"dofs": 3, "mass": mass, "pitch_inertia": second, "coupler_offset": list(offset), "coupler_slope": list(slope)},
    )


def _rigid_system(mass: float, sensors: int) -> SecondOrderSystem:
    return SecondOrderSystem(
        "rigid",
        np.array([[mass]]),
        np.zeros((1, 1)),
        np.zeros((1, 1)),
        np.array([[-1.0, 1.0]]),
        np.ones((2, 1)),
        np.ones((sensors, 1)),
        translation=np.ones(1),
        settings={"dofs": 1, "mass": mass},
    )


def _load_names(body: Body) -> tuple[str, ...]:
    return ("F1", "F2") if body.kind == "rod" else ("N1", "N2", "G1", "G2")


def _with_outputs(result: ModelResult, scene: Scene, accel: NDArray, displacement: NDArray, force: NDArray) -> ModelResult:
    outputs = {"acceleration": accel, "displacement": displacement}
    if scene.body.kind == "rod":
        outputs["axial_force"] = force
    result.set_probe_outputs(scene.probes, outputs)
    return result
