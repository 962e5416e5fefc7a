"""Quasi-rigid rod: rigid-body motion plus the creep deformation under inertia-balanced load.

Rod on ``x ∈ [−l, l]`` (docs/design.md §2): ``F = EA u_x + cA u_xt`` (Voigt; any Prony creep
kernel, :mod:`.creep`), ``F_x = m u_tt``, internal end forces ``F(−l) = F1``,
``F(+l) = F2`` (tension positive).

Leading order: ``M a₀ = F2 − F1`` and the force that balances that rigid inertia,

    F₀(x, t) = F1 + (F2 − F1) S₀(x)/M,      S₀(x) = ∫_{−l}^{x} m dx.

Next order: the creep strain of F₀, ``EA e + cA ė = F₀`` (first-order lag, time constant
``cA/EA`` varying along x), integrated from the centre and shifted so that the
correction carries no momentum (``∫ m u₁ dx = 0``):

    u₁(x, t) = ∫_{−l}^{l} [S₀(s)/M − H(s − x)] e(s, t) ds,
    a(x, t)  = (F2 − F1)/M + ∂²u₁/∂t²(x, t).

Frequency domain (``e^{−iωt}``): ``e = F₀/(EA − iω cA)`` and
``a(x, ω) = (F2 − F1)/M − ω² u₁(x, ω)``. Closed forms it reproduces (tests):

* homogeneous, centre, load F2: ``M a/F2 = 1 + q²/6``, ``q² = λ²/(1 − iλβ)`` — the first
  two terms of the exact ``q/sin q``;
* homogeneous elastic ends: ``M a(−l) = F2 − F1 − (m l²/6EA)(8F1'' + 4F2'')``,
  ``M a(+l) = F2 − F1 + (m l²/6EA)(4F1'' + 8F2'')`` (printed 7/11 and 5/1 were wrong);
* two-value density (m₁ for |x| > l/2, m₂ inside, r = m₂/m₁, λ with the mean mass),
  centre, load at one end: ``a* = 1 + (r² + 6r + 1) λ²/(12 (1 + r)² (1 − iλβ))`` (printed
  numerator 7 + r² was wrong);
* two-value viscosity (β₁ outside, β₂ inside): ``a* = 1 + (λ²/12)(1/(1 − iλβ₁) + 1/(1 − iλβ₂))``
  (printed weights 7/48, 1/48 were wrong).

Verified: the error against the exact transfer-matrix solution falls like λ⁴ for
homogeneous and two-segment bodies (tests/reduced/quasi_rigid/test_frequency.py); the time
response against the exact transient (tests/reduced/quasi_rigid/test_time.py).
"""

from __future__ import annotations

from typing import Iterable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .body import HarmonicResponse, LoadLike, QuasiRigidBody, TransientResponse
from .coupled import QuasiRigidStepper
from .creep import VOIGT, CreepKernel
from .profiles import GAUSS_POINTS, BodyQuadrature, ProfileLike


class QuasiRigidRod(QuasiRigidBody):
    """Two-term quasi-rigid model of a rod with arbitrary profiles (SI units).

    Parameters: ``half_length`` l (m); ``mass_per_length`` m(x) (kg/m);
    ``axial_stiffness`` EA(x) (N); ``axial_viscosity`` cA(x) (N·s; 0 elastic, ∞ rigid);
    profiles are numbers or callables of x ∈ [−l, l]; ``jumps`` are positions where a
    profile jumps (profile objects' ``jumps``/``kinks`` attributes are used too);
    ``creep`` the kernel (default Voigt). The profile integrals are computed here,
    once (Gauss–Legendre, ``gauss_points`` per panel, ``panels_per_segment``).
    """

    load_names = ("F1", "F2")
    order = 1

    def __init__(
        self,
        half_length: float,
        mass_per_length: ProfileLike,
        axial_stiffness: ProfileLike,
        axial_viscosity: ProfileLike = 0.0,
        *,
        jumps: Iterable[float] = (),
        creep: CreepKernel = VOIGT,
        gauss_points: int = GAUSS_POINTS,
        panels_per_segment: int = 4,
        max_tau_groups: int = 24,
    ) -> None:
        quadrature = BodyQuadrature(half_length, mass_per_length, axial_stiffness, axial_viscosity, jumps,
                                    gauss_points=gauss_points, panels_per_segment=panels_per_segment)
        super().__init__(quadrature, creep, max_tau_groups)

    def _shapes(self, s: NDArray[np.float64], S: NDArray[np.float64]) -> NDArray[np.float64]:
        phi = np.empty((*s.shape, 2))
        np.divide(S[..., 0], self.quadrature.total_mass, out=phi[..., 1])  # S₀/M
        np.subtract(1.0, phi[..., 1], out=phi[..., 0])
        return phi

    def rigid_modes(self, x: ArrayLike, derivative: int = 0) -> NDArray[np.float64]:
        return np.full((np.size(x), 1), 1.0 if derivative == 0 else 0.0)

    @property
    def rigid_gain(self) -> NDArray[np.float64]:
        M = self.mass
        return np.array([[-1.0 / M, 1.0 / M]])

    def harmonic(self, omega: ArrayLike, x: ArrayLike, F1: complex = 0.0, F2: complex = 0.0) -> HarmonicResponse:
        """Two-term response at ``e^{−iωt}`` to end-force amplitudes F1, F2 (N) at positions x (m)."""
        return self._harmonic(omega, x, {"F1": F1, "F2": F2})

    def complex_mass(self, omega: ArrayLike, x: ArrayLike, end: str = "F2") -> NDArray[np.complex128]:
        """Frequency-dependent complex mass ``M*(ω, x) = F/a(x)`` for a unit force at one end (kg).

        ``end = "F2"`` (pull at +l) gives ``M/(1 + q²/6)`` at the centre of a homogeneous rod;
        ``"F1"`` uses ``−F1/a`` so that both are ``M`` for a rigid body.
        """
        if end not in self.load_names:
            raise ValueError(f"end must be one of {self.load_names}")
        response = self.harmonic(omega, x, **{end: 1.0})
        sign = 1.0 if end == "F2" else -1.0
        return sign / response.acceleration

    def transient(
        self,
        t: ArrayLike,
        x: ArrayLike,
        F1: LoadLike = None,
        F2: LoadLike = None,
        *,
        initial_velocity: float = 0.0,
        load_time_scale: float | None = None,
    ) -> TransientResponse:
        """Acceleration, velocity and displacement at x from end-force histories on a uniform grid t.

        ``F1``/``F2``: arrays of samples (N), callables of t, :class:`~.body.LoadHistory`
        (with analytic derivatives) or None. ``load_time_scale`` (s) sets ε; by default
        ``π √(∫ΣF²/∫ΣḞ²)`` (the pulse length of a half-sine).
        """
        return self._transient(t, x, {"F1": F1, "F2": F2}, initial_velocity, load_time_scale)

    def stepper(self, probes: ArrayLike = (), **kwargs: object) -> QuasiRigidStepper:
        """A :class:`~.coupled.QuasiRigidStepper` for coupled simulation (ends first, then ``probes``)."""
        return QuasiRigidStepper(self, probes, **kwargs)
