"""Implicit time stepping of ``M ü + C u̇ + K u = B f(t)``: Newmark and generalized-α.

Generalized-α (Chung & Hulbert 1993) balances the equation at intermediate times,

    M a_{n+1−αm} + C v_{n+1−αf} + K u_{n+1−αf} = f_{n+1−αf},
    u_{n+1} = u_n + dt v_n + dt² ((½ − β) a_n + β a_{n+1}),
    v_{n+1} = v_n + dt ((1 − γ) a_n + γ a_{n+1}),

with ``αm = (2ρ∞ − 1)/(ρ∞ + 1)``, ``αf = ρ∞/(ρ∞ + 1)``, ``γ = ½ − αm + αf``,
``β = ¼ (1 − αm + αf)²``; Newmark average acceleration is ``αm = αf = 0, β = ¼, γ = ½``.
Both are second order and unconditionally stable; ρ∞ < 1 damps the highest modes.

The unknown is the new acceleration (solving for a keeps digits that recovering it
from ``(4/dt²)Δu`` would lose as n grows):

    S a_{n+1} = f_{n+1−αf} − K u_n − (C + (1−αf) dt K) v_n
                − (αm M + (1−αf)(1−γ) dt C + (1−αf)(½−β) dt² K) a_n,
    S = (1 − αm) M + (1 − αf) γ dt C + (1 − αf) β dt² K,

so each step costs three banded (DIA) products with fixed matrices and one pair of
banded triangular solves with S, factorised once per run.
"""

from __future__ import annotations

import functools
import math
import time as _time
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from femref.fem.banded import BandedCholesky
from femref.fem.operators import Operators
from femref.core.timegrid import output_steps, steps_to
from femref.core.energy import energy_balance_error
from femref.core.signals import Signal


@dataclass(frozen=True)
class Integrator:
    """Coefficients of a generalized-α family member."""

    name: str
    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float

    @classmethod
    def newmark(cls) -> "Integrator":
        """Average acceleration (trapezoidal rule): energy conserving, no numerical damping."""
        return cls("newmark", 0.0, 0.0, 0.25, 0.5)

    @classmethod
    def generalized_alpha(cls, rho_inf: float) -> "Integrator":
        """Chung–Hulbert with spectral radius ``rho_inf ∈ [0, 1]`` at infinite frequency."""
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf}")
        alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        alpha_f = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 - alpha_m + alpha_f
        return cls(f"generalized_alpha(rho_inf={rho_inf:g})", alpha_m, alpha_f, 0.25 * (1.0 - alpha_m + alpha_f) ** 2, gamma)


INTEGRATORS: dict[str, Callable[..., Integrator]] = {
    "newmark": lambda rho_inf=1.0: Integrator.newmark(),
    "generalized_alpha": Integrator.generalized_alpha,
}


@dataclass
class State:
    """Displacement, velocity and acceleration DOF vectors at ``time``; the stepper reuses them."""

    step: int
    time: float
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    a: NDArray[np.float64]


def load_history(ops: Operators, loads: dict[str, Signal], times: NDArray[np.float64]) -> NDArray[np.float64]:
    """End loads sampled at ``times``: array ``(Nt, len(ops.load_names))``."""
    unknown = set(loads) - set(ops.load_names)
    if unknown:
        raise ValueError(f"loads {sorted(unknown)} do not act on a {ops.kind}; use {ops.load_names}")
    history = np.zeros((times.size, len(ops.load_names)))
    for j, name in enumerate(ops.load_names):
        if name in loads:
            history[:, j] = loads[name](times)
    return history


class DenseCholesky:
    """Solver for a small dense SPD matrix (modal and rigid cars) with the BandedCholesky interface.

    The matrix is Cholesky-checked once and its inverse kept: for a few DOFs one small
    matrix product per solve beats LAPACK's call overhead several times over.
    """

    def __init__(self, matrix: NDArray[np.float64]) -> None:
        matrix = np.asarray(matrix, dtype=float)
        self.shape = matrix.shape
        factor = scipy.linalg.cho_factor(matrix)  # raises LinAlgError when not positive definite
        self._inverse = scipy.linalg.cho_solve(factor, np.eye(matrix.shape[0]))

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._inverse @ rhs


