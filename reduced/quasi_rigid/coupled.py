"""Displacement form of a quasi-rigid body, stepped in time inside a coupled simulation.

The displacement of material point x is the rigid-body motion of the centre of mass
(and, for a beam, the rotation about it) plus the quasi-static deformation under the
current inertia-balanced load, delayed by the creep filters (:mod:`.correction`):

    u(x, t) = Σ_k r_k(x) q_k(t) + Σ_j Σ_g C[x, j, g] y_{g,j}(t),
    q̈ = R L(t),     τ_g ẏ_{g,j} + y_{g,j} = L_j(t).

Within a step the end loads are linear in time, and every part is advanced by its
exact update for such loads: ``q`` by the cubic Taylor step of a linear acceleration,
``y`` by the exponential update of :func:`.creep.update_coefficients`, and the
velocity filter ``z = L_τ[L̇]`` by the exact update for a constant slope. So the new
displacement and velocity are affine in the new loads,

    u_{n+1} = u_free + G_u L_{n+1},     v_{n+1} = v_free + G_v L_{n+1},

and :meth:`QuasiRigidStepper.predict` returns ``(u_free, G_u, v_free, G_v)`` — the exact
Jacobian for a Newton iteration on a coupler force. The elastic limit (τ = 0) gives
``y = L`` (quasi-static deformation at once), the rigid limit (τ = ∞) ``y`` frozen.

Accelerations add ``Σ C L_τ[L̈]`` to the rigid ones; L̈ at ``t_{n+1}`` is the second
derivative of the cubic through the last four load samples: no look-ahead, error
``≈ (11/12) dt² L⁗`` for smooth loads; a kink of slope jump s shows as ``(2, −1)·s/dt``
over two steps. ``initial_shape="undeformed"`` (an impact whose coupler force jumps at
contact): the loads count as zero before t = 0 and the deformation under the initial
loads develops through the creep filters; the rate filters count the load's change after
t = 0 only, so the velocity misses the decaying ``C L₀ e^{−t/τ}/τ`` of the jump.

Verified: tests/reduced/quasi_rigid/test_coupled.py (the time-domain model, momentum, the
harmonic steady state, the exact response to O(ε²), the two-mass closed form) and
tests/models/test_cars.py (the undeformed start).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .body import QuasiRigidBody
from .creep import update_coefficients


@dataclass(frozen=True, eq=False)
class StepPrediction:
    """Affine dependence of the probe displacements and velocities at the end of a step on its end loads.

    ``displacement + displacement_gain @ L`` (m; gain in m/N) and
    ``velocity + velocity_gain @ L`` (m/s), probes in the stepper's order (ends first).
    """

    dt: float
    displacement: NDArray[np.float64]
    displacement_gain: NDArray[np.float64]
    velocity: NDArray[np.float64]
    velocity_gain: NDArray[np.float64]

    def at(self, loads: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Displacements and velocities for trial end loads ``L`` (order of ``load_names``)."""
        L = np.asarray(loads, dtype=float)
        return self.displacement + self.displacement_gain @ L, self.velocity + self.velocity_gain @ L


@dataclass(frozen=True, eq=False)
class StepMatrices:
    """One step of :class:`QuasiRigidStepper` as a linear map (:meth:`QuasiRigidStepper.transition`).

    ``x_{n+1} = transition @ x_n + input @ L_{n+1}``; at the stepper's positions,
    ``displacement @ x + displacement_offset`` (m), ``velocity @ x`` (m/s) and
    ``acceleration @ x`` (m/s²).
    """

    transition: NDArray[np.float64]
    input: NDArray[np.float64]
    displacement: NDArray[np.float64]
    displacement_offset: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]


def _second_derivative_weights(ta: float, tb: float, tc: float, td: float) -> NDArray[np.float64]:
    """Weights on four samples (oldest first) of ``p''(t_d)``, p the cubic through them:
    ``p''(t_d) = 2 f[t_d, t_c, t_b] + 2 f[t_d, t_c, t_b, t_a] ((t_d − t_c) + (t_d − t_b))``
    (uniform step: ``(−1, 4, −5, 2)/dt²``)."""
    spread = (td - tc) + (td - tb)
    return np.array([
        2.0 * spread / ((ta - tb) * (ta - tc) * (ta - td)),
        2.0 / ((tb - tc) * (tb - td)) + 2.0 * spread / ((tb - ta) * (tb - tc) * (tb - td)),
        2.0 / ((tc - tb) * (tc - td)) + 2.0 * spread / ((tc - ta) * (tc - tb) * (tc - td)),
        2.0 / ((td - tb) * (td - tc)) + 2.0 * spread / ((td - ta) * (td - tb) * (td - tc)),
    ])


