"""Exact response of a free-free Kelvin-Voigt Euler-Bernoulli beam to end shears and moments.

Equations (docs/design.md §2), Laplace variable ``s`` (``s = −iω`` for the time factor
``e^{−iωt}``), zero initial state::

    G = K(s) w_xx,  K(s) = EI + s·cI     (N·m)
    N = G_x,        N_x + m s² w = 0      (N)
    N(∓l) = N1, N2,  G(∓l) = G1, G2

with rigid-body laws ``M a_v = N1 − N2`` and ``J Ω = G2 − G1 − l(N1 + N2)``. The solvers
use the state ``(a, θ, G, N) = (s² w, s² w_x, G, N)`` — the beam's ``(w, w_x, G, N)``
with the motions scaled by ``s²`` (accelerations), so nothing is nearly singular at
low frequency::

    a_x = θ,  θ_x = (s²/K) G,  G_x = N,  N_x = −m a;     a_xxxx = κ⁴ a,  κ⁴ = −m s²/K

In the harmonic case ``κ⁴ = ω² m/(EI − iω cI)`` and ``q = κl`` has
``q⁴ = λ²/(1 − iλβ)``, ``λ = ωl²√(m/EI)``, ``β = (cI/l²)/√(m·EI)``.

Solutions are written with the Krylov functions (series in ``z⁴``, no cancellation at
small ``z``)::

    S = (cosh z + cos z)/2,  T = (sinh z + sin z)/2,  U = (cosh z − cos z)/2,  V = (sinh z − sin z)/2
    S' = V, T' = S, U' = T, V' = U
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from math import factorial
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.exact.segments import Segments, check_amplitude, check_frequencies, check_laplace, check_positions

#: Largest ``|κ h|`` of one transfer-matrix step (the Krylov series then converge in 7 terms
#: and a step amplifies the state by at most ``cosh 1``).
MAX_STEP_WAVENUMBER = 1.0
#: Beyond this ``|κ l|`` the closed form would overflow; the transfer solution takes over.
CLOSED_FORM_LIMIT = 300.0

_SERIES_TERMS = 8
# coefficients of S, T/z, U/z², V/z³ as power series in w = z⁴: 1/(4k + j)!
_SERIES = np.array([[1.0 / factorial(4 * k + j) for k in range(_SERIES_TERMS)] for j in range(4)])


class BeamFields(NamedTuple):
    """Transfer functions ``(Ns, Nx)`` for one unit end load: acceleration ``a = s² w`` (m/s²),
    angular acceleration ``θ = s² w_x`` (1/s²), moment ``G`` (N·m), shear ``N`` (N)."""

    acceleration: NDArray[np.complex128]
    angular_acceleration: NDArray[np.complex128]
    moment: NDArray[np.complex128]
    shear: NDArray[np.complex128]


class BeamUnitResponse(NamedTuple):
    """The beam's response to each unit end load (the others zero)."""

    N1: BeamFields
    N2: BeamFields
    G1: BeamFields
    G2: BeamFields


@dataclass(frozen=True, eq=False)
class BeamHarmonic:
    """Steady harmonic response ``Re[W(x) e^{−iωt}]`` of a beam; arrays ``(Nw, Nx)`` complex.

    ``deflection`` W (m), ``slope`` W_x (rad), ``acceleration`` −ω²W (m/s²) and
    ``angular_acceleration`` −ω²W_x (rad/s²) (both computed directly, not from W),
    ``moment`` G (N·m), ``shear`` N = G_x (N).
    """

    omega: NDArray[np.float64]
    x: NDArray[np.float64]
    deflection: NDArray[np.complex128]
    slope: NDArray[np.complex128]
    acceleration: NDArray[np.complex128]
    angular_acceleration: NDArray[np.complex128]
    moment: NDArray[np.complex128]
    shear: NDArray[np.complex128]


# --------------------------------------------------------------------------- public API


def beam_harmonic(
    segments: Segments,
    omega: ArrayLike,
    x: ArrayLike,
    N1: ArrayLike = 0.0,
    N2: ArrayLike = 0.0,
    G1: ArrayLike = 0.0,
    G2: ArrayLike = 0.0,
) -> BeamHarmonic:
    """Harmonic response of a free-free Voigt beam to end shears ``N(∓l) = N1, N2`` (N) and
    moments ``G(∓l) = G1, G2`` (N·m), complex amplitudes (scalars or ``(Nw,)``).

    One segment: the closed form (:func:`beam_harmonic_closed_form`), unless ``|q|`` is
    beyond :data:`CLOSED_FORM_LIMIT`; several: the transfer-matrix solution.
    """
    omega = check_frequencies(omega)
    if segments.n_segments == 1 and np.max(np.abs(_quartic_wavenumber(segments, -1j * omega))) ** 0.25 * segments.half_length < CLOSED_FORM_LIMIT:
        return beam_harmonic_closed_form(segments, omega, x, N1, N2, G1, G2)
    return beam_harmonic_transfer(segments, omega, x, N1, N2, G1, G2)


