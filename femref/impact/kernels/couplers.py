"""Compiled twin of the coupler iteration of one impact step (:class:`femref.impact.couplers.CouplerSolve`).

The laws of :mod:`reduced.couplers` are packed once per scene into arrays
(:func:`pack_laws` → :class:`CouplerLaws`); the couplers' forces, states and energy accounts
live in :class:`CouplerState` (:func:`new_state`), updated in place by :func:`start` (the
forces at t = 0) and :func:`solve` (one step), both ``@njit``. The arithmetic is the Python
reference's, operation by operation, so the two agree to round-off:

* the law helpers (``kelvin_voigt_*``, ``power_law_*``, ``draft_gear_*``, ``table_*``; the
  dispatchers ``law_*``) mirror the laws' methods; :func:`evaluate` mirrors
  :meth:`reduced.couplers.Coupling.evaluate`, with its branch and mode rule: the guards'
  signs are strict (``> 0`` is +1, so a guard at exactly zero counts as negative), while a
  law method called with ``branch=None`` (the contact guards' law force, the stored energy,
  the dissipation rate, :func:`start`'s engaged force) picks its piece with the ``>= 0``
  rule of :func:`reduced.couplers.base.select_branch` — :func:`law_branch` takes the rule. The
  kernels work on one coupler's :class:`CouplerLaw` (its scalars and its rows of the
  arrays); the entry points the tests compare with the laws' methods — :func:`law_branch`,
  :func:`law_force`, :func:`law_stored_energy`, :func:`law_dissipation_rate`,
  :func:`evaluate` — take ``(laws, j)`` and call their twins ``_law_*``, :func:`_evaluate`
  on ``_law_of(laws, j)``;
* :func:`_mirror` mirrors :meth:`reduced.couplers.Coupling.state_mirrored` (the sided gear
  state of a bilateral draft gear with slack): every use of the committed state ``s_n``,
  ``ṡ_n`` — the state residual, the state under a held force, the dissipation's midpoint —
  takes ``σ s_n``, ``σ ṡ_n`` with ``σ = −1.0`` where the step's closure is beyond the other
  side's slack boundary and the gear is still compressed from the first side, as
  :meth:`CouplerSolve._step_start` (``σ x`` is exact, so the engines still agree to the bit);
  :func:`state_mirror` is its twin on ``(laws, j)``;
* :func:`solve` is :meth:`CouplerSolve.solve` given the free closures and rates and the
  Schur gains ``D_u``, ``D_v``: Newton on ``(P, s)``, then the Gauss–Seidel fallback with
  Brent's method (:func:`brent_root`, scipy's ``brentq`` transcribed) in a bracket widened
  until ``P − T`` changes sign for a memoryless coupler, and a 2 × 2 Newton for a stateful
  one — where that cycles, Brent's method on its force with the state following it
  (:func:`_state_under`) — then the energy bookkeeping of ``_commit``.
  The Newton systems are :func:`linear_solve` (LAPACK ``dgesv``'s order of operations); the
  products with the gains are loops over a row, summed in index order without fused
  multiply-adds, where numpy's ``@`` calls BLAS (OpenBLAS fuses them). So the iterations
  agree to the bit for one coupler (but for the odd last bit of a square: Python's ``x**2``
  calls ``pow``, numba multiplies), and for more to a few units in the last place of the
  products, which the iteration carries over: the tests' runs differ by at most about
  1e-16 of each quantity's largest value, with the same modes and iteration counts.

A failed step returns a failure code instead of raising :class:`CouplerConvergenceError`
(numba cannot build it); :func:`failure_detail` gives the error's text. What raises in the
reference raises here too, with a fixed message: a non-finite closure or rate (ValueError),
a non-positive ``force_tolerance`` (ValueError), 100 Brent iterations (RuntimeError), an
exactly singular Newton matrix (``np.linalg.LinAlgError``).

Layout of :attr:`CouplerLaws.params` (row j, zero-padded to the widest law):

* kind 0, :class:`~reduced.couplers.KelvinVoigt`: ``[c, μ]``;
* kind 1, :class:`~reduced.couplers.PowerLawGear`: ``[c, n, N0, K, γ_0, …, γ_{K−1}]``
  (K damping coefficients);
* kind 2, :class:`~reduced.couplers.StandardLinearDraftGear`: ``[D, c, μ, stroke, c*]``
  with ``D = 1/c1 + 1/c2`` (the law's ``series_compliance``);
* kind 3, :class:`~reduced.couplers.HystereticTable`: ``[c_v, v_s]``; its table is
  ``table[j, :, :m]`` with ``m = table_size[j]``, rows closure, loading L, unloading U,
  ``∫₀L``, ``∫₀U`` at the table points (the law's own arrays).

Pass C-contiguous float64 arrays to :func:`solve` (others work, but compile again and run
slower). The iteration limits and the state tolerance travel in :class:`CouplerLaws`
(taken from :mod:`femref.impact.couplers` when packing): a cached compilation would keep
stale compile-time constants, since numba's cache only watches this file.

A step of a few couplers is some hundred floating-point operations, so what a call costs
beyond them is the calls themselves. Hence:

* nothing allocates: :func:`solve`'s scratch (its iterate, the residual, the Jacobian and
  its LU factors …) is the ``work_*`` arrays of :class:`CouplerState`, made once by
  :func:`new_state`;
* the kernels are compiled without numba's reference counting (``_nrt=False``, a private
  numba option): with it, every call increfs and decrefs each array it is passed (numba's
  pruning of those pairs fails across branches and raise paths), an atomic operation
  each: ~4 µs of a single coupler's step, ~0.4 µs without. Without it a kernel can
  neither allocate nor hand an array to reference-counted code (hence :func:`_law_of` is
  private); callers with reference counting (:mod:`femref.impact.kernels.loop`) keep theirs;
* a call copies every array of its arguments into its argument list (an array is 7 to 11
  words), so the kernels below :func:`solve` take a :class:`CouplerLaw`, not ``laws``, and
  the dispatchers inside :func:`_evaluate` are inlined (``inline="always"``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from femref.impact.couplers import (
    BRACKET_EXPANSIONS,
    JUMP_FRACTION,
    MAX_NEWTON_ITERATIONS,
    MAX_SWEEPS,
    NEWTON_ITERATIONS,
    STATE_TOLERANCE,
    bracket_detail,
    coupler_newton_detail,
    sweeps_detail,
)
from reduced.couplers import CONTACT_KINDS, Coupling, HystereticTable, KelvinVoigt, PowerLawGear, StandardLinearDraftGear

_JIT = dict(cache=True, _nrt=False)  # every kernel's options (module docstring: no reference counting)

KELVIN_VOIGT, POWER_LAW, STANDARD_LINEAR, TABLE = 0, 1, 2, 3
"""Values of :attr:`CouplerLaws.kind`."""
COMPRESSION_ONLY, BILATERAL = 0, 1
"""Values of :attr:`CouplerLaws.contact` (the order of :data:`reduced.couplers.CONTACT_KINDS`)."""
SWEEPS_EXHAUSTED, COUPLER_NEWTON_FAILED, BRACKET_NOT_FOUND = 1, 2, 3
"""Failure kinds :func:`solve` returns: Gauss–Seidel sweeps exhausted; a stateful coupler's Newton failed and
its state under the held force did not settle; the scalar root's bracket found no sign change."""

