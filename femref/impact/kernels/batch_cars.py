"""The second-order cars' step for B samples side by side: one car pool's matrices, B states, the samples innermost.

The samples of a values-only sweep (speeds, measurement) step cars whose matrices are the same numbers; only their
state differs. Here the matrices are read from one pool ``w`` (:mod:`femref.impact.kernels.pool`'s storage) and the
state of every sample is a column of ``s``: ``s[row + i, b]`` is entry ``i`` of a state field of sample ``b``, the
field's ``row`` in the ``layout`` column of that field (:data:`STATE_FIELDS`; the other columns are offsets into ``w``,
as in a run's own pool). Each band product, banded solve and dense map walks its matrix once for all B samples, the
inner loop over the samples contiguous (it vectorises).

The arithmetic is :mod:`femref.impact.kernels.cars`'s for a second-order car, operation for operation and in the same
order for each sample (each sum starts at zero and adds its terms in the same order; a scratch row of ``s`` holds
what a single-sample kernel holds in a local): so every sample's numbers are those of its run alone, bit for bit.
``spare`` is the first of :data:`SPARE_ROWS` scratch rows of ``s``. :func:`observe` writes the histories of the
samples with ``live[b]`` set only.
"""

from __future__ import annotations

from numba import njit
from numpy.typing import NDArray

from femref.impact.kernels.pool import (
    A, ALPHA_F, A_FREE, BAND, CA, COEFFICIENTS, CU, CV_NEW, CV_OLD, DAMPING, DISSIPATED, DOFS, DT, EFFECTIVE_FACTOR,
    END_COUNT, END_FEEDTHROUGH, END_FREE, END_NOW, END_OUTPUTS, END_RATE_FREE, EQUILIBRIUM, FEEDTHROUGH_ENERGY,
    HISTORY_A, HISTORY_U, HISTORY_V, LOAD, LOADS, LOAD_COUNT, LOAD_RATE, MASS, MASS_FACTOR, NEW_LOADS, OFFSET, PIVOT,
    RESPONSE, SCALARS, SENSOR_COUNT, SENSOR_FEEDTHROUGH, SENSOR_OUTPUTS, SENSOR_START, SENSOR_TRAVEL, STIFFNESS,
    SUM_LOAD2, SUM_RATE2, TRANSLATION, U, U_FREE, V, V_FREE, WORK1, WORK2, WORK3, X, X_FREE,
)

#: The pool fields that are a sample's state (a column of ``s`` each); every other field is a matrix or constant the
#: samples share.
STATE_FIELDS = (U, V, A, U_FREE, V_FREE, A_FREE, X, X_FREE, LOADS, LOAD_RATE, NEW_LOADS, END_FREE, END_RATE_FREE, END_NOW,
                SCALARS, WORK1, WORK2, WORK3)
#: Scratch rows at the end of ``s``: the per-sample accumulators of sums that a single run keeps in locals.
SPARE_ROWS = 4


# -- linear algebra: matrices at offsets into ``w``, vectors at rows of ``s`` ------------------------------------


@njit(cache=True, _nrt=False)
def band_product(w: NDArray, bands: int, p: int, n: int, s: NDArray, x: int, out: int) -> None:
    """``out = A x`` for every sample (:func:`femref.impact.kernels.pool.band_product`: diagonal by diagonal, each row
    summing its diagonals in order k = 0 … 2p; a diagonal one as ``0 + A_ii x_i``)."""
    if p == 0:
        for i in range(n):
            a, source, target = w[bands + i], s[x + i], s[out + i]
            for b in range(target.size):
                target[b] = 0.0 + a * source[b]
        return
    for i in range(n):  # row by row, its diagonals in order: each row's sum is the one diagonal by diagonal
        target = s[out + i]
        for b in range(target.size):
            target[b] = 0.0
        for k in range(max(0, p - i), min(2 * p + 1, n + p - i)):
            a, source = w[bands + k * n + i], s[x + i + k - p]
            for b in range(target.size):
                target[b] += a * source[b]


