"""The quasi-rigid model of :mod:`reduced.quasi_rigid` as a femref model.

Two-term low-frequency perturbation of the rigid-body motion (docs/formulas.md §D, E):
harmonic scenes use the complex response, transient scenes the time-domain form with
O(1)-per-step creep filters. The ε it was computed at goes into the settings.

In an impact the car is the displacement-form stepper of :mod:`reduced.quasi_rigid.coupled`
as a state-space system (:func:`quasi_rigid_car`): its displacement is its rigid-body motion
plus the creep deformation under the inertia-balanced end loads,

    u(x, t) = q(t) + Σ_j Σ_g C[x, j, g] y_{g,j}(t),   M q̈ = F2 − F1,   τ_g ẏ + y = L_j,

stepped exactly for end loads linear within a step; the step is one matrix
(:meth:`QuasiRigidStepper.transition`). The car starts undeformed at its rigid velocity
(``initial_shape="undeformed"``): an impact's coupler force may jump at contact.

Verified (tests/models/test_cars.py): the affine prediction, O(ε²) against the FEM car,
momentum, the stiff limit, the Voigt car's dissipated energy.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from femref.core.body import Body
from femref.core.timegrid import output_steps, steps_to
from femref.impact.systems import StateSpaceSystem
from femref.models.base import CarFidelity, Progress, built_once
from femref.results import ModelResult
from femref.scene import Car, ImpactScene, Scene
from reduced.quasi_rigid import LoadHistory, QuasiRigidBeam, QuasiRigidRod, step_matrices


def quasi_rigid_body(body: Body) -> QuasiRigidRod | QuasiRigidBeam:
    """The body's quasi-rigid model (profiles and jumps as given), built once per geometry."""
    kind = QuasiRigidRod if body.kind == "rod" else QuasiRigidBeam
    return built_once(
        ("quasi_rigid_body", body.geometry),
        lambda: kind(body.half_length, body.mass_per_length, body.stiffness, body.viscosity, jumps=body.jumps),
    )


class QuasiRigidModel(CarFidelity):
    name = "quasi_rigid"
    expansion_order = 1
    range_limit = 0.1
    """ε_loc of the end loads above which a car is outside its range (:mod:`femref.run.validity`; its error against
    the fem grows like ε²: ~1 % at 0.1)."""
    setup_us = (2917.0,)
    """Set-up of a two-car run, µs (:meth:`femref.models.base.CarFidelity.cost`): the fit's 5064 before the issue-31
    build × 0.576, the ratio of the two builds' refits by ``benchmarks/fit_ladder_costs.py`` in one session (1951 /
    3387), so that it stays on the scale of the other fidelities' constants."""
    step_us = (4.556,)
    """One step of a two-car run, µs."""

    def harmonic(self, scene: Scene) -> ModelResult:
        response = quasi_rigid_body(scene.body).harmonic(scene.omega, scene.probe_x, **scene.loads)
        result = ModelResult(self.name, settings={"epsilon_max": float(np.max(response.epsilon))})
        result.axes = {"omega": scene.omega, "lambda": scene.body.frequency_to_lambda(scene.omega)}
        result.set_probe_outputs(scene.probes, {"acceleration": response.acceleration, "displacement": response.displacement})
        return result

    def transient(self, scene: Scene, progress: Progress | None = None) -> ModelResult:
        steps = steps_to(scene.end, scene.dt)
        t_all = scene.dt * np.arange(steps + 1)
        loads = {
            name: LoadHistory(signal, lambda t, s=signal: s.derivative(t, 1), lambda t, s=signal: s.derivative(t, 2))
            for name, signal in scene.loads.items()
        }
        response = quasi_rigid_body(scene.body).transient(t_all, scene.probe_x, **loads, load_time_scale=_finite(scene.load_time_scale))
        keep = output_steps(steps, scene.output_stride)
        result = ModelResult(self.name, settings={"epsilon": float(response.epsilon), "dt": scene.dt, "load_derivatives": "analytic"})
        result.axes = {"time": t_all[keep]}
        result.set_probe_outputs(scene.probes, {"acceleration": response.acceleration[keep], "displacement": response.displacement[keep]})
        return result

    def car(self, car: Car, scene: ImpactScene, dt: float) -> StateSpaceSystem:
        """The car as a quasi-rigid rod stepped exactly at ``dt``, undeformed at its initial velocity."""
        return quasi_rigid_car(car, dt)


