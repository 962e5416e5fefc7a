"""The cars' step in numba: factorise, start, predict, advance and observe one car of the pool.

Every kernel takes ``(layout, values, c)``, the pool of :mod:`femref.impact.kernels.pool` that
:mod:`femref.impact.kernels.packing` fills, and branches on the car's kind. Once per prepared car
:func:`factorise` factorises it and precomputes its gains, and :func:`start` sets its consistent
initial acceleration when a run's pool is packed. Each step the loop calls
:func:`predict` (the free step, read at the end outputs) and :func:`advance` (add the
response to the new end loads); :func:`observe` reads sensors and energies at the output
steps only (calls, not inlined: inlined into the loop they slowed a fem car's banded sweeps by 6–10 %;
the pool's products inside them are inlined). The arithmetic is that of the readable steppers of ``tests/support/reference_engine``
(tests hold the two together to 1e-9):

* **second order** (kind 0), generalized-α on ``M ü + C u̇ + K u = B L`` with
  ``S a_{n+1} = −K u_n − (C + (1−αf) dt K) v_n − (αm M + (1−αf)(1−γ) dt C + (1−αf)(½−β) dt² K) a_n
  + αf B L_n + (1−αf) B L_{n+1}``, ``S = (1−αm) M + (1−αf) γ dt C + (1−αf) β dt² K``: the three
  history products are one fused banded sweep, S is factorised once (banded Cholesky), the
  response to the new loads is ``Z L_{n+1}`` with ``Z = (1−αf) S⁻¹ B``; the dissipated energy is
  ``Σ dt v̄ᵀ C v̄``, v̄ the step-mean velocity (one more banded product). A dense modal or rigid
  car is a banded one whose band is the whole matrix.
* **state space** (kind 1), ``x_{n+1} = A x_n + B L_{n+1}``: one sparse product per step (A and the
  output maps stored by rows, compressed by :func:`factorise`: :func:`~femref.impact.kernels.pool.compress_rows`); the
  work of the end loads ``L̄ᵀ W Δy`` is booked every step for its dissipated energy.
"""

from __future__ import annotations

from numba import njit
from numpy.typing import NDArray

from femref.impact.kernels.pool import (
    A, ALPHA_F, A_FREE, BAND, CA, COEFFICIENTS, CU, CV_NEW, CV_OLD, DAMPING, DISSIPATED, DOFS, DT,
    EFFECTIVE_FACTOR, END_COUNT, END_FEEDTHROUGH, END_FREE, END_NOW, END_OUTPUTS, END_RATES, END_RATE_FREE,
    EQUILIBRIUM, FEEDTHROUGH_ENERGY, GAIN_U, GAIN_V, HISTORY_A, HISTORY_U, HISTORY_V, INITIAL_ENERGY, KIND,
    KINETIC_FORM, LOAD, LOADS, LOAD_COUNT, LOAD_RATE, MASS, MASS_FACTOR, NEW_LOADS, OFFSET, PIVOT, RESPONSE,
    SCALARS, SENSOR_ACCELERATIONS, SENSOR_COUNT, SENSOR_FEEDTHROUGH, SENSOR_OUTPUTS, SENSOR_RATES, SENSOR_START,
    SENSOR_TRAVEL, STATE_SPACE, STIFFNESS, STRAIN_FORM, SUM_LOAD2, SUM_RATE2, TRANSITION, TRANSLATION, U, U_FREE,
    V, V_FREE, WORK1, WORK2, WORK3, WORK_MAP, X, X_FREE, band_cholesky, band_product, band_solve, dot, matvec,
    compress_rows, matvec_add, quadratic, sparse_matvec, sparse_quadratic, sparse_row,
)


