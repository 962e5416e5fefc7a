"""Quasi-rigid Euler–Bernoulli beam with even profiles: rigid motion plus creep bending.

Beam on ``x ∈ [−l, l]`` (docs/design.md §2): ``G = EI w_xx + cI w_xxt`` (Voigt; any Prony
creep kernel), ``N = G_x``, ``N_x + m w_tt = 0``; end shears ``N(∓l) = N1, N2`` and
moments ``G(∓l) = G1, G2``; m, EI, cI even in x.

Leading order, rigid: ``M a_v = N1 − N2``, ``J Ω = G2 − G1 − l(N1 + N2)``,
``a₀(x) = a_v + x Ω``. The moment balancing that rigid inertia, with
``S_p(x) = ∫_{−l}^{x} s^p m ds``, ``Q₀ = x S₀ − S₁``, ``Q₁ = x S₁ − S₂``
(derived from ``N₀ = N1 − a_v S₀ − Ω S₁``, ``G₀ = G1 + ∫_{−l}^{x} N₀``):

    G₀(x) = G1 + N1 (x + l) − a_v Q₀(x) − Ω Q₁(x)
          = N1 [x + l − Q₀/M + l Q₁/J] + N2 [Q₀/M + l Q₁/J] + G1 [1 + Q₁/J] − G2 Q₁/J,

which meets ``G₀(+l) = G2`` identically. (The source's vertical and rotational forms
are its special cases for symmetric and antisymmetric loads.) Next order: curvature
``EI κ + cI κ̇ = G₀``, integrated twice, with the rigid modes removed in the mass
inner product (``∫ m w₁ = ∫ m x w₁ = 0``):

    w₁(x, t) = ∫ [(x − s)₊ − A(s)/M − x B(s)/J] κ(s, t) ds,   a = a₀ + ∂²w₁/∂t².

Homogeneous low-frequency constants it reproduces (``q⁴ = λ²/(1 − iλβ)``, tests):
vertical, centre, ``a_v*``: ``1 + 3q⁴/40``; rotation ``α*``: ``1 + 11q⁴/840`` by end shears
and ``1 + 13q⁴/280`` by end moments (3/40 for rotation was a misprint). Verified against
the exact beam transfer functions (error ∝ λ⁴, tests/reduced/quasi_rigid/test_frequency.py).
"""

from __future__ import annotations

from typing import Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .body import HarmonicResponse, LoadLike, QuasiRigidBody, TransientResponse
from .coupled import QuasiRigidStepper
from .creep import VOIGT, CreepKernel
from .profiles import GAUSS_POINTS, BodyQuadrature, ProfileLike


class QuasiRigidBeam(QuasiRigidBody):
    """Two-term quasi-rigid model of a beam with even profiles (SI units).

    Parameters: ``half_length`` l (m); ``mass_per_length`` m(x) (kg/m);
    ``bending_stiffness`` EI(x) (N·m²); ``bending_viscosity`` cI(x) (N·m²·s); ``jumps``,
    ``creep`` and the quadrature settings as for :class:`~.rod.QuasiRigidRod`.
    Raises ``ValueError`` if a profile is not even in x.
    """

    load_names = ("N1", "N2", "G1", "G2")
    order = 2

    def __init__(
        self,
        half_length: float,
        mass_per_length: ProfileLike,
        bending_stiffness: ProfileLike,
        bending_viscosity: ProfileLike = 0.0,
        *,
        jumps: Iterable[float] = (),
        creep: CreepKernel = VOIGT,
        gauss_points: int = GAUSS_POINTS,
        panels_per_segment: int = 4,
        max_tau_groups: int = 24,
    ) -> None:
        jumps = list(jumps)
        jumps = sorted({*jumps, *(-j for j in jumps)})  # an even body jumps symmetrically
        quadrature = BodyQuadrature(half_length, mass_per_length, bending_stiffness, bending_viscosity, jumps,
                                    gauss_points=gauss_points, panels_per_segment=panels_per_segment)
        if not quadrature.is_even():
            raise ValueError("the quasi-rigid beam needs even profiles m(x), EI(x), cI(x)")
        super().__init__(quadrature, creep, max_tau_groups)

    @property
    def moment_of_inertia(self) -> float:
        """``J = ∫ x² m dx`` (kg·m²) about the centre."""
        return self.quadrature.second_moment

    def _shapes(self, s: NDArray[np.float64], S: NDArray[np.float64]) -> NDArray[np.float64]:
        q = self.quadrature
        M, J, l = q.total_mass, q.second_moment, q.half_length
        Q0 = s * S[..., 0] - S[..., 1]
        Q1 = s * S[..., 1] - S[..., 2]
        return np.stack([s + l - Q0 / M + l * Q1 / J, Q0 / M + l * Q1 / J, 1.0 + Q1 / J, -Q1 / J], axis=-1)

    def rigid_modes(self, x: ArrayLike, derivative: int = 0) -> NDArray[np.float64]:
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if derivative == 1:
            return np.stack([np.zeros_like(x), np.ones_like(x)], axis=-1)
        return np.stack([np.ones_like(x), x], axis=-1)

    @property
    def rigid_gain(self) -> NDArray[np.float64]:
        M, J, l = self.mass, self.moment_of_inertia, self.half_length
        return np.array([[1.0 / M, -1.0 / M, 0.0, 0.0], [-l / J, -l / J, -1.0 / J, 1.0 / J]])

    def harmonic(self, omega: ArrayLike, x: ArrayLike, N1: complex = 0.0, N2: complex = 0.0,
                 G1: complex = 0.0, G2: complex = 0.0, *, rotation: bool = False) -> HarmonicResponse:
        """Two-term response at ``e^{−iωt}`` to end shears (N) and moments (N·m) at positions x (m).

        ``rotation=True`` returns the section rotation ``∂w/∂x`` instead of the deflection
        (its acceleration in rad/s²; at x = 0 divided by Ω it is the ``α*`` of docs/formulas.md §X).
        """
        return self._harmonic(omega, x, {"N1": N1, "N2": N2, "G1": G1, "G2": G2}, int(rotation))

    def transient(
        self,
        t: ArrayLike,
        x: ArrayLike,
        N1: LoadLike = None,
        N2: LoadLike = None,
        G1: LoadLike = None,
        G2: LoadLike = None,
        *,
        initial_velocity: float = 0.0,
        initial_angular_velocity: float = 0.0,
        load_time_scale: float | None = None,
        rotation: bool = False,
    ) -> TransientResponse:
        """Transverse acceleration, velocity and deflection at x from end-load histories (see the rod).

        ``rotation=True``: the section rotation ``∂w/∂x`` and its rates instead.
        """
        return self._transient(t, x, {"N1": N1, "N2": N2, "G1": G1, "G2": G2},
                               (initial_velocity, initial_angular_velocity), load_time_scale, int(rotation))

    def stepper(self, probes: ArrayLike = (), **kwargs: object) -> QuasiRigidStepper:
        """A :class:`~.coupled.QuasiRigidStepper` for coupled simulation (ends first, then ``probes``)."""
        return QuasiRigidStepper(self, probes, **kwargs)