class StepOperators:
    """The fixed operators of one generalized-α step of size ``dt`` (see the module docstring).

    ``effective`` is S factorised once; :meth:`history_terms` is the load-free right-hand
    side ``−K u_n − (C + (1−αf) dt K) v_n − (αm M + …) a_n`` (three banded products);
    :meth:`step` makes one step. Sparse
    matrices are factorised banded and multiplied in DIA storage; dense ones (a few
    modal or rigid DOFs) with LAPACK Cholesky and dense products.
    """

    def __init__(self, mass, damping, stiffness, integrator: Integrator, dt: float) -> None:
        am, af, beta, gamma = integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma
        self.integrator, self.dt = integrator, dt
        effective = (1.0 - am) * mass + (1.0 - af) * gamma * dt * damping + (1.0 - af) * beta * dt * dt * stiffness
        history = (
            stiffness,
            damping + (1.0 - af) * dt * stiffness,
            am * mass + (1.0 - af) * (1.0 - gamma) * dt * damping + (1.0 - af) * (0.5 - beta) * dt * dt * stiffness,
        )
        if sp.issparse(effective):
            self.effective = BandedCholesky(sp.csr_matrix(effective))
            # scipy's DIA product is ~3× faster than CSR for these few diagonals
            self._on_u, self._on_v, self._on_a = (sp.dia_matrix(-matrix) for matrix in history)
        else:
            self.effective = DenseCholesky(effective)
            self._on_u, self._on_v, self._on_a = (-np.asarray(matrix, dtype=float) for matrix in history)
        self.cu, self.ca = dt * dt * (0.5 - beta), dt * dt * beta
        self.cv_old, self.cv_new = dt * (1.0 - gamma), dt * gamma

    def history_terms(self, u: NDArray, v: NDArray, a: NDArray) -> NDArray:
        rhs = self._on_u @ u
        rhs += self._on_v @ v
        rhs += self._on_a @ a
        return rhs

    def step(self, u: NDArray, v: NDArray, a: NDArray, load: NDArray | None = None) -> tuple[NDArray, NDArray, NDArray]:
        """One step from ``(u_n, v_n, a_n)`` with the generalized load term ``load`` of the right-hand
        side (``f_{n+1−αf}``; None: no load): ``(a_{n+1}, u_{n+1}, v_{n+1})``, new arrays.

        ``S a_{n+1} = load + history_terms``, ``u_{n+1} = u_n + dt v_n + dt²((½−β) a_n + β a_{n+1})``,
        ``v_{n+1} = v_n + dt((1−γ) a_n + γ a_{n+1})``. The single-body stepper (:class:`Stepper`) and
        the readable impact cars (``LinearCar`` of ``tests/support/reference_engine``, affine in their end loads)
        both step through here.
        """
        rhs = self.history_terms(u, v, a)
        if load is not None:
            rhs += load
        a_new = self.effective.solve(rhs)
        u_new = self.dt * v  # built in place: as few temporaries as an in-place update of u
        u_new += u
        u_new += self.cu * a
        u_new += self.ca * a_new
        v_new = self.cv_old * a
        v_new += v
        v_new += self.cv_new * a_new
        return a_new, u_new, v_new