def beam_harmonic_closed_form(
    segments: Segments,
    omega: ArrayLike,
    x: ArrayLike,
    N1: ArrayLike = 0.0,
    N2: ArrayLike = 0.0,
    G1: ArrayLike = 0.0,
    G2: ArrayLike = 0.0,
) -> BeamHarmonic:
    """Closed form for a homogeneous beam (see :func:`beam_unit_response_closed_form`)."""
    return _harmonic(segments.homogeneous(), omega, x, (N1, N2, G1, G2), beam_unit_response_closed_form)


def beam_harmonic_transfer(
    segments: Segments,
    omega: ArrayLike,
    x: ArrayLike,
    N1: ArrayLike = 0.0,
    N2: ArrayLike = 0.0,
    G1: ArrayLike = 0.0,
    G2: ArrayLike = 0.0,
) -> BeamHarmonic:
    """Transfer-matrix solution for any piecewise-constant beam (see :func:`beam_unit_response_transfer`)."""
    return _harmonic(segments, omega, x, (N1, N2, G1, G2), beam_unit_response_transfer)


def beam_unit_response_closed_form(segments: Segments, s: ArrayLike, x: ArrayLike) -> BeamUnitResponse:
    """Homogeneous beam, any ``x``. With ``q = κl``, ``X = κx``, Krylov functions ``S…V`` of ``q``
    and ``Sx…Vx`` of ``X``, and the load parts ``Ge = (G1+G2)/2``, ``Go = (G2−G1)/2``,
    ``No = (N2−N1)/2``, ``Ne = (N1+N2)/2``::

        m a(x) = −[κ² Ge (T Ux − V Sx) + κ No (S Sx − U Ux)] / (S T − U V)      (symmetric)
                 −[κ Ne (T Tx − V Vx) − κ² Go (S Tx − U Vx)] / (T U − S V)      (antisymmetric)

    and ``θ = a_x``, ``G = −(m/κ⁴) a_xx``, ``N = G_x`` by ``S' = V, T' = S, U' = T, V' = U``.
    In trigonometric form (``2(ST − UV) = cos q sinh q + sin q cosh q``,
    ``2(TU − SV) = sin q cosh q − cos q sinh q``) the centre values are

        M a(0)/(N1 − N2) = q (cos q + cosh q)/(cos q sinh q + sin q cosh q) = 1 + 3q⁴/40 + …
        J a_x(0)/(−l(N1 + N2)) = q² (sin q + sinh q)/(3(sin q cosh q − cos q sinh q)) = 1 + 11q⁴/840 + …
        J a_x(0)/(G2 − G1) = 1 + 13q⁴/280 + …

    with ``q⁴ = λ²/(1 − iλβ)``, ``β = (cI/l²)/√(m EI)`` (dimensionless). Corrections to the
    source: its rotation constant 3/40 is the vertical one (11/840 is right: 4 % off at
    λ = 1), and its viscosity parameter had the wrong dimensions (the ratio ``cI/EI`` is
    a time; ``λβ = ω cI/EI``). Checked: end values ``G(∓l), N(∓l)`` equal the loads;
    ``N_x = −m a``; the series above to O(q⁸) with exact rational coefficients;
    equality with the transfer-matrix solution to 1e-12; reciprocity
    (tests/exact/test_beam.py).
    """
    segments = segments.homogeneous()
    s = check_laplace(s)
    x = check_positions(segments, x)
    m, l = segments.mass_per_length[0], segments.half_length
    kappa = np.sqrt(np.sqrt(_quartic_wavenumber(segments, s)[:, 0]))[:, None]
    S, T, U, V = krylov(kappa * l)
    Sx, Tx, Ux, Vx = krylov(kappa * x[None, :])
    sym, anti = S * T - U * V, T * U - S * V
    k1, k2 = kappa, kappa * kappa

    def fields(Ge: float, Go: float, No: float, Ne: float) -> BeamFields:
        # a = cS·Sx + cT·Tx + cU·Ux + cV·Vx
        cS = -(-k2 * Ge * V + k1 * No * S) / (m * sym)
        cU = -(k2 * Ge * T - k1 * No * U) / (m * sym)
        cT = -(-k2 * Go * S + k1 * Ne * T) / (m * anti)
        cV = -(k2 * Go * U - k1 * Ne * V) / (m * anti)
        a = cS * Sx + cT * Tx + cU * Ux + cV * Vx
        theta = k1 * (cS * Vx + cT * Sx + cU * Tx + cV * Ux)
        G = -(m / k2) * (cS * Ux + cT * Vx + cU * Sx + cV * Tx)
        N = -(m / k1) * (cS * Tx + cT * Ux + cU * Vx + cV * Sx)
        return BeamFields(a, theta, G, N)

    return BeamUnitResponse(
        N1=fields(0.0, 0.0, -0.5, 0.5),
        N2=fields(0.0, 0.0, 0.5, 0.5),
        G1=fields(0.5, -0.5, 0.0, 0.0),
        G2=fields(0.5, 0.5, 0.0, 0.0),
    )