_LAW_KINDS: dict[type, int] = {
    KelvinVoigt: KELVIN_VOIGT,
    PowerLawGear: POWER_LAW,
    StandardLinearDraftGear: STANDARD_LINEAR,
    HystereticTable: TABLE,
}

BRENT_RTOL = 4.0 * float(np.finfo(float).eps)  # scipy.optimize.brentq's default (and smallest) rtol
BRENT_MAXITER = 100  # scipy.optimize.brentq's default maxiter
LinAlgError = np.linalg.LinAlgError


class CouplerLaws(NamedTuple):
    """The scene's coupler laws and contacts as arrays (constant; layout of ``params`` in the module docstring)."""

    kind: NDArray[np.int64]  # (n,) 0 kelvin_voigt, 1 power_law, 2 standard_linear draft gear, 3 hysteretic table
    contact: NDArray[np.int64]  # (n,) 0 compression_only, 1 bilateral
    slack: NDArray[np.float64]  # (n,) m
    tension_slack: NDArray[np.float64]  # (n,) m
    stateful: NDArray[np.int64]  # (n,) 1 if the law carries one state variable (the draft gear's x_g), else 0
    params: NDArray[np.float64]  # (n, P) law parameters, zero-padded
    initial_state: NDArray[np.float64]  # (n,) the law's initial state (0 for stateless laws)
    table: NDArray[np.float64]  # (n, 5, M) closure, L, U, ∫L, ∫U of a table law (zeros otherwise)
    table_size: NDArray[np.int64]  # (n,) table points of a table law (0 otherwise)
    limits: NDArray[np.int64]  # (4,) NEWTON_ITERATIONS, MAX_NEWTON_ITERATIONS, MAX_SWEEPS, BRACKET_EXPANSIONS
    state_tolerance: NDArray[np.float64]  # (1,) STATE_TOLERANCE (m)
    jump_fraction: NDArray[np.float64]  # (1,) JUMP_FRACTION (femref.impact.couplers.held_at_jump)
    state_row: NDArray[np.int64]  # (n,) row of the coupler's state among the Newton unknowns (P, s); −1 stateless


class CouplerState(NamedTuple):
    """The couplers now (mutable: :func:`start` and :func:`solve` update the arrays in place), and
    :func:`solve`'s scratch (``work_*``: no state, their values mean nothing between calls)."""

    force: NDArray[np.float64]  # (n,) P, N, compression positive
    state: NDArray[np.float64]  # (n,) the law state (0 for stateless laws)
    closure: NDArray[np.float64]  # (n,) δ, m
    rate: NDArray[np.float64]  # (n,) δ̇, m/s
    state_rate: NDArray[np.float64]  # (n,) ṡ
    stored: NDArray[np.float64]  # (n,) J
    dissipated: NDArray[np.float64]  # (n,) J
    work: NDArray[np.float64]  # (n,) J: work the cars did on the coupler, Σ P̄ Δδ
    mode: NDArray[np.int64]  # (n,) +1 compression, −1 tension, 0 open
    held: NDArray[np.int64]  # (n,) 1 if the last step ended held at a jump of the law (held_at_jump), else 0
    # solve's scratch, allocated once by new_state (no meaning between calls; m = n + the stateful couplers)
    work_force: NDArray[np.float64]  # (n,) the iterated P
    work_state: NDArray[np.float64]  # (n,) the iterated s
    work_mode: NDArray[np.int64]  # (n,) the previous Newton iteration's modes
    work_new_mode: NDArray[np.int64]  # (n,) this iteration's modes
    work_closure: NDArray[np.float64]  # (n,)
    work_rate: NDArray[np.float64]  # (n,)
    work_state_rate: NDArray[np.float64]  # (n,)
    work_tangent: NDArray[np.float64]  # (n, 7) the fields of CouplerTangent
    work_residual: NDArray[np.float64]  # (m,)
    work_step: NDArray[np.float64]  # (m,) −residual, then the Newton step
    work_jacobian: NDArray[np.float64]  # (m, m), then its LU factors
    work_pivots: NDArray[np.int64]  # (max(m, 2),)
    work_block: NDArray[np.float64]  # (2, 2) a stateful coupler's own Newton matrix, then its LU factors
    work_local: NDArray[np.float64]  # (2,) its −residual, then its step


def pack_laws(couplings: Sequence[Coupling]) -> CouplerLaws:
    """The laws and contacts of ``couplings`` as :class:`CouplerLaws` (ValueError for a law without a compiled twin)."""
    n = len(couplings)
    laws = [c.law for c in couplings]
    for j, law in enumerate(laws):
        size = getattr(law, "state_size", None)
        if isinstance(size, int) and size > 1:
            raise ValueError(
                f"coupler {j}: law {type(law).__name__} carries {size} state variables; "
                "the compiled coupler iteration handles at most one"
            )
        if type(law) not in _LAW_KINDS:
            known = ", ".join(cls.__name__ for cls in _LAW_KINDS)
            raise ValueError(f"coupler {j}: law {type(law).__name__} has no compiled twin (known laws: {known})")
    rows: list[list[float]] = []
    tables: dict[int, list[NDArray[np.float64]]] = {}
    for j, law in enumerate(laws):
        if isinstance(law, KelvinVoigt):
            rows.append([law.stiffness, law.damping])
        elif isinstance(law, PowerLawGear):
            rows.append([law.stiffness, law.exponent, law.preload, float(len(law.damping)), *law.damping])
        elif isinstance(law, StandardLinearDraftGear):
            rows.append([law.series_compliance, law.gear_stiffness, law.gear_damping, law.stroke, law.solid_stiffness])
        else:  # the law's own arrays, integrals included, so that the compiled curves are the same numbers
            rows.append([law.damping, law.switch_velocity])
            tables[j] = [law._x, law._l, law._u, law._l_int, law._u_int]
    params = np.zeros((n, max((len(r) for r in rows), default=1)))
    for j, row in enumerate(rows):
        params[j, : len(row)] = row
    table = np.zeros((n, 5, max((t[0].size for t in tables.values()), default=2)))
    table_size = np.zeros(n, dtype=np.int64)
    for j, arrays in tables.items():
        for r, values in enumerate(arrays):
            table[j, r, : values.size] = values
        table_size[j] = arrays[0].size
    state_row = np.full(n, -1, dtype=np.int64)
    m = n
    for j, law in enumerate(laws):
        if law.state_size:
            state_row[j] = m
            m += 1
    return CouplerLaws(
        kind=np.array([_LAW_KINDS[type(law)] for law in laws], dtype=np.int64),
        contact=np.array([CONTACT_KINDS.index(c.contact) for c in couplings], dtype=np.int64),
        slack=np.array([c.slack for c in couplings], dtype=float),
        tension_slack=np.array([c.tension_slack for c in couplings], dtype=float),
        stateful=np.array([law.state_size for law in laws], dtype=np.int64),
        params=params,
        initial_state=np.array([float(law.initial_state()[0]) if law.state_size else 0.0 for law in laws]),
        table=table,
        table_size=table_size,
        limits=np.array([NEWTON_ITERATIONS, MAX_NEWTON_ITERATIONS, MAX_SWEEPS, BRACKET_EXPANSIONS], dtype=np.int64),
        state_tolerance=np.array([STATE_TOLERANCE]),
        jump_fraction=np.array([JUMP_FRACTION]),
        state_row=state_row,
    )


