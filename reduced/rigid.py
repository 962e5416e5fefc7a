"""Two rigid cars joined by a Kelvin-Voigt coupler: closed form and small-damping series.

docs/formulas.md §A1–A2. The hammer car (mass m1, speed v1) strikes the anvil car (m2,
speed v2, usually 0) at ``t = 0``; ``x1``, ``x2`` are their displacements from the
positions at impact, ``x = x2 − x1`` the relative displacement (negative while the
coupler is compressed), ``m* = m1 m2/(m1 + m2)``, closing speed ``w = v1 − v2``::

    m* x'' + μ x' + c x = 0,   x(0) = 0,   x'(0) = −w
    tension T = c x + μ x',    coupler force P = −T   (compression positive)
    a1 = T/m1 = −P/m1,         a2 = −T/m2 = P/m2

For ``t < 0`` the cars approach at their speeds and ``P = 0`` (records may start
before the impact). Results are :class:`reduced.history.TwoMassHistory` objects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks
from reduced.couplers import CONTACT_KINDS
from reduced.history import TwoMassHistory


@dataclass(frozen=True)
class ImpactPair:
    """Two rigid cars: hammer (1) at ``hammer_speed`` strikes anvil (2). Masses kg, speeds m/s."""

    hammer_mass: float
    anvil_mass: float
    hammer_speed: float
    anvil_speed: float = 0.0

    def __post_init__(self) -> None:
        _checks.positive("hammer_mass", self.hammer_mass)
        _checks.positive("anvil_mass", self.anvil_mass)
        _checks.finite("hammer_speed", self.hammer_speed)
        _checks.finite("anvil_speed", self.anvil_speed)

    @classmethod
    def source_study(cls, hammer_speed: float = 2.2) -> ImpactPair:
        """The source study's test pair: 263,000 lb (119 t) hammer, 220,000 lb (100 t) anvil."""
        return cls(hammer_mass=119.0e3, anvil_mass=100.0e3, hammer_speed=hammer_speed)

    @property
    def total_mass(self) -> float:
        return self.hammer_mass + self.anvil_mass

    @property
    def reduced_mass(self) -> float:
        """``m* = m1 m2/(m1 + m2)`` (kg)."""
        return self.hammer_mass * self.anvil_mass / self.total_mass

    @property
    def closing_speed(self) -> float:
        """``w = v1 − v2`` (m/s)."""
        return self.hammer_speed - self.anvil_speed

    @property
    def centre_of_mass_speed(self) -> float:
        return (self.hammer_mass * self.hammer_speed + self.anvil_mass * self.anvil_speed) / self.total_mass

    @property
    def kinetic_energy(self) -> float:
        """``(m1 v1² + m2 v2²)/2`` (J)."""
        return 0.5 * (self.hammer_mass * self.hammer_speed**2 + self.anvil_mass * self.anvil_speed**2)

    @property
    def relative_kinetic_energy(self) -> float:
        """``m* w²/2`` (J): the energy a coupler can absorb."""
        return 0.5 * self.reduced_mass * self.closing_speed**2


def _with_pair(
    pair: ImpactPair,
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    xd: NDArray[np.float64],
    xdd: NDArray[np.float64],
    force: NDArray[np.float64],
    separation_time: float | None,
    model: str,
) -> TwoMassHistory:
    """Absolute motions from the relative motion and the centre of mass (no external force)."""
    m1, m2, mt = pair.hammer_mass, pair.anvil_mass, pair.total_mass
    vc = pair.centre_of_mass_speed
    return TwoMassHistory(
        time=t,
        relative_displacement=x,
        relative_velocity=xd,
        relative_acceleration=xdd,
        hammer_displacement=vc * t - (m2 / mt) * x,
        hammer_velocity=vc - (m2 / mt) * xd,
        hammer_acceleration=-(m2 / mt) * xdd,
        anvil_displacement=vc * t + (m1 / mt) * x,
        anvil_velocity=vc + (m1 / mt) * xd,
        anvil_acceleration=(m1 / mt) * xdd,
        coupler_force=force,
        separation_time=separation_time,
        model=model,
    )


def _check_coupler(stiffness: float, damping: float) -> tuple[float, float]:
    return _checks.positive("stiffness", stiffness), _checks.non_negative("damping", damping)