def beam_unit_response_transfer(segments: Segments, s: ArrayLike, x: ArrayLike) -> BeamUnitResponse:
    """Piecewise-constant beam by transfer matrices of the state ``(a, θ, G, N)``, applied as a
    2×2 impedance (Riccati) sweep in steps with ``|κh| ≤ 1`` so that it is stable at any frequency.

    Step matrix over ``h`` (``p = s²/K``, ``w = κ⁴h⁴ = −m p h⁴``; ``S, T̂ = T/z, Û = U/z²,
    V̂ = V/z³`` as series in ``w``)::

        Φ(h) = [[ S,        hT̂,       p h²Û,    p h³V̂ ],
                [ −m p h³V̂, S,        p hT̂,     p h²Û ],
                [ −m h²Û,   −m h³V̂,   S,        hT̂    ],
                [ −m hT̂,    −m h²Û,   −m p h³V̂, S     ]]

    For loads at the left end (right end free) the impedance ``Z`` with
    ``(G, N) = Z (a, θ)`` starts from ``Z(l) = 0`` and is carried left with
    ``Ψ = Φ(−h)``: ``Z_a = (Ψfm + Ψff Z_b)(Ψmm + Ψmf Z_b)⁻¹``; then
    ``(a, θ)(−l) = Z(−l)⁻¹ (G1, N1)`` and ``(a, θ)_b = (Ψmm + Ψmf Z_b)⁻¹ (a, θ)_a``.
    Loads at the right end: the same on the mirrored beam (``x → −x``: ``a, G`` keep
    their sign, ``θ, N`` change it). Checked against the closed form (1e-12),
    reciprocity and ``∫ m a dx = N1 − N2`` (tests/exact/test_beam.py).
    """
    s = check_laplace(s)
    x = check_positions(segments, x)
    left = _left_load_sweep(segments, s, x)
    mirror = _left_load_sweep(segments.mirrored(), s, -x)
    flip = np.array([1.0, -1.0, 1.0, -1.0])[:, None, None]  # a, θ, G, N under x → −x

    def fields(stack: NDArray) -> BeamFields:
        return BeamFields(*stack)

    return BeamUnitResponse(
        N1=fields(left[:, 1]),
        N2=fields(-flip * mirror[:, 1]),
        G1=fields(left[:, 0]),
        G2=fields(flip * mirror[:, 0]),
    )


def krylov(z: ArrayLike) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Krylov functions ``S, T, U, V`` of complex ``z`` (power series for ``|z| < 1``)."""
    z = np.asarray(z, dtype=complex)
    small = np.abs(z) < 1.0
    zs = np.where(small, z, 0.0)
    Sh, Th, Uh, Vh = _scaled_krylov(zs**4)
    zl = np.where(small, 1.0, z)
    ch, sh, c, sn = np.cosh(zl), np.sinh(zl), np.cos(zl), np.sin(zl)
    return (
        np.where(small, Sh, 0.5 * (ch + c)),
        np.where(small, zs * Th, 0.5 * (sh + sn)),
        np.where(small, zs**2 * Uh, 0.5 * (ch - c)),
        np.where(small, zs**3 * Vh, 0.5 * (sh - sn)),
    )


# --------------------------------------------------------------------------- kernels


def _harmonic(
    segments: Segments,
    omega: ArrayLike,
    x: ArrayLike,
    loads: tuple[ArrayLike, ArrayLike, ArrayLike, ArrayLike],
    unit_response: Callable[[Segments, NDArray, NDArray], BeamUnitResponse],
) -> BeamHarmonic:
    omega = check_frequencies(omega)
    x = check_positions(segments, x)
    amplitudes = [check_amplitude(v, omega.size, name)[:, None] for v, name in zip(loads, ("N1", "N2", "G1", "G2"))]
    response = unit_response(segments, -1j * omega, x)
    total = [sum(f[i] * a for f, a in zip(response, amplitudes)) for i in range(4)]
    acceleration, angular, moment, shear = total
    minus_w2 = -(omega**2)[:, None]
    return BeamHarmonic(omega, x, acceleration / minus_w2, angular / minus_w2, acceleration, angular, moment, shear)



def _quartic_wavenumber(segments: Segments, s: NDArray) -> NDArray:
    """``κ⁴ = −m s²/(EI + s cI)`` per frequency and segment, shape ``(Ns, n)``."""
    K = segments.stiffness[None, :] + s[:, None] * segments.viscosity[None, :]
    return -(s * s)[:, None] * segments.mass_per_length[None, :] / K


def _scaled_krylov(w: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``S, T/z, U/z², V/z³`` as power series in ``w = z⁴`` (Horner; accurate for ``|w| ≤ 1``)."""
    out = []
    for coefficients in _SERIES:
        acc = np.full(np.shape(w), coefficients[-1], dtype=complex)
        for c in coefficients[-2::-1]:
            acc = acc * w + c
        out.append(acc)
    return tuple(out)