def new_state(laws: CouplerLaws) -> CouplerState:
    """Zero forces, closures, rates and energies, the laws' initial states, all contacts open; solve's scratch."""
    n = laws.kind.size
    m = n + int(np.count_nonzero(laws.state_row >= 0))
    return CouplerState(
        force=np.zeros(n),
        state=laws.initial_state.copy(),
        closure=np.zeros(n),
        rate=np.zeros(n),
        state_rate=np.zeros(n),
        stored=np.zeros(n),
        dissipated=np.zeros(n),
        work=np.zeros(n),
        mode=np.zeros(n, dtype=np.int64),
        held=np.zeros(n, dtype=np.int64),
        work_force=np.zeros(n),
        work_state=np.zeros(n),
        work_mode=np.zeros(n, dtype=np.int64),
        work_new_mode=np.zeros(n, dtype=np.int64),
        work_closure=np.zeros(n),
        work_rate=np.zeros(n),
        work_state_rate=np.zeros(n),
        work_tangent=np.zeros((n, 7)),
        work_residual=np.zeros(m),
        work_step=np.zeros(m),
        work_jacobian=np.zeros((m, m)),
        work_pivots=np.zeros(max(m, 2), dtype=np.int64),
        work_block=np.zeros((2, 2)),
        work_local=np.zeros(2),
    )


def failure_detail(failure_kind: int, change: float) -> str:
    """The detail text :class:`CouplerConvergenceError` carries for a failure :func:`solve` returned."""
    if failure_kind == SWEEPS_EXHAUSTED:
        return sweeps_detail(change)
    if failure_kind == COUPLER_NEWTON_FAILED:
        return coupler_newton_detail()
    if failure_kind == BRACKET_NOT_FOUND:
        return bracket_detail()
    kinds = f"{SWEEPS_EXHAUSTED}, {COUPLER_NEWTON_FAILED} or {BRACKET_NOT_FOUND}"
    raise ValueError(f"failure_kind must be {kinds}, got {failure_kind!r}")


# --- coupler j's law, as the kernels read it ----------------------------------------------


class CouplerLaw(NamedTuple):
    """Coupler j's law and contact (:func:`_law_of`): scalars and views of :class:`CouplerLaws`' rows."""

    kind: int
    contact: int
    slack: float
    tension_slack: float
    params: NDArray[np.float64]  # (P,) row j of CouplerLaws.params
    table: NDArray[np.float64]  # (5, M) table j
    size: int  # table points (a table law)


@njit(**_JIT)
def _law_of(laws, j):
    """Coupler j's :class:`CouplerLaw` (the kernels pass it rather than ``laws`` and ``j``: a few words, not all
    the arrays). Its arrays are views without a reference of their own: for kernels only (module docstring)."""
    return CouplerLaw(laws.kind[j], laws.contact[j], laws.slack[j], laws.tension_slack[j], laws.params[j], laws.table[j], laws.table_size[j])


# --- Kelvin-Voigt -------------------------------------------------------------------------


@njit(**_JIT)
def kelvin_voigt_force(law, closure, rate):
    """``P = c δ + μ δ̇`` (mirrors reduced.couplers.KelvinVoigt.force)."""
    return law.params[0] * closure + law.params[1] * rate


@njit(**_JIT)
def kelvin_voigt_tangent(law):
    """``∂P/∂δ = c``, ``∂P/∂δ̇ = μ`` (mirrors reduced.couplers.KelvinVoigt.tangent)."""
    return law.params[0], law.params[1], 0.0, 0.0, 0.0, 0.0, 0.0


@njit(**_JIT)
def kelvin_voigt_stored_energy(law, closure, engaged):
    """``c δ²/2`` while engaged, else 0 (mirrors reduced.couplers.KelvinVoigt.stored_energy)."""
    return 0.5 * law.params[0] * closure**2 if engaged else 0.0


@njit(**_JIT)
def kelvin_voigt_dissipation_rate(law, rate, engaged):
    """``μ δ̇²`` while engaged, else 0 (mirrors reduced.couplers.KelvinVoigt.dissipation_rate)."""
    return law.params[1] * rate**2 if engaged else 0.0


# --- power law ----------------------------------------------------------------------------


@njit(**_JIT)
def power_law_damping(law, closure):
    """``γ(δ) = Σ_k γ_k |δ|^k`` and ``dγ/dδ`` (mirrors reduced.couplers.PowerLawGear.damping_at)."""
    a = abs(closure)
    g = 0.0
    dg = 0.0
    for k in range(int(law.params[3])):
        gk = law.params[4 + k]
        g += gk * a ** float(k)
        if k >= 1:
            dg += float(k) * gk * a ** float(k - 1)
    return g, dg * (1.0 if closure >= 0.0 else -1.0)


@njit(**_JIT)
def power_law_force(law, closure, rate, side):
    """``P = σ (c |δ|ⁿ + N0) + γ(δ) δ̇`` on the side ``σ = ±1`` (mirrors reduced.couplers.PowerLawGear.force)."""
    g, _ = power_law_damping(law, closure)
    return side * (law.params[0] * abs(closure) ** law.params[1] + law.params[2]) + g * rate


@njit(**_JIT)
def power_law_tangent(law, closure, rate):
    """``∂P/∂δ = n c |δ|^{n−1} + γ'(δ) δ̇``, ``∂P/∂δ̇ = γ(δ)`` (mirrors reduced.couplers.PowerLawGear.tangent)."""
    g, dg = power_law_damping(law, closure)
    a = abs(closure)
    spring = law.params[1] * law.params[0] * a ** (law.params[1] - 1.0)
    return spring + dg * rate, g, 0.0, 0.0, 0.0, 0.0, 0.0


@njit(**_JIT)
def power_law_stored_energy(law, closure, engaged):
    """``c |δ|^{n+1}/(n+1) + N0 |δ|`` while engaged (mirrors reduced.couplers.PowerLawGear.stored_energy)."""
    if not engaged:
        return 0.0
    a = abs(closure)
    c, n, preload = law.params[0], law.params[1], law.params[2]
    return c * a ** (n + 1.0) / (n + 1.0) + preload * a


@njit(**_JIT)
def power_law_dissipation_rate(law, closure, rate, engaged):
    """``γ(δ) δ̇²`` while engaged (mirrors reduced.couplers.PowerLawGear.dissipation_rate)."""
    return power_law_damping(law, closure)[0] * rate**2 if engaged else 0.0


# --- standard-linear draft gear -----------------------------------------------------------


@njit(**_JIT)
def draft_gear_spring(law, gear_compression, piece):
    """``F_g(x_g)`` and ``F_g'``: ``c x_g`` open (piece 0), ``c* x_g + (c − c*) stroke piece`` closed
    (piece ±1) (mirrors reduced.couplers.StandardLinearDraftGear.gear_spring)."""
    c, s, cs = law.params[1], law.params[3], law.params[4]
    if piece == 0:
        return c * gear_compression, c
    return cs * gear_compression + (c - cs) * s * piece, cs


@njit(**_JIT)
def draft_gear_force(law, closure, state):
    """``P = (δ − x_g)/D`` (mirrors reduced.couplers.StandardLinearDraftGear.force)."""
    return (closure - state) / law.params[0]


