"""Frequency response of a free body: one complex solve per frequency.

With the factor ``e^{−iωt}`` the discrete equation is ``(K − iωC − ω²M) U = f``.
For a free body ``K − iωC`` is singular on the rigid modes Φ, so at low frequency
the matrix is nearly singular (condition ∝ n²/λ² rod, n⁴/λ² beam). The rigid part is
therefore solved exactly and the elastic part orthogonally to it:

    U = Φ q + U_e,   Φᵀ M U_e = 0,
    α = (ΦᵀMΦ)⁻¹ Φᵀ f              (rigid-body accelerations, exact),
    q = −α/ω²,
    [K − iωC − ω²M   MΦ] [U_e]   [f − MΦα]
    [ΦᵀM             0 ] [ s ] = [   0   ]      (s = 0 at the solution),

and the acceleration ``A = −ω²U = Φα − ω²U_e`` carries no cancellation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.linalg import splu

from femref.fem.operators import Operators


@dataclass(frozen=True)
class HarmonicResponse:
    """Complex amplitudes at the probes, shape ``(Nω, Nprobes)``; ``axial_force`` for rods only."""

    omega: NDArray[np.float64]
    x: NDArray[np.float64]
    displacement: NDArray[np.complex128]
    acceleration: NDArray[np.complex128]
    axial_force: NDArray[np.complex128] | None


def harmonic_response(
    ops: Operators, omega: NDArray[np.float64], amplitudes: dict[str, complex], x: NDArray[np.float64]
) -> HarmonicResponse:
    """Steady response to end loads ``amplitudes`` (keys from ``ops.load_names``) at positions ``x``."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if np.any(omega <= 0.0) or not np.all(np.isfinite(omega)):
        raise ValueError("frequencies must be positive and finite")
    unknown = set(amplitudes) - set(ops.load_names)
    if unknown:
        raise ValueError(f"loads {sorted(unknown)} do not act on a {ops.kind}; use {ops.load_names}")
    load = np.array([amplitudes.get(name, 0.0) for name in ops.load_names], dtype=complex)
    f = ops.load_matrix @ load

    phi = ops.rigid_modes
    m_phi = ops.mass @ phi
    rigid_mass = phi.T @ m_phi
    alpha = np.linalg.solve(rigid_mass, phi.T @ f)  # rigid accelerations (translation, rotation)
    f_balanced = f - m_phi @ alpha
    r = phi.shape[1]
    rhs = np.concatenate([f_balanced, np.zeros(r)])
    border = sp.csr_matrix(m_phi)

    values = ops.interpolation(x)
    slopes = ops.interpolation(x, derivative=1) if ops.kind == "rod" else None
    n_w, n_x = omega.size, np.size(x)
    displacement = np.empty((n_w, n_x), dtype=complex)
    acceleration = np.empty((n_w, n_x), dtype=complex)
    force = np.empty((n_w, n_x), dtype=complex) if slopes is not None else None
    for k, w in enumerate(omega):
        dynamic = (ops.stiffness - 1j * w * ops.damping - w * w * ops.mass).astype(complex)
        bordered = sp.bmat([[dynamic, border], [border.T, None]], format="csc")
        elastic = splu(bordered).solve(rhs)[: ops.ndof]
        u = phi @ (-alpha / w**2) + elastic
        a = phi @ alpha - w * w * elastic
        displacement[k] = values @ u
        acceleration[k] = values @ a
        if force is not None:
            complex_stiffness = ops.stiffness_profile(x) - 1j * w * ops.viscosity_profile(x)
            force[k] = complex_stiffness * (slopes @ u)
    return HarmonicResponse(omega, np.asarray(x, dtype=float), displacement, acceleration, force)