def _step_blocks(p: NDArray, m: float, h: float) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Blocks ``Φmm, Φmf, Φfm, Φff`` (each ``(Ns, 2, 2)``) of the step matrix over ``h`` (may be < 0)."""
    S, Th, Uh, Vh = _scaled_krylov(-m * p * h**4)
    h2, h3 = h * h, h**3

    def block(a, b, c, d):
        return np.stack([np.stack([a, b], -1), np.stack([c, d], -1)], -2)

    mm = block(S, h * Th, -m * p * h3 * Vh, S)
    mf = block(p * h2 * Uh, p * h3 * Vh, p * h * Th, p * h2 * Uh)
    fm = block(-m * h2 * Uh, -m * h3 * Vh, -m * h * Th, -m * h2 * Uh)
    return mm, mf, fm, mm


def _inverse2(A: NDArray) -> NDArray:
    det = A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]
    inv = np.empty_like(A)
    inv[..., 0, 0] = A[..., 1, 1] / det
    inv[..., 1, 1] = A[..., 0, 0] / det
    inv[..., 0, 1] = -A[..., 0, 1] / det
    inv[..., 1, 0] = -A[..., 1, 0] / det
    return inv


def _step_nodes(segments: Segments, s: NDArray, x: NDArray) -> NDArray:
    """Edges, query points and enough points in between for ``|κh| ≤ MAX_STEP_WAVENUMBER``."""
    kappa = np.max(np.abs(_quartic_wavenumber(segments, s)), axis=0) ** 0.25
    pieces = np.maximum(1, np.ceil(kappa * segments.lengths / MAX_STEP_WAVENUMBER).astype(int))
    inner = [np.linspace(a, b, n + 1)[1:-1] for a, b, n in zip(segments.edges[:-1], segments.edges[1:], pieces)]
    return np.unique(np.concatenate([segments.edges, x, *inner]))


def _left_load_sweep(segments: Segments, s: NDArray, x: NDArray) -> NDArray:
    """Fields for unit ``G1`` and unit ``N1`` (right end free): array ``(4 fields, 2 loads, Ns, Nx)``."""
    nodes = _step_nodes(segments, s, x)
    piece = segments.segment_index(0.5 * (nodes[:-1] + nodes[1:]))
    h = np.diff(nodes)
    K = segments.stiffness[None, :] + s[:, None] * segments.viscosity[None, :]
    p_segment = (s * s)[:, None] / K
    n = nodes.size
    Z = np.zeros((n, s.size, 2, 2), dtype=complex)
    L = np.empty((n - 1, s.size, 2, 2), dtype=complex)
    for i in range(n - 2, -1, -1):
        j = piece[i]
        mm, mf, fm, ff = _step_blocks(p_segment[:, j], segments.mass_per_length[j], -h[i])
        L[i] = _inverse2(mm + mf @ Z[i + 1])
        Z[i] = (fm + ff @ Z[i + 1]) @ L[i]
    motion = np.empty_like(Z)  # (a, θ) rows, load (G1, N1) columns
    motion[0] = _inverse2(Z[0])
    for i in range(n - 1):
        motion[i + 1] = L[i] @ motion[i]
    force = Z @ motion
    index = np.searchsorted(nodes, x)
    fields = np.stack([motion[index, :, 0, :], motion[index, :, 1, :], force[index, :, 0, :], force[index, :, 1, :]])
    # (4, Nx, Ns, 2 loads) -> (4, 2 loads, Ns, Nx)
    return np.transpose(fields, (0, 3, 2, 1))