# -- set-up ------------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def factorise(layout: NDArray, w: NDArray, c: int) -> bool:
    """Factorise car ``c`` and precompute its response and gains (constant for its step); False if S or M
    is not positive definite. A state-space car's maps, packed dense, are compressed to sparse rows first."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    gain_u, gain_v, load = at[GAIN_U], at[GAIN_V], at[LOAD]
    if at[KIND] == STATE_SPACE:
        S = at[SENSOR_COUNT]
        compress_rows(w, at[TRANSITION], n, n)
        compress_rows(w, at[KINETIC_FORM], n, n)
        compress_rows(w, at[STRAIN_FORM], n, n)
        compress_rows(w, at[END_OUTPUTS], Y, n)
        compress_rows(w, at[END_RATES], Y, n)
        compress_rows(w, at[SENSOR_OUTPUTS], S, n)
        compress_rows(w, at[SENSOR_RATES], S, n)
        compress_rows(w, at[SENSOR_ACCELERATIONS], S, n)
        for i in range(Y):  # gains: end maps (sparse) times the input
            for j in range(J):
                w[gain_u + i * J + j] = sparse_row(w, at[END_OUTPUTS], Y, i, load + j, J)
                w[gain_v + i * J + j] = sparse_row(w, at[END_RATES], Y, i, load + j, J)
        return True
    if not band_cholesky(w, at[EFFECTIVE_FACTOR], p, n) or not band_cholesky(w, at[MASS_FACTOR], p, n):
        return False
    cf = at[COEFFICIENTS]
    column, response, end_feedthrough = at[WORK1], at[RESPONSE], at[END_FEEDTHROUGH]
    for j in range(J):  # Z = (1−αf) S⁻¹ B, column by column
        for i in range(n):
            w[column + i] = w[load + i * J + j]
        band_solve(w, at[EFFECTIVE_FACTOR], p, n, column)
        for i in range(n):
            w[response + i * J + j] = (1.0 - w[cf + ALPHA_F]) * w[column + i]
    for i in range(Y):
        for j in range(J):
            ez = 0.0  # (E Z)[i, j]
            for k in range(n):
                ez += w[at[END_OUTPUTS] + i * n + k] * w[response + k * J + j]
            w[gain_u + i * J + j] = w[cf + CA] * ez + w[end_feedthrough + i * J + j]
            w[gain_v + i * J + j] = w[cf + CV_NEW] * ez + w[end_feedthrough + i * J + j] / w[cf + DT]
    return True


@njit(cache=True, _nrt=False)
def start(layout: NDArray, w: NDArray, c: int) -> None:
    """Car ``c`` at t = 0, its velocities (or state) and loads set: for a second-order car the consistent
    initial acceleration ``M a₀ = B L₀ − C v₀``, for a state-space car its end outputs and energy."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    if at[KIND] == STATE_SPACE:
        x = at[X]
        sparse_matvec(w, at[END_OUTPUTS], Y, x, at[END_NOW])
        w[at[SCALARS] + INITIAL_ENERGY] = 0.5 * sparse_quadratic(w, at[KINETIC_FORM], n, x) + 0.5 * sparse_quadratic(w, at[STRAIN_FORM], n, x)
        return
    a = at[A]
    band_product(w, at[DAMPING], p, n, at[V], a)
    for i in range(n):
        w[a + i] = -w[a + i]
    matvec_add(w, at[LOAD], n, J, at[LOADS], 1.0, a)
    band_solve(w, at[MASS_FACTOR], p, n, a)