def _damped_kernels(
    alpha: float, omega0_sq: float, t: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``e^{αt} sin(βt)/β`` and ``e^{αt} cos(βt)`` with ``β² = ω0² − α²`` of either sign.

    No 0/0 near critical damping: the sine part is written ``t e^{αt} sinc(βt)``
    (underdamped) and ``t e^{(α+κ)t} (1 − e^{−2κt})/(2κt)`` with ``κ = √(α² − ω0²)``
    and ``α + κ = −ω0²/(κ − α)`` (overdamped; no cancellation, no overflow), which
    both tend to ``t e^{αt}`` as ``β → 0``.
    """
    s = omega0_sq - alpha * alpha
    if s > 0.0:
        beta = math.sqrt(s)
        e = np.exp(alpha * t)
        return e * t * np.sinc(beta * t / math.pi), e * np.cos(beta * t)
    if s == 0.0:
        e = np.exp(alpha * t)
        return t * e, e
    kappa = math.sqrt(-s)
    rate = -omega0_sq / (kappa - alpha)  # α + κ without cancellation (α ≤ 0)
    e = np.exp(rate * t)
    y = 2.0 * kappa * t
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.where(y > 0.0, -np.expm1(-y) / np.where(y > 0.0, y, 1.0), 1.0)
    return e * t * phi, e * 0.5 * (1.0 + np.exp(-y))


def _separation_time(reduced_mass: float, stiffness: float, damping: float) -> float:
    """First ``t > 0`` with ``P(t) = 0`` for the bilateral closed form.

    ``P ∝ e^{αt} [(c + μα) S(t) + μ C(t)]`` with ``S = sin(βt)/β``, ``C = cos(βt)``. With
    ``A = c + μα``: if ``A ≥ 0`` (underdamped only) ``βt_s = atan2(μβ, −A)``; if ``A < 0``
    ``t_s = (μ/|A|) g(q)`` with ``q = μβ/|A|`` and ``g = atan(q)/q`` (underdamped) or
    ``atanh(q)/q`` (overdamped, ``q = μκ/|A| < 1`` since ``A² − μ²κ² = c²``), ``g(0) = 1``.
    """
    c, mu, m = stiffness, damping, reduced_mass
    alpha = -mu / (2.0 * m)
    s = c / m - alpha * alpha
    a = c + mu * alpha
    if a >= 0.0:
        beta = math.sqrt(s)
        return math.atan2(mu * beta, -a) / beta
    scale = mu / (-a)
    if s > 0.0:
        q = mu * math.sqrt(s) / (-a)
        return scale * (math.atan(q) / q if q > 1e-8 else 1.0 - q * q / 3.0)
    if s < 0.0:
        q = mu * math.sqrt(-s) / (-a)
        return scale * (math.atanh(q) / q if q > 1e-8 else 1.0 + q * q / 3.0)
    return scale


def kelvin_voigt_impact(
    pair: ImpactPair,
    stiffness: float,
    damping: float,
    time: ArrayLike,
    contact: str = "bilateral",
) -> TwoMassHistory:
    """Closed-form two-mass impact through a Kelvin-Voigt coupler (docs/formulas.md §A1, corrected).

    ``m* x'' + μ x' + c x = 0``, ``x(0) = 0``, ``x'(0) = −w``; with ``α = −μ/(2m*)`` and
    ``β = √(c/m* − α²)`` (the printed source mixes up ``m*`` and ``1/m*`` here)::

        x  = −w e^{αt} sin(βt)/β
        x' = −w e^{αt} (α sin(βt)/β + cos(βt))
        P  = −(c x + μ x') = w e^{αt} ((c + μα) sin(βt)/β + μ cos(βt))

    for under-, critically and over-damped couplers alike (``β`` imaginary above
    critical: ``sin(βt)/β → sinh(κt)/κ``), evaluated without 0/0 at critical damping
    (:func:`_damped_kernels`). ``contact='compression_only'`` (free to roll): the cars
    separate at the first ``t_s > 0`` with ``P = 0`` (closed form in
    :func:`_separation_time`) and then move at constant speeds; ``'bilateral'``
    (coupled): the formula holds for all ``t ≥ 0``. A compression-only pair that does
    not close (``w ≤ 0``) never touches. ``stiffness`` c (N/m), ``damping`` μ (N·s/m).
    Checked against ``solve_ivp`` across damping ratios (``tests/reduced/test_rigid.py``).
    """
    c, mu = _check_coupler(stiffness, damping)
    _checks.choice("contact", contact, CONTACT_KINDS)
    t = _checks.time_grid("time", time, min_length=1)
    m = pair.reduced_mass
    w = pair.closing_speed
    alpha = -mu / (2.0 * m)
    tp = np.maximum(t, 0.0)
    es, ec = _damped_kernels(alpha, c / m, tp)
    x = -w * es
    xd = -w * (alpha * es + ec)
    force = -(c * x + mu * xd)
    separation = None
    if contact == "compression_only" and w <= 0.0:
        # the cars do not close: no contact, free motion
        x, xd, force = -w * tp, np.full_like(tp, -w), np.zeros_like(tp)
    elif contact == "compression_only":
        ts = _separation_time(m, c, mu)
        separation = ts
        es_s, ec_s = _damped_kernels(alpha, c / m, np.array([ts]))
        xs = float(-w * es_s[0])
        xds = float(-w * (alpha * es_s[0] + ec_s[0]))
        after = tp > ts
        x = np.where(after, xs + xds * (tp - ts), x)
        xd = np.where(after, xds, xd)
        force = np.where(after, 0.0, force)
    before = t < 0.0
    x = np.where(before, -w * t, x)
    xd = np.where(before, -w, xd)
    force = np.where(before, 0.0, force)
    xdd = force / m  # m* x'' = −(c x + μ x') = P
    return _with_pair(pair, t, x, xd, xdd, force, separation, f"kelvin_voigt_closed_form[{contact}]")


def small_damping_parameter(pair: ImpactPair, stiffness: float, damping: float) -> float:
    """``ε = μ/√(c m*)`` (twice the damping ratio) of docs/formulas.md §A2."""
    c, mu = _check_coupler(stiffness, damping)
    return mu / math.sqrt(c * pair.reduced_mass)


def perturbation_terms(tau: ArrayLike, order: int = 3) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Terms ``X_k(τ)`` and ``X_k'(τ)``, k = 0…order ≤ 3, of ``X = Σ ε^k X_k`` (docs/formulas.md §A2).

    ``X'' + ε X' + X = 0``, ``X(0) = 0``, ``X'(0) = −1`` (``x = V X`` with
    ``V = w √(m*/c)``, ``τ = t √(c/m*)``). Each order is a forced undamped oscillator,
    ``X_k'' + X_k = −X_{k−1}'``, ``X_k(0) = X_k'(0) = 0`` for k ≥ 1, whose secular
    solutions are::

        X0 = −sin τ
        X1 = (τ/2) sin τ
        X2 = (τ cos τ − sin τ − τ² sin τ)/8
        X3 = τ³ sin τ/48 + τ sin τ/16 − τ² cos τ/16

    (the Taylor expansion of the exact ``−e^{−ετ/2} sin(Ωτ)/Ω``, ``Ω = √(1 − ε²/4)``;
    tests/reduced/test_rigid.py). Returns arrays of shape ``(order + 1, len(τ))``.
    """
    if order not in (0, 1, 2, 3):
        raise ValueError(f"order must be 0, 1, 2 or 3, got {order!r}")
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    if not np.all(np.isfinite(tau)):
        raise ValueError("tau contains non-finite values")
    s, c = np.sin(tau), np.cos(tau)
    t2, t3 = tau**2, tau**3
    x = np.array(
        [
            -s,
            0.5 * tau * s,
            (tau * c - s - t2 * s) / 8.0,
            t3 * s / 48.0 + tau * s / 16.0 - t2 * c / 16.0,
        ]
    )
    xd = np.array(
        [
            -c,
            0.5 * (s + tau * c),
            (-3.0 * tau * s - t2 * c) / 8.0,
            s / 16.0 - tau * c / 16.0 + t2 * s / 8.0 + t3 * c / 48.0,
        ]
    )
    return x[: order + 1], xd[: order + 1]


def kelvin_voigt_perturbation(
    pair: ImpactPair,
    stiffness: float,
    damping: float,
    time: ArrayLike,
    order: int = 3,
) -> TwoMassHistory:
    """Small-damping series of the bilateral Kelvin-Voigt impact to ``order`` (docs/formulas.md §A2).

    ``x = V Σ_{k≤order} ε^k X_k(τ)`` with ``τ = t√(c/m*)``, ``ε = μ/√(c m*)``,
    ``V = w√(m*/c)`` (:func:`perturbation_terms`); the acceleration and the force are
    the consistently truncated series ``X'' = Σ ε^k X_k''``, ``X_k'' = −X_k − X_{k−1}'``,
    ``P = m* x''``. Secular terms (``τ^k`` growth) limit it to ``ετ ≪ 1``; at fixed τ
    its error falls like ``ε^{order+1}``.
    """
    c, mu = _check_coupler(stiffness, damping)
    t = _checks.time_grid("time", time, min_length=1)
    if np.any(t < 0.0):
        raise ValueError("time must be >= 0 for the perturbation series (it starts at impact)")
    m = pair.reduced_mass
    eps = mu / math.sqrt(c * m)
    omega = math.sqrt(c / m)
    v_scale = pair.closing_speed / omega
    xs, xds = perturbation_terms(omega * t, order)
    powers = eps ** np.arange(order + 1)
    xdds = -xs.copy()
    xdds[1:] -= xds[:-1]
    x = v_scale * (powers @ xs)
    xd = v_scale * omega * (powers @ xds)
    xdd = v_scale * omega**2 * (powers @ xdds)
    force = m * xdd
    return _with_pair(pair, t, x, xd, xdd, force, None, f"kelvin_voigt_perturbation[order={order}]")


__all__ = [
    "ImpactPair",
    "kelvin_voigt_impact",
    "kelvin_voigt_perturbation",
    "perturbation_terms",
    "small_damping_parameter",
]
