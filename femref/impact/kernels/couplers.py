"""The compiled coupler iteration of one impact step (its readable twin is the oracle the tests hold it to).

The scene's laws are packed once into arrays (:func:`femref.impact.kernels.laws.pack_laws`);
the couplers' forces, states and energy accounts live in :class:`CouplerState`
(:func:`new_state`), updated in place by :func:`start` (the forces at t = 0) and :func:`solve`
(one step), both ``@njit``. The laws are the law modules' own functions, compiled
(:mod:`femref.impact.kernels.laws`), the contact around them :mod:`femref.impact.kernels.coupling`.
The arithmetic is the readable reference's (``tests/support/reference_engine``), operation by
operation, so the two agree to round-off:

* :func:`solve` is the reference's step given the free closures and rates and the Schur gains
  ``D_u``, ``D_v``: Newton on ``(P, s)``, then the Gauss–Seidel fallback with Brent's method
  (:func:`brent_root`, scipy's ``brentq`` transcribed) in a bracket widened until ``P − T``
  changes sign for a memoryless coupler, and a 2 × 2 Newton for a stateful one — where that
  cycles, Brent's method on its force with the state following it (:func:`_state_under`) —
  then the energy bookkeeping of ``_commit``. Every use of the committed state ``s_n``,
  ``ṡ_n`` takes ``σ s_n``, ``σ ṡ_n`` with ``σ`` of :func:`~femref.impact.kernels.coupling.mirror`
  (the sided state, :mod:`femref.impact.couplers`; ``σ x`` is exact, so the engines agree to the bit).
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

Pass C-contiguous float64 arrays to :func:`solve` (others work, but compile again and run
slower). A step of a few couplers is some hundred floating-point operations, so what a call
costs beyond them is the calls themselves. Hence:

* nothing allocates: :func:`solve`'s scratch (its iterate, the residual, the Jacobian and
  its LU factors …) is the ``work_*`` arrays of :class:`CouplerState`, made once by
  :func:`new_state`;
* the kernels are compiled without numba's reference counting (``_nrt=False``, a private
  numba option): with it, every call increfs and decrefs each array it is passed (numba's
  pruning of those pairs fails across branches and raise paths), an atomic operation
  each: ~4 µs of a single coupler's step, ~0.4 µs without. Without it a kernel can
  neither allocate nor hand an array to reference-counted code (hence ``law_of`` is for
  kernels only); callers with reference counting (:mod:`femref.impact.kernels.loop`) keep theirs;
* a call copies every array of its arguments into its argument list (an array is 7 to 11
  words), so the kernels below :func:`solve` take a ``CouplerLaw``, not ``laws``, the law
  dispatchers are inlined (``inline="always"``), and so are :func:`solve` and the parts of
  its Newton iteration on ``(laws, st)`` (residual, Jacobian, commit) — into the loop's step
  (with the pool's products inlined into the cars' kernels, a rigid line's step 0.78 → 0.56 µs).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from femref.impact.couplers import bracket_detail, coupler_newton_detail, sweeps_detail
from femref.impact.kernels.coupling import effective_closure, evaluate_law, mirror, stored_energy
from femref.impact.kernels.laws import CouplerLaws, law_dissipation_rate_at, law_force, law_of, law_piece, law_state_rate, law_tangent
from femref.impact.kernels.pool import linear_solve

_JIT = dict(cache=True, _nrt=False)  # every kernel's options (module docstring: no reference counting)

SWEEPS_EXHAUSTED, COUPLER_NEWTON_FAILED, BRACKET_NOT_FOUND = 1, 2, 3
"""Failure kinds :func:`solve` returns: Gauss–Seidel sweeps exhausted; a stateful coupler's Newton failed and
its state under the held force did not settle; the scalar root's bracket found no sign change."""

BRENT_RTOL = 4.0 * float(np.finfo(float).eps)  # scipy.optimize.brentq's default (and smallest) rtol
BRENT_MAXITER = 100  # scipy.optimize.brentq's default maxiter


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



# --- the iteration ------------------------------------------------------------------------


@njit(**_JIT)
def start(laws, st, closure_rate):
    """Forces at t = 0 from the laws at zero closure and the initial closure rates (mirrors CouplerSolve.start).

    A coupler without slack that is closing but open by its law at zero closure (a dashpot's
    force jump) is engaged from t = 0 when its engaged force is compressive.
    """
    for j in range(laws.kind.size):
        law = law_of(laws, j)
        st.rate[j] = closure_rate[j]
        state = st.state[j]
        force, mode, state_rate, _, _, _, _, _, _, _ = evaluate_law(law, 0.0, closure_rate[j], state)
        if law.slack == 0.0 and closure_rate[j] > 0.0 and mode == 0:
            de = effective_closure(law, 0.0, 1)
            engaged = law_force(law, de, closure_rate[j], state, law_piece(law, de, state, False))
            if engaged > 0.0:
                force, mode = engaged, 1
        st.force[j] = force
        st.mode[j] = mode
        st.state_rate[j] = state_rate
        st.stored[j] = stored_energy(law, 0.0, state, mode)


