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
from scipy.linalg import lapack


def half_bandwidth(matrix: sp.spmatrix) -> int:
    coo = sp.coo_matrix(matrix)
    return int(np.max(np.abs(coo.row - coo.col))) if coo.nnz else 0


def upper_banded(matrix: sp.spmatrix, bandwidth: int | None = None) -> NDArray[np.float64]:
    """LAPACK upper band storage: ``ab[b + i − j, j] = A[i, j]`` for ``j − b ≤ i ≤ j``."""
    coo = sp.coo_matrix(matrix)
    b = half_bandwidth(coo) if bandwidth is None else bandwidth
    keep = coo.row <= coo.col
    ab = np.zeros((b + 1, coo.shape[0]))
    np.add.at(ab, (b + coo.row[keep] - coo.col[keep], coo.col[keep]), coo.data[keep])
    return ab


class BandedCholesky:
    """``A = Uᵀ U`` of a symmetric positive definite banded matrix; ``solve(b)`` reuses it.

    Raises ``np.linalg.LinAlgError`` when A is not positive definite (e.g. a free body's
    singular stiffness), naming the failing pivot.
    """

    def __init__(self, matrix: sp.spmatrix) -> None:
        self.shape = matrix.shape
        self.bandwidth = max(1, half_bandwidth(matrix))
        ab = upper_banded(matrix, self.bandwidth)
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