@njit(cache=True, _nrt=False)
def band_solve(w: NDArray, low: int, p: int, n: int, s: NDArray, rhs: int) -> None:
    """``rhs ← A⁻¹ rhs`` for every sample with the factor of :func:`femref.impact.kernels.pool.band_cholesky`, in
    :func:`femref.impact.kernels.pool.band_solve`'s order."""
    if p == 0:
        for j in range(n):
            d, target = w[low + j], s[rhs + j]
            for b in range(target.size):
                target[b] = target[b] * d * d
        return
    for j in range(n):  # L y = b
        d, xj = w[low + j], s[rhs + j]
        for b in range(xj.size):
            xj[b] = xj[b] * d
        for i in range(j + 1, min(n, j + p + 1)):
            factor, target = w[low + (i - j) * n + j], s[rhs + i]
            for b in range(target.size):
                target[b] -= factor * xj[b]
    for i in range(n - 1, -1, -1):  # Lᵀ x = y
        d, xi = w[low + i], s[rhs + i]
        for b in range(xi.size):
            xi[b] = xi[b] * d
        for k in range(max(0, i - p), i):
            factor, target = w[low + (i - k) * n + k], s[rhs + k]
            for b in range(target.size):
                target[b] -= factor * xi[b]


@njit(cache=True, _nrt=False)
def matvec(w: NDArray, A_: int, rows: int, cols: int, s: NDArray, x: int, out: int) -> None:
    """``out = A x`` for every sample (``A`` dense, row-major)."""
    for i in range(rows):
        target = s[out + i]
        for b in range(target.size):
            target[b] = 0.0
        for j in range(cols):
            a, source = w[A_ + i * cols + j], s[x + j]
            for b in range(target.size):
                target[b] += a * source[b]


@njit(cache=True, _nrt=False)
def matvec_add(w: NDArray, A_: int, rows: int, cols: int, s: NDArray, x: int, factor: float, out: int, spare: int) -> None:
    """``out += factor · A x`` for every sample (the sum ``A x`` first, in row ``spare``)."""
    for i in range(rows):
        matvec(w, A_ + i * cols, 1, cols, s, x, spare)
        total, target = s[spare], s[out + i]
        for b in range(target.size):
            target[b] += factor * total[b]


@njit(cache=True, _nrt=False)
def dot(s: NDArray, x: int, y: int, n: int, out: int) -> None:
    """Row ``out`` = ``xᵀ y`` of every sample."""
    total = s[out]
    for b in range(total.size):
        total[b] = 0.0
    for i in range(n):
        left, right = s[x + i], s[y + i]
        for b in range(total.size):
            total[b] += left[b] * right[b]


@njit(cache=True, _nrt=False)
def quadratic(w: NDArray, A_: int, n: int, s: NDArray, x: int, out: int, spare: int) -> None:
    """Row ``out`` = ``xᵀ A x`` of every sample (A n × n, row by row as :func:`femref.impact.kernels.pool.quadratic`)."""
    total = s[out]
    for b in range(total.size):
        total[b] = 0.0
    for i in range(n):
        matvec(w, A_ + i * n, 1, n, s, x, spare)
        row, xi = s[spare], s[x + i]
        for b in range(total.size):
            total[b] += xi[b] * row[b]


