"""Banded Cholesky pieces the modal reduction uses: the factor ``A = UᵀU`` and its triangular solves, and a
factorisation from band storage (the grounded stiffness of the inertia-relief flexibility)."""

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femref.fem.banded import BandedCholesky, CholeskyFactor, half_bandwidth, upper_banded


def spd_band(n: int, bandwidth: int, seed: int = 0) -> sp.csr_matrix:
    """A random symmetric positive definite matrix of the given half-bandwidth (diagonally dominant)."""
    rng = np.random.default_rng(seed)
    offsets = range(1, bandwidth + 1)
    off = [rng.uniform(-1.0, 1.0, n - k) for k in offsets]
    upper = sp.diags(off, list(offsets), shape=(n, n))
    return sp.csr_matrix(upper + upper.T + sp.diags(np.full(n, 2.0 * bandwidth + 1.0)))


def test_cholesky_factor_solves_with_u_and_its_transpose():
    """``U⁻ᵀ`` then ``U⁻¹`` is ``A⁻¹``, for a vector and for columns; and ``‖U x‖² = xᵀ A x``."""
    for bandwidth in (1, 2, 3):
        A = spd_band(40, bandwidth, seed=bandwidth)
        U = CholeskyFactor(A)
        assert U.bandwidth == half_bandwidth(A) == bandwidth
        b = np.random.default_rng(7).normal(size=(40, 3))
        exact = spla.spsolve(A.tocsc(), b)
        np.testing.assert_allclose(U.solve(U.solve(b[:, 0], transpose=True)), exact[:, 0], rtol=1e-12)
        np.testing.assert_allclose(U.solve(U.solve(b, transpose=True)), exact, rtol=1e-12)
        y = U.solve(b[:, 1])  # U y = b: yᵀ A y = ‖U y‖² = ‖b‖²
        np.testing.assert_allclose(float(y @ (A @ y)), float(b[:, 1] @ b[:, 1]), rtol=1e-12)


def test_factorisation_from_band_storage_equals_the_one_from_the_matrix():
    A = spd_band(30, 2, seed=3)
    b = np.linspace(-1.0, 2.0, 30)
    np.testing.assert_allclose(BandedCholesky.from_bands(upper_banded(A, minimum=1)).solve(b), BandedCholesky(A).solve(b), rtol=1e-14)
    grounded = upper_banded(A, minimum=1)
    grounded[-1, 0] *= 2.0  # the diagonal's first entry doubled, as the modal static correction grounds K
    A_grounded = A.tolil()
    A_grounded[0, 0] *= 2.0
    np.testing.assert_allclose(BandedCholesky.from_bands(grounded).solve(b), spla.spsolve(A_grounded.tocsc(), b), rtol=1e-12)
