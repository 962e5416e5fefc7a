"""Banded Cholesky factorisation of symmetric positive definite sparse matrices.

The FEM matrices are banded once DOFs are numbered by position (half-bandwidth 1, 2, 3
for P1, P2, Hermite). LAPACK ``dpbtrf`` factorises once in O(n b²); each ``dpbtrs``
solve is O(n b) — the "bare triangular solves" that the time stepper is measured
against. No dense n × n matrix is ever formed.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import blas, lapack


def entries(matrix: sp.spmatrix | NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """The stored (sparse) or nonzero (dense) entries ``(i, j, A_ij)`` of a matrix, duplicates summed. A CSR matrix
    (what the assembly gives) is read from its index arrays: building a COO matrix costs scipy's
    checks, a tenth of a millisecond each, which a small car's set-up paid a dozen times."""
    if sp.issparse(matrix) and matrix.format == "csr":
        if not matrix.has_canonical_format:
            matrix = matrix.copy()
            matrix.sum_duplicates()
        rows = np.repeat(np.arange(matrix.shape[0]), np.diff(matrix.indptr))
        return rows, matrix.indices, matrix.data
    if not sp.issparse(matrix):
        dense = np.asarray(matrix, dtype=float)
        rows, cols = np.nonzero(dense)
        return rows, cols, dense[rows, cols]
    coo = matrix.tocoo()
    coo.sum_duplicates()
    return coo.row, coo.col, coo.data


def half_bandwidth(matrix: sp.spmatrix | NDArray[np.float64]) -> int:
    """``max |i − j|`` over the stored entries."""
    rows, cols, _ = entries(matrix)
    return int(np.max(np.abs(rows - cols))) if rows.size else 0


def upper_banded(matrix: sp.spmatrix, bandwidth: int | None = None, *, minimum: int = 0) -> NDArray[np.float64]:
    """LAPACK upper band storage: ``ab[b + i − j, j] = A[i, j]`` for ``j − b ≤ i ≤ j``, b the matrix's
    half-bandwidth (or ``bandwidth``), at least ``minimum``."""
    rows, cols, data = entries(matrix)
    b = max(minimum, (int(np.max(np.abs(rows - cols))) if rows.size else 0) if bandwidth is None else bandwidth)
    keep = rows <= cols
    ab = np.zeros((b + 1, matrix.shape[0]))
    ab[b + rows[keep] - cols[keep], cols[keep]] = data[keep]  # entries are distinct after summing duplicates
    return ab


class BandedCholesky:
    """``A = Uᵀ U`` of a symmetric positive definite banded matrix; ``solve(b)`` reuses it.

    Raises ``np.linalg.LinAlgError`` when A is not positive definite (e.g. a free body's
    singular stiffness), naming the failing pivot.
    """

    def __init__(self, matrix: sp.spmatrix) -> None:
        self._factorise(upper_banded(matrix, minimum=1))

    @classmethod
    def from_bands(cls, ab: NDArray[np.float64]) -> "BandedCholesky":
        """The factorisation of the matrix in upper band storage ``ab`` (:func:`upper_banded`, at least one
        superdiagonal; ``ab`` is overwritten)."""
        factorisation = cls.__new__(cls)
        factorisation._factorise(ab)
        return factorisation

    def _factorise(self, ab: NDArray[np.float64]) -> None:
        self.shape = (ab.shape[1], ab.shape[1])
        self.bandwidth = ab.shape[0] - 1
        if self.bandwidth == 1:  # tridiagonal (P1): LDLᵀ with dpttrf/dpttrs, about twice as fast
            d, e, info = lapack.dpttrf(ab[1], ab[0, 1:])
            self._factor = (d, e)
        else:
            self._factor, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded Cholesky failed: leading minor {info} is not positive definite")

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.bandwidth == 1:
            x, info = lapack.dpttrs(*self._factor, rhs)
        else:
            x, info = lapack.dpbtrs(self._factor, rhs, lower=0)
        if info != 0:  # pragma: no cover - the solves only fail on bad arguments
            raise ValueError(f"banded solve: illegal argument {-info}")
        return x


class CholeskyFactor:
    """The upper-triangular banded factor ``U`` of a symmetric positive definite ``A = UᵀU`` (LAPACK ``dpbtrf``)
    and solves with it, ``U⁻¹ b`` and ``U⁻ᵀ b`` (``dtbsv`` for a vector, ``dtbtrs`` for columns), O(n b) each.

    What the change of variables ``χ = U φ`` needs, which turns ``B φ = μ A φ`` into the
    standard ``U⁻ᵀ B U⁻¹ χ = μ χ`` (:func:`femref.fem.modes.free_free_modes`).
    """

    def __init__(self, matrix: sp.spmatrix) -> None:
        ab = upper_banded(matrix, minimum=1)
        self.bandwidth = ab.shape[0] - 1
        self._factor, info = lapack.dpbtrf(ab, lower=0, overwrite_ab=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"banded Cholesky failed: leading minor {info} is not positive definite")

    def solve(self, rhs: NDArray[np.float64], transpose: bool = False) -> NDArray[np.float64]:
        """``U⁻¹ rhs`` (``U⁻ᵀ rhs`` with ``transpose``) for a vector or the columns of a matrix."""
        if rhs.ndim == 1:
            return blas.dtbsv(self.bandwidth, self._factor, rhs, trans=int(transpose))
        x, info = lapack.dtbtrs(self._factor, rhs, trans="T" if transpose else "N")
        if info != 0:  # pragma: no cover - U from a successful dpbtrf is nonsingular
            raise ValueError(f"banded triangular solve: info {info}")
        return x