# -- one step ----------------------------------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def predict(layout: NDArray, w: NDArray, s: NDArray, c: int, spare: int) -> None:
    """:func:`femref.impact.kernels.cars.predict` of second-order car ``c`` for every sample."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    cf = at[COEFFICIENTS]
    u, v, a, u_free, v_free, a_free = at[U], at[V], at[A], at[U_FREE], at[V_FREE], at[A_FREE]
    hu, hv, ha = at[HISTORY_U], at[HISTORY_V], at[HISTORY_A]
    if p == 0:
        for i in range(n):
            bu, bv, ba, su, sv, sa, target = w[hu + i], w[hv + i], w[ha + i], s[u + i], s[v + i], s[a + i], s[a_free + i]
            for b in range(target.size):
                target[b] = 0.0 + (bu * su[b] + bv * sv[b] + ba * sa[b])
    else:  # the three history products in one sweep, row by row (each row's diagonals in order, as band_product)
        for i in range(n):
            target = s[a_free + i]
            for b in range(target.size):
                target[b] = 0.0
            for k in range(max(0, p - i), min(2 * p + 1, n + p - i)):
                j = i + k - p
                bu, bv, ba = w[hu + k * n + i], w[hv + k * n + i], w[ha + k * n + i]
                su, sv, sa = s[u + j], s[v + j], s[a + j]
                for b in range(target.size):
                    target[b] += bu * su[b] + bv * sv[b] + ba * sa[b]
    if w[cf + ALPHA_F] != 0.0:
        matvec_add(w, at[LOAD], n, J, s, at[LOADS], w[cf + ALPHA_F], a_free, spare)
    band_solve(w, at[EFFECTIVE_FACTOR], p, n, s, a_free)
    dt, cu, ca, cv_old, cv_new = w[cf + DT], w[cf + CU], w[cf + CA], w[cf + CV_OLD], w[cf + CV_NEW]
    for i in range(n):
        ui, vi, ai, afi, ufi, vfi = s[u + i], s[v + i], s[a + i], s[a_free + i], s[u_free + i], s[v_free + i]
        for b in range(ui.size):
            ufi[b] = ui[b] + dt * vi[b] + cu * ai[b] + ca * afi[b]
            vfi[b] = vi[b] + cv_old * ai[b] + cv_new * afi[b]
    end_free, end_rate_free = at[END_FREE], at[END_RATE_FREE]
    matvec(w, at[END_OUTPUTS], Y, n, s, u_free, end_free)
    matvec(w, at[END_OUTPUTS], Y, n, s, v_free, end_rate_free)
    matvec_add(w, at[END_FEEDTHROUGH], Y, J, s, at[LOADS], -1.0 / dt, end_rate_free, spare)
    offset = s[at[SCALARS] + OFFSET]
    for i in range(Y):
        target = s[end_free + i]
        for b in range(target.size):
            target[b] += offset[b]


@njit(cache=True, _nrt=False)
def advance(layout: NDArray, w: NDArray, s: NDArray, c: int, spare: int) -> None:
    """:func:`femref.impact.kernels.cars.advance` of second-order car ``c`` for every sample (its ``new_loads`` set)."""
    at = layout[c]
    n, p, J = at[DOFS], at[BAND], at[LOAD_COUNT]
    scalars = at[SCALARS]
    cf = at[COEFFICIENTS]
    dt, ca, cv_new = w[cf + DT], w[cf + CA], w[cf + CV_NEW]
    L0, L1, load_rate = at[LOADS], at[NEW_LOADS], at[LOAD_RATE]
    rate2, load2 = s[spare + 1], s[spare + 2]
    for b in range(rate2.size):
        rate2[b] = 0.0
        load2[b] = 0.0
    for j in range(J):
        before, after, slope = s[L0 + j], s[L1 + j], s[load_rate + j]
        for b in range(slope.size):
            slope[b] = (after[b] - before[b]) / dt
            rate2[b] += slope[b] * slope[b]
            load2[b] += before[b] * before[b] + after[b] * after[b]
    sum_load2, sum_rate2 = s[scalars + SUM_LOAD2], s[scalars + SUM_RATE2]
    for b in range(rate2.size):
        sum_load2[b] += 0.5 * dt * load2[b]
        sum_rate2[b] += dt * rate2[b]
    u, v, a, u_free, v_free, a_free = at[U], at[V], at[A], at[U_FREE], at[V_FREE], at[A_FREE]
    response, v_mid, damped = at[WORK1], at[WORK2], at[WORK3]
    matvec(w, at[RESPONSE], n, J, s, L1, response)
    for i in range(n):
        ri, mi, ai, ui, vi = s[response + i], s[v_mid + i], s[a + i], s[u + i], s[v + i]
        afi, ufi, vfi = s[a_free + i], s[u_free + i], s[v_free + i]
        for b in range(ri.size):
            mi[b] = 0.5 * vi[b]
            ai[b] = afi[b] + ri[b]
            ui[b] = ufi[b] + ca * ri[b]
            vi[b] = vfi[b] + cv_new * ri[b]
            mi[b] += 0.5 * vi[b]
    # move the rigid travel out of u (K t = C t = 0: the dynamics are unchanged)
    t, pivot = at[TRANSLATION], at[PIVOT]
    shift, offset = s[spare + 3], s[scalars + OFFSET]
    at_pivot, t_pivot = s[u + pivot], w[t + pivot]
    for b in range(shift.size):
        shift[b] = at_pivot[b] / t_pivot
    for i in range(n):
        ti, ui = w[t + i], s[u + i]
        for b in range(ui.size):
            ui[b] -= shift[b] * ti
    for b in range(shift.size):
        offset[b] += shift[b]
    band_product(w, at[DAMPING], p, n, s, v_mid, damped)
    dot(s, v_mid, damped, n, spare + 1)
    dissipated, power = s[scalars + DISSIPATED], s[spare + 1]
    for b in range(power.size):
        dissipated[b] += dt * power[b]
    for j in range(J):
        before, after = s[L0 + j], s[L1 + j]
        for b in range(before.size):
            before[b] = after[b]


@njit(cache=True, _nrt=False)
def observe(layout: NDArray, w: NDArray, s: NDArray, c: int, spare: int, live: NDArray, k: int, displacement: NDArray,
            velocity: NDArray, acceleration: NDArray, energy: NDArray) -> None:
    """:func:`femref.impact.kernels.cars.observe` of second-order car ``c`` for every sample, into row ``k`` of the
    histories (``[b, k, ...]``) of the samples ``b`` with ``live[b]``."""
    at = layout[c]
    n, p, J, S = at[DOFS], at[BAND], at[LOAD_COUNT], at[SENSOR_COUNT]
    first = at[SENSOR_START]
    scalars = at[SCALARS]
    u, v, loads = at[U], at[V], at[LOADS]
    stiffness_u, mass_v = at[WORK1], at[WORK2]
    band_product(w, at[STIFFNESS], p, n, s, u, stiffness_u)
    band_product(w, at[MASS], p, n, s, v, mass_v)
    sensor_outputs, sensor_feedthrough, travel = at[SENSOR_OUTPUTS], at[SENSOR_FEEDTHROUGH], at[SENSOR_TRAVEL]
    offset = s[scalars + OFFSET]
    for i in range(S):
        matvec(w, sensor_outputs + i * n, 1, n, s, u, spare)
        matvec(w, sensor_outputs + i * n, 1, n, s, v, spare + 1)
        matvec(w, sensor_feedthrough + i * J, 1, J, s, loads, spare + 2)
        matvec(w, sensor_feedthrough + i * J, 1, J, s, at[LOAD_RATE], spare + 3)
        sd, sv, feedthrough, feedthrough_rate = s[spare], s[spare + 1], s[spare + 2], s[spare + 3]
        for b in range(live.size):
            if live[b]:
                displacement[b, k, first + i] = sd[b] + feedthrough[b] + w[travel + i] * offset[b]
                velocity[b, k, first + i] = sv[b] + feedthrough_rate[b]
    dot(s, u, stiffness_u, n, spare + 2)
    quadratic(w, at[FEEDTHROUGH_ENERGY], J, s, loads, spare + 3, spare)
    strain, forms = s[spare + 2], s[spare + 3]
    for b in range(strain.size):
        strain[b] = 0.5 * strain[b] + 0.5 * forms[b]
    accelerations = at[A]
    if w[at[COEFFICIENTS] + EQUILIBRIUM] != 0.0:
        # M⁻¹(B L − C v − K u): generalized-α's own a_n lags by (αm − αf) dt
        accelerations = at[WORK3]
        band_product(w, at[DAMPING], p, n, s, v, accelerations)
        for i in range(n):
            ai, ki = s[accelerations + i], s[stiffness_u + i]
            for b in range(ai.size):
                ai[b] = -ai[b] - ki[b]
        matvec_add(w, at[LOAD], n, J, s, loads, 1.0, accelerations, spare)
        band_solve(w, at[MASS_FACTOR], p, n, s, accelerations)
    for i in range(S):
        matvec(w, sensor_outputs + i * n, 1, n, s, accelerations, spare)
        sa = s[spare]
        for b in range(live.size):
            if live[b]:
                acceleration[b, k, first + i] = sa[b]
    dot(s, v, mass_v, n, spare + 3)
    kinetic, dissipated = s[spare + 3], s[scalars + DISSIPATED]
    for b in range(live.size):
        if live[b]:
            energy[b, k, 0] += 0.5 * kinetic[b]
            energy[b, k, 1] += strain[b]
            energy[b, k, 2] += dissipated[b]


__all__ = ["SPARE_ROWS", "STATE_FIELDS", "advance", "band_product", "band_solve", "dot", "matvec", "matvec_add", "observe",
           "predict", "quadratic"]
