"""Exact response of a free-free Kelvin-Voigt rod to end forces, in the Laplace / frequency domain.

Equations (docs/design.md §2), Laplace variable ``s`` (``s = −iω`` for the time factor
``e^{−iωt}``), zero initial state::

    F = K(s) u_x,   K(s) = EA + s·cA     (N)
    F_x = m s² u = m a,                   a = s² u   (acceleration, m/s²)
    F(−l) = F1,  F(+l) = F2               (internal force at the ends, tension > 0)

so the rigid-body law is ``M a = F2 − F1``. Both solvers work with the state
``(a, F) = (s² u, F)`` — the rod's ``(u, F)`` with the displacement scaled by
``s²`` — because then nothing is nearly singular at low frequency: on a segment
``a_x = (s²/K) F`` and ``F_x = m a``, so with ``γ² = s² m/K`` (``Re γ ≥ 0``)::

    [a(x+h)]   [ cosh γh          (s²/(Kγ)) sinh γh ] [a(x)]
    [F(x+h)] = [ (m/γ) sinh γh    cosh γh           ] [F(x)]

The acceleration is solved for directly (the displacement is ``a/s²``), so the
rigid part ``(F2 − F1)/M`` never comes out of a difference of large numbers.
In the harmonic case ``γ = −i k``, ``k l = q`` with ``q² = λ²/(1 − iλβ)``,
``λ = ωl√(m/EA)``, ``β = (cA/l)/√(m·EA)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.exact.segments import Segments, check_amplitude, check_frequencies, check_laplace, check_positions


class RodUnitResponse(NamedTuple):
    """Transfer functions ``(Ns, Nx)`` of the rod: acceleration ``a`` (m/s² per N) and
    axial force ``F`` (N per N) for a unit end force ``F1 = 1`` (``*_left``) or ``F2 = 1`` (``*_right``)."""

    acceleration_left: NDArray[np.complex128]
    force_left: NDArray[np.complex128]
    acceleration_right: NDArray[np.complex128]
    force_right: NDArray[np.complex128]


@dataclass(frozen=True, eq=False)
class RodHarmonic:
    """Steady harmonic response ``Re[U(x) e^{−iωt}]`` of a rod; arrays ``(Nw, Nx)`` complex.

    ``displacement`` U (m), ``acceleration`` = −ω² U (m/s², computed directly, not as
    −ω²U), ``axial_force`` F = (EA − iω cA) U_x (N, tension positive).
    """

    omega: NDArray[np.float64]
    x: NDArray[np.float64]
    displacement: NDArray[np.complex128]
    acceleration: NDArray[np.complex128]
    axial_force: NDArray[np.complex128]


# --------------------------------------------------------------------------- public API


def rod_harmonic(segments: Segments, omega: ArrayLike, x: ArrayLike, F1: ArrayLike = 0.0, F2: ArrayLike = 0.0) -> RodHarmonic:
    """Harmonic response of a free-free Voigt rod to end forces ``F(−l) = F1``, ``F(l) = F2`` (N).

    One segment: the closed form (:func:`rod_harmonic_closed_form`); several: the
    transfer-matrix solution (:func:`rod_harmonic_transfer`). ``omega`` (rad/s, > 0)
    has shape ``(Nw,)``, ``x`` (m) shape ``(Nx,)`` in ``[−l, l]``; ``F1``, ``F2`` are
    complex amplitudes, scalars or ``(Nw,)``.
    """
    if segments.n_segments == 1:
        return rod_harmonic_closed_form(segments, omega, x, F1, F2)
    return rod_harmonic_transfer(segments, omega, x, F1, F2)


def rod_harmonic_closed_form(
    segments: Segments, omega: ArrayLike, x: ArrayLike, F1: ArrayLike = 0.0, F2: ArrayLike = 0.0
) -> RodHarmonic:
    """Closed form for a homogeneous rod (see :func:`rod_unit_response_closed_form`)."""
    return _harmonic(segments.homogeneous(), omega, x, F1, F2, rod_unit_response_closed_form)


def rod_harmonic_transfer(
    segments: Segments, omega: ArrayLike, x: ArrayLike, F1: ArrayLike = 0.0, F2: ArrayLike = 0.0
) -> RodHarmonic:
    """Transfer-matrix solution for any piecewise-constant rod (see :func:`rod_unit_response_transfer`)."""
    return _harmonic(segments, omega, x, F1, F2, rod_unit_response_transfer)


def rod_unit_response(segments: Segments, s: ArrayLike, x: ArrayLike) -> RodUnitResponse:
    """Unit-load transfer functions at Laplace variables ``s`` (``Re s ≥ 0``, ``s ≠ 0``): closed
    form for one segment, transfer matrices for several."""
    if segments.n_segments == 1:
        return rod_unit_response_closed_form(segments, s, x)
    return rod_unit_response_transfer(segments, s, x)


def rod_unit_response_closed_form(segments: Segments, s: ArrayLike, x: ArrayLike) -> RodUnitResponse:
    """Homogeneous rod, any ``x``, with ``γ² = s² m/(EA + s cA)``, ``y = x + l``, ``L = 2l``::

        a(x) = (γ/m) [F2 cosh(γy) − F1 cosh(γ(L − y))] / sinh(γL)          (m/s²)
        F(x) =       [F2 sinh(γy) + F1 sinh(γ(L − y))] / sinh(γL)          (N)

    Harmonic form (``γ = −ik``, ``q = kl``, ``ξ = x/l``):
    ``M a(x) = 2q [F2 cos(q(1+ξ)) − F1 cos(q(1−ξ))] / sin 2q``, so the centre under F2 is
    ``M a(0)/F2 = q/sin q = 1 + q²/6 + 7q⁴/360 + …`` with ``q² = λ²/(1 − iλβ)``.
    Corrected from the source, which printed ``q/sinh q`` for this ``q`` (the hyperbolic
    form needs ``γl = −iq``). Checked: the boundary values ``F(∓l) = F1, F2`` and
    ``F_x = m a`` hold; the Taylor series above; equality with the transfer-matrix
    solution to 1e-13 (tests/exact/test_rod.py).

    Evaluated with ``e^{−γ(…)}`` factors and ``expm1`` so that neither large ``Re γL``
    (Laplace inversion) nor small ``γL`` (low frequency) loses digits.
    """
    segments = segments.homogeneous()
    s = check_laplace(s)
    x = check_positions(segments, x)
    m = segments.mass_per_length[0]
    L = 2.0 * segments.half_length
    gamma = np.sqrt(s * s * m / (segments.stiffness[0] + s * segments.viscosity[0]))[:, None]
    y = (x + segments.half_length)[None, :]
    acc_right = _cosh_over_sinh(gamma, y, L) / m
    acc_left = -_cosh_over_sinh(gamma, L - y, L) / m
    force_right = _sinh_ratio(gamma, y, L)
    force_left = _sinh_ratio(gamma, L - y, L)
    return RodUnitResponse(acc_left, force_left, acc_right, force_right)


def rod_unit_response_transfer(segments: Segments, s: ArrayLike, x: ArrayLike) -> RodUnitResponse:
    """Piecewise-constant rod by the segment transfer matrices (module docstring), applied
    as an impedance sweep so that it is stable for any ``|γh|``.

    For the load at the left end (right end free) the impedance ``ζ(x) = F/a`` of the part
    of the rod right of ``x`` starts from ``ζ(l) = 0`` and is carried leftwards over a
    piece ``[x_a, x_b]`` of one segment by the inverse transfer matrix::

        ζ_a = (ζ_b − m h τ) / (1 − (s²/K) h τ ζ_b),     τ = tanh(γh)/(γh)

    then ``a(−l) = F1/ζ(−l)`` and, going right, ``a_b = a_a sech(γh) / (1 − (s²/K) h τ ζ_b)``,
    ``F = ζ a``. At low frequency ``ζ(−l) → −M``, i.e. ``a → −F1/M``. The load at the right
    end is the same sweep on the mirrored body (``x → −x``: ``a → −a``, ``F → F``).
    Checked against the closed form (one segment, 1e-13), momentum ``∫ m a dx = F2 − F1``,
    reciprocity, and the two-value-density asymptotics (tests/exact/test_rod.py).
    """
    s = check_laplace(s)
    x = check_positions(segments, x)
    acc_left, force_left = _left_load_sweep(segments, s, x)
    acc_mirror, force_mirror = _left_load_sweep(segments.mirrored(), s, -x)
    return RodUnitResponse(acc_left, force_left, -acc_mirror, force_mirror)


# --------------------------------------------------------------------------- kernels


def _harmonic(
    segments: Segments,
    omega: ArrayLike,
    x: ArrayLike,
    F1: ArrayLike,
    F2: ArrayLike,
    unit_response: Callable[[Segments, NDArray, NDArray], RodUnitResponse],
) -> RodHarmonic:
    omega = check_frequencies(omega)
    x = check_positions(segments, x)
    F1 = check_amplitude(F1, omega.size, "F1")[:, None]
    F2 = check_amplitude(F2, omega.size, "F2")[:, None]
    r = unit_response(segments, -1j * omega, x)
    acceleration = r.acceleration_left * F1 + r.acceleration_right * F2
    force = r.force_left * F1 + r.force_right * F2
    displacement = acceleration / -(omega**2)[:, None]
    return RodHarmonic(omega, x, displacement, acceleration, force)



def _cosh_over_sinh(gamma: NDArray, y: NDArray, L: float) -> NDArray:
    """``γ cosh(γy)/sinh(γL)`` for ``0 ≤ y ≤ L``, ``Re γ ≥ 0``, without overflow or loss at small γ."""
    e = np.exp(-gamma * (L - y)) * (1.0 + np.exp(-2.0 * gamma * y))
    return e * (gamma / -np.expm1(-2.0 * gamma * L))


def _sinh_ratio(gamma: NDArray, y: NDArray, L: float) -> NDArray:
    """``sinh(γy)/sinh(γL)`` for ``0 ≤ y ≤ L``, ``Re γ ≥ 0``."""
    return np.exp(-gamma * (L - y)) * np.expm1(-2.0 * gamma * y) / np.expm1(-2.0 * gamma * L)


def _tanhc(z: NDArray) -> NDArray:
    """``tanh(z)/z`` (1 at z = 0)."""
    small = np.abs(z) < 1e-4
    zs = np.where(small, 1.0, z)
    z2 = z * z
    return np.where(small, 1.0 - z2 / 3.0 + 2.0 * z2 * z2 / 15.0, np.tanh(zs) / zs)


def _sech(z: NDArray) -> NDArray:
    """``1/cosh z`` for ``Re z ≥ 0`` without overflow."""
    e = np.exp(-z)
    return 2.0 * e / (1.0 + e * e)


def _left_load_sweep(segments: Segments, s: NDArray, x: NDArray) -> tuple[NDArray, NDArray]:
    """Acceleration and force ``(Ns, Nx)`` for ``F1 = 1``, ``F2 = 0`` (impedance sweep)."""
    nodes = np.union1d(segments.edges, x)
    # segment of each piece (nodes[i], nodes[i+1]): by its midpoint
    piece = segments.segment_index(0.5 * (nodes[:-1] + nodes[1:]))
    h = np.diff(nodes)
    m = segments.mass_per_length[piece]
    K = segments.stiffness[piece][None, :] + s[:, None] * segments.viscosity[piece][None, :]
    p = (s * s)[:, None] / K  # s²/K per piece
    z = np.sqrt(p * m[None, :]) * h[None, :]  # γh, Re ≥ 0
    tau = _tanhc(z)
    n_nodes = nodes.size
    zeta = np.zeros((s.size, n_nodes), dtype=complex)
    denominator = np.empty((s.size, n_nodes - 1), dtype=complex)
    for i in range(n_nodes - 2, -1, -1):
        zb = zeta[:, i + 1]
        denominator[:, i] = 1.0 - p[:, i] * h[i] * tau[:, i] * zb
        zeta[:, i] = (zb - m[i] * h[i] * tau[:, i]) / denominator[:, i]
    acc = np.empty_like(zeta)
    acc[:, 0] = 1.0 / zeta[:, 0]
    sech = _sech(z)
    for i in range(n_nodes - 1):
        acc[:, i + 1] = acc[:, i] * sech[:, i] / denominator[:, i]
    force = zeta * acc
    index = np.searchsorted(nodes, x)
    return acc[:, index], force[:, index]