@njit(**_JIT)
def draft_gear_state_rate(law, state, force, piece):
    """``ẋ_g = (P − F_g(x_g))/μ`` (mirrors reduced.couplers.StandardLinearDraftGear.state_rate)."""
    fg, _ = draft_gear_spring(law, state, piece)
    return (force - fg) / law.params[2]


@njit(**_JIT)
def draft_gear_tangent(law, state, piece):
    """``∂P/∂δ = 1/D``, ``∂P/∂x_g = −1/D``, ``∂ẋ_g/∂x_g = −F_g'/μ``, ``∂ẋ_g/∂P = 1/μ``
    (mirrors reduced.couplers.StandardLinearDraftGear.tangent)."""
    _, kg = draft_gear_spring(law, state, piece)
    d, mu = law.params[0], law.params[2]
    return 1.0 / d, 0.0, -1.0 / d, 0.0, 0.0, -kg / mu, 1.0 / mu


@njit(**_JIT)
def draft_gear_stored_energy(law, closure, state, engaged, piece):
    """``D P²/2`` (engaged) ``+ ∫₀^{x_g} F_g`` (mirrors reduced.couplers.StandardLinearDraftGear.stored_energy)."""
    d, c, s, cs = law.params[0], law.params[1], law.params[3], law.params[4]
    series = 0.5 * d * draft_gear_force(law, closure, state) ** 2 if engaged else 0.0
    if piece == 0:
        gear = 0.5 * c * state**2
    else:
        a = abs(state)
        gear = 0.5 * c * s**2 + 0.5 * cs * (a**2 - s**2) + (c - cs) * s * (a - s)
    return series + gear


@njit(**_JIT)
def draft_gear_dissipation_rate(law, state, force, piece):
    """``(P − F_g(x_g))²/μ`` (mirrors reduced.couplers.StandardLinearDraftGear.dissipation_rate)."""
    fg, _ = draft_gear_spring(law, state, piece)
    return (force - fg) ** 2 / law.params[2]


# --- hysteretic table ---------------------------------------------------------------------


@njit(**_JIT)
def table_curve(law, row, a):
    """Value, slope and ``∫₀^a`` of table row 1 (L) or 2 (U) at ``a ≥ 0``, extrapolating the last
    segment (mirrors reduced.couplers.table._piecewise_linear)."""
    m = law.size
    x = law.table[0]
    y = law.table[row]
    integral = law.table[row + 2]
    right = 0  # np.searchsorted(x, a, side="right")
    while right < m and x[right] <= a:
        right += 1
    i = min(max(right - 1, 0), m - 2)
    slope = (y[i + 1] - y[i]) / (x[i + 1] - x[i])
    h = a - x[i]
    return y[i] + slope * h, slope, integral[i] + y[i] * h + 0.5 * slope * h * h


@njit(**_JIT)
def table_switch(law, closure, rate):
    """``σ = sgn δ`` (at δ = 0: ``sgn δ̇``, +1 at rest), ``s(σδ̇) = clip(σδ̇/v_s, 0, 1)`` and its right
    derivative (mirrors reduced.couplers.HystereticTable._switch)."""
    if closure != 0.0:
        sigma = 1.0 if closure > 0.0 else -1.0
    else:
        sigma = 1.0 if rate >= 0.0 else -1.0
    r = sigma * rate
    vs = law.params[1]
    s = min(max(r / vs, 0.0), 1.0)
    ds = 1.0 / vs if 0.0 <= r < vs else 0.0
    return sigma, s, ds


@njit(**_JIT)
def table_force(law, closure, rate):
    """``P = σ [U + (L − U) s(σδ̇)](|δ|) + c_v δ̇`` (mirrors reduced.couplers.HystereticTable.force)."""
    a = abs(closure)
    lo = table_curve(law, 1, a)[0]
    un = table_curve(law, 2, a)[0]
    sigma, s, _ = table_switch(law, closure, rate)
    return sigma * (un + (lo - un) * s) + law.params[0] * rate


@njit(**_JIT)
def table_tangent(law, closure, rate):
    """``∂P/∂δ = U' + (L' − U') s``, ``∂P/∂δ̇ = (L − U) s' + c_v`` (mirrors reduced.couplers.HystereticTable.tangent)."""
    a = abs(closure)
    lo, dlo, _ = table_curve(law, 1, a)
    un, dun, _ = table_curve(law, 2, a)
    _, s, ds = table_switch(law, closure, rate)
    return dun + (dlo - dun) * s, (lo - un) * ds + law.params[0], 0.0, 0.0, 0.0, 0.0, 0.0


@njit(**_JIT)
def table_stored_energy(law, closure, engaged):
    """``∫₀^{|δ|} U`` while engaged (mirrors reduced.couplers.HystereticTable.stored_energy)."""
    return table_curve(law, 2, abs(closure))[2] if engaged else 0.0


@njit(**_JIT)
def table_dissipation_rate(law, closure, rate, engaged):
    """``(L − U)(|δ|) s(σδ̇) σ δ̇ + c_v δ̇²`` while engaged (mirrors reduced.couplers.HystereticTable.dissipation_rate)."""
    if not engaged:
        return 0.0
    a = abs(closure)
    lo = table_curve(law, 1, a)[0]
    un = table_curve(law, 2, a)[0]
    sigma, s, _ = table_switch(law, closure, rate)
    return (lo - un) * s * sigma * rate + law.params[0] * rate**2


# --- the law of a coupler, whatever its kind ----------------------------------------------
# (each on a CouplerLaw, with its twin on (laws, j) for the tests and for Python callers)


@njit(inline="always", **_JIT)
def _law_branch(law, closure, state, strict):
    """The law's piece from the signs of its guards at the law closure ``closure``.

    Power law: the side ``σ = ±1`` of ``δ``; draft gear: +1 closed in compression
    (``x_g − stroke`` positive), −1 closed in tension (``x_g + stroke`` negative), 0 open;
    the other laws have no guards (0). ``strict``: a guard is positive iff ``> 0``, the rule of
    :meth:`Coupling.evaluate`; else iff ``>= 0``, the rule of ``reduced.couplers.base.select_branch``
    (a law method called with ``branch=None``).
    """
    kind = law.kind
    if kind == POWER_LAW:
        positive = closure > 0.0 if strict else closure >= 0.0
        return 1 if positive else -1
    if kind == STANDARD_LINEAR:
        stroke = law.params[3]
        above, below = state - stroke, state + stroke
        above_positive = above > 0.0 if strict else above >= 0.0
        below_positive = below > 0.0 if strict else below >= 0.0
        if above_positive:
            return 1
        if not below_positive:
            return -1
        return 0
    return 0


@njit(inline="always", **_JIT)
def _law_force(law, closure, rate, state, branch):
    """The engaged law force ``F(δ, δ̇, s)`` on the piece ``branch`` (:func:`_law_branch`)."""
    kind = law.kind
    if kind == KELVIN_VOIGT:
        return kelvin_voigt_force(law, closure, rate)
    if kind == POWER_LAW:
        return power_law_force(law, closure, rate, branch)
    if kind == STANDARD_LINEAR:
        return draft_gear_force(law, closure, state)
    return table_force(law, closure, rate)