#: Initial shapes of a loaded body (:class:`QuasiRigidStepper`).
INITIAL_SHAPES: tuple[str, ...] = ("equilibrium", "undeformed")


class QuasiRigidStepper:
    """Stateful stepper of a quasi-rigid body; ``positions`` are ``[−l, +l, *probes]``.

    ``initial_loads`` (order of ``body.load_names``) are held before t = ``time``; displacements count from
    the initial shape: quasi-static equilibrium under them (``initial_shape="equilibrium"``) or undeformed
    (``"undeformed"``, module docstring). ``initial_rigid_velocity`` is the rigid-mode velocity (rod:
    centre-of-mass velocity, m/s; beam: ``(v, Ω)``).
    """

    def __init__(
        self,
        body: QuasiRigidBody,
        probes: ArrayLike = (),
        *,
        initial_loads: ArrayLike | None = None,
        initial_rigid_velocity: ArrayLike = 0.0,
        time: float = 0.0,
        initial_shape: str = "equilibrium",
    ) -> None:
        if initial_shape not in INITIAL_SHAPES:
            raise ValueError(f"initial_shape must be one of {INITIAL_SHAPES}, got {initial_shape!r}")
        self.body = body
        self.positions, self._C, self._Cf, self._modes, self._gain, self._modes_gain = _position_tables(body, probes)
        self._tau = body.tau_groups
        K, J = self._gain.shape
        G = self._tau.size
        L0 = np.zeros(J) if initial_loads is None else np.asarray(initial_loads, dtype=float).reshape(J)
        self.time = float(time)
        self.loads = L0.copy()
        self.rigid_displacement = np.zeros(K)
        self.rigid_velocity = np.empty(K)
        self.rigid_velocity[...] = initial_rigid_velocity
        # filter states, (3, G, J): L_τ[L] (steady state of the held load), L_τ[L̇], L_τ[L̈]
        self._state = np.zeros((3, G, J))
        if initial_shape == "equilibrium":
            self._state[0] = L0
        self._y0 = self._state[0].ravel().copy()            # displacements count from this shape
        self._second = np.zeros(J)                          # L̈ estimate at the current time
        self._times: list[float] = []                       # the last four sample times and loads
        self._history = np.empty((4, J))                    # (held before the start)
        self._history[...] = L0
        self._inputs = np.zeros((2, 3, 1, J))               # filter inputs at both ends of a step
        self._cached_dt: float | None = None
        self._sum_load2 = 0.0
        self._sum_rate2 = 0.0
        self.steps = 0

    # -- one step --------------------------------------------------------------------
    def _coefficients(self, dt: float) -> None:
        """Filter updates and step gains for ``dt`` (recomputed only when dt changes)."""
        if self._cached_dt == dt:
            return
        d, a, b = update_coefficients(dt, self._tau)
        phi = a + b
        self._d, self._a, self._b = d[:, None], a[:, None], b[:, None]
        self._phi_dt = (phi / dt)[:, None]
        Cf, J = self._Cf, self._gain.shape[1]
        G = self._tau.size
        # y0 cancels in the gains because d + a + b = 1
        self._u_gain = self._modes_gain * (dt * dt / 6.0) + (Cf.reshape(-1, G, J) * b[None, :, None]).sum(axis=1)
        self._v_gain = self._modes_gain * (0.5 * dt) + (Cf.reshape(-1, G, J) * (phi / dt)[None, :, None]).sum(axis=1)
        self._u_gain.flags.writeable = False  # shared by the predictions of every step of this dt
        self._v_gain.flags.writeable = False
        self._cached_dt = dt

    def predict(self, dt: float) -> StepPrediction:
        """Displacements and velocities at ``time + dt`` as affine functions of the new end loads."""
        if not dt > 0.0:
            raise ValueError("dt must be > 0")
        self._coefficients(dt)
        L = self.loads
        qdd = self._gain @ L
        q_free = self.rigid_displacement + dt * self.rigid_velocity + (dt * dt / 3.0) * qdd
        qd_free = self.rigid_velocity + (0.5 * dt) * qdd
        y_free = self._d * self._state[0] + self._a * L
        z_free = self._d * self._state[1] - self._phi_dt * L
        u = self._modes @ q_free + self._Cf @ (y_free.ravel() - self._y0)
        v = self._modes @ qd_free + self._Cf @ z_free.ravel()
        return StepPrediction(dt, u, self._u_gain, v, self._v_gain)

    def step(self, dt: float, *loads: float, **named: float) -> None:
        """Advance by ``dt`` with the end loads at the end of the step (linear within it).

        Rod: ``step(dt, F1, F2)``; beam: ``step(dt, N1, N2, G1, G2)``; or by name.
        """
        if not dt > 0.0:
            raise ValueError("dt must be > 0")
        L1 = self._load_vector(loads, named)
        self._coefficients(dt)
        L0 = self.loads
        slope = (L1 - L0) / dt
        qdd0, qdd1 = self._gain @ L0, self._gain @ L1
        self.rigid_displacement = self.rigid_displacement + dt * self.rigid_velocity + (dt * dt / 6.0) * (2.0 * qdd0 + qdd1)
        self.rigid_velocity = self.rigid_velocity + (0.5 * dt) * (qdd0 + qdd1)
        second = self._second_derivative(self.time + dt, L1, dt)
        # y: input L; z: input L̇ (constant on the step, so a + b = 1 − d multiplies it); w: input L̈
        start, end = self._inputs
        start[0, 0], start[1, 0], start[2, 0] = L0, slope, self._second
        end[0, 0], end[1, 0], end[2, 0] = L1, slope, second
        self._state = self._d * self._state + self._a * start + self._b * end
        self._second = second
        self._sum_load2 += 0.5 * dt * float(L0 @ L0 + L1 @ L1)
        self._sum_rate2 += dt * float(slope @ slope)
        self.time += dt
        self.loads = L1
        self.steps += 1

    def _load_vector(self, loads: tuple[float, ...], named: dict[str, float]) -> NDArray[np.float64]:
        names = self.body.load_names
        if loads and named:
            raise TypeError("give the loads either by position or by name")
        if named:
            unknown = set(named) - set(names)
            if unknown:
                raise ValueError(f"unknown loads {sorted(unknown)}; this body takes {names}")
            return np.array([float(named.get(n, 0.0)) for n in names])
        if len(loads) != len(names):
            raise TypeError(f"expected {len(names)} loads {names}, got {len(loads)}")
        return np.array(loads, dtype=float)

    def _second_derivative(self, t1: float, L1: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """``L̈(t₁)``: second derivative of the cubic through the last four samples (held before the start)."""
        times = self._times
        if not times:  # held before the first sample, one step apart
            times.extend([self.time - 2.0 * dt, self.time - dt, self.time])
        times.append(t1)
        if len(times) > 4:
            del times[0]
        history = self._history
        history[:-1] = history[1:]
        history[-1] = L1
        return _second_derivative_weights(*times) @ history

    def run(self, dt: float, loads: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Step through load samples ``loads[n]`` (shape ``(Nt, J)``, the first being the current loads).

        Returns ``time``, ``displacement``, ``velocity``, ``acceleration`` ``(Nt, P)``.
        """
        loads = np.asarray(loads, dtype=float)
        n = loads.shape[0]
        out = {key: np.empty((n, self.positions.size)) for key in ("displacement", "velocity", "acceleration")}
        times = np.empty(n)
        for k in range(n):
            if k > 0:
                self.step(dt, *loads[k])
            times[k] = self.time
            out["displacement"][k] = self.displacement
            out["velocity"][k] = self.velocity
            out["acceleration"][k] = self.acceleration
        out["time"] = times
        return out

    # -- the step as a linear map ----------------------------------------------------
    def state_vector(self) -> NDArray[np.float64]:
        """The stepper's state as one vector, in the order of :meth:`transition`."""
        return np.concatenate([self.rigid_displacement, self.rigid_velocity, self._state.ravel(), self._second, self._history[1:].ravel()])

    def transition(self, dt: float) -> StepMatrices:
        """The step of ``dt`` as a linear map on the state: ``x_{n+1} = A x_n + B L_{n+1}``.

        The state is ``x = (q, q̇, y, z, w, L̈_n, L_{n−2}, L_{n−1}, L_n)``: the rigid displacement and velocity
        (K each), the three filter states ``(G, J)`` flattened as ``g·J + j``, the current L̈ estimate and the
        last three load samples (J each). Every part of :meth:`step` is linear in ``(x, L_{n+1})`` for a fixed
        ``dt``: the filter update is ``S' = d S + a·(L_n, L̇, L̈_n) + b·(L_{n+1}, L̇, L̈_{n+1})``. The outputs
        are ``displacement = D x + d₀`` (``d₀ = −C y₀``), ``velocity = V x``, ``acceleration = Acc x``;
        tests/reduced/quasi_rigid/test_coupled.py holds ``A`` to :meth:`step`.
        """
        return _step_matrices(dt, self._tau, self._gain, self._modes, self._Cf, self._modes_gain, self._y0)

    # -- state -----------------------------------------------------------------------
    @property
    def displacement(self) -> NDArray[np.float64]:
        """Displacement at :attr:`positions` from the initial position and shape (m), rigid motion included."""
        return self._modes @ self.rigid_displacement + self._Cf @ (self._state[0].ravel() - self._y0)

    @property
    def velocity(self) -> NDArray[np.float64]:
        """Velocity at :attr:`positions` (m/s), exact for loads linear within each step."""
        return self._modes @ self.rigid_velocity + self._Cf @ self._state[1].ravel()

    @property
    def acceleration(self) -> NDArray[np.float64]:
        """Acceleration at :attr:`positions` (m/s²)."""
        return self._modes_gain @ self.loads + self._Cf @ self._state[2].ravel()

    @property
    def correction_loads(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The filtered loads behind the correction now, ``(y − y₀, z)``, each ``(G, J)``:
        ``u(x) = r(x) q + Σ_{g,j} C[x, j, g] (y − y₀)[g, j]``, ``v(x) = r(x) q̇ + Σ C[x, j, g] z[g, j]`` (:meth:`at`)."""
        G, J = self._state.shape[1:]
        return self._state[0] - self._y0.reshape(G, J), self._state[1].copy()

    def at(self, x: ArrayLike, derivative: int = 0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Displacement and velocity (``derivative = 1``: their x-derivatives) at any positions x now, without
        making x a probe (the body caches the coefficient table of x)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        C = self.body.coefficients(x, derivative)
        y, z = self.correction_loads
        modes = self.body.rigid_modes(x, derivative)
        return (modes @ self.rigid_displacement + np.einsum("xjg,gj->x", C, y),
                modes @ self.rigid_velocity + np.einsum("xjg,gj->x", C, z))

    @property
    def end_displacement(self) -> NDArray[np.float64]:
        """Displacements at ``(−l, +l)`` (m)."""
        return self.displacement[:2]

    @property
    def end_velocity(self) -> NDArray[np.float64]:
        return self.velocity[:2]

    def sensitivity(self, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(∂u_end/∂L, ∂v_end/∂L)`` over a step of ``dt``: 2 × J matrices (m/N, m/(s·N))."""
        p = self.predict(dt)
        return p.displacement_gain[:2], p.velocity_gain[:2]

    @property
    def load_time_scale(self) -> float:
        """``π √(∫ΣL²/∫ΣL̇²)`` over the steps so far (s; ∞ before any change)."""
        if self._sum_rate2 == 0.0:
            return math.inf
        return math.pi * math.sqrt(self._sum_load2 / self._sum_rate2)

    @property
    def epsilon(self) -> float:
        """Small parameter at the load time scale seen so far (:meth:`QuasiRigidBody.epsilon_of_time_scale`)."""
        return self.body.epsilon_of_time_scale(self.load_time_scale)


def _position_tables(body: QuasiRigidBody, probes: ArrayLike) -> tuple[NDArray[np.float64], ...]:
    """``(positions, C, C_flat, modes, gain, modes @ gain)`` at ``positions = [−l, +l, *probes]``: the coefficients
    ``C[x, j, g]`` ``(P, J, G)`` and flattened in the state's order ``g·J + j`` ``(P, G·J)``, the rigid modes
    ``(P, K)``, the rigid gain ``(K, J)`` and the rigid accelerations per unit load there ``(P, J)``."""
    l = body.half_length
    positions = np.concatenate([[-l, l], np.atleast_1d(np.asarray(probes, dtype=float))])
    C = body.coefficients(positions)
    flat = np.ascontiguousarray(C.transpose(0, 2, 1).reshape(C.shape[0], -1))
    modes, gain = body.rigid_modes(positions), body.rigid_gain
    return positions, C, flat, modes, gain, modes @ gain


def step_matrices(body: QuasiRigidBody, probes: ArrayLike, dt: float) -> StepMatrices:
    """:meth:`QuasiRigidStepper.transition` of an undeformed stepper (``y₀ = 0``) at ``[−l, +l, *probes]``, without
    making the stepper: what a car that is stepped as one matrix needs."""
    _, _, flat, modes, gain, modes_gain = _position_tables(body, probes)
    return _step_matrices(dt, body.tau_groups, gain, modes, flat, modes_gain, np.zeros(flat.shape[1]))


def _step_matrices(dt: float, tau: NDArray[np.float64], gain: NDArray[np.float64], modes: NDArray[np.float64],
                   Cf: NDArray[np.float64], modes_gain: NDArray[np.float64], y0: NDArray[np.float64]) -> StepMatrices:
    """:meth:`QuasiRigidStepper.transition` from the tables of :func:`_position_tables` and the initial filter
    state ``y₀``."""
    if not dt > 0.0:
        raise ValueError("dt must be > 0")
    d, a, b = update_coefficients(dt, tau)
    K, J = gain.shape
    G = tau.size
    gj = G * J
    q, qd, y, z, w, second = 0, K, 2 * K, 2 * K + gj, 2 * K + 2 * gj, 2 * K + 3 * gj
    history = second + J
    n = history + 3 * J
    A = np.zeros((n, n))
    B = np.zeros((n, J))
    eye_j = np.eye(J)
    current = slice(history + 2 * J, history + 3 * J)
    g = gain

    def stacked(coefficient: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(G·J, J)``: ``coefficient[g] · I_J`` in the rows ``g·J + j`` of group g."""
        return (coefficient[:, None, None] * eye_j).reshape(gj, J)

    # the diagonal: q and q̇ carried over, each filter state decays by d
    diagonal = np.zeros(n)
    diagonal[:2 * K] = 1.0
    diagonal[y:second].reshape(3, G, J)[...] = d[:, None]
    A.flat[::n + 1] = diagonal
    # rigid motion: q' = q + dt q̇ + dt²/6 (2 g L_n + g L_{n+1}),  q̇' = q̇ + dt/2 g (L_n + L_{n+1})
    A[q:q + K, qd:qd + K] = dt * np.eye(K)
    A[q:q + K, current] = (dt * dt / 3.0) * g
    B[q:q + K] = (dt * dt / 6.0) * g
    A[qd:qd + K, current] = B[qd:qd + K] = 0.5 * dt * g
    # L̈_{n+1} from the last four samples
    weights = _second_derivative_weights(-3.0 * dt, -2.0 * dt, -dt, 0.0)
    estimate = A[second:second + J, history:n]                              # (L_{n−2}, L_{n−1}, L_n) columns
    estimate[...] = (eye_j[:, None, :] * weights[:3, None]).reshape(J, 3 * J)
    B[second:second + J] = weights[3] * eye_j
    # the filters, group by group (rows g·J + j): S' = d S + a·(start input) + b·(end input)
    A[y:y + gj, current] = stacked(a)                                       # y: input L (L_n, then L_{n+1})
    B[y:y + gj] = stacked(b)
    rate = (a + b) / dt
    A[z:z + gj, current] = -stacked(rate)                                   # z: input L̇ = (L_{n+1} − L_n)/dt
    B[z:z + gj] = stacked(rate)
    A[w:w + gj, second:second + J] = stacked(a)                             # w: input L̈ (L̈_n, then its new estimate)
    A[w:w + gj, history:n] = (b[:, None, None] * estimate[None]).reshape(gj, 3 * J)
    B[w:w + gj] = stacked(b * weights[3])
    # the load history shifts: L_{n−1} → L_{n−2}, L_n → L_{n−1}, L_{n+1} → L_n
    A[history:history + 2 * J, history + J:n] = np.eye(2 * J)
    B[current] = eye_j
    P = modes.shape[0]
    displacement, velocity, acceleration = np.zeros((P, n)), np.zeros((P, n)), np.zeros((P, n))
    displacement[:, q:q + K] = modes
    displacement[:, y:y + gj] = Cf
    velocity[:, qd:qd + K] = modes
    velocity[:, z:z + gj] = Cf
    acceleration[:, current] = modes_gain
    acceleration[:, w:w + gj] = Cf
    return StepMatrices(A, B, displacement, -(Cf @ y0), velocity, acceleration)
