"""Exact transient response of a piecewise-constant Voigt rod to end-force histories.

From rest (``u = u_t = 0`` at ``t = 0``), with loads ``F(−l, t) = F1(t)``, ``F(l, t) = F2(t)``
that start at ``t ≥ 0``, the Laplace transform of the solution is the rod's transfer
function (``femref.exact.rod``, ``s`` in place of ``−iω``, stiffness ``EA + s cA``) times
the loads' transforms::

    a(x, s) = H_a1(x, s) F1(s) + H_a2(x, s) F2(s),   F(x, s) = H_F1 F1(s) + H_F2 F2(s),   u = a/s²

and the time histories come from the numerical inverse transform of de Hoog, Knight &
Stokes (``femref.exact.laplace``).

Accuracy (measured against modal superposition, tests/test_exact_transient.py): for
viscous rods (``β ≳ 0.01``) acceleration and force errors are ≲ 1e-5 of their peak at
times up to several pulse lengths. Limits: an elastic rod (``β → 0``) has
accelerations that jump at each wave front (and forces with kinks); the inversion
resolves them only to ``≈ T/M`` (Gibbs-like ringing near the fronts, errors of a few
per cent of the peak right at a jump, converging away from it). Raise ``terms`` or
add viscosity when pointwise elastic accelerations matter; displacements and forces
of elastic rods converge well.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.exact.laplace import invert_laplace
from femref.exact.rod import rod_unit_response
from femref.exact.segments import Segments, check_positions
from femref.signals import Signal


@dataclass(frozen=True, eq=False)
class RodTransient:
    """Time histories ``(Nt, Nx)`` of a rod from rest: ``displacement`` u (m),
    ``acceleration`` u_tt (m/s²), ``axial_force`` F = EA u_x + cA u_xt (N, tension positive)."""

    time: NDArray[np.float64]
    x: NDArray[np.float64]
    displacement: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    axial_force: NDArray[np.float64]


def rod_transient(
    segments: Segments,
    t: ArrayLike,
    x: ArrayLike,
    F1: Signal | None,
    F2: Signal | None,
    *,
    terms: int = 24,
) -> RodTransient:
    """Response of a free-free Voigt rod, at rest at ``t = 0``, to end forces ``F1(t)`` at ``−l``
    and ``F2(t)`` at ``+l`` (N, internal force, tension positive; ``None`` = no load).

    ``t`` (s, ``(Nt,)``, ``≥ 0``), ``x`` (m, ``(Nx,)`` in ``[−l, l]``). ``terms`` is the
    de Hoog order ``M`` (``2M + 1`` transform values per time window).
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(t < 0.0):
        raise ValueError("times t must be a 1-D array of finite values >= 0 s")
    x = check_positions(segments, x)
    loads = [(signal, side) for signal, side in ((F1, "left"), (F2, "right")) if signal is not None]
    zeros = np.zeros((t.size, x.size))
    if not loads or not np.any(t > 0.0):
        return RodTransient(t, x, zeros, zeros.copy(), zeros.copy())

    def transforms(s: NDArray[np.complex128]) -> NDArray[np.complex128]:
        r = rod_unit_response(segments, s, x)
        acc = np.zeros((s.size, x.size), dtype=complex)
        force = np.zeros_like(acc)
        for signal, side in loads:
            load = np.asarray(signal.laplace(s), dtype=complex)[:, None]
            acc += getattr(r, f"acceleration_{side}") * load
            force += getattr(r, f"force_{side}") * load
        return np.stack([acc / (s * s)[:, None], acc, force], axis=1)

    u, a, F = np.moveaxis(invert_laplace(transforms, t, terms=terms), 1, 0)
    return RodTransient(t, x, u, a, F)
