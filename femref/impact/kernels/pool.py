"""The pool of the compiled cars: every car of a run in two arrays, and the linear algebra on it.

:func:`~femref.impact.kernels.packing.pack_cars` lays every car of a run — a
:class:`~femref.impact.systems.SecondOrderSystem` or a
:class:`~femref.impact.systems.StateSpaceSystem` — into one :class:`CarPool`: a float
pool ``values`` holding every car's matrices and state, and an integer ``layout`` with one
row per car (its sizes, then the offset in ``values`` of each of its fields: the column
constants here). The kernels (:mod:`femref.impact.kernels.cars`) take ``(layout, values, c)``
and index the pool directly. This is a performance contract, not a style: numba
reference-counts every array a function receives (about 20 ns each), so a car passed as
a record of some fifty arrays cost about a microsecond per call, several times a rigid
car's arithmetic. The kernels are compiled without numba's reference counting
(``_nrt=False``, :mod:`femref.impact.kernels.couplers`): they never allocate.

Storage in the pool: dense matrices row-major; banded ones ``bands[k, i] = A[i, i + k − p]``
(p the half-bandwidth, 2p + 1 rows of n) and Cholesky factors ``low[k, j] = L[j + k, j]``
(p + 1 rows of n, the diagonal row holding ``1 / L[j, j]``), also row-major; a state-space car's
maps sparse by rows (:func:`compress_rows`: a quasi-rigid car's 16 × 16 transition has 35 nonzeros,
and its products summed over them are the dense ones bit for bit). The linear algebra here (banded
Cholesky, solve and product, dense and sparse products) takes every operand as an offset into the
pool; the products and solves are inlined into the cars' kernels (``inline="always"``: a call cost
more than a one-DOF car's arithmetic); :func:`linear_solve` is the coupler iteration's small dense solve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

SECOND_ORDER, STATE_SPACE = 0, 1
LinAlgError = np.linalg.LinAlgError

# columns of CarPool.layout: the car's sizes ...
KIND, DOFS, BAND, PIVOT, SENSOR_START, LOAD_COUNT, END_COUNT, SENSOR_COUNT, COUPLER_COUNT = range(9)
# ... then the offset in CarPool.values of each field (shapes in FIELD_SHAPES)
FIELDS = (
    "coefficients",          # (7,) DT … EQUILIBRIUM
    "history_u",             # second order, banded: −K
    "history_v",             # −(C + (1−αf) dt K)
    "history_a",             # −(αm M + (1−αf)(1−γ) dt C + (1−αf)(½−β) dt² K)
    "damping", "stiffness", "mass",
    "effective_factor",      # Cholesky factor of S (factorised in place by factorise)
    "mass_factor",           # of M
    "load",                  # (n, J) B: loads to generalized forces, or the state-space input
    "response",              # (n, J) Z = (1−αf) S⁻¹ B
    "translation",           # (n,)
    "sensor_travel",         # (S,) what each sensor row reads of a unit rigid translation: O t (1 axial, 0 vertical, pitch)
    "transition",            # state space: (n, n) A (this and the maps below to sensor_accelerations sparse, compress_rows)
    "kinetic_form", "strain_form",  # (n, n)
    "work_map",              # (J, Y)
    "end_outputs",           # (Y, n) E, or the state-space end displacement map
    "end_rates",             # (Y, n) state-space end velocity map
    "sensor_outputs",        # (S, n) O, or the state-space sensor displacement map
    "sensor_rates",          # (S, n) state-space sensor velocity map
    "sensor_accelerations",  # (S, n) state-space sensor acceleration map
    "end_feedthrough",       # (Y, J)
    "sensor_feedthrough",    # (S, J)
    "feedthrough_energy",    # (J, J)
    "gain_u",                # (Y, J) ∂(end outputs)/∂L over one step
    "gain_v",                # (Y, J) ∂(end rates)/∂L
    "coupler_loads",         # (J, n_c) L = coupler_loads @ P
    "coupler_outputs",       # (n_c, Y) closure contributions
    # the state, updated in place
    "u", "v", "a",           # second order: displacement (less the rigid travel), velocity, acceleration
    "u_free", "v_free", "a_free",  # and the free step
    "x", "x_free",           # state space: the state and its free step
    "loads",                 # (J,) L_n
    "load_rate",             # (J,) (L_n − L_{n−1})/dt: the sensor feedthrough's velocity
    "new_loads",             # (J,) L_{n+1}, set by the loop
    "end_free",              # (Y,) free end outputs of the step being solved
    "end_rate_free",         # (Y,) and their rates
    "end_now",               # (Y,) end outputs now (state space: for the work)
    "scalars",               # (5,) OFFSET … INITIAL_ENERGY
    "work1", "work2", "work3",  # (n,) scratch
)
(COEFFICIENTS, HISTORY_U, HISTORY_V, HISTORY_A, DAMPING, STIFFNESS, MASS, EFFECTIVE_FACTOR, MASS_FACTOR,
 LOAD, RESPONSE, TRANSLATION, SENSOR_TRAVEL, TRANSITION, KINETIC_FORM, STRAIN_FORM, WORK_MAP, END_OUTPUTS, END_RATES,
 SENSOR_OUTPUTS, SENSOR_RATES, SENSOR_ACCELERATIONS, END_FEEDTHROUGH, SENSOR_FEEDTHROUGH, FEEDTHROUGH_ENERGY, GAIN_U,
 GAIN_V, COUPLER_LOADS, COUPLER_OUTPUTS, U, V, A, U_FREE, V_FREE, A_FREE, X, X_FREE, LOADS, LOAD_RATE, NEW_LOADS,
 END_FREE, END_RATE_FREE, END_NOW, SCALARS, WORK1, WORK2, WORK3) = range(COUPLER_COUNT + 1, COUPLER_COUNT + 1 + len(FIELDS))

# entries of the coefficients field
DT, ALPHA_F, CU, CA, CV_OLD, CV_NEW, EQUILIBRIUM = range(7)
# entries of the scalars field
OFFSET, DISSIPATED, SUM_LOAD2, SUM_RATE2, INITIAL_ENERGY = range(5)


@dataclass(frozen=True)
class CarPool:
    """Every car of a run in two arrays (module docstring); ``shapes[c][field]`` for reading a field back."""

    layout: NDArray[np.int64]  # (cars, COUPLER_COUNT + 1 + len(FIELDS))
    values: NDArray[np.float64]
    shapes: tuple[dict[int, tuple[int, ...]], ...]

    def field(self, c: int, field: int) -> NDArray[np.float64]:
        """Car ``c``'s ``field`` (a column constant) as a view of the pool, in its shape."""
        shape = self.shapes[c][field]
        start = int(self.layout[c, field])
        return self.values[start: start + math.prod(shape)].reshape(shape)


