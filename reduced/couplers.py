"""Coupler force laws as small frozen value objects, and the contact that wraps them.

Sign conventions (DESIGN.md §2, §8)
-----------------------------------
The coupler joins the hammer car (1, moving at ``v``) to the anvil car (2). Its
**closure** is ``δ = x1 − x2`` (m; positive when the coupler is compressed, i.e.
``δ = −x`` with the source's relative displacement ``x = x2 − x1``), its closure
rate ``δ̇`` (m/s). Every law returns the **coupler force** ``P`` (N) **positive in
compression** (buff); the force on the hammer is ``−P``, on the anvil ``+P``.

Interface of a law (:class:`CouplerLaw`)
----------------------------------------
A law is a frozen dataclass with

* ``state_size`` internal state variables (0 for memoryless laws; the draft gear
  carries its gear compression ``x_g``), ``initial_state()``;
* ``force(δ, δ̇, s)`` — the engaged law force ``P`` (may be negative = tension);
* ``state_rate(δ, δ̇, s, P)`` — ``ṡ`` given the force ``P`` actually transmitted
  (so an open contact, ``P = 0``, lets the gear relax);
* ``tangent(δ, δ̇, s, P)`` — the partial derivatives a Newton iteration on the
  coupler force needs: ``∂P/∂δ``, ``∂P/∂δ̇``, ``∂P/∂s``, ``∂ṡ/∂P``, ``∂ṡ/∂s``,
  ``∂ṡ/∂δ``, ``∂ṡ/∂δ̇`` (:class:`CouplerTangent`);
* ``guards(δ, δ̇, s)`` — functions whose sign selects the piece of a piecewise law
  (gear open/closed, sign of ``δ`` for a preloaded gear). Each method takes an
  optional ``branch`` (one sign per guard) that freezes the piece: the ODE driver
  (:mod:`reduced.nonlinear`) freezes it between events so each segment is smooth,
  and restarts at each guard's zero; ``branch=None`` picks it from the signs;
* ``stored_energy`` and ``dissipation_rate`` for energy balances;
* ``guard_events`` — names of the events when each guard turns positive/negative.

The table law (:class:`HystereticTable`: loading/unloading curves with
hysteresis) fits the same interface memorylessly: the closure rate selects the
curve (loading while the closure magnitude grows, unloading while it shrinks).

Contact (:class:`Coupling`)
---------------------------
``Coupling(law, contact, slack, tension_slack)`` adds the contact: with
``compression_only`` (free to roll) the coupler transmits ``P`` only while
``δ − slack > 0`` *and* the law force is compressive — the cars separate when
the force would become tensile and may re-contact later; ``bilateral`` (coupled
cars) transmits tension as well — with zero slack the law is always engaged,
with slack the free play ``−tension_slack < δ < slack`` transmits nothing and
each side behaves as a compression-only contact. ``slack`` is the initial gap
(m) that the cars close before contact.

Registry: :data:`COUPLER_LAWS` maps the case-file names to the classes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

CONTACT_KINDS: tuple[str, ...] = ("compression_only", "bilateral")
"""Contact kinds: ``compression_only`` (free to roll) and ``bilateral`` (coupled)."""

Branch = tuple[int, ...]

_EMPTY = np.zeros(0)
_EMPTY2 = np.zeros((0, 0))


@dataclass(frozen=True, eq=False)
class CouplerTangent:
    """Partial derivatives of a coupler law at one point (SI units).

    ``force_closure = ∂P/∂δ`` (N/m, the tangent stiffness), ``force_rate = ∂P/∂δ̇``
    (N·s/m, the tangent damping), ``force_state = ∂P/∂s``; for the state rate
    ``ṡ = q(δ, δ̇, s, P)``: ``rate_closure = ∂q/∂δ``, ``rate_rate = ∂q/∂δ̇``,
    ``rate_state = ∂q/∂s`` and ``rate_force = ∂q/∂P``.
    """

    force_closure: float
    force_rate: float
    force_state: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)
    rate_closure: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)
    rate_rate: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)
    rate_state: NDArray[np.float64] = field(default_factory=lambda: _EMPTY2)
    rate_force: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)


class CouplerLaw(Protocol):
    """What the rigid-body ODE driver and, later, the FE coupler Newton iteration need."""

    state_size: ClassVar[int]
    guard_events: ClassVar[tuple[tuple[str, str], ...]]

    def initial_state(self) -> NDArray[np.float64]: ...

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]: ...

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float: ...

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]: ...

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent: ...

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float: ...

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float: ...

    @property
    def reference_stiffness(self) -> float: ...


def _branch(guards: NDArray[np.float64], branch: Branch | None) -> Branch:
    """The frozen branch, or the signs of the guards (a zero counts as positive)."""
    if branch is not None:
        return branch
    return tuple(1 if g >= 0.0 else -1 for g in guards)


# --------------------------------------------------------------------------- laws


@dataclass(frozen=True)
class KelvinVoigt:
    """Linear spring and dashpot in parallel: ``P = c δ + μ δ̇`` (N).

    ``stiffness`` c (N/m), ``damping`` μ (N·s/m). Stored energy ``c δ²/2``, dissipation
    ``μ δ̇²``. Tangent: ``∂P/∂δ = c``, ``∂P/∂δ̇ = μ``. Its two-mass closed form is
    :func:`reduced.rigid.kelvin_voigt_impact`; the ODE driver reproduces it to 3e-11
    of the peaks (``tests/test_reduced_nonlinear.py``).
    """

    stiffness: float
    damping: float = 0.0

    state_size: ClassVar[int] = 0
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = ()

    def __post_init__(self) -> None:
        _checks.positive("stiffness", self.stiffness)
        _checks.non_negative("damping", self.damping)

    @classmethod
    def design_example(cls) -> KelvinVoigt:
        """The coupler of DESIGN.md's example impact case: 4e7 N/m, 3e5 N·s/m."""
        return cls(stiffness=4.0e7, damping=3.0e5)

    @property
    def reference_stiffness(self) -> float:
        return float(self.stiffness)

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(0)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.zeros(0)

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        return self.stiffness * closure + self.damping * closure_rate

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        return np.zeros(0)

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        return CouplerTangent(float(self.stiffness), float(self.damping))

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        return 0.5 * self.stiffness * closure**2 if engaged else 0.0

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float:
        return self.damping * closure_rate**2 if engaged else 0.0