@njit(inline="always", **_JIT)
def _law_state_rate(law, closure, rate, state, force, branch):
    """``ṡ = q(δ, δ̇, s, P)`` given the transmitted force (0 for a stateless law)."""
    if law.kind == STANDARD_LINEAR:
        return draft_gear_state_rate(law, state, force, branch)
    return 0.0


@njit(inline="always", **_JIT)
def _law_tangent(law, closure, rate, state, force, branch):
    """``(∂P/∂δ, ∂P/∂δ̇, ∂P/∂s, ∂ṡ/∂δ, ∂ṡ/∂δ̇, ∂ṡ/∂s, ∂ṡ/∂P)`` — the fields of CouplerTangent in order."""
    kind = law.kind
    if kind == KELVIN_VOIGT:
        return kelvin_voigt_tangent(law)
    if kind == POWER_LAW:
        return power_law_tangent(law, closure, rate)
    if kind == STANDARD_LINEAR:
        return draft_gear_tangent(law, state, branch)
    return table_tangent(law, closure, rate)


@njit(**_JIT)
def _law_stored_energy(law, closure, state, engaged):
    """The law's stored energy at the law closure (its piece by the ``>= 0`` rule, as ``branch=None``)."""
    kind = law.kind
    if kind == KELVIN_VOIGT:
        return kelvin_voigt_stored_energy(law, closure, engaged)
    if kind == POWER_LAW:
        return power_law_stored_energy(law, closure, engaged)
    if kind == STANDARD_LINEAR:
        return draft_gear_stored_energy(law, closure, state, engaged, _law_branch(law, closure, state, False))
    return table_stored_energy(law, closure, engaged)


@njit(**_JIT)
def _law_dissipation_rate(law, closure, rate, state, force, engaged):
    """The law's dissipation rate (its piece by the ``>= 0`` rule, as ``branch=None``)."""
    kind = law.kind
    if kind == KELVIN_VOIGT:
        return kelvin_voigt_dissipation_rate(law, rate, engaged)
    if kind == POWER_LAW:
        return power_law_dissipation_rate(law, closure, rate, engaged)
    if kind == STANDARD_LINEAR:
        return draft_gear_dissipation_rate(law, state, force, _law_branch(law, closure, state, False))
    return table_dissipation_rate(law, closure, rate, engaged)


@njit(**_JIT)
def law_branch(laws, j, closure, state, strict):
    """:func:`_law_branch` of coupler j's law (:func:`_law_of`)."""
    return _law_branch(_law_of(laws, j), closure, state, strict)


@njit(**_JIT)
def law_force(laws, j, closure, rate, state, branch):
    """:func:`_law_force` of coupler j's law (:func:`_law_of`)."""
    return _law_force(_law_of(laws, j), closure, rate, state, branch)


@njit(**_JIT)
def law_stored_energy(laws, j, closure, state, engaged):
    """:func:`_law_stored_energy` of coupler j's law (:func:`_law_of`)."""
    return _law_stored_energy(_law_of(laws, j), closure, state, engaged)


@njit(**_JIT)
def law_dissipation_rate(laws, j, closure, rate, state, force, engaged):
    """:func:`_law_dissipation_rate` of coupler j's law (:func:`_law_of`)."""
    return _law_dissipation_rate(_law_of(laws, j), closure, rate, state, force, engaged)


# --- the coupling (contact and slack around the law) --------------------------------------


@njit(inline="always", **_JIT)
def _effective_closure(law, closure, mode):
    """``δ − slack`` in compression or open, ``δ + tension_slack`` in tension (mirrors Coupling.effective_closure)."""
    if mode < 0:
        return closure + law.tension_slack
    return closure - law.slack


@njit(inline="always", **_JIT)
def _mirror(law, closure, state):
    """``σ = −1.0`` where the gear state is to be mirrored at ``closure``, else ``+1.0`` (mirrors
    Coupling.state_mirrored): a draft gear, bilateral with slack, with ``x_g > 0`` and
    ``δ + tension_slack < 0`` or ``x_g < 0`` and ``δ − slack > 0``. A step to ``closure``
    starts from ``σ (s_n, ṡ_n)`` (femref.impact.couplers, module docstring)."""
    if law.kind != STANDARD_LINEAR or law.contact != BILATERAL or (law.slack == 0.0 and law.tension_slack == 0.0):
        return 1.0
    if (state > 0.0 and closure + law.tension_slack < 0.0) or (state < 0.0 and closure - law.slack > 0.0):
        return -1.0
    return 1.0


@njit(inline="always", **_JIT)
def _transmitted_force(law, closure, rate, state, mode, branch):
    """``P`` in the contact mode: 0 open, else the law force at the effective closure (mirrors Coupling.transmitted_force)."""
    if mode == 0:
        return 0.0
    return _law_force(law, _effective_closure(law, closure, mode), rate, state, branch)


@njit(**_JIT)
def _evaluate(law, closure, rate, state):
    """The coupler of ``law`` at ``(δ, δ̇, s)``, mode and branch from the guards' strict signs (mirrors Coupling.evaluate).

    Compression (+1) iff ``min(δ − slack, F(δ − slack)) > 0``; tension (−1, bilateral with
    slack) iff not, and ``max(δ + tension_slack, F(δ + tension_slack))`` is not ``> 0``;
    bilateral without slack: always +1; else open (0). The contact guards' ``F`` take the
    ``>= 0`` piece rule, the transmitted force the strict one of the law guards at ``δ − slack``.
    Returns ``(P, mode, ṡ, ∂P/∂δ, ∂P/∂δ̇, ∂P/∂s, ∂ṡ/∂δ, ∂ṡ/∂δ̇, ∂ṡ/∂s, ∂ṡ/∂P)``, the force
    derivatives zero while open.
    """
    if not math.isfinite(closure):
        raise ValueError("closure must be finite")
    if not math.isfinite(rate):
        raise ValueError("closure_rate must be finite")
    slack, tension_slack = law.slack, law.tension_slack
    bilateral = law.contact == BILATERAL
    branch = _law_branch(law, closure - slack, state, True)
    if bilateral and slack == 0.0 and tension_slack == 0.0:
        mode = 1
    else:
        dc = closure - slack
        fc = _law_force(law, dc, rate, state, _law_branch(law, dc, state, False))
        guard = fc if fc < dc else dc  # Python's min(dc, F)
        if guard > 0.0:
            mode = 1
        elif bilateral:
            dt = closure + tension_slack
            ft = _law_force(law, dt, rate, state, _law_branch(law, dt, state, False))
            guard = ft if ft > dt else dt  # Python's max(dt, F)
            mode = 0 if guard > 0.0 else -1
        else:
            mode = 0
    p = _transmitted_force(law, closure, rate, state, mode, branch)
    de = _effective_closure(law, closure, mode)
    state_rate = _law_state_rate(law, de, rate, state, p, branch)
    fcl, frt, fst, rcl, rrt, rst, rfo = _law_tangent(law, de, rate, state, p, branch)
    if mode == 0:
        fcl, frt, fst = 0.0, 0.0, 0.0
    return p, mode, state_rate, fcl, frt, fst, rcl, rrt, rst, rfo


@njit(**_JIT)
def _stored_energy(law, closure, state, mode):
    """The stored energy of the coupler of ``law`` in the contact mode (mirrors CouplerSolve._stored)."""
    return _law_stored_energy(law, _effective_closure(law, closure, mode), state, mode != 0)