# -- linear algebra on the pool: every operand is an offset into ``w`` -----------------------


@njit(cache=True, _nrt=False)
def band_cholesky(w: NDArray, low: int, p: int, n: int) -> bool:
    """In place: ``low[k, j] = A[j + k, j]`` becomes ``L[j + k, j]`` (k ≥ 1) with ``A = L Lᵀ``, and
    ``low[0, j] = 1 / L[j, j]`` (the solves multiply); False if A is not positive definite."""
    for j in range(n):
        s = w[low + j]
        for k in range(max(0, j - p), j):
            s -= w[low + (j - k) * n + k] ** 2
        if not s > 0.0:
            return False
        reciprocal = 1.0 / math.sqrt(s)
        w[low + j] = reciprocal
        for i in range(j + 1, min(n, j + p + 1)):
            s = w[low + (i - j) * n + j]
            for k in range(max(0, i - p), j):
                s -= w[low + (i - k) * n + k] * w[low + (j - k) * n + k]
            w[low + (i - j) * n + j] = s * reciprocal
    return True


@njit(cache=True, _nrt=False, inline="always")
def band_solve(w: NDArray, low: int, p: int, n: int, rhs: int) -> None:
    """In place: ``rhs ← A⁻¹ rhs`` with the factor of :func:`band_cholesky`, both sweeps by columns
    (each finished unknown updates the p after it: the dependency chain is one product per row); a diagonal
    matrix (p = 0: a point mass, a modal car) row by row, the same two products."""
    if p == 0:
        for j in range(n):
            w[rhs + j] = w[rhs + j] * w[low + j] * w[low + j]
        return
    for j in range(n):  # L y = b
        xj = w[rhs + j] * w[low + j]
        w[rhs + j] = xj
        for i in range(j + 1, min(n, j + p + 1)):
            w[rhs + i] -= w[low + (i - j) * n + j] * xj
    for i in range(n - 1, -1, -1):  # Lᵀ x = y
        xi = w[rhs + i] * w[low + i]
        w[rhs + i] = xi
        for k in range(max(0, i - p), i):
            w[rhs + k] -= w[low + (i - k) * n + k] * xi


@njit(cache=True, _nrt=False, inline="always")
def band_product(w: NDArray, bands: int, p: int, n: int, x: int, out: int) -> None:
    """``out = A x`` for ``bands[k, i] = A[i, i + k − p]``, diagonal by diagonal: each row still sums
    its diagonals in order k = 0 … 2p, and the inner loop, over views with a zero-based index (so
    numba adds no negative-index test), vectorises — three times faster than row by row; a diagonal one (p = 0)
    without the views, the same sum ``0 + A_ii x_i``."""
    if p == 0:
        for i in range(n):
            w[out + i] = 0.0 + w[bands + i] * w[x + i]
        return
    result = w[out: out + n]
    result[:] = 0.0
    for k in range(2 * p + 1):
        first, last = max(0, p - k), min(n, n + p - k)  # rows i whose column i + k − p exists
        band = w[bands + k * n + first: bands + k * n + last]
        shifted = w[x + first + k - p: x + last + k - p]
        rows = result[first:last]
        for i in range(last - first):
            rows[i] += band[i] * shifted[i]