@dataclass(frozen=True)
class PowerLawGear:
    """Power-law gear with preload and closure-dependent damping (SOURCE-NOTES A3).

    ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``, ``γ(δ) = Σ_k γ_k |δ|^k`` (N).

    ``stiffness`` c (N/mⁿ), ``exponent`` n ≥ 1 (n < 1 has infinite stiffness at
    δ = 0, which no Newton iteration or stiff solver can use), ``preload`` N0 (N,
    the initial tightening: the force jumps to ±N0 as δ passes 0), ``damping``
    (γ_0 in N·s/m, γ_1 in N·s/m², …). With n = 1, N0 = 0, γ = (μ,) it is
    :class:`KelvinVoigt` (the ODE driver reproduces the closed form to 3e-11).

    Stored energy ``c|δ|^{n+1}/(n+1) + N0|δ|``; dissipation ``γ(δ) δ̇²``; tangent
    ``∂P/∂δ = n c |δ|^{n−1} + γ'(δ) δ̇``, ``∂P/∂δ̇ = γ(δ)``. One guard, ``δ`` itself
    (the preload jump; with compression-only contact the contact guard covers it).
    """

    stiffness: float
    exponent: float = 1.0
    preload: float = 0.0
    damping: tuple[float, ...] = (0.0,)

    state_size: ClassVar[int] = 0
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = (("closure_turns_compressive", "closure_turns_tensile"),)

    def __post_init__(self) -> None:
        _checks.positive("stiffness", self.stiffness)
        n = _checks.finite("exponent", self.exponent)
        if n < 1.0:
            raise ValueError(f"exponent must be >= 1 (infinite stiffness at zero closure otherwise), got {n!r}")
        _checks.non_negative("preload", self.preload)
        if len(self.damping) == 0:
            raise ValueError("damping needs at least one coefficient (gamma_0)")
        for k, g in enumerate(self.damping):
            _checks.non_negative(f"damping[{k}]", g)
        object.__setattr__(self, "damping", tuple(float(g) for g in self.damping))

    @classmethod
    def m901e_like(cls, damping: float = 5.0e5) -> PowerLawGear:
        """A Group-J (M-901E class) gear as ``P = c δ²``: 2.52 MN at the 74 mm rating travel.

        ``c = 2.52e6/0.074² ≈ 4.6e8 N/m²`` gives 3.1 MN and 86 kJ at the 82.5 mm
        travel (data sheet: 3.82 MN near 80 mm, capacity 62–71 kJ; DESIGN.md §8).
        ``damping`` γ_0 (N·s/m) stands in for the gear friction.
        """
        return cls(stiffness=2.52e6 / 0.074**2, exponent=2.0, preload=0.0, damping=(damping,))

    @property
    def reference_stiffness(self) -> float:
        """Secant stiffness at 10 mm closure (N/m), for time scales only."""
        return float(self.stiffness * 0.01 ** (self.exponent - 1.0) + self.preload / 0.01)

    def damping_at(self, closure: float) -> tuple[float, float]:
        """``γ(δ)`` and ``dγ/dδ``."""
        a = abs(closure)
        g = 0.0
        dg = 0.0
        for k, gk in enumerate(self.damping):
            g += gk * a**k
            if k >= 1:
                dg += k * gk * a ** (k - 1)
        return g, dg * (1.0 if closure >= 0.0 else -1.0)

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(0)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.array([closure])

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        (side,) = _branch(self.guards(closure, closure_rate, state), branch)
        g, _ = self.damping_at(closure)
        return side * (self.stiffness * abs(closure) ** self.exponent + self.preload) + g * closure_rate

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        return np.zeros(0)

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        g, dg = self.damping_at(closure)
        a = abs(closure)
        spring = self.exponent * self.stiffness * a ** (self.exponent - 1.0)
        return CouplerTangent(float(spring + dg * closure_rate), float(g))

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        if not engaged:
            return 0.0
        a = abs(closure)
        return self.stiffness * a ** (self.exponent + 1.0) / (self.exponent + 1.0) + self.preload * a

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float:
        return self.damping_at(closure)[0] * closure_rate**2 if engaged else 0.0