MODEL = QuasiRigidModel()


def _finite(value: float) -> float | None:
    return value if np.isfinite(value) else None


def quasi_rigid_rod(car: Car) -> QuasiRigidRod:
    """The car's body as a :class:`QuasiRigidRod` (profiles and jumps as given)."""
    if car.body.kind != "rod":
        raise ValueError(f"a quasi-rigid car is a rod, got a {car.body.kind}")
    return quasi_rigid_body(car.body)


def _energy_forms(rod: QuasiRigidRod | QuasiRigidBeam) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(∫ m C Cᵀ, ∫ m C, ∫ m x C, ∫ EA C' C'ᵀ)`` over the body's Gauss rule; C flattened as ``(g, j)`` (a
    beam: ``∫ EI C'' C''ᵀ``, its ψ being the curvature per unit filtered load; ``∫ m x C`` its pitch's
    kinetic coupling to the correction).

    ``C[x, j, g]`` (:meth:`CreepCorrection.node_coefficients`) and its x-derivative ψ, the strain
    per unit filtered load (:attr:`CreepCorrection.psi_at_nodes`), at the quadrature nodes
    (panels end on every profile jump).
    """
    q, correction = rod.quadrature, rod.correction

    def flat(table: NDArray[np.float64]) -> NDArray[np.float64]:
        return table.transpose(0, 2, 1).reshape(q.nodes.size, -1)

    C = flat(correction.node_coefficients())
    D = flat(correction.psi_at_nodes.reshape(q.nodes.size, *correction.psi_at_nodes.shape[2:]))
    mass, stiffness = (q.weights * q.mass).ravel(), (q.weights * q.stiffness).ravel()
    return C.T @ (mass[:, None] * C), mass @ C, (mass * q.nodes.ravel()) @ C, D.T @ (stiffness[:, None] * D)


def quasi_rigid_car(car: Car, dt: float) -> StateSpaceSystem:
    """The car as a quasi-rigid rod stepped at ``dt`` (module docstring), sensors as probes; built once per
    geometry, sensors and step.

    The state is the stepper's (:meth:`QuasiRigidStepper.transition`): ``(q, q̇, y, z, w, L̈, L_{n−2},
    L_{n−1}, L_n)``. It starts undeformed: the filters at rest, ``q̇ = v₀`` and the load history
    held at ``L₀``. Energies as the quadratic forms of the quadrature of ``½∫ m v² dx`` and
    ``½∫ EA u_x² dx`` (:func:`_energy_forms`, Gram matrices of the coefficient table):
    ``T = ½ M q̇² + q̇ (∫ m C) z + ½ zᵀ (∫ m C Cᵀ) z``, ``V = ½ yᵀ (∫ EA C' C'ᵀ) y``. The model
    has no exact energy identity, so the dissipated energy is ``T₀ + W − T − V``, W the work of
    the end loads (internal end forces, tension positive: ``−F1`` acts at ``−l``, ``+F2`` at
    ``+l``): for a Voigt car it approximates the viscous dissipation; for an elastic car it
    measures the model's energy error (small, either sign: the correction's own kinetic
    energy, O(ε) of the strain energy, is not balanced by the model).
    """
    bending = None if car.bending is None else car.bending.geometry
    key = ("quasi_rigid", car.body.geometry, bending, car.coupler_offset, car.coupler_slope, tuple(car.sensors.values()), float(dt))
    if car.bending is not None:
        return built_once(key, lambda: _bending_quasi_rigid_system(car, dt))
    return built_once(key, lambda: _quasi_rigid_system(car, dt))


def _quasi_rigid_system(car: Car, dt: float) -> StateSpaceSystem:
    rod = quasi_rigid_rod(car)
    step = step_matrices(rod, car.sensor_x, dt)
    n = step.transition.shape[0]
    K, J = rod.rigid_gain.shape
    gj = rod.tau_groups.size * J
    qd, y, z, history = K, 2 * K, 2 * K + gj, 2 * K + 3 * gj + J
    kinetic_form, kinetic_cross, _, strain_form = _energy_forms(rod)
    kinetic = np.zeros((n, n))
    kinetic[qd, qd] = rod.mass
    kinetic[qd, z:z + gj] = kinetic[z:z + gj, qd] = kinetic_cross
    kinetic[z:z + gj, z:z + gj] = kinetic_form
    strain = np.zeros((n, n))
    strain[y:y + gj, y:y + gj] = strain_form
    velocity_state = np.zeros(n)
    velocity_state[qd] = 1.0
    load_state = np.zeros((n, J))
    load_state[history:].reshape(3, J, J)[...] = np.eye(J)  # L_{n−2}, L_{n−1}, L_n: the loads held before t = 0
    momentum = np.zeros(n)
    momentum[qd] = rod.mass  # the creep correction carries none (∫ m C dx = 0)
    return StateSpaceSystem(
        "quasi_rigid",
        dt,
        step.transition,
        step.input,
        step.displacement[:2],
        step.velocity[:2],
        step.displacement[2:],
        step.velocity[2:],
        step.acceleration[2:],
        velocity_state,
        load_state,
        kinetic,
        strain,
        np.diag([-1.0, 1.0]),
        momentum,
        settings={"tau_groups": [float(t) for t in rod.tau_groups]},
        settings_of_time_scale=lambda time_scale: {"epsilon": rod.epsilon_of_time_scale(time_scale)},
    )


def _bending_quasi_rigid_system(car: Car, dt: float) -> StateSpaceSystem:
    """A car that bends, quasi-rigid: the rod car above beside the quasi-rigid beam (docs/formulas.md §E) —
    heave and pitch plus the creep bending under the inertia-balanced end moments — joined at the coupler
    line as the fem car is (:func:`femref.models.fem.bending_system`)::

        x = (x_rod, x_beam),   beam loads (N1, N2, G1, G2) = (−s₁ F1, −s₂ F2, h₁ F1, h₂ F2),
        end outputs  u(∓l) + h θ(∓l) + s w(∓l),   sensors: the rod's axial rows, then w, then θ = ∂w/∂x

    The beam block is the stepper's own (:meth:`QuasiRigidStepper.transition`, its load samples in
    beam units, ``T L``); its slopes come from the rigid modes' and the correction's x-derivatives
    (no numerical differentiation). Energies: the rod's forms plus the beam's, ``½ ∫ m v_w² dx`` and
    ``½ ∫ EI κ² dx`` by the same quadrature Gram matrices. The beam needs even profiles.
    """
    rod = _quasi_rigid_system(car, dt)
    assert car.bending is not None
    beam = quasi_rigid_body(car.bending)
    step = step_matrices(beam, car.sensor_x, dt)
    (h1, h2), (s1, s2) = car.coupler_offset, car.coupler_slope
    to_beam = np.array([[-s1, 0.0], [0.0, -s2], [h1, 0.0], [0.0, h2]])  # (N1, N2, G1, G2) from (F1, F2)
    n_b = step.transition.shape[0]
    K, J = beam.rigid_gain.shape
    gj = beam.tau_groups.size * J
    qd, y, z, w = K, 2 * K, 2 * K + gj, 2 * K + 2 * gj
    history = 2 * K + 3 * gj + J
    current = slice(history + 2 * J, history + 3 * J)
    positions = np.concatenate([[-beam.half_length, beam.half_length], car.sensor_x])

    def flat(table: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.ascontiguousarray(table.transpose(0, 2, 1).reshape(table.shape[0], -1))

    slope_modes, slope_table = beam.rigid_modes(positions, 1), flat(beam.coefficients(positions, 1))
    slope = np.zeros((positions.size, n_b))
    slope[:, 0:K] = slope_modes
    slope[:, y:y + gj] = slope_table
    slope_rate = np.zeros((positions.size, n_b))
    slope_rate[:, qd:qd + K] = slope_modes
    slope_rate[:, z:z + gj] = slope_table
    slope_acceleration = np.zeros((positions.size, n_b))
    slope_acceleration[:, current] = slope_modes @ beam.rigid_gain
    slope_acceleration[:, w:w + gj] = slope_table
    offsets, slopes = np.array([[h1], [h2]]), np.array([[s1], [s2]])
    n_r, S = rod.transition.shape[0], car.sensor_x.size

    def side_by_side(rod_rows: NDArray[np.float64], beam_rows: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.hstack([rod_rows, beam_rows])

    kinetic_form, kinetic_cross, pitch_cross, strain_form = _energy_forms(beam)
    beam_kinetic = np.zeros((n_b, n_b))
    beam_kinetic[qd:qd + K, qd:qd + K] = np.diag([beam.mass, beam.moment_of_inertia])
    beam_kinetic[z:z + gj, z:z + gj] = kinetic_form
    cross = np.stack([kinetic_cross, pitch_cross])  # ∫ m C and ∫ m x C: zero to rounding
    beam_kinetic[qd:qd + K, z:z + gj] = cross
    beam_kinetic[z:z + gj, qd:qd + K] = cross.T
    beam_strain = np.zeros((n_b, n_b))
    beam_strain[y:y + gj, y:y + gj] = strain_form
    load_state = np.zeros((n_b, 2))
    for k in range(3):
        load_state[history + k * J:history + (k + 1) * J] = to_beam
    return StateSpaceSystem(
        "quasi_rigid",
        dt,
        scipy.linalg.block_diag(rod.transition, step.transition),
        np.vstack([rod.input, step.input @ to_beam]),
        side_by_side(rod.end_displacement, offsets * slope[:2] + slopes * step.displacement[:2]),
        side_by_side(rod.end_velocity, offsets * slope_rate[:2] + slopes * step.velocity[:2]),
        np.vstack([side_by_side(rod.sensor_displacement, np.zeros((S, n_b))),
                   side_by_side(np.zeros((S, n_r)), step.displacement[2:]),
                   side_by_side(np.zeros((S, n_r)), slope[2:])]),
        np.vstack([side_by_side(rod.sensor_velocity, np.zeros((S, n_b))),
                   side_by_side(np.zeros((S, n_r)), step.velocity[2:]),
                   side_by_side(np.zeros((S, n_r)), slope_rate[2:])]),
        np.vstack([side_by_side(rod.sensor_acceleration, np.zeros((S, n_b))),
                   side_by_side(np.zeros((S, n_r)), step.acceleration[2:]),
                   side_by_side(np.zeros((S, n_r)), slope_acceleration[2:])]),
        np.concatenate([rod.velocity_state, np.zeros(n_b)]),
        np.vstack([rod.load_state, load_state]),
        scipy.linalg.block_diag(rod.kinetic_form, beam_kinetic),
        scipy.linalg.block_diag(rod.strain_form, beam_strain),
        rod.work_map,
        np.concatenate([rod.momentum, np.zeros(n_b)]),
        settings=dict(rod.settings, bending_tau_groups=[float(t) for t in beam.tau_groups], coupler_offset=list(car.coupler_offset),
                      coupler_slope=list(car.coupler_slope)),
        settings_of_time_scale=rod.settings_of_time_scale,
    )

