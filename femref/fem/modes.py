"""Free-free modes of a body's FEM operators, and the static flexibility of the modes left out.

``K φ = ω² M φ`` with the rigid translation split off exactly; the inertia-relief elastic
flexibility ``G_e = Πᵀ K⁺ Π`` (``Π = I − M φ_r φ_rᵀ``: loads balanced by rigid-body
inertia) and the residual flexibility ``R = G_e B − Σ_{i ≤ k} φ_i φ_iᵀ B / ω_i²`` of the
modes beyond the k kept ones (the static correction of a modal model,
:mod:`femref.models.modal`).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from femref.fem.banded import BandedCholesky, CholeskyFactor, upper_banded
from femref.fem.operators import Operators


def free_free_modes(ops: Operators, modes: int, wave_travel_time: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The rigid translation and the ``modes`` lowest elastic modes of ``K φ = ω² M φ``.

    Returns ``(Φ, ω²)`` with ``Φ`` (ndof × (modes + 1)) mass-normalised, ``Φᵀ M Φ = I``,
    rigid mode first (exactly ``1/√M_tot``, ``ω² = 0``). K is singular (free-free), so the
    pencil is shifted by ``σ = −10⁻² ω_est²``, below the spectrum (``K − σM`` is positive
    definite), with ``ω_est = π/(2 T_wave)`` the first elastic frequency of a homogeneous rod,
    and brought to standard form by the banded Cholesky factor ``K − σM = UᵀU``: the lowest
    modes are the largest eigenvalues ``1/(ω² − σ)`` of ``U⁻ᵀ M U⁻¹`` (Lanczos, ``eigsh``; a
    step is two banded triangular solves and a sparse product), ``φ = U⁻¹χ``. The vectors are
    then M-orthogonalised to the rigid mode and the elastic ones M-normalised and cleaned by a
    Rayleigh–Ritz step on their span (``Φᵀ K Φ`` diagonal to rounding). Signs: ``φ_i(+l) ≥ 0``.
    """
    ndof = ops.ndof
    if not 0 <= modes <= ndof - 2:
        raise ValueError(f"a modal car keeps 0 … {ndof - 2} elastic modes of its {ndof}-DOF mesh, got {modes}")
    M, K = ops.mass, ops.stiffness
    rigid = ops.rigid_modes[:, 0] / math.sqrt(ops.total_mass)
    if modes == 0:
        return rigid[:, None], np.zeros(1)
    sigma = -1e-2 * (math.pi / (2.0 * wave_travel_time)) ** 2
    shifted = CholeskyFactor(sp.csr_matrix(K - sigma * M))

    def inverted(chi: NDArray[np.float64]) -> NDArray[np.float64]:
        return shifted.solve(M @ shifted.solve(chi), transpose=True)

    start = np.exp(np.linspace(0.0, 1.0, ndof))  # fixed, neither even nor odd: no hidden RNG
    _, chi = spla.eigsh(spla.LinearOperator((ndof, ndof), matvec=inverted, dtype=float), k=modes + 1, which="LA", v0=start)
    vectors = shifted.solve(chi)
    vectors = vectors - np.outer(rigid, rigid @ (M @ vectors))
    # the rigid vector is now (numerically) zero: keep the `modes` directions of most mass
    mass_norm = np.einsum("ij,ij->j", vectors, M @ vectors)
    vectors = vectors[:, np.argsort(mass_norm)[1:]]
    omega2, ritz = _rayleigh_ritz(K, M, vectors)
    elastic = vectors @ ritz
    elastic *= np.where(elastic[-1] < 0.0, -1.0, 1.0)
    return np.column_stack([rigid, elastic]), np.concatenate([[0.0], omega2])


def _rayleigh_ritz(K, M, vectors: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenpairs of ``(VᵀKV, VᵀMV)``: ascending ``ω²`` and coefficients with ``(VY)ᵀ M (VY) = I``."""
    k_small = vectors.T @ (K @ vectors)
    m_small = vectors.T @ (M @ vectors)
    omega2, ritz = scipy.linalg.eigh(0.5 * (k_small + k_small.T), 0.5 * (m_small + m_small.T))
    return omega2, ritz


def inertia_relief_flexibility(ops: Operators, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    """``G_e f = Πᵀ K⁺ Π f``: static elastic displacement under loads balanced by rigid-body inertia.

    ``Π f = f − M φ_r φ_rᵀ f`` removes the resultant (the rigid body's inertia force
    balances it); the free-free ``K u = Π f`` is solved with K grounded at DOF 0
    (``K + K₀₀ e₀e₀ᵀ``, SPD and banded: one banded Cholesky, no dense matrix — summing
    the rows gives ``u₀ = 0``, so it solves ``K u = Π f`` exactly), and the rigid part
    is removed, ``u − φ_r φ_rᵀ M u``. ``rhs`` is ndof × n (columns solved together).
    """
    M, K = ops.mass, ops.stiffness
    rigid = ops.rigid_modes[:, 0] / math.sqrt(ops.total_mass)
    m_rigid = M @ rigid
    balanced = rhs - np.outer(m_rigid, rigid @ rhs)
    grounded = upper_banded(K, minimum=1)
    grounded[-1, 0] *= 2.0  # K₀₀ + K₀₀
    u = BandedCholesky.from_bands(grounded).solve(balanced)
    return u - np.outer(rigid, m_rigid @ u)


def residual_flexibility(ops: Operators, phi: NDArray[np.float64], omega2: NDArray[np.float64]) -> NDArray[np.float64]:
    """``R = G_e B − Σ_{kept elastic i} φ_i φ_iᵀ B / ω_i²`` (ndof × 2, m/N): the dropped modes' static response."""
    B = ops.load_matrix.toarray()
    elastic, w2 = phi[:, 1:], omega2[1:]
    return inertia_relief_flexibility(ops, B) - elastic @ ((elastic.T @ B) / w2[:, None])