@njit(inline="always", **_JIT)
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
        law = law_of(laws, j)
        force, modes[j], state_rate[j], fcl, frt, fst, rcl, rrt, rst, rfo = evaluate_law(law, closure[j], rate[j], s[j])
        tangent[j, 0], tangent[j, 1], tangent[j, 2], tangent[j, 3] = fcl, frt, fst, rcl
        tangent[j, 4], tangent[j, 5], tangent[j, 6] = rrt, rst, rfo
        residual[j] = P[j] - force
        if rows[j] >= 0:
            sigma = mirror(law, closure[j], st.state[j])  # the step starts from σ (s_n, ṡ_n)
            residual[rows[j]] = s[j] - sigma * st.state[j] - 0.5 * dt * (sigma * st.state_rate[j] + state_rate[j])


@njit(inline="always", **_JIT)
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


@njit(inline="always", **_JIT)
def _converged(residual, n, force_tolerance, state_tolerance):
    for k in range(residual.size):
        if not abs(residual[k]) <= (force_tolerance if k < n else state_tolerance):
            return False
    return True


@njit(**_JIT)
def _driven_rate(law, closure, rate, state, force):
    """``ṡ = q(δ_e, δ̇, s, P)`` driven by the transmitted force ``P = force`` and ``∂q/∂s``, mode and branch
    from the guards' strict signs at ``(δ, δ̇, s)`` (mirrors CouplerSolve._driven_rate)."""
    mode = evaluate_law(law, closure, rate, state)[1]
    branch = law_piece(law, closure - law.slack, state, True)
    de = effective_closure(law, closure, mode)
    return law_state_rate(law, de, rate, state, force, branch), law_tangent(law, de, rate, state, force, branch)[5]


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
        sigma = mirror(law, closure, st.state[j])  # the step starts from σ (s_n, ṡ_n)
        s[j], settled = _state_under(
            law, laws.state_tolerance[0], laws.limits[1], sigma * st.state[j], sigma * st.state_rate[j], dt, closure, rate, force, s[j]
        )
    value = force - evaluate_law(law, closure, rate, s[j])[0]
    if math.isnan(value):
        raise ValueError("The function value is NaN; solver cannot continue.")
    return value, settled


@njit(**_JIT)
def brent_root(laws, st, dt, j, closure_free, rate_free, gain_u, gain_v, P, s, xa, xb, xtol):
    """The root of :func:`_excess` in ``[xa, xb]`` by Brent's method: scipy.optimize.brentq transcribed
    (scipy/optimize/Zeros/brentq.c; ``rtol = 4 eps``, 100 iterations), same evaluations, same result."""
    if xtol <= 0.0:
        raise ValueError("xtol too small (xtol <= 0)")
    law = law_of(laws, j)
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
    law = law_of(laws, j)
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
    law = law_of(laws, j)
    last = 0.0
    for _ in range(laws.limits[1]):
        closure_gain = 0.0  # row j of D_u P, D_v P
        rate_gain = 0.0
        for k in range(P.size):
            closure_gain += gain_u[j, k] * P[k]
            rate_gain += gain_v[j, k] * P[k]
        closure = closure_free[j] + closure_gain
        rate = rate_free[j] + rate_gain
        p, _, state_rate, fcl, frt, fst, rcl, rrt, rst, rfo = evaluate_law(law, closure, rate, s[j])
        local[0] = P[j] - p
        sigma = mirror(law, closure, st.state[j])  # the step starts from σ (s_n, ṡ_n)
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
    law_value = force - force_residual
    return abs(force_residual) > max(tolerance, jump_fraction * max(abs(force), abs(law_value)))


@njit(inline="always", **_JIT)
def _commit(laws, st, dt, force_tolerance, P, s, closure, rate, state_rate, modes, residual):
    """Book the step's coupler energy and take the new values (mirrors CouplerSolve._commit; ``residual[j]``
    is ``P − T`` of coupler j)."""
    for j in range(P.size):
        law = law_of(laws, j)
        mode = modes[j]
        stored = stored_energy(law, closure[j], s[j], mode)
        work = 0.5 * (P[j] + st.force[j]) * (closure[j] - st.closure[j])
        st.work[j] += work
        held = _held_at_jump(P[j], residual[j], force_tolerance, laws.jump_fraction[0])
        if mode == st.mode[j] and not held and st.held[j] == 0:  # on the law from end to end
            mid_closure = 0.5 * (closure[j] + st.closure[j])
            mid = effective_closure(law, mid_closure, mode)
            rate_mid = 0.5 * (rate[j] + st.rate[j])
            start = mirror(law, closure[j], st.state[j]) * st.state[j]  # the committed state, mirrored where the step crossed
            st.dissipated[j] += dt * law_dissipation_rate_at(
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


@njit(inline="always", **_JIT)
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
                state_rate[j] = _driven_rate(law_of(laws, j), closure[j], rate[j], s[j], P[j])[0]
        iteration += sweeps
    _commit(laws, st, dt, force_tolerance, P, s, closure, rate, state_rate, new_modes, residual)
    return iteration, -1, 0, 0.0