@dataclass(frozen=True)
class StandardLinearDraftGear:
    """Standard-linear draft gear with a stroke (SOURCE-NOTES A4).

    Two linear springs ``c1``, ``c2`` (car body and coupler compliance, in series:
    ``D = 1/c1 + 1/c2``) carry the coupler force to the gear element, a spring
    ``F_g(x_g)`` in parallel with a dashpot μ. The state is the gear compression
    ``x_g`` (m)::

        P     = (δ − x_g)/D                         (series springs)
        μ ẋ_g = P − F_g(x_g)                         (gear element; P transmitted)
        F_g   = c x_g                               |x_g| ≤ stroke (gear open)
              = c* x_g + (c − c*) stroke sgn(x_g)   |x_g| > stroke (gear closed, solid)

    The series springs make the gear equation first order in ``x_g`` (the printed
    source carries ``x_g'`` in the state; it is not independent). Guards
    ``x_g − stroke`` and ``x_g + stroke`` mark closure; the ODE driver restarts there.
    Stored energy ``D P²/2 + ∫₀^{x_g} F_g``, dissipation ``μ ẋ_g² = (P − F_g)²/μ``
    (the energy balance of the ODE solution closes to 1e-10 of the impact energy, and
    the closure time matches a brute-force integration to 3e-13 s, in the tests).

    Tangent: ``∂P/∂δ = 1/D``, ``∂P/∂x_g = −1/D``, ``∂ẋ_g/∂P = 1/μ``,
    ``∂ẋ_g/∂x_g = −F_g'(x_g)/μ``. Requires ``μ > 0`` (rate-independent gears need a
    different state law). Units: stiffnesses N/m, μ N·s/m, stroke m.
    """

    series_stiffness_1: float
    series_stiffness_2: float
    gear_stiffness: float
    gear_damping: float
    stroke: float
    solid_stiffness: float

    state_size: ClassVar[int] = 1
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = (
        ("gear_closed", "gear_reopened"),
        ("gear_reopened_tension", "gear_closed_tension"),
    )

    def __post_init__(self) -> None:
        _checks.positive("series_stiffness_1", self.series_stiffness_1)
        _checks.positive("series_stiffness_2", self.series_stiffness_2)
        _checks.positive("gear_stiffness", self.gear_stiffness)
        _checks.positive("gear_damping", self.gear_damping)
        _checks.positive("stroke", self.stroke)
        _checks.positive("solid_stiffness", self.solid_stiffness)

    @classmethod
    def m901e_like(
        cls,
        *,
        series_stiffness: float = 4.0e8,
        gear_damping: float = 5.0e5,
        solid_stiffness: float = 2.0e8,
    ) -> StandardLinearDraftGear:
        """A Group-J (M-901E class) gear, linearised (DESIGN.md §8).

        ``c = 2.52 MN / 74 mm = 34 MN/m`` (secant to the rating point), stroke 82.5 mm
        (the gear travel), solid stiffness ``c* = 200 MN/m`` (the published friction
        gear's solid stiffness); ``c1 = c2 = series_stiffness`` (car body and coupler),
        ``μ = gear_damping`` (0.2 of critical for the 119 t / 100 t pair). With the
        source study's pair it closes at 3.58 m/s (8 mph) under 3.68 MN, not at 2.68 m/s
        (80.7 mm). One gear: two cars' gears in series act as ``c/2`` with twice the stroke.
        """
        return cls(
            series_stiffness_1=series_stiffness,
            series_stiffness_2=series_stiffness,
            gear_stiffness=2.52e6 / 0.074,
            gear_damping=gear_damping,
            stroke=0.0825,
            solid_stiffness=solid_stiffness,
        )

    @property
    def series_compliance(self) -> float:
        """``D = 1/c1 + 1/c2`` (m/N)."""
        return 1.0 / self.series_stiffness_1 + 1.0 / self.series_stiffness_2

    @property
    def reference_stiffness(self) -> float:
        """Static stiffness of the open gear with the series springs (N/m)."""
        return 1.0 / (self.series_compliance + 1.0 / self.gear_stiffness)

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(1)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        xg = float(state[0])
        return np.array([xg - self.stroke, xg + self.stroke])

    def _piece(self, state: NDArray[np.float64], branch: Branch | None) -> int:
        """+1 closed in compression, −1 closed in tension, 0 open."""
        above, below = _branch(self.guards(0.0, 0.0, state), branch)
        if above > 0:
            return 1
        if below < 0:
            return -1
        return 0

    def gear_spring(self, gear_compression: float, branch: Branch | None = None) -> tuple[float, float]:
        """``F_g(x_g)`` (N) and ``F_g'(x_g)`` (N/m) on the (frozen) piece."""
        piece = self._piece(np.array([gear_compression]), branch)
        c, cs, s = self.gear_stiffness, self.solid_stiffness, self.stroke
        if piece == 0:
            return c * gear_compression, c
        return cs * gear_compression + (c - cs) * s * piece, cs

    def _gear_energy(self, xg: float, piece: int) -> float:
        c, cs, s = self.gear_stiffness, self.solid_stiffness, self.stroke
        if piece == 0:
            return 0.5 * c * xg**2
        a = abs(xg)
        return 0.5 * c * s**2 + 0.5 * cs * (a**2 - s**2) + (c - cs) * s * (a - s)

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        return (closure - float(state[0])) / self.series_compliance

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        fg, _ = self.gear_spring(float(state[0]), branch)
        return np.array([(force - fg) / self.gear_damping])

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        _, kg = self.gear_spring(float(state[0]), branch)
        d = self.series_compliance
        return CouplerTangent(
            force_closure=1.0 / d,
            force_rate=0.0,
            force_state=np.array([-1.0 / d]),
            rate_closure=np.zeros(1),
            rate_rate=np.zeros(1),
            rate_state=np.array([[-kg / self.gear_damping]]),
            rate_force=np.array([1.0 / self.gear_damping]),
        )

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        xg = float(state[0])
        series = 0.5 * self.series_compliance * self.force(closure, 0.0, state) ** 2 if engaged else 0.0
        return series + self._gear_energy(xg, self._piece(state, branch))

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float:
        fg, _ = self.gear_spring(float(state[0]), branch)
        return (force - fg) ** 2 / self.gear_damping