@njit(**_JIT)
def state_mirror(laws, j, closure, state):
    """:func:`_mirror` of coupler j's law (:func:`_law_of`): −1.0 where Coupling.state_mirrored, else 1.0."""
    return _mirror(_law_of(laws, j), closure, state)


@njit(**_JIT)
def evaluate(laws, j, closure, rate, state):
    """Coupler j at ``(δ, δ̇, s)`` (mirrors Coupling.evaluate): :func:`_evaluate` of its law (:func:`_law_of`)."""
    return _evaluate(_law_of(laws, j), closure, rate, state)


# --- the iteration ------------------------------------------------------------------------


@njit(**_JIT)
def start(laws, st, closure_rate):
    """Forces at t = 0 from the laws at zero closure and the initial closure rates (mirrors CouplerSolve.start).

    A coupler without slack that is closing but open by its law at zero closure (a dashpot's
    force jump) is engaged from t = 0 when its engaged force is compressive.
    """
    for j in range(laws.kind.size):
        law = _law_of(laws, j)
        st.rate[j] = closure_rate[j]
        state = st.state[j]
        force, mode, state_rate, _, _, _, _, _, _, _ = _evaluate(law, 0.0, closure_rate[j], state)
        if law.slack == 0.0 and closure_rate[j] > 0.0 and mode == 0:
            de = _effective_closure(law, 0.0, 1)
            engaged = _law_force(law, de, closure_rate[j], state, _law_branch(law, de, state, False))
            if engaged > 0.0:
                force, mode = engaged, 1
        st.force[j] = force
        st.mode[j] = mode
        st.state_rate[j] = state_rate
        st.stored[j] = _stored_energy(law, 0.0, state, mode)


@njit(**_JIT)
def _residual(laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, closure, rate, modes, state_rate, tangent, residual):
    """Closures, rates, modes, ``ṡ``, tangents and the residual ``(P − T, s − σ s_n − dt/2 (σ ṡ_n + ṡ))`` (in place;
    ``σ`` of :func:`_mirror` at the trial closure)."""
    n = closure.size
    rows = laws.state_row
    for j in range(n):
        closure_gain = 0.0  # (D_u P)_j, (D_v P)_j: loops, not BLAS calls, on a few couplers
        rate_gain = 0.0
        for k in range(n):
            closure_gain += gain_u[j, k] * P[k]
            rate_gain += gain_v[j, k] * P[k]
        closure[j] = closure_free[j] + closure_gain
        rate[j] = rate_free[j] + rate_gain
        law = _law_of(laws, j)
        force, modes[j], state_rate[j], fcl, frt, fst, rcl, rrt, rst, rfo = _evaluate(law, closure[j], rate[j], s[j])
        tangent[j, 0], tangent[j, 1], tangent[j, 2], tangent[j, 3] = fcl, frt, fst, rcl
        tangent[j, 4], tangent[j, 5], tangent[j, 6] = rrt, rst, rfo
        residual[j] = P[j] - force
        if rows[j] >= 0:
            sigma = _mirror(law, closure[j], st.state[j])  # the step starts from σ (s_n, ṡ_n)
            residual[rows[j]] = s[j] - sigma * st.state[j] - 0.5 * dt * (sigma * st.state_rate[j] + state_rate[j])


@njit(**_JIT)
def _jacobian(dt, gain_u, gain_v, rows, tangent, jacobian):
    """∂(residual)/∂(P, s) from the tangents and the gains, into ``jacobian`` (mirrors CouplerSolve._jacobian)."""
    n = rows.size
    m = jacobian.shape[0]
    for i in range(m):  # np.eye(m)
        for k in range(m):
            jacobian[i, k] = 0.0
        jacobian[i, i] = 1.0
    for j in range(n):
        fcl, frt, fst, rcl = tangent[j, 0], tangent[j, 1], tangent[j, 2], tangent[j, 3]
        rrt, rst, rfo = tangent[j, 4], tangent[j, 5], tangent[j, 6]
        for k in range(n):
            jacobian[j, k] -= fcl * gain_u[j, k] + frt * gain_v[j, k]
        r = rows[j]
        if r < 0:
            continue
        jacobian[j, r] = -fst
        # ṡ is evaluated with the transmitted force T(δ, δ̇, s): chain through it
        d_closure = rcl + rfo * fcl
        d_rate = rrt + rfo * frt
        for k in range(n):
            jacobian[r, k] = -0.5 * dt * (d_closure * gain_u[j, k] + d_rate * gain_v[j, k])
        jacobian[r, r] -= 0.5 * dt * (rst + rfo * fst)


@njit(**_JIT)
def linear_solve(a, x, pivots):
    """``x ← a⁻¹ x`` in place, ``a`` overwritten by its LU factors, ``pivots`` (at least ``x.size`` long) by
    the row swaps: LU with partial pivoting in the order of OpenBLAS's ``dgesv`` (left-looking ``getf2``,
    then the two triangular solves), equal to ``np.linalg.solve`` bit for bit up to 5 unknowns (measured;
    round-off beyond), and cheaper to compile than numba's ``np.linalg.solve``."""
    n = x.size
    for j in range(n):
        for i in range(j):  # the earlier row swaps, on column j
            p = pivots[i]
            if p != i:
                a[i, j], a[p, j] = a[p, j], a[i, j]
        for i in range(1, j):  # U above the diagonal
            t = 0.0
            for k in range(i):
                t += a[i, k] * a[k, j]
            a[i, j] -= t
        for r in range(j, n):  # the rest of the column
            t = 0.0
            for k in range(j):
                t += a[r, k] * a[k, j]
            a[r, j] -= t
        p = j
        big = abs(a[j, j])
        for r in range(j + 1, n):
            if abs(a[r, j]) > big:
                p = r
                big = abs(a[r, j])
        pivots[j] = p
        if a[p, j] == 0.0:
            raise LinAlgError("Singular matrix")
        if p != j:
            for c in range(j + 1):
                a[j, c], a[p, c] = a[p, c], a[j, c]
        reciprocal = 1.0 / a[j, j]
        for r in range(j + 1, n):
            a[r, j] *= reciprocal
    for k in range(n):
        p = pivots[k]
        if p != k:
            x[k], x[p] = x[p], x[k]
    for k in range(n):
        for i in range(k + 1, n):
            x[i] -= a[i, k] * x[k]
    for k in range(n - 1, -1, -1):
        x[k] /= a[k, k]
        for i in range(k):
            x[i] -= a[i, k] * x[k]


@njit(**_JIT)
def _converged(residual, n, force_tolerance, state_tolerance):
    for k in range(residual.size):
        if not abs(residual[k]) <= (force_tolerance if k < n else state_tolerance):
            return False
    return True


@njit(**_JIT)
def _driven_rate(law, closure, rate, state, force):
    """``ṡ = q(δ_e, δ̇, s, P)`` driven by the transmitted force ``P = force`` and ``∂q/∂s``, mode and branch
    from the guards' strict signs at ``(δ, δ̇, s)`` (mirrors CouplerSolve._driven_rate)."""
    mode = _evaluate(law, closure, rate, state)[1]
    branch = _law_branch(law, closure - law.slack, state, True)
    de = _effective_closure(law, closure, mode)
    return _law_state_rate(law, de, rate, state, force, branch), _law_tangent(law, de, rate, state, force, branch)[5]