# -- one step ----------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def predict(layout: NDArray, w: NDArray, c: int) -> None:
    """Car ``c``'s step with the new end loads left out; its end outputs and rates into its
    ``end_free``, ``end_rate_free``."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    end_free, end_rate_free = at[END_FREE], at[END_RATE_FREE]
    if at[KIND] == STATE_SPACE:
        x_free = at[X_FREE]
        sparse_matvec(w, at[TRANSITION], n, at[X], x_free)
        sparse_matvec(w, at[END_OUTPUTS], Y, x_free, end_free)
        sparse_matvec(w, at[END_RATES], Y, x_free, end_rate_free)
        return
    cf = at[COEFFICIENTS]
    u, v, a, u_free, v_free, a_free = at[U], at[V], at[A], at[U_FREE], at[V_FREE], at[A_FREE]
    hu, hv, ha = at[HISTORY_U], at[HISTORY_V], at[HISTORY_A]
    if p == 0:  # a point mass or a diagonal car: the sweep's one diagonal, without the views
        for i in range(n):
            w[a_free + i] = 0.0 + (w[hu + i] * w[u + i] + w[hv + i] * w[v + i] + w[ha + i] * w[a + i])
    else:  # the three history products in one sweep, diagonal by diagonal (see band_product)
        result = w[a_free: a_free + n]
        result[:] = 0.0
        for k in range(2 * p + 1):
            first, last = max(0, p - k), min(n, n + p - k)
            start, shift = k * n + first, first + k - p
            bu, bv, ba = w[hu + start: hu + start + last - first], w[hv + start: hv + start + last - first], w[ha + start: ha + start + last - first]
            su, sv, sa = w[u + shift: u + shift + last - first], w[v + shift: v + shift + last - first], w[a + shift: a + shift + last - first]
            rows = result[first:last]
            for i in range(last - first):
                rows[i] += bu[i] * su[i] + bv[i] * sv[i] + ba[i] * sa[i]
    if w[cf + ALPHA_F] != 0.0:
        matvec_add(w, at[LOAD], n, J, at[LOADS], w[cf + ALPHA_F], a_free)
    band_solve(w, at[EFFECTIVE_FACTOR], p, n, a_free)
    dt, cu, ca, cv_old, cv_new = w[cf + DT], w[cf + CU], w[cf + CA], w[cf + CV_OLD], w[cf + CV_NEW]
    for i in range(n):
        w[u_free + i] = w[u + i] + dt * w[v + i] + cu * w[a + i] + ca * w[a_free + i]
        w[v_free + i] = w[v + i] + cv_old * w[a + i] + cv_new * w[a_free + i]
    matvec(w, at[END_OUTPUTS], Y, n, u_free, end_free)
    matvec(w, at[END_OUTPUTS], Y, n, v_free, end_rate_free)
    matvec_add(w, at[END_FEEDTHROUGH], Y, J, at[LOADS], -1.0 / dt, end_rate_free)
    offset = w[at[SCALARS] + OFFSET]
    for i in range(Y):
        w[end_free + i] += offset


@njit(cache=True, _nrt=False)
def advance(layout: NDArray, w: NDArray, c: int) -> None:
    """Commit car ``c``'s step with its new end loads ``new_loads`` (``L_{n+1}``, linear within the step)."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    scalars = at[SCALARS]
    dt = w[at[COEFFICIENTS] + DT]
    L0, L1, load_rate = at[LOADS], at[NEW_LOADS], at[LOAD_RATE]
    rate2 = 0.0
    load2 = 0.0
    for j in range(J):
        slope = (w[L1 + j] - w[L0 + j]) / dt
        w[load_rate + j] = slope
        rate2 += slope * slope
        load2 += w[L0 + j] * w[L0 + j] + w[L1 + j] * w[L1 + j]
    w[scalars + SUM_LOAD2] += 0.5 * dt * load2
    w[scalars + SUM_RATE2] += dt * rate2
    if at[KIND] == STATE_SPACE:
        x, end_outputs, end_now, work_map = at[X], at[END_OUTPUTS], at[END_NOW], at[WORK_MAP]
        for i in range(n):
            w[x + i] = w[at[X_FREE] + i]
        matvec_add(w, at[LOAD], n, J, L1, 1.0, x)
        work = 0.0
        for i in range(Y):
            after = sparse_row(w, end_outputs, Y, i, x)
            change = after - w[end_now + i]
            w[end_now + i] = after
            for j in range(J):
                work += 0.5 * (w[L0 + j] + w[L1 + j]) * w[work_map + j * Y + i] * change
        w[scalars + DISSIPATED] += work
    else:
        cf = at[COEFFICIENTS]
        ca, cv_new = w[cf + CA], w[cf + CV_NEW]
        u, v, a, u_free, v_free, a_free = at[U], at[V], at[A], at[U_FREE], at[V_FREE], at[A_FREE]
        response, v_mid, damped = at[WORK1], at[WORK2], at[WORK3]
        matvec(w, at[RESPONSE], n, J, L1, response)
        for i in range(n):
            w[v_mid + i] = 0.5 * w[v + i]
            w[a + i] = w[a_free + i] + w[response + i]
            w[u + i] = w[u_free + i] + ca * w[response + i]
            w[v + i] = w[v_free + i] + cv_new * w[response + i]
            w[v_mid + i] += 0.5 * w[v + i]
        # move the rigid travel out of u (K t = C t = 0: the dynamics are unchanged)
        t = at[TRANSLATION]
        shift = w[u + at[PIVOT]] / w[t + at[PIVOT]]
        for i in range(n):
            w[u + i] -= shift * w[t + i]
        w[scalars + OFFSET] += shift
        band_product(w, at[DAMPING], p, n, v_mid, damped)
        w[scalars + DISSIPATED] += dt * dot(w, v_mid, damped, n)
    for j in range(J):
        w[L0 + j] = w[L1 + j]


