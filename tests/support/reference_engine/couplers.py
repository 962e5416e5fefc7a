"""The readable coupler iteration of one impact step, in Python: the oracle of the compiled one.

:class:`CouplerSolve` is the method of :mod:`femref.impact.couplers` (its docstring: Newton on the
coupler forces and states through the cars' Schur complement, the bracketed Gauss–Seidel fallback,
the sided gear state, the energy bookkeeping), written plainly on the laws' methods
(:meth:`reduced.couplers.Coupling.evaluate`); :mod:`femref.impact.kernels.couplers` is held to it.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from femref.impact.couplers import (
    BRACKET_EXPANSIONS,
    MAX_NEWTON_ITERATIONS,
    MAX_SWEEPS,
    NEWTON_ITERATIONS,
    STATE_TOLERANCE,
    CouplerConvergenceError,
    bracket_detail,
    coupler_newton_detail,
    force_tolerance,
    held_at_jump,
    sweeps_detail,
)
from femref.scene import ImpactScene


def same_sign(a: float, b: float) -> bool:
    """``a`` and ``b`` are both > 0 or both < 0 (no sign change between them; a zero is a root)."""
    return (a > 0.0 and b > 0.0) or (a < 0.0 and b < 0.0)


class CouplerSolve:
    """The couplers' forces, states and energy accounts, and the Newton iteration on them (module docstring)."""

    def __init__(self, scene: ImpactScene, dt: float) -> None:
        self.couplings = [c.coupling for c in scene.couplers]
        self.rear = np.array([c.rear for c in scene.couplers])
        self.front = self.rear + 1
        n_cars = len(scene.cars)
        # per car: index of its rear and front coupler (−1: none, reads the appended 0)
        self.car_rear = np.full(n_cars, -1)
        self.car_front = np.full(n_cars, -1)
        for j, c in enumerate(scene.couplers):
            self.car_front[c.rear] = j
            self.car_rear[c.front] = j
        self.dt = dt
        self.state_slices = []
        start = 0
        for coupling in self.couplings:
            self.state_slices.append(slice(start, start + coupling.law.state_size))
            start += coupling.law.state_size
        self.n = len(self.couplings)
        self.n_state = start
        self.state = np.concatenate([c.law.initial_state() for c in self.couplings] + [np.zeros(0)])
        self.force = np.zeros(self.n)
        self.closure = np.zeros(self.n)
        self.rate = np.zeros(self.n)
        self.modes = np.zeros(self.n, dtype=int)
        self.held = np.zeros(self.n, dtype=bool)  # the last step ended held at a jump of the law (held_at_jump)
        self.state_rate = np.zeros(self.n_state)
        self.stored = np.zeros(self.n)
        self.dissipated = np.zeros(self.n)
        self.work = np.zeros(self.n)  # J: work the cars did on each coupler, Σ P̄ Δδ (trapezoidal P̄)
        self.gain_u: NDArray | None = None
        self.gain_v: NDArray | None = None
        self.force_tolerance = force_tolerance(scene)
        self.bracket_expansions = BRACKET_EXPANSIONS
        self._state_settled = True  # the last _state_under converged (read after the scalar root's last trial)

    def _mirrored(self, j: int, closure: float) -> bool:
        """``σ = −1`` for coupler j's step to the closure ``closure``: its committed gear state is mirrored there
        (:meth:`reduced.couplers.Coupling.state_mirrored`, module docstring)."""
        sl = self.state_slices[j]
        return sl.stop > sl.start and self.couplings[j].state_mirrored(closure, self.state[sl])

    def _step_start(self, closure: NDArray) -> tuple[NDArray, NDArray]:
        """The committed states and state rates the step to the closures ``closure`` starts from: each
        coupler's ``σ (s_n, ṡ_n)`` (:meth:`_mirrored`), the committed values where ``σ = +1``."""
        start, start_rate = self.state, self.state_rate
        for j, sl in enumerate(self.state_slices):
            if self._mirrored(j, float(closure[j])):
                if start is self.state:
                    start, start_rate = self.state.copy(), self.state_rate.copy()
                start[sl], start_rate[sl] = -self.state[sl], -self.state_rate[sl]
        return start, start_rate

    def loads(self, forces: NDArray) -> NDArray:
        """End loads ``(F1, F2)`` of every car, ``(n_cars, 2)``: a coupler pushing an end is ``F = −P``."""
        padded = np.append(forces, 0.0)
        return -np.stack([padded[self.car_rear], padded[self.car_front]], axis=1)

    def start(self, closure_rate: NDArray) -> None:
        """Forces at t = 0 from the law at zero closure and the initial closure rates."""
        self.rate = closure_rate.copy()
        for j, coupling in enumerate(self.couplings):
            state = self.state[self.state_slices[j]]
            response = coupling.evaluate(0.0, float(closure_rate[j]), state)
            self.force[j], self.modes[j] = response.force, response.mode
            if coupling.slack == 0.0 and closure_rate[j] > 0.0 and response.mode == 0:
                # faces touching and closing: the contact is engaged from t = 0 (a dashpot's force jump)
                engaged = coupling.transmitted_force(0.0, float(closure_rate[j]), state, 1)
                if engaged > 0.0:
                    self.force[j], self.modes[j] = engaged, 1
            self.state_rate[self.state_slices[j]] = response.state_rate
            self.stored[j] = self._stored(j, 0.0, state, int(self.modes[j]))

    def _stored(self, j: int, closure: float, state: NDArray, mode: int) -> float:
        coupling = self.couplings[j]
        return coupling.law.stored_energy(coupling.effective_closure(closure, mode), state, mode != 0)

    def assemble_gains(self, predictions: list) -> None:
        """``D_u = ∂δ/∂P`` and ``D_v = ∂δ̇/∂P`` from the cars' end gains (fixed for a fixed step)."""
        n = self.n
        self.gain_u, self.gain_v = np.zeros((n, n)), np.zeros((n, n))
        for j in range(n):
            r, f = predictions[self.rear[j]], predictions[self.front[j]]
            for gain, rear_gain, front_gain in ((self.gain_u, r.displacement_gain, f.displacement_gain), (self.gain_v, r.velocity_gain, f.velocity_gain)):
                # δ_j = u_r(+l) − u_f(−l); u_r(+l) feels F1_r = −P_{rear coupler of r}, F2_r = −P_j;
                # u_f(−l) feels F1_f = −P_j, F2_f = −P_{front coupler of f}
                gain[j, j] += -rear_gain[1, 1] + front_gain[0, 0]
                if self.car_rear[self.rear[j]] >= 0:
                    gain[j, self.car_rear[self.rear[j]]] += -rear_gain[1, 0]
                if self.car_front[self.front[j]] >= 0:
                    gain[j, self.car_front[self.front[j]]] += front_gain[0, 1]

    def solve(self, predictions: list) -> int:
        """Newton on ``(P, s)`` at ``t_{n+1}``; updates forces, states, closures; returns the iteration count.

        Converged when the contact modes repeat and the residuals are below round-off
        scales (``1e-10`` of the rigid peak force; 1e-13 m of state). Linear pieces
        converge in one step, so a step usually costs two law evaluations.
        """
        if self.gain_u is None:
            self.assemble_gains(predictions)
        rear = [predictions[i] for i in self.rear]
        front = [predictions[i] for i in self.front]
        closure_free = np.array([r.displacement[1] - f.displacement[0] for r, f in zip(rear, front)])
        rate_free = np.array([r.velocity[1] - f.velocity[0] for r, f in zip(rear, front)])
        n = self.n
        P, s = self.force.copy(), self.state.copy()
        modes = self.modes
        for iteration in range(1, NEWTON_ITERATIONS + 1):
            closure, rate, responses, residual, state_rate = self._residual(closure_free, rate_free, P, s)
            new_modes = np.array([r.mode for r in responses])
            settled = np.array_equal(new_modes, modes)
            modes = new_modes
            if settled and self._converged(residual):
                break
            step = np.linalg.solve(self._jacobian(responses), -residual)
            P += step[:n]
            s += step[n:]
        else:  # Newton cycles where a law is nearly discontinuous (a friction gear's switch band)
            P, s, sweeps = self._gauss_seidel(closure_free, rate_free)
            closure, rate, responses, residual, state_rate = self._residual(closure_free, rate_free, P, s)
            for j, sl in enumerate(self.state_slices):  # the sweeps drove each state by the force P (not T)
                if sl.stop > sl.start:
                    state_rate[sl] = self._driven_rate(j, float(closure[j]), float(rate[j]), float(P[j]), s[sl])[0]
            iteration += sweeps
        self._commit(P, s, closure, rate, state_rate, np.array([r.mode for r in responses]), residual[:n])
        return iteration

    def _residual(self, closure_free: NDArray, rate_free: NDArray, P: NDArray, s: NDArray) -> tuple:
        """Closures, rates, the laws' responses, the residual ``(P − T, s − σ s_n − dt/2 (σ ṡ_n + ṡ))`` and ``ṡ``
        (``σ`` the mirror of :meth:`_step_start` at the trial closures)."""
        closure = closure_free + self.gain_u @ P
        rate = rate_free + self.gain_v @ P
        responses = [
            coupling.evaluate(float(closure[j]), float(rate[j]), s[self.state_slices[j]])
            for j, coupling in enumerate(self.couplings)
        ]
        residual = np.empty(self.n + self.n_state)
        residual[: self.n] = P - np.array([r.force for r in responses])
        state_rate = np.concatenate([r.state_rate for r in responses]) if self.n_state else np.zeros(0)
        start, start_rate = self._step_start(closure)
        residual[self.n :] = s - start - 0.5 * self.dt * (start_rate + state_rate)
        return closure, rate, responses, residual, state_rate

    def _converged(self, residual: NDArray) -> bool:
        return bool(
            np.max(np.abs(residual[: self.n])) <= self.force_tolerance
            and np.max(np.abs(residual[self.n :]), initial=0.0) <= STATE_TOLERANCE
        )

    def _gauss_seidel(self, closure_free: NDArray, rate_free: NDArray) -> tuple[NDArray, NDArray, int]:
        """Coupler by coupler, the others held: a bracketed scalar root for a memoryless law, Newton otherwise.

        For a memoryless law ``f(P_j) = P_j − T(δ(P), δ̇(P))`` has slope ≥ 1 where T does not
        decrease with closure or rate (both fall as P_j pushes the ends apart), so
        ``[P − f(P), P]`` (or its mirror) brackets the root and Brent's method finds it
        however steep T is; elsewhere :meth:`_scalar_root` widens the bracket. A stateful
        coupler takes Newton on its force and state, and where that cycles (a force jump at
        a contact with the gear still compressed) the scalar root with its state following
        the force. The couplers interact only through the cars' end gains, so the sweeps
        converge fast.
        """
        P, s = self.force.copy(), self.state.copy()
        for sweep in range(1, MAX_SWEEPS + 1):
            change, worst = 0.0, 0
            for j in range(self.n):
                previous = P[j]
                sl = self.state_slices[j]
                if sl.stop == sl.start:
                    P[j] = self._scalar_root(j, closure_free, rate_free, P, s)
                else:
                    state = s[sl].copy()
                    if not self._coupler_newton(j, closure_free, rate_free, P, s):
                        if sl.stop - sl.start != 1:
                            raise CouplerConvergenceError(j, coupler_newton_detail())
                        P[j], s[sl] = previous, state  # from where the cycling Newton started
                        P[j] = self._scalar_root(j, closure_free, rate_free, P, s)
                if abs(P[j] - previous) > change:
                    change, worst = abs(P[j] - previous), j
            if change <= self.force_tolerance:
                return P, s, sweep
        raise CouplerConvergenceError(worst, sweeps_detail(change))

    def _excess(self, j: int, closure_free: NDArray, rate_free: NDArray, P: NDArray, s: NDArray, force: float) -> float:
        """``f(P_j) = P_j − T_j(δ(P), δ̇(P), s_j)`` with the other forces held; sets ``P[j]`` and, for a
        stateful coupler, ``s_j`` to its state under the force ``P_j`` (:meth:`_state_under`)."""
        P[j] = force
        closure = float(closure_free[j] + self.gain_u[j] @ P)
        rate = float(rate_free[j] + self.gain_v[j] @ P)
        sl = self.state_slices[j]
        if sl.stop > sl.start:
            s[sl], self._state_settled = self._state_under(j, closure, rate, force, s[sl])
        return force - self.couplings[j].evaluate(closure, rate, s[sl]).force

    def _scalar_root(self, j: int, closure_free: NDArray, rate_free: NDArray, P: NDArray, s: NDArray) -> float:
        """Coupler j's force with the others held: the root of ``f(P_j) = P_j − T_j`` (:meth:`_excess`) by Brent's method.

        The bracket is ``[P − f(P), P]`` (or its mirror) where ``f(P − f(P))`` has the other
        sign than ``f(P)``, as it has when ``f`` rises with slope ≥ 1; else it is widened
        from there in the same direction, the step doubling (at least the force tolerance)
        up to :data:`BRACKET_EXPANSIONS` times, until ``f`` changes sign. A stateful coupler's
        state is left at the root's. Raises :class:`CouplerConvergenceError` (coupler j) when
        no sign change is found or the state at the root does not settle.
        """
        excess = lambda force: self._excess(j, closure_free, rate_free, P, s, force)  # noqa: E731
        start = float(P[j])
        f0 = excess(start)
        if f0 == 0.0:
            return start
        a, fa = start, f0
        step = -f0
        b = start + step
        fb = excess(b)
        expansions = 0
        while same_sign(fa, fb):
            if expansions == self.bracket_expansions:
                raise CouplerConvergenceError(j, bracket_detail())
            expansions += 1
            a, fa = b, fb
            step = 2.0 * step
            if abs(step) < self.force_tolerance:
                step = math.copysign(self.force_tolerance, step)
            b = a + step
            fb = excess(b)
        if fb == 0.0:
            root = b
        else:
            low, high = (a, b) if a < b else (b, a)
            root = float(scipy.optimize.brentq(excess, low, high, xtol=self.force_tolerance))
        if self.state_slices[j].stop > self.state_slices[j].start:
            excess(root)  # the state at the root (Brent's last trial need not be its answer)
            if not self._state_settled:
                raise CouplerConvergenceError(j, coupler_newton_detail())
        return root

    def _state_under(self, j: int, closure: float, rate: float, force: float, state: NDArray) -> tuple[NDArray, bool]:
        """Coupler j's one state under the held transmitted force ``P = force``: the root of
        ``R(s) = s − σ s_n − dt/2 (σ ṡ_n + q(δ, δ̇, s, P))`` by Newton, kept in a shrinking bracket
        (``σ`` the mirror of :meth:`_step_start` at the closure ``δ``).

        ``∂q/∂s ≤ 0`` (the draft gear: ``q = (P − F_g(s))/μ``, F_g rising) gives ``R' ≥ 1``, so
        ``[s − R(s), s]`` brackets the root; a Newton step leaving the bracket is replaced by
        bisection. Returns the state and whether ``|R| ≤`` :data:`STATE_TOLERANCE` within
        :data:`MAX_NEWTON_ITERATIONS` steps (else the last iterate).
        """
        sl, dt = self.state_slices[j], self.dt
        sigma = -1.0 if self._mirrored(j, closure) else 1.0
        previous, previous_rate = sigma * float(self.state[sl][0]), sigma * float(self.state_rate[sl][0])

        def residual(x: float) -> tuple[float, float]:
            q, dq = self._driven_rate(j, closure, rate, force, np.array([x]))
            return x - previous - 0.5 * dt * (previous_rate + float(q[0])), 1.0 - 0.5 * dt * float(dq[0, 0])

        x = float(state[0])
        r, slope = residual(x)
        low, high = (x - r, x) if r > 0.0 else (x, x - r)
        for _ in range(MAX_NEWTON_ITERATIONS):
            if abs(r) <= STATE_TOLERANCE:
                return np.array([x]), True
            trial = x - r / slope
            if not low <= trial <= high:
                trial = 0.5 * (low + high)
            x = trial
            r, slope = residual(x)
            if r > 0.0:
                high = x
            else:
                low = x
        return np.array([x]), abs(r) <= STATE_TOLERANCE

    def _driven_rate(self, j: int, closure: float, rate: float, force: float, state: NDArray) -> tuple[NDArray, NDArray]:
        """``ṡ = q(δ_e, δ̇, s, P)`` of coupler j driven by the transmitted force ``P = force`` and ``∂q/∂s``,
        the contact mode and law branch from the guards' signs at ``(δ, δ̇, s)`` as in ``Coupling.evaluate``."""
        coupling = self.couplings[j]
        mode, branch = coupling.split_branch(tuple(1 if g > 0.0 else -1 for g in coupling.guards(closure, rate, state)))
        de = coupling.effective_closure(closure, mode)
        return coupling.law.state_rate(de, rate, state, force, branch), coupling.law.tangent(de, rate, state, force, branch).rate_state

    def _coupler_newton(self, j: int, closure_free: NDArray, rate_free: NDArray, P: NDArray, s: NDArray) -> bool:
        """Newton on coupler j's force and state with the other forces held (in place); False if it did not converge."""
        sl = self.state_slices[j]
        rows = np.r_[j, self.n + np.arange(sl.start, sl.stop)]
        for _ in range(MAX_NEWTON_ITERATIONS):
            _, _, responses, residual, _ = self._residual(closure_free, rate_free, P, s)
            local = residual[rows]
            if abs(local[0]) <= self.force_tolerance and np.max(np.abs(local[1:])) <= STATE_TOLERANCE:
                return True
            step = np.linalg.solve(self._jacobian(responses)[np.ix_(rows, rows)], -local)
            P[j] += step[0]
            s[sl] += step[1:]
        return False

    def _jacobian(self, responses: list) -> NDArray:
        """∂(residual)/∂(P, s) from the laws' tangents and the cars' gains ``D_u``, ``D_v``."""
        n, dt = self.n, self.dt
        jacobian = np.eye(n + self.n_state)
        for j, response in enumerate(responses):
            t = response.tangent
            jacobian[j, :n] -= t.force_closure * self.gain_u[j] + t.force_rate * self.gain_v[j]
            sl = self.state_slices[j]
            if sl.stop == sl.start:
                continue
            rows = slice(n + sl.start, n + sl.stop)
            jacobian[j, rows] = -t.force_state
            # ṡ is evaluated with the transmitted force T(δ, δ̇, s): chain through it
            d_closure = t.rate_closure + t.rate_force * t.force_closure
            d_rate = t.rate_rate + t.rate_force * t.force_rate
            jacobian[rows, :n] = -0.5 * dt * (np.outer(d_closure, self.gain_u[j]) + np.outer(d_rate, self.gain_v[j]))
            jacobian[rows, rows] -= 0.5 * dt * (t.rate_state + np.outer(t.rate_force, t.force_state))
        return jacobian

    def _commit(
        self, P: NDArray, s: NDArray, closure: NDArray, rate: NDArray, state_rate: NDArray, modes: NDArray, force_residual: NDArray
    ) -> None:
        """Book the step's coupler energy and take the new values (``force_residual``: ``P − T`` per coupler)."""
        dt = self.dt
        start, _ = self._step_start(closure)  # the committed states, mirrored where the step crossed (midpoint)
        for j, coupling in enumerate(self.couplings):
            sl = self.state_slices[j]
            stored = self._stored(j, float(closure[j]), s[sl], int(modes[j]))
            work = 0.5 * (P[j] + self.force[j]) * (closure[j] - self.closure[j])
            self.work[j] += work
            held = held_at_jump(float(P[j]), float(force_residual[j]), self.force_tolerance)
            if modes[j] == self.modes[j] and not held and not self.held[j]:  # on the law from end to end
                mid_closure = 0.5 * (closure[j] + self.closure[j])
                mid = coupling.effective_closure(float(mid_closure), int(modes[j]))
                rate_mid = 0.5 * (rate[j] + self.rate[j])
                self.dissipated[j] += dt * coupling.law.dissipation_rate(
                    mid, float(rate_mid), 0.5 * (s[sl] + start[sl]), 0.5 * (P[j] + self.force[j]), modes[j] != 0
                )
            else:  # the contact changed within the step, or held at a jump: absorbed work less the change of stored energy
                self.dissipated[j] += work - (stored - self.stored[j])
            self.stored[j] = stored
            self.held[j] = held
        self.force, self.state, self.closure, self.rate = P, s, closure, rate
        self.state_rate = state_rate
        self.modes = modes