@njit(**_JIT)
def _state_under(law, state_tolerance, iterations, previous, previous_rate, dt, closure, rate, force, start):
    """The state under the held force ``P = force``: the root of ``R(s) = s − s_n − dt/2 (ṡ_n + q(s, P))``
    by Newton in a shrinking bracket from ``start`` (mirrors CouplerSolve._state_under); returns
    ``(s, settled)``, settled when ``|R| ≤ state_tolerance``."""
    x = start
    q, dq = _driven_rate(law, closure, rate, x, force)
    r = x - previous - 0.5 * dt * (previous_rate + q)
    slope = 1.0 - 0.5 * dt * dq
    low, high = (x - r, x) if r > 0.0 else (x, x - r)
    for _ in range(iterations):
        if abs(r) <= state_tolerance:
            return x, True
        trial = x - r / slope
        if not low <= trial <= high:
            trial = 0.5 * (low + high)
        x = trial
        q, dq = _driven_rate(law, closure, rate, x, force)
        r = x - previous - 0.5 * dt * (previous_rate + q)
        slope = 1.0 - 0.5 * dt * dq
        if r > 0.0:
            high = x
        else:
            low = x
    return x, abs(r) <= state_tolerance


@njit(**_JIT)
def _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, force):
    """``f(P_j) = P_j − T_j(δ(P), δ̇(P), s_j)`` with the other forces held (``law``: coupler j's); sets ``P[j]``
    and, for a stateful law, ``s[j]`` to its state under ``P_j`` (as the reference does). Returns
    ``(f, settled)``: settled is False when that state did not converge."""
    P[j] = force
    closure_gain = 0.0
    rate_gain = 0.0
    for k in range(P.size):
        closure_gain += gain_u[j, k] * P[k]
        rate_gain += gain_v[j, k] * P[k]
    closure = closure_free[j] + closure_gain
    rate = rate_free[j] + rate_gain
    settled = True
    if laws.stateful[j] != 0:
        sigma = _mirror(law, closure, st.state[j])  # the step starts from σ (s_n, ṡ_n)
        s[j], settled = _state_under(
            law, laws.state_tolerance[0], laws.limits[1], sigma * st.state[j], sigma * st.state_rate[j], dt, closure, rate, force, s[j]
        )
    value = force - _evaluate(law, closure, rate, s[j])[0]
    if math.isnan(value):
        raise ValueError("The function value is NaN; solver cannot continue.")
    return value, settled


@njit(**_JIT)
def brent_root(laws, st, dt, j, closure_free, rate_free, gain_u, gain_v, P, s, xa, xb, xtol):
    """The root of :func:`_excess` in ``[xa, xb]`` by Brent's method: scipy.optimize.brentq transcribed
    (scipy/optimize/Zeros/brentq.c; ``rtol = 4 eps``, 100 iterations), same evaluations, same result."""
    if xtol <= 0.0:
        raise ValueError("xtol too small (xtol <= 0)")
    law = _law_of(laws, j)
    rtol = BRENT_RTOL
    xpre, xcur = xa, xb
    xblk, fblk, spre, scur = 0.0, 0.0, 0.0, 0.0
    fpre = _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, xpre)[0]
    fcur = _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, xcur)[0]
    if fpre * fcur > 0.0:
        raise ValueError("f(a) and f(b) must have different signs")
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    for _ in range(BRENT_MAXITER):
        if fpre != 0.0 and fcur != 0.0 and (math.copysign(1.0, fpre) < 0.0) != (math.copysign(1.0, fcur) < 0.0):
            xblk = xpre
            fblk = fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            bound = 3 * abs(sbis) - delta
            if 2 * abs(stry) < (abs(spre) if abs(spre) < bound else bound):  # good short step
                spre = scur
                scur = stry
            else:  # bisect
                spre = sbis
                scur = sbis
        else:  # bisect
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, xcur)[0]
    raise RuntimeError("Failed to converge after 100 iterations.")


@njit(**_JIT)
def _same_sign(a, b):
    """``a`` and ``b`` both > 0 or both < 0 (mirrors femref.impact.couplers.same_sign)."""
    return (a > 0.0 and b > 0.0) or (a < 0.0 and b < 0.0)


@njit(**_JIT)
def _scalar_root(laws, st, dt, j, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s):
    """Coupler j's force with the others held, bracketed by ``[P − f(P), P]`` and widened, doubling its
    step, while ``f`` keeps its sign (mirrors CouplerSolve._scalar_root); a stateful coupler's state left at
    the root's. Returns ``(root, failure kind)``: 0, BRACKET_NOT_FOUND or COUPLER_NEWTON_FAILED (its state
    at the root did not settle)."""
    law = _law_of(laws, j)
    start = P[j]
    f0 = _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, start)[0]
    if f0 == 0.0:
        return start, 0
    a, fa = start, f0
    step = -f0
    b = start + step
    fb = _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, b)[0]
    expansions = 0
    while _same_sign(fa, fb):
        if expansions == laws.limits[3]:
            return b, BRACKET_NOT_FOUND
        expansions += 1
        a, fa = b, fb
        step = 2.0 * step
        if abs(step) < force_tolerance:
            step = math.copysign(force_tolerance, step)
        b = a + step
        fb = _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, b)[0]
    if fb == 0.0:
        root = b
    else:
        low, high = (a, b) if a < b else (b, a)
        root = brent_root(laws, st, dt, j, closure_free, rate_free, gain_u, gain_v, P, s, low, high, force_tolerance)
    if laws.stateful[j] != 0:
        if not _excess(law, j, laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, root)[1]:
            return root, COUPLER_NEWTON_FAILED
    return root, 0


@njit(**_JIT)
def _coupler_newton(laws, st, dt, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s, j, block, local, pivots):
    """Newton on coupler j's force and state, the other forces held (mirrors CouplerSolve._coupler_newton);
    ``block`` (2 × 2), ``local`` (2) and ``pivots`` (2 or more) are scratch.

    Returns ``(converged, |force residual|)`` of the last evaluation.
    """
    state_tolerance = laws.state_tolerance[0]
    law = _law_of(laws, j)
    last = 0.0
    for _ in range(laws.limits[1]):
        closure_gain = 0.0  # row j of D_u P, D_v P
        rate_gain = 0.0
        for k in range(P.size):
            closure_gain += gain_u[j, k] * P[k]
            rate_gain += gain_v[j, k] * P[k]
        closure = closure_free[j] + closure_gain
        rate = rate_free[j] + rate_gain
        p, _, state_rate, fcl, frt, fst, rcl, rrt, rst, rfo = _evaluate(law, closure, rate, s[j])
        local[0] = P[j] - p
        sigma = _mirror(law, closure, st.state[j])  # the step starts from σ (s_n, ṡ_n)
        local[1] = s[j] - sigma * st.state[j] - 0.5 * dt * (sigma * st.state_rate[j] + state_rate)
        last = abs(local[0])
        if abs(local[0]) <= force_tolerance and abs(local[1]) <= state_tolerance:
            return True, last
        block[0, 0] = 1.0 - (fcl * gain_u[j, j] + frt * gain_v[j, j])
        block[0, 1] = -fst
        block[1, 0] = -0.5 * dt * ((rcl + rfo * fcl) * gain_u[j, j] + (rrt + rfo * frt) * gain_v[j, j])
        block[1, 1] = 1.0 - 0.5 * dt * (rst + rfo * fst)
        local[0] = -local[0]
        local[1] = -local[1]
        linear_solve(block, local, pivots)  # local ← the step
        P[j] += local[0]
        s[j] += local[1]
    return False, last