@njit(cache=True, _nrt=False)
def observe(layout: NDArray, w: NDArray, c: int, k: int, displacement: NDArray, velocity: NDArray, acceleration: NDArray,
            energy: NDArray) -> None:
    """Car ``c``'s sensor displacements, velocities and accelerations now into row ``k`` of the histories
    (its columns from its sensor start; a second-order car's velocities ``O v + R_s (L_n − L_{n−1})/dt``),
    and add its kinetic, strain and dissipated energy (J) to ``energy[k, 0:3]``."""
    at = layout[c]
    n, p, J, S = at[DOFS], at[BAND], at[LOAD_COUNT], at[SENSOR_COUNT]
    first = at[SENSOR_START]
    scalars = at[SCALARS]
    if at[KIND] == STATE_SPACE:
        x = at[X]
        kinetic = 0.5 * sparse_quadratic(w, at[KINETIC_FORM], n, x)
        strain = 0.5 * sparse_quadratic(w, at[STRAIN_FORM], n, x)
        for i in range(S):
            displacement[k, first + i] = sparse_row(w, at[SENSOR_OUTPUTS], S, i, x)
            velocity[k, first + i] = sparse_row(w, at[SENSOR_RATES], S, i, x)
            acceleration[k, first + i] = sparse_row(w, at[SENSOR_ACCELERATIONS], S, i, x)
        energy[k, 0] += kinetic
        energy[k, 1] += strain
        energy[k, 2] += w[scalars + INITIAL_ENERGY] + w[scalars + DISSIPATED] - kinetic - strain
        return
    u, v, loads = at[U], at[V], at[LOADS]
    stiffness_u, mass_v = at[WORK1], at[WORK2]
    band_product(w, at[STIFFNESS], p, n, u, stiffness_u)
    band_product(w, at[MASS], p, n, v, mass_v)
    sensor_outputs, sensor_feedthrough, travel = at[SENSOR_OUTPUTS], at[SENSOR_FEEDTHROUGH], at[SENSOR_TRAVEL]
    load_rate = at[LOAD_RATE]
    for i in range(S):
        s = 0.0
        sv = 0.0
        for j in range(n):
            s += w[sensor_outputs + i * n + j] * w[u + j]
            sv += w[sensor_outputs + i * n + j] * w[v + j]
        feedthrough = 0.0
        feedthrough_rate = 0.0
        for j in range(J):
            feedthrough += w[sensor_feedthrough + i * J + j] * w[loads + j]
            feedthrough_rate += w[sensor_feedthrough + i * J + j] * w[load_rate + j]
        displacement[k, first + i] = s + feedthrough + w[travel + i] * w[scalars + OFFSET]
        velocity[k, first + i] = sv + feedthrough_rate
    strain = 0.5 * dot(w, u, stiffness_u, n) + 0.5 * quadratic(w, at[FEEDTHROUGH_ENERGY], J, loads)
    accelerations = at[A]
    if w[at[COEFFICIENTS] + EQUILIBRIUM] != 0.0:
        # M⁻¹(B L − C v − K u): generalized-α's own a_n lags by (αm − αf) dt
        accelerations = at[WORK3]
        band_product(w, at[DAMPING], p, n, v, accelerations)
        for i in range(n):
            w[accelerations + i] = -w[accelerations + i] - w[stiffness_u + i]
        matvec_add(w, at[LOAD], n, J, loads, 1.0, accelerations)
        band_solve(w, at[MASS_FACTOR], p, n, accelerations)
    for i in range(S):
        s = 0.0
        for j in range(n):
            s += w[sensor_outputs + i * n + j] * w[accelerations + j]
        acceleration[k, first + i] = s
    energy[k, 0] += 0.5 * dot(w, v, mass_v, n)
    energy[k, 1] += strain
    energy[k, 2] += w[scalars + DISSIPATED]



__all__ = ["advance", "factorise", "observe", "predict", "start"]
