"""Inverse estimators: coupler forces from measured accelerations.

* :func:`rigid_coupler_force` — rigid car, ``P = ±M a``.
* :class:`CoupledImpactInversion` — quasi-rigid car body with accelerometers at both
  ends (docs/formulas.md §F): ``F1'' = k1 (a2 − a1) + k2 a1''`` with ``k1``, ``k2`` from the
  profiles (uniform or variable ``m(x)``, ``EA(x)``) or fitted by least squares on
  data; the force is recovered by integration with stated initial conditions.

Conventions (docs/design.md §2): the car body occupies ``x ∈ [−l, l]``; ``F1 = F(−l)``,
``F2 = F(+l)`` are the internal axial forces at its ends, **tension positive**, so that
``M a = F2 − F1``; ``a1 = a(−l)``, ``a2 = a(+l)`` (m/s²). The coupler at the −l end
pushes with the compression-positive coupler force ``P1 = −F1``; the coupler at the
+l end with ``P2 = F2``.

Derivation of the variable-profile inversion (re-derived; the source printed it for
variable density only). To leading order in ``ε`` the body moves rigidly and carries
the inertia-balanced force ``F0(x) = F1 + (F2 − F1) μ(x)/M``, ``μ(x) = ∫_{−l}^{x} m``; the
next term of the displacement is the static deformation under ``F0`` (docs/formulas.md §X:
"end deflection relative to the centre of mass = the static deformation under the
inertia-balanced force"). The end-to-end elongation is therefore::

    u(l) − u(−l) = ∫_{−l}^{l} F0/EA dx = C F1 + B (F2 − F1),
    C = ∫_{−l}^{l} dx/EA(x),   B = (1/M) ∫_{−l}^{l} μ(x)/EA(x) dx

and twice differentiated ``a2 − a1 = C F1'' + B (F2 − F1)''``. With the rigid-body law
``(F2 − F1)'' = M a0'' ≈ M a1''`` (the difference is one order higher in ε)::

    F1'' = k1 (a2 − a1) + k2 a1'',   k1 = 1/C,   k2 = −B M/C = −(∫ μ/EA dx)/(∫ dx/EA)
    F2'' = k1 (a2 − a1) + (k2 + M) a1''

Uniform EA: ``k1 = EA/2l``, ``k2 = −(1/2l) ∫_{−l}^{l} ∫_{−l}^{x} m dx₁ dx`` (the source's
variable-density form); homogeneous: ``k2 = −M/2`` (the source's uniform form). Even
profiles give ``k2 = −M/2`` whatever their shape (``μ(x) + μ(−x) = M``). Checked against an
independent lumped rod of varying profiles (``tests/reduced/test_inverse.py``): the error falls like
λ²; a few per cent for yard-impact pulses (λ ≈ 0.3), where the O(ε) truncation, not noise, limits it.

Time-harmonic form (``F'' = −ω² F``): ``F1 = −k1 (a2 − a1)/ω² + k2 a1``. The source's
``F1,2 = (EA/(2lω²))(a2 − a1) ∓ (M/2) a1`` has the wrong sign on the first term for
the ``e^{−iωt}`` convention with ``a = −ω² u``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks
from reduced.signal_tools import SavitzkyGolay, SpectralLowPass, integrate_twice

COUPLER_ENDS: tuple[str, ...] = ("left", "right")
FIT_FORMS: tuple[str, ...] = ("integrated", "differentiated")


def rigid_coupler_force(mass: float, acceleration: ArrayLike, coupler_at: str = "left") -> NDArray[np.float64]:
    """Rigid car: ``P = M a`` (coupler at its −l end, ``left``) or ``P = −M a`` (at +l, ``right``).

    ``P`` compression-positive (N), ``mass`` M (kg), ``acceleration`` (m/s²). The struck car of a yard
    impact has the coupler at its left end.
    """
    m = _checks.positive("mass", mass)
    a = _checks.record("acceleration", acceleration, min_length=1)
    _checks.choice("coupler_at", coupler_at, COUPLER_ENDS)
    return m * a if coupler_at == "left" else -m * a


def _profile_value(name: str, profile: Callable[[float], float], x: float) -> float:
    value = float(np.asarray(profile(x), dtype=float))
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name}({x:.6g}) = {value!r}: a profile must be finite and > 0 on [-l, l]")
    return value


@dataclass(frozen=True)
class CoupledImpactInversion:
    """``F1'' = k1 (a2 − a1) + k2 a1''`` (docs/formulas.md §F; derivation in the module docstring).

    ``k1`` (N/m), ``k2`` (kg), ``total_mass`` M (kg, for the +l end force; None if
    unknown), ``fit_rms`` (N) the residual of a least-squares fit (None otherwise).
    Construct with :meth:`uniform`, :meth:`from_profiles` or :meth:`fit`.
    """

    k1: float
    k2: float
    total_mass: float | None = None
    fit_rms: float | None = None

    def __post_init__(self) -> None:
        _checks.finite("k1", self.k1)
        _checks.finite("k2", self.k2)
        if self.total_mass is not None:
            _checks.positive("total_mass", self.total_mass)

    @classmethod
    def uniform(cls, total_mass: float, axial_stiffness: float, half_length: float) -> CoupledImpactInversion:
        """Homogeneous rod: ``k1 = EA/(2l)``, ``k2 = −M/2`` (docs/formulas.md §F, uniform form)."""
        m = _checks.positive("total_mass", total_mass)
        ea = _checks.positive("axial_stiffness", axial_stiffness)
        l = _checks.positive("half_length", half_length)
        return cls(k1=ea / (2.0 * l), k2=-0.5 * m, total_mass=m)

    @classmethod
    def from_profiles(
        cls,
        mass_per_length: Callable[[float], float],
        axial_stiffness: Callable[[float], float],
        half_length: float,
        *,
        breakpoints: tuple[float, ...] = (),
        span: tuple[float, float] | None = None,
    ) -> CoupledImpactInversion:
        """Variable ``m(x)`` (kg/m) and ``EA(x)`` (N) on ``[−l, l]``: ``k1 = 1/C``, ``k2 = −(∫ μ/EA)/C``.

        ``C = ∫ dx/EA``, ``μ(x) = ∫_{−l}^{x} m``, ``M = μ(l)``, by ``scipy.integrate.quad`` with
        ``breakpoints`` (jumps of the profiles) as ``points``.

        ``span = (x1, x2)``: accelerometers at ``x1 < x2`` instead of the ends; both integrals then run
        over ``[x1, x2]`` (``μ`` still counts from ``−l``); tests/models/test_inverse.py.
        """
        from scipy.integrate import quad  # scipy.integrate costs ~0.3 s to import: only a flexible car's inversion needs it

        l = _checks.positive("half_length", half_length)
        if not callable(mass_per_length) or not callable(axial_stiffness):
            raise ValueError("mass_per_length and axial_stiffness must be callables of x (m)")
        pts = tuple(sorted(_checks.finite("breakpoint", b) for b in breakpoints))
        if any(not -l < b < l for b in pts):
            raise ValueError(f"breakpoints must lie inside (-l, l) = ({-l!r}, {l!r}), got {pts!r}")
        for x in np.concatenate([np.linspace(-l, l, 65), np.asarray(pts, dtype=float)]):
            _profile_value("mass_per_length", mass_per_length, float(x))
            _profile_value("axial_stiffness", axial_stiffness, float(x))

        def m(x: float) -> float:
            return float(np.asarray(mass_per_length(x), dtype=float))

        def flex(x: float) -> float:
            return 1.0 / float(np.asarray(axial_stiffness(x), dtype=float))

        def points_in(a: float, b: float) -> list[float] | None:
            inside = [p for p in pts if a < p < b]
            return inside or None

        def mu(x: float) -> float:
            if x <= -l:
                return 0.0
            return quad(m, -l, x, points=points_in(-l, x), limit=200, epsabs=0.0, epsrel=1e-12)[0]

        x1, x2 = (-l, l) if span is None else (_checks.finite("span[0]", span[0]), _checks.finite("span[1]", span[1]))
        if not -l <= x1 < x2 <= l:
            raise ValueError(f"span must satisfy -l <= x1 < x2 <= l with l = {l!r}, got {span!r}")
        total = mu(l)
        compliance = quad(flex, x1, x2, points=points_in(x1, x2), limit=200, epsabs=0.0, epsrel=1e-12)[0]
        weighted = quad(lambda x: mu(x) * flex(x), x1, x2, points=points_in(x1, x2), limit=200, epsabs=0.0, epsrel=1e-11)[0]
        return cls(k1=1.0 / compliance, k2=-weighted / compliance, total_mass=total)

    @classmethod
    def fit(
        cls,
        time: ArrayLike,
        left_acceleration: ArrayLike,
        right_acceleration: ArrayLike,
        end_force: ArrayLike,
        *,
        form: str = "integrated",
        differentiator: SavitzkyGolay | SpectralLowPass | None = None,
        baseline_samples: int = 0,
        total_mass: float | None = None,
    ) -> CoupledImpactInversion:
        """Least-squares ``k1``, ``k2`` from records of ``a1``, ``a2`` and the end force ``F1``.

        ``form='integrated'``: fit ``F1 − F1(0) = k1 ∬(a2 − a1) + k2 a1`` (:meth:`end_force`).
        ``form='differentiated'`` (the source's way, noisier): fit ``F1'' = k1 (a2 − a1) + k2 a1''``, every
        term through ``differentiator`` (default ``SavitzkyGolay(31, 4)``) so the filter cancels. ``F1`` is
        tension positive (N): pass ``−P1`` for a coupler record. Uniform ``time`` (s).
        """
        _checks.choice("form", form, FIT_FORMS)
        t, a1, a2 = _records(time, left_acceleration, right_acceleration)
        f = _checks.record("end_force", end_force)
        _checks.same_length(time=t, end_force=f)
        dt = float(t[1] - t[0])
        if form == "integrated":
            d, a1c = _integrated_terms(a1, a2, dt, baseline_samples)
            design = np.column_stack([d, a1c])
            target = f - f[0]
        else:
            diff = SavitzkyGolay() if differentiator is None else differentiator
            # the same filter on every term, so that it cancels from the fitted relation
            design = np.column_stack([diff.derivative(a2 - a1, dt, 0), diff.derivative(a1, dt, 2)])
            target = diff.derivative(f, dt, 2)
        scale = np.max(np.abs(design), axis=0)
        if np.any(scale == 0.0):
            raise ValueError("the acceleration records carry no signal to fit (a term is identically zero)")
        coef, *_ = np.linalg.lstsq(design / scale, target, rcond=None)
        k1, k2 = coef / scale
        rms = float(np.sqrt(np.mean((design @ (coef / scale) - target) ** 2)))
        return cls(k1=float(k1), k2=float(k2), total_mass=total_mass, fit_rms=rms)

    def second_derivative(
        self, left_acceleration: ArrayLike, right_acceleration: ArrayLike, left_acceleration_second_derivative: ArrayLike
    ) -> NDArray[np.float64]:
        """``F1'' = k1 (a2 − a1) + k2 a1''`` (N/s²) from given ``a1``, ``a2`` and ``a1''`` (m/s⁴)."""
        a1 = _checks.record("left_acceleration", left_acceleration, min_length=1)
        a2 = _checks.record("right_acceleration", right_acceleration, min_length=1)
        j = _checks.record("left_acceleration_second_derivative", left_acceleration_second_derivative, min_length=1)
        _checks.same_length(left_acceleration=a1, right_acceleration=a2, left_acceleration_second_derivative=j)
        return self.k1 * (a2 - a1) + self.k2 * j

    def end_force(
        self,
        time: ArrayLike,
        left_acceleration: ArrayLike,
        right_acceleration: ArrayLike,
        *,
        baseline_samples: int = 0,
    ) -> NDArray[np.float64]:
        """``F1(t)`` (N, tension positive) by integrating ``F1''`` twice.

        The record starts at rest before the impact (``F1``, ``a1``, ``a2 − a1`` and their first
        derivatives vanish at t = 0), so exactly ``F1(t) = k1 ∬₀ᵗ (a2 − a1) + k2 a1(t)``: no differentiation.
        ``baseline_samples = n > 0`` subtracts each record's mean over its first n samples as a sensor
        offset; an offset ``b`` left in ``a2 − a1`` grows as ``k1 b t²/2``, and so does the noise of a short
        baseline: use no baseline or a long pre-trigger. Uniform ``time`` (s).
        """
        return self._left_force(time, left_acceleration, right_acceleration, baseline_samples)[0]

    def _left_force(
        self, time: ArrayLike, left: ArrayLike, right: ArrayLike, baseline_samples: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``F1`` and the baseline-corrected ``a1``."""
        t, a1, a2 = _records(time, left, right)
        d, a1c = _integrated_terms(a1, a2, float(t[1] - t[0]), baseline_samples)
        return self.k1 * d + self.k2 * a1c, a1c

    def end_forces(
        self,
        time: ArrayLike,
        left_acceleration: ArrayLike,
        right_acceleration: ArrayLike,
        *,
        baseline_samples: int = 0,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(F1, F2)`` (N, tension positive); ``F2 = F1 + M a1`` from ``F2'' − F1'' = M a1''``."""
        if self.total_mass is None:
            raise ValueError("total_mass is needed for the +l end force; construct with it")
        f1, a1c = self._left_force(time, left_acceleration, right_acceleration, baseline_samples)
        return f1, f1 + self.total_mass * a1c

    def coupler_force(
        self,
        time: ArrayLike,
        left_acceleration: ArrayLike,
        right_acceleration: ArrayLike,
        *,
        baseline_samples: int = 0,
    ) -> NDArray[np.float64]:
        """Compression-positive force of the coupler at the −l end, ``P1 = −F1`` (N)."""
        return -self.end_force(time, left_acceleration, right_acceleration, baseline_samples=baseline_samples)

    def end_force_harmonic(self, omega: ArrayLike, left_acceleration: ArrayLike, right_acceleration: ArrayLike) -> NDArray[np.complex128]:
        """Time-harmonic amplitude ``F1 = −k1 (a2 − a1)/ω² + k2 a1`` (``ω`` rad/s > 0, complex amplitudes)."""
        w = np.asarray(omega, dtype=float)
        if not np.all(np.isfinite(w)) or np.any(w <= 0.0):
            raise ValueError("omega must be finite and > 0")
        a1 = np.asarray(left_acceleration, dtype=complex)
        a2 = np.asarray(right_acceleration, dtype=complex)
        if a1.shape != a2.shape or np.broadcast(w, a1).shape != a1.shape:
            raise ValueError(f"shapes do not match: omega {w.shape}, a1 {a1.shape}, a2 {a2.shape}")
        if not (np.all(np.isfinite(a1)) and np.all(np.isfinite(a2))):
            raise ValueError("accelerations contain non-finite values")
        return -self.k1 * (a2 - a1) / w**2 + self.k2 * a1


def _records(
    time: ArrayLike, left: ArrayLike, right: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    t = _checks.time_grid("time", time, uniform=True)
    a1 = _checks.record("left_acceleration", left)
    a2 = _checks.record("right_acceleration", right)
    _checks.same_length(time=t, left_acceleration=a1, right_acceleration=a2)
    return t, a1, a2


def _integrated_terms(
    a1: NDArray[np.float64], a2: NDArray[np.float64], dt: float, baseline_samples: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``∬(a2 − a1)`` and ``a1``, each record less its pre-impact level (0 when ``baseline_samples = 0``)."""
    n = int(baseline_samples)
    if n != baseline_samples or not 0 <= n <= a1.size:
        raise ValueError(f"baseline_samples must be an integer in [0, {a1.size}], got {baseline_samples!r}")
    a1c, a2c = (a - (float(a[:n].mean()) if n > 0 else 0.0) for a in (a1, a2))
    return integrate_twice(a2c - a1c, dt), a1c


__all__ = ["COUPLER_ENDS", "FIT_FORMS", "CoupledImpactInversion", "rigid_coupler_force"]