@njit(**_JIT)
def _gauss_seidel(laws, st, dt, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s):
    """Sweeps coupler by coupler from the committed forces (mirrors CouplerSolve._gauss_seidel), in place on P, s
    (a stateful coupler's Newton on st's scratch block).

    Returns ``(sweeps, worst coupler, failure kind, change)``: failure kind 0 on success.
    """
    n = P.size
    change, worst = 0.0, 0
    for sweep in range(1, laws.limits[2] + 1):
        change, worst = 0.0, 0
        for j in range(n):
            previous = P[j]
            kind = 0
            if laws.stateful[j] == 0:
                P[j], kind = _scalar_root(laws, st, dt, j, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s)
            else:
                state = s[j]
                ok, last = _coupler_newton(
                    laws, st, dt, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s, j, st.work_block, st.work_local, st.work_pivots
                )
                if not ok:  # from where the cycling Newton started: the scalar root, the state following the force
                    P[j] = previous
                    s[j] = state
                    P[j], kind = _scalar_root(laws, st, dt, j, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s)
            if kind != 0:
                return sweep, j, kind, 0.0
            if abs(P[j] - previous) > change:
                change, worst = abs(P[j] - previous), j
        if change <= force_tolerance:
            return sweep, -1, 0, 0.0
    return laws.limits[2], worst, SWEEPS_EXHAUSTED, change


@njit(**_JIT)
def _held_at_jump(force, force_residual, tolerance, jump_fraction):
    """``|P − T| > max(tolerance, jump_fraction · max(|P|, |T|))``: the step ended held at a jump of the law
    (mirrors femref.impact.couplers.held_at_jump)."""
    law_force = force - force_residual
    return abs(force_residual) > max(tolerance, jump_fraction * max(abs(force), abs(law_force)))


@njit(**_JIT)
def _commit(laws, st, dt, force_tolerance, P, s, closure, rate, state_rate, modes, residual):
    """Book the step's coupler energy and take the new values (mirrors CouplerSolve._commit; ``residual[j]``
    is ``P − T`` of coupler j)."""
    for j in range(P.size):
        law = _law_of(laws, j)
        mode = modes[j]
        stored = _stored_energy(law, closure[j], s[j], mode)
        work = 0.5 * (P[j] + st.force[j]) * (closure[j] - st.closure[j])
        st.work[j] += work
        held = _held_at_jump(P[j], residual[j], force_tolerance, laws.jump_fraction[0])
        if mode == st.mode[j] and not held and st.held[j] == 0:  # on the law from end to end
            mid_closure = 0.5 * (closure[j] + st.closure[j])
            mid = _effective_closure(law, mid_closure, mode)
            rate_mid = 0.5 * (rate[j] + st.rate[j])
            start = _mirror(law, closure[j], st.state[j]) * st.state[j]  # the committed state, mirrored where the step crossed
            st.dissipated[j] += dt * _law_dissipation_rate(
                law, mid, rate_mid, 0.5 * (s[j] + start), 0.5 * (P[j] + st.force[j]), mode != 0
            )
        else:  # the contact changed within the step, or held at a jump: absorbed work less the change of stored energy
            st.dissipated[j] += work - (stored - st.stored[j])
        st.stored[j] = stored
        st.held[j] = 1 if held else 0
    for j in range(P.size):  # (slice assignments would cost seconds of compilation each)
        st.force[j] = P[j]
        st.state[j] = s[j]
        st.closure[j] = closure[j]
        st.rate[j] = rate[j]
        st.state_rate[j] = state_rate[j]
        st.mode[j] = modes[j]


@njit(**_JIT)
def solve(laws, st, dt, force_tolerance, closure_free, rate_free, gain_u, gain_v):
    """One step of the couplers (mirrors CouplerSolve.solve given the free closures, rates and gains).

    ``closure_free``, ``rate_free`` (n,): the closures and rates with zero coupler forces;
    ``gain_u = ∂δ/∂P``, ``gain_v = ∂δ̇/∂P`` (n × n). Newton on ``(P, s)`` from the committed
    values until the modes repeat and the residuals are within ``force_tolerance`` (N) and
    the state tolerance; after NEWTON_ITERATIONS the Gauss–Seidel fallback from the
    committed values. On success commits (energy bookkeeping included) and returns
    ``(iterations, -1, 0, 0.0)``; on failure leaves ``st`` unchanged and returns
    ``(iterations so far, worst coupler, failure kind, change)``: kind 1 (SWEEPS_EXHAUSTED)
    with the last sweep's largest change in P (N), kind 2 (COUPLER_NEWTON_FAILED) for the
    stateful coupler whose Newton cycled and whose state under the held force did not
    settle, kind 3 (BRACKET_NOT_FOUND) for the coupler whose scalar root found no sign
    change (change 0.0 for both).
    """
    n = closure_free.size
    rows = laws.state_row
    P, s, modes, new_modes = st.work_force, st.work_state, st.work_mode, st.work_new_mode
    closure, rate, state_rate, tangent = st.work_closure, st.work_rate, st.work_state_rate, st.work_tangent
    residual, step, jacobian, pivots = st.work_residual, st.work_step, st.work_jacobian, st.work_pivots
    for j in range(n):  # (new_modes, closure, rate, state_rate, tangent, residual: all set by _residual before use)
        P[j] = st.force[j]
        s[j] = st.state[j]
        modes[j] = st.mode[j]
    newton_iterations = laws.limits[0]
    iteration = 0
    converged = False
    for it in range(1, newton_iterations + 1):
        iteration = it
        _residual(laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, closure, rate, new_modes, state_rate, tangent, residual)
        settled = True
        for j in range(n):
            if new_modes[j] != modes[j]:
                settled = False
            modes[j] = new_modes[j]
        if settled and _converged(residual, n, force_tolerance, laws.state_tolerance[0]):
            converged = True
            break
        _jacobian(dt, gain_u, gain_v, rows, tangent, jacobian)
        for k in range(residual.size):
            step[k] = -residual[k]
        linear_solve(jacobian, step, pivots)  # step ← the Newton step
        for j in range(n):
            P[j] += step[j]
            if rows[j] >= 0:
                s[j] += step[rows[j]]
    if not converged:  # Newton cycles where a law is nearly discontinuous (a friction gear's switch band)
        for j in range(n):
            P[j] = st.force[j]
            s[j] = st.state[j]
        sweeps, worst, kind, change = _gauss_seidel(laws, st, dt, force_tolerance, closure_free, rate_free, gain_u, gain_v, P, s)
        if kind != 0:
            return iteration + sweeps, worst, kind, change
        _residual(laws, st, dt, closure_free, rate_free, gain_u, gain_v, P, s, closure, rate, new_modes, state_rate, tangent, residual)
        for j in range(n):  # the sweeps drove each state by the force P (not T)
            if laws.stateful[j] != 0:
                state_rate[j] = _driven_rate(_law_of(laws, j), closure[j], rate[j], s[j], P[j])[0]
        iteration += sweeps
    _commit(laws, st, dt, force_tolerance, P, s, closure, rate, state_rate, new_modes, residual)
    return iteration, -1, 0, 0.0