@dataclass(frozen=True, eq=False)
class Stepper:
    """Time stepping configuration; :meth:`iterate` yields states, :meth:`solve` collects outputs."""

    ops: Operators
    integrator: Integrator
    dt: float
    loads: dict[str, Signal] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (self.dt > 0.0 and math.isfinite(self.dt)):
            raise ValueError(f"the time step must be positive and finite, got {self.dt}")

    @functools.cached_property
    def mass_factor(self) -> BandedCholesky:
        """Cholesky factor of M, for consistent and equilibrium accelerations (computed once)."""
        return BandedCholesky(self.ops.mass)

    def iterate(self, steps: int, u0: NDArray | None = None, v0: NDArray | None = None) -> Iterator[State]:
        """Yield the state at steps ``0 … steps`` (the state object is reused; its arrays are new each step)."""
        ops, it, dt = self.ops, self.integrator, self.dt
        n = ops.ndof
        M, C, K = ops.mass, ops.damping, ops.stiffness
        times = dt * np.arange(steps + 1)
        history = load_history(ops, self.loads, times)
        nodal = ops.load_matrix.tocoo()
        load_rows, load_cols, load_signs = nodal.row, nodal.col, nodal.data

        u = np.zeros(n) if u0 is None else np.array(u0, dtype=float)
        v = np.zeros(n) if v0 is None else np.array(v0, dtype=float)
        f0 = np.zeros(n)
        np.add.at(f0, load_rows, load_signs * history[0, load_cols])
        a = self.mass_factor.solve(f0 - C @ v - K @ u)  # consistent initial acceleration
        state = State(0, 0.0, u, v, a)
        yield state

        step_ops = StepOperators(M, C, K, it, dt)
        af = it.alpha_f
        loads_alpha = (1.0 - af) * history[1:] + af * history[:-1]
        load = np.zeros(n)
        for step in range(1, steps + 1):
            load[load_rows] = load_signs * loads_alpha[step - 1, load_cols]  # one load per DOF
            a, u, v = step_ops.step(u, v, a, load)
            state.step, state.time = step, float(times[step])
            state.u, state.v, state.a = u, v, a
            yield state

    def solve(
        self,
        end: float,
        x: NDArray[np.float64],
        output_stride: int = 1,
        fields: bool = False,
        energy: bool = True,
        progress: Callable[[int, int], None] | None = None,
    ) -> "TransientResponse":
        """Run to ``end`` and collect probe outputs every ``output_stride`` steps.

        ``fields`` keeps the displacement at the mesh nodes at the same times; ``energy``
        keeps kinetic and strain energy, the energy dissipated by the Voigt viscosity
        (``Σ dt v̄ᵀ C v̄``, v̄ the step-mean velocity) and the work of the end loads
        (``Σ Δuᵀ f̄``); for average acceleration these balance to round-off.
        """
        steps = steps_to(end, self.dt)
        ops = self.ops
        x = np.atleast_1d(np.asarray(x, dtype=float))
        values = ops.interpolation(x)
        slopes = ops.interpolation(x, derivative=1) if ops.kind == "rod" else None
        ea, ca = ops.stiffness_profile(x), ops.viscosity_profile(x)
        outputs = output_steps(steps, output_stride)
        n_out = outputs.size
        field_values = ops.interpolation(ops.nodes) if fields else None
        # generalized-α's a_n is second-order accurate at t_n + (αm − αf)dt, not at t_n: report
        # the equilibrium acceleration M⁻¹(f(t_n) − C v_n − K u_n) at the outputs instead
        shifted = self.integrator.alpha_m != self.integrator.alpha_f
        mass_factor = self.mass_factor if shifted else None
        out = TransientResponse.empty(n_out, x, ops.nodes.size if fields else 0, rod=slopes is not None)
        history = load_history(ops, self.loads, self.dt * np.arange(steps + 1))
        dissipated = 0.0
        external = 0.0
        k = 0
        v_prev = u_prev = None
        started = _time.perf_counter()
        for state in self.iterate(steps):
            if energy and state.step > 0:
                v_mid = 0.5 * (state.v + v_prev)
                dissipated += self.dt * float(v_mid @ (ops.damping @ v_mid))
                f_mid = ops.load_matrix @ (0.5 * (history[state.step] + history[state.step - 1]))
                external += float((state.u - u_prev) @ f_mid)
            if energy:
                v_prev, u_prev = state.v.copy(), state.u.copy()
            if k < n_out and state.step == outputs[k]:
                out.time[k] = state.time
                out.displacement[k] = values @ state.u
                if mass_factor is not None:
                    f_n = ops.load_matrix @ history[state.step]
                    out.acceleration[k] = values @ mass_factor.solve(f_n - ops.damping @ state.v - ops.stiffness @ state.u)
                else:
                    out.acceleration[k] = values @ state.a
                if slopes is not None:
                    out.axial_force[k] = ea * (slopes @ state.u) + ca * (slopes @ state.v)
                if field_values is not None:
                    out.fields[k] = field_values @ state.u
                if energy:
                    out.kinetic[k] = 0.5 * float(state.v @ (ops.mass @ state.v))
                    out.strain[k] = 0.5 * float(state.u @ (ops.stiffness @ state.u))
                    out.dissipated[k] = dissipated
                    out.external_work[k] = external
                k += 1
                if progress is not None:
                    progress(state.step, steps)
        out.steps = steps
        out.wall_time = _time.perf_counter() - started
        return out


@dataclass
class TransientResponse:
    """Probe histories ``(Nt_out, Nprobes)``; energies ``(Nt_out,)`` (J); fields ``(Nt_out, Nnodes)`` if kept."""

    time: NDArray[np.float64]
    x: NDArray[np.float64]
    displacement: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    axial_force: NDArray[np.float64] | None
    fields: NDArray[np.float64] | None
    kinetic: NDArray[np.float64]
    strain: NDArray[np.float64]
    dissipated: NDArray[np.float64]
    external_work: NDArray[np.float64]
    steps: int = 0
    wall_time: float = 0.0

    @classmethod
    def empty(cls, n_out: int, x: NDArray, ndof: int, rod: bool) -> "TransientResponse":
        shape = (n_out, x.size)
        return cls(
            time=np.zeros(n_out),
            x=x,
            displacement=np.zeros(shape),
            acceleration=np.zeros(shape),
            axial_force=np.zeros(shape) if rod else None,
            fields=np.zeros((n_out, ndof)) if ndof else None,
            kinetic=np.zeros(n_out),
            strain=np.zeros(n_out),
            dissipated=np.zeros(n_out),
            external_work=np.zeros(n_out),
        )

    @property
    def energy_balance_error(self) -> float:
        """``max |E(t) − E(0) − W(t)| / max(|E|, |W|)`` over the stored times, ``E = T + V + D`` (kinetic, strain,
        dissipated) and ``W`` the end loads' work (:func:`femref.core.energy.energy_balance_error`)."""
        return energy_balance_error(self.kinetic + self.strain + self.dissipated, self.external_work)