def _float_tuple(name: str, values: object) -> tuple[float, ...]:
    """``values`` as a tuple of finite floats (at least two), naming a bad entry."""
    try:
        items = list(values)  # type: ignore[call-overload]
    except TypeError:
        raise ValueError(f"{name} must be a sequence of numbers, got {values!r}") from None
    if len(items) < 2:
        raise ValueError(f"{name} needs at least 2 points, got {len(items)}")
    return tuple(_checks.finite(f"{name}[{k}]", v) for k, v in enumerate(items))


def _piecewise_linear(
    x: NDArray[np.float64], y: NDArray[np.float64], integral: NDArray[np.float64], a: float
) -> tuple[float, float, float]:
    """Value, slope and ``∫₀^a`` of the table ``(x, y)`` at ``a ≥ 0`` (linear extrapolation
    with the last segment beyond ``x[-1]``; the slope at a table point is the right one)."""
    i = min(max(int(np.searchsorted(x, a, side="right")) - 1, 0), x.size - 2)
    slope = (y[i + 1] - y[i]) / (x[i + 1] - x[i])
    h = a - x[i]
    return float(y[i] + slope * h), float(slope), float(integral[i] + y[i] * h + 0.5 * slope * h * h)


def _cumulative_trapezoid(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(x))])


@dataclass(frozen=True)
class HystereticTable:
    """Tabulated friction gear: loading curve ``L(δ)``, unloading curve ``U(δ)`` and a rate switch.

    For ``δ ≥ 0`` (N; closure δ in m, rate δ̇ in m/s)::

        P = U(δ) + (L(δ) − U(δ)) s(δ̇) + c_v δ̇,    s(δ̇) = clip(δ̇/v_s, 0, 1)

    and oddly extended, ``P(−δ, −δ̇) = −P(δ, δ̇)`` (draft acts like buff): with
    ``σ = sgn δ`` (at ``δ = 0``: ``sgn δ̇``, +1 at rest), ``P = σ [U(|δ|) + (L − U)(|δ|)
    s(σδ̇)] + c_v δ̇``. So the force follows ``L`` while the closure magnitude grows
    faster than ``v_s`` = ``switch_velocity``, ``U`` while it shrinks, and crosses
    between them within the band ``0 < σδ̇ < v_s`` (continuous, kinked at its edges).
    ``L`` and ``U`` are piecewise linear through the table (``closure`` strictly
    increasing from 0; forces in N) and continue beyond the last point with the last
    segment's slope (the gear going solid). ``damping`` ``c_v`` (N·s/m) adds a dashpot.

    Memoryless (``state_size = 0``, no guards): unloading from any closure drops at
    once to ``U``, so inner loops are not modelled (a state holding the turning
    point would be needed for that); the ODE driver integrates through the kinks of
    the table and of the switch band (its adaptive steps shorten there).

    Implicit coupled solves: across a turning point the force drops by ``L − U`` within
    a closure-rate band ``v_s`` wide, i.e. within a force band of about ``v_s/g_v``
    (``g_v`` the car ends' velocity gain per newton over one step) — for FE car ends a
    few kN against a drop of ~1 MN. A plain Newton iteration on the coupler force
    then jumps over the band and cycles between the two curves (measured on the
    default impact scene with the friction envelope as its coupler: fem, modal and
    quasi-rigid cars fail at ``v_s`` = 0.01 m/s, modal and quasi-rigid still at 0.1 m/s,
    all run at 1 m/s); it needs a safeguard (the residual is monotone in P, so
    bracketing works).

    Energy: ``stored = ∫₀^{|δ|} U`` (the part given back on unloading), dissipation
    rate ``(P − σU(|δ|)) δ̇ = (L − U)(|δ|) s(σδ̇) σδ̇ + c_v δ̇² ≥ 0`` because ``s > 0``
    only while ``σδ̇ > 0`` and ``L ≥ U`` everywhere (table checks, plus the last
    slopes ``0 ≤ U' ≤ L'`` so that it stays so beyond the table). A slow closed
    cycle ``0 → δ_m → 0`` dissipates ``∫₀^{δ_m} (L − U)``, the loop area, exactly
    in the limit ``v_s → 0`` (``tests/test_reduced_table_law.py``, with the energy
    balance of :func:`reduced.nonlinear.simulate_impact`).

    Tangent: ``∂P/∂δ = U' + (L' − U') s``, ``∂P/∂δ̇ = (L − U) s' + c_v`` with
    ``s' = 1/v_s`` for ``0 ≤ σδ̇ < v_s`` and 0 outside (right derivatives at the kinks;
    checked against central differences away from them).
    """

    closure: tuple[float, ...]
    loading: tuple[float, ...]
    unloading: tuple[float, ...]
    damping: float = 0.0
    switch_velocity: float = 0.01

    state_size: ClassVar[int] = 0
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = ()
    FRICTION_GEAR_SLACK: ClassVar[float] = 0.0119
    """Slack (m) of :meth:`friction_gear_envelope`, for ``Coupling(slack=…)``."""

    _x: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _l: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _u: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _l_int: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _u_int: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        x = _float_tuple("closure", self.closure)
        lo = _float_tuple("loading", self.loading)
        un = _float_tuple("unloading", self.unloading)
        if not len(x) == len(lo) == len(un):
            raise ValueError(
                f"closure, loading and unloading must have the same length, got {len(x)}, {len(lo)}, {len(un)}"
            )
        _check_table(x, lo, un)
        _checks.non_negative("damping", self.damping)
        _checks.positive("switch_velocity", self.switch_velocity)
        for name, value in (("closure", x), ("loading", lo), ("unloading", un)):
            object.__setattr__(self, name, value)
        xa, la, ua = np.array(x), np.array(lo), np.array(un)
        for name, value in (("_x", xa), ("_l", la), ("_u", ua)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "_l_int", _cumulative_trapezoid(xa, la))
        object.__setattr__(self, "_u_int", _cumulative_trapezoid(xa, ua))

    @classmethod
    def friction_gear_envelope(
        cls,
        *,
        unloading_fraction: float = 0.3,
        solid_stiffness: float = 2.0e8,
        solid_travel: float = 0.01,
        damping: float = 0.0,
        switch_velocity: float = 0.01,
        slack_in_table: bool = True,
    ) -> HystereticTable:
        """The friction draft-gear envelope of one published train simulator (DESIGN.md §8).

        Loading: 0 N up to 11.9 mm (slack), 0.12 MN at 18.8 mm, 0.68 MN at 49.5 mm,
        1.35 MN at 125 mm; then solid, ``solid_stiffness`` (200 MN/m) over one more
        table segment of ``solid_travel`` (10 mm, to 3.35 MN) that the law extrapolates
        beyond. Any point on the solid line gives the same force law; this one only sets
        ``reference_stiffness`` (the secant there, 24.8 MN/m).

        Unloading (an assumption — the source gives only "far below loading"):
        ``unloading_fraction`` (0.3) of the loading force at the published points, so
        a slow full cycle within the gear travel returns 30 % of the work and
        dissipates 70 % (friction gears give back the smaller part of the energy they
        absorb; change the fraction to match a gear's measured rebound). On the
        solid segment the unloading curve runs parallel to loading (slope
        ``solid_stiffness``): the solid gear unloads elastically, so pressing it
        further adds no friction loss and the loop height stays
        ``(1 − fraction)·1.35 MN``.

        The 11.9 mm slack is in the table (zero force on both curves): with a
        ``compression_only`` coupling that plateau leaves the contact guard at exactly
        zero and the ODE driver records spurious contact/separation events while it
        crosses; there, prefer ``Coupling(friction_gear_envelope(slack_in_table=False),
        slack=HystereticTable.FRICTION_GEAR_SLACK)`` (the table shifted by the slack).
        """
        fraction = _checks.finite("unloading_fraction", unloading_fraction)
        if not 0.0 <= fraction <= 1.0:
            raise ValueError(f"unloading_fraction must be in [0, 1], got {fraction!r}")
        ks = _checks.positive("solid_stiffness", solid_stiffness)
        travel = _checks.positive("solid_travel", solid_travel)
        x = [0.0, 0.0119, 0.0188, 0.0495, 0.125]
        lo = [0.0, 0.0, 0.12e6, 0.68e6, 1.35e6]
        un = [fraction * f for f in lo]
        x.append(x[-1] + travel)
        lo.append(lo[-1] + ks * travel)
        un.append(un[-1] + ks * travel)
        if not slack_in_table:
            x, lo, un = [v - x[1] for v in x[1:]], lo[1:], un[1:]
        return cls(tuple(x), tuple(lo), tuple(un), damping=damping, switch_velocity=switch_velocity)

    @property
    def reference_stiffness(self) -> float:
        """Secant of the loading curve at the last table point, ``L(δ_n)/δ_n`` (N/m)."""
        return float(self._l[-1] / self._x[-1])

    def curves(self, closure: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """``(L, L', ∫₀L)`` and ``(U, U', ∫₀U)`` at ``|δ|`` (N, N/m, J; the curves of the
        buff side, extrapolated beyond the table)."""
        a = abs(float(closure))
        return (
            _piecewise_linear(self._x, self._l, self._l_int, a),
            _piecewise_linear(self._x, self._u, self._u_int, a),
        )

    def _switch(self, closure: float, closure_rate: float) -> tuple[float, float, float]:
        """``σ``, ``s(σδ̇)`` and ``s'(σδ̇)``."""
        if closure != 0.0:
            sigma = 1.0 if closure > 0.0 else -1.0
        else:
            sigma = 1.0 if closure_rate >= 0.0 else -1.0
        r = sigma * closure_rate
        vs = self.switch_velocity
        s = min(max(r / vs, 0.0), 1.0)
        ds = 1.0 / vs if 0.0 <= r < vs else 0.0
        return sigma, s, ds

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(0)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.zeros(0)

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        (lo, _, _), (un, _, _) = self.curves(closure)
        sigma, s, _ = self._switch(closure, closure_rate)
        return sigma * (un + (lo - un) * s) + self.damping * closure_rate

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        return np.zeros(0)

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        (lo, dlo, _), (un, dun, _) = self.curves(closure)
        _, s, ds = self._switch(closure, closure_rate)
        return CouplerTangent(float(dun + (dlo - dun) * s), float((lo - un) * ds + self.damping))

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        return self.curves(closure)[1][2] if engaged else 0.0

    def dissipation_rate(
        self,
        closure: float,
        closure_rate: float,
        state: NDArray[np.float64],
        force: float,
        engaged: bool,
        branch: Branch | None = None,
    ) -> float:
        if not engaged:
            return 0.0
        (lo, _, _), (un, _, _) = self.curves(closure)
        sigma, s, _ = self._switch(closure, closure_rate)
        return (lo - un) * s * sigma * closure_rate + self.damping * closure_rate**2


def _check_table(x: tuple[float, ...], lo: tuple[float, ...], un: tuple[float, ...]) -> None:
    """The table rules of :class:`HystereticTable` (ValueError naming the rule and the point)."""
    if x[0] != 0.0:
        raise ValueError(f"closure must start at 0 (the gear at rest), got closure[0] = {x[0]!r}")
    for k in range(1, len(x)):
        if not x[k] > x[k - 1]:
            raise ValueError(f"closure must increase strictly, got closure[{k - 1}] = {x[k - 1]!r}, closure[{k}] = {x[k]!r}")
    if lo[0] != 0.0 or un[0] != 0.0:
        raise ValueError(f"loading[0] and unloading[0] must be 0 (no force at zero closure), got {lo[0]!r}, {un[0]!r}")
    for k in range(1, len(x)):
        if lo[k] < lo[k - 1]:
            raise ValueError(f"loading must be nondecreasing, got loading[{k - 1}] = {lo[k - 1]!r} > loading[{k}] = {lo[k]!r}")
    for k in range(len(x)):
        if not 0.0 <= un[k] <= lo[k]:
            raise ValueError(f"unloading must satisfy 0 <= unloading <= loading, got unloading[{k}] = {un[k]!r}, loading[{k}] = {lo[k]!r}")
    if not lo[-1] > 0.0:
        raise ValueError("loading must rise above 0 somewhere in the table (a gear that never pushes)")
    h = x[-1] - x[-2]
    slope_l, slope_u = (lo[-1] - lo[-2]) / h, (un[-1] - un[-2]) / h
    if not 0.0 <= slope_u <= slope_l:
        raise ValueError(
            "beyond the table the curves continue with their last slopes, which must satisfy "
            f"0 <= unloading slope <= loading slope (else unloading turns negative or exceeds loading); "
            f"got unloading slope {slope_u:.6g} N/m, loading slope {slope_l:.6g} N/m"
        )


COUPLER_LAWS: dict[str, type] = {
    "kelvin_voigt": KelvinVoigt,
    "power_law": PowerLawGear,
    "standard_linear": StandardLinearDraftGear,
    "draft_gear": StandardLinearDraftGear,
    "table": HystereticTable,
}
"""Case-file name → law class (the schema and its error messages share this map).
``draft_gear`` is the case-file name of :class:`StandardLinearDraftGear` (an alias of
``standard_linear``)."""


# ------------------------------------------------------------------------ contact


@dataclass(frozen=True, eq=False)
class CouplerResponse:
    """The coupler at one point: transmitted force ``P`` (N, compression positive),
    contact ``mode`` (+1 compression, −1 tension, 0 open), the state rate and the
    tangent of the transmitted force (all zero while open)."""

    force: float
    mode: int
    state_rate: NDArray[np.float64]
    tangent: CouplerTangent


@dataclass(frozen=True)
class Coupling:
    """A coupler law with its contact: ``compression_only`` or ``bilateral``, and slack.

    Transmitted force, with the engaged law force ``F(δ_e) = law.force(δ_e, δ̇, s)``:

    * compression engaged (mode +1) when ``δ − slack > 0`` and ``F(δ − slack) > 0``:
      ``P = F(δ − slack)``;
    * tension engaged (mode −1; ``bilateral`` with slack only) when
      ``δ + tension_slack < 0`` and ``F(δ + tension_slack) < 0``: ``P = F(δ + tension_slack)``;
    * ``bilateral`` without slack: always engaged, ``P = F(δ)`` of either sign;
    * otherwise open: ``P = 0`` and the law's state relaxes (``state_rate`` with P = 0).

    The contact guards are ``e_c = min(δ − slack, F(δ − slack))`` (engaged in
    compression iff ``e_c > 0``) and ``e_t = max(δ + tension_slack, F(δ + tension_slack))``
    (engaged in tension iff ``e_t < 0``); their zeros are the contact and separation
    events. The memoryless laws (Kelvin-Voigt, power law) drop their stored energy
    when a compression-only contact separates with ``δ − slack > 0``; the ODE driver
    books it as dissipated (the cushion's own relaxation).
    """

    law: CouplerLaw
    contact: str = "compression_only"
    slack: float = 0.0
    tension_slack: float = 0.0

    def __post_init__(self) -> None:
        _checks.choice("contact", self.contact, CONTACT_KINDS)
        _checks.non_negative("slack", self.slack)
        _checks.non_negative("tension_slack", self.tension_slack)
        if self.contact == "compression_only" and self.tension_slack != 0.0:
            raise ValueError("tension_slack applies to bilateral contact only; compression_only never transmits tension")

    @property
    def always_engaged(self) -> bool:
        """Bilateral without slack: the law acts at every closure."""
        return self.contact == "bilateral" and self.slack == 0.0 and self.tension_slack == 0.0

    @property
    def contact_guard_events(self) -> tuple[tuple[str, str], ...]:
        """Event names (guard turns positive, guard turns negative) of the contact guards."""
        if self.always_engaged:
            return ()
        events = (("contact", "separation"),)
        if self.contact == "bilateral":
            events += (("tension_separation", "tension_contact"),)
        return events

    @property
    def guard_events(self) -> tuple[tuple[str, str], ...]:
        """Contact guards first, then the law's guards."""
        return self.contact_guard_events + self.law.guard_events

    def effective_closure(self, closure: float, mode: int) -> float:
        """Closure the law sees: ``δ − slack`` in compression/open, ``δ + tension_slack`` in tension."""
        if mode < 0:
            return closure + self.tension_slack
        return closure - self.slack

    def guards(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], law_branch: Branch | None = None
    ) -> NDArray[np.float64]:
        """Values of all guards (contact guards, then the law's)."""
        law_guards = self.law.guards(self.effective_closure(closure, 0), closure_rate, state)
        if self.always_engaged:
            return law_guards
        dc = closure - self.slack
        values = [min(dc, self.law.force(dc, closure_rate, state, law_branch))]
        if self.contact == "bilateral":
            dt = closure + self.tension_slack
            values.append(max(dt, self.law.force(dt, closure_rate, state, law_branch)))
        return np.concatenate([np.array(values), law_guards])

    def split_branch(self, sides: Branch) -> tuple[int, Branch]:
        """Contact mode and law branch from the signs of all guards."""
        n = len(self.contact_guard_events)
        law_branch = tuple(sides[n:])
        if self.always_engaged:
            return 1, law_branch
        if sides[0] > 0:
            return 1, law_branch
        if self.contact == "bilateral" and sides[1] < 0:
            return -1, law_branch
        return 0, law_branch

    def transmitted_force(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], mode: int, law_branch: Branch | None = None
    ) -> float:
        """``P`` (N, compression positive) in the given contact mode."""
        if mode == 0:
            return 0.0
        return self.law.force(self.effective_closure(closure, mode), closure_rate, state, law_branch)

    def evaluate(self, closure: float, closure_rate: float, state: NDArray[np.float64] | None = None) -> CouplerResponse:
        """Force, mode, state rate and tangent with the branch and mode taken from the signs.

        This is the entry point for a coupler iteration outside the ODE driver
        (e.g. Newton on the coupler force between finite-element car bodies).
        """
        closure = _checks.finite("closure", closure)
        closure_rate = _checks.finite("closure_rate", closure_rate)
        s = self.law.initial_state() if state is None else np.asarray(state, dtype=float)
        if s.shape != (self.law.state_size,):
            raise ValueError(f"state must have shape ({self.law.state_size},), got {s.shape}")
        sides = tuple(1 if g > 0.0 else -1 for g in self.guards(closure, closure_rate, s))
        mode, law_branch = self.split_branch(sides)
        p = self.transmitted_force(closure, closure_rate, s, mode, law_branch)
        de = self.effective_closure(closure, mode)
        rate = self.law.state_rate(de, closure_rate, s, p, law_branch)
        tangent = self.law.tangent(de, closure_rate, s, p, law_branch)
        if mode == 0:
            n = self.law.state_size
            tangent = CouplerTangent(
                0.0, 0.0, np.zeros(n), tangent.rate_closure, tangent.rate_rate, tangent.rate_state, tangent.rate_force
            )
        return CouplerResponse(force=p, mode=mode, state_rate=rate, tangent=tangent)


def coupling_from_name(name: str, parameters: dict[str, float], **contact: float | str) -> Coupling:
    """Build a :class:`Coupling` from a registry name and law parameters (case-file form)."""
    _checks.choice("coupler law", name, tuple(COUPLER_LAWS))
    law = COUPLER_LAWS[name](**parameters)
    return Coupling(law, **contact)  # type: ignore[arg-type]


__all__ = [
    "CONTACT_KINDS",
    "COUPLER_LAWS",
    "CouplerLaw",
    "CouplerResponse",
    "CouplerTangent",
    "Coupling",
    "HystereticTable",
    "KelvinVoigt",
    "PowerLawGear",
    "StandardLinearDraftGear",
    "coupling_from_name",
]