@njit(cache=True, _nrt=False, inline="always")
def dot(w: NDArray, x: int, y: int, n: int) -> float:
    """``xᵀ y``."""
    s = 0.0
    for i in range(n):
        s += w[x + i] * w[y + i]
    return s


@njit(cache=True, _nrt=False, inline="always")
def matvec(w: NDArray, A: int, rows: int, cols: int, x: int, out: int) -> None:
    """``out = A x`` (small or sparse-in-effect dense maps: a loop beats a BLAS call here)."""
    for i in range(rows):
        s = 0.0
        for j in range(cols):
            s += w[A + i * cols + j] * w[x + j]
        w[out + i] = s


@njit(cache=True, _nrt=False, inline="always")
def matvec_add(w: NDArray, A: int, rows: int, cols: int, x: int, factor: float, out: int) -> None:
    """``out += factor · A x``."""
    for i in range(rows):
        s = 0.0
        for j in range(cols):
            s += w[A + i * cols + j] * w[x + j]
        w[out + i] += factor * s


@njit(cache=True, _nrt=False, inline="always")
def sparse_row(w: NDArray, A: int, rows: int, i: int, x: int, stride: int = 1) -> float:
    """``(A x)_i = Σ_j A_ij x_j`` (``x_j`` at ``x + j · stride``) over the stored entries of row i of a sparse ``A``
    (:func:`compress_rows`), in column order: the dense sum's terms but its zeros, so the same value (a zero's sign
    aside)."""
    columns = A + rows + 1
    values = columns + int(w[A + rows])
    s = 0.0
    for k in range(int(w[A + i]), int(w[A + i + 1])):
        s += w[values + k] * w[x + int(w[columns + k]) * stride]
    return s


@njit(cache=True, _nrt=False, inline="always")
def sparse_matvec(w: NDArray, A: int, rows: int, x: int, out: int) -> None:
    """``out = A x`` of a sparse ``A`` (:func:`compress_rows`); ``out`` must not overlap ``x``."""
    for i in range(rows):
        w[out + i] = sparse_row(w, A, rows, i, x)


@njit(cache=True, _nrt=False, inline="always")
def sparse_quadratic(w: NDArray, A: int, n: int, x: int) -> float:
    """``xᵀ A x`` of a sparse n × n ``A`` (:func:`compress_rows`), row by row as :func:`quadratic`."""
    s = 0.0
    for i in range(n):
        s += w[x + i] * sparse_row(w, A, n, i, x)
    return s


def sparse_size(rows: int, cols: int) -> int:
    """Floats a sparse ``rows × cols`` field takes in the pool: its row starts and, for a full matrix, a column and a
    value per entry (:func:`compress_rows`)."""
    return rows + 1 + 2 * rows * cols


@njit(cache=True, _nrt=False, inline="always")
def compress_rows(w: NDArray, A: int, rows: int, cols: int) -> None:
    """The dense row-major ``rows × cols`` matrix at the end of the field at ``A`` (:func:`sparse_size` long) as
    sparse rows, in place: ``[starts (rows + 1), columns (nnz), values (nnz)]`` from ``A``, row i's entries at
    ``starts[i] … starts[i + 1] − 1`` in column order (indices as floats, exact). Every entry moves to or before
    where it is read, and after it is read."""
    dense = A + rows + 1 + rows * cols
    nnz = 0
    for k in range(rows * cols):
        if w[dense + k] != 0.0:
            nnz += 1
    columns = A + rows + 1
    values = columns + nnz
    k = 0
    for i in range(rows):
        w[A + i] = k
        for j in range(cols):
            entry = w[dense + i * cols + j]
            if entry != 0.0:
                w[columns + k] = j
                w[values + k] = entry
                k += 1
    w[A + rows] = k


def dense_of(stored: NDArray[np.float64], rows: int, cols: int) -> NDArray[np.float64]:
    """The dense ``rows × cols`` matrix of a sparse one as :func:`compress_rows` stores it (reading a pool back)."""
    starts = stored[: rows + 1].astype(np.int64)
    nnz = int(starts[-1])
    matrix = np.zeros((rows, cols))
    matrix[np.repeat(np.arange(rows), np.diff(starts)), stored[rows + 1: rows + 1 + nnz].astype(np.int64)] = stored[rows + 1 + nnz: rows + 1 + 2 * nnz]
    return matrix


@njit(cache=True, _nrt=False, inline="always")
def quadratic(w: NDArray, A: int, n: int, x: int) -> float:
    """``xᵀ A x`` (A n × n)."""
    s = 0.0
    for i in range(n):
        row = 0.0
        for j in range(n):
            row += w[A + i * n + j] * w[x + j]
        s += w[x + i] * row
    return s


@njit(cache=True, _nrt=False)
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


__all__ = ["CarPool", "band_cholesky", "band_product", "band_solve", "dense_of", "dot", "linear_solve", "matvec", "matvec_add", "quadratic",
           "compress_rows", "sparse_matvec", "sparse_quadratic", "sparse_row", "sparse_size"]
