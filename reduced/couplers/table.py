"""Tabulated hysteretic friction gear: for ``δ ≥ 0`` (N)::

    P = U(δ) + (L(δ) − U(δ)) s(δ̇) + c_v δ̇,    s(δ̇) = clip(δ̇/v_s, 0, 1)

oddly extended to ``δ < 0``. The table law (:class:`HystereticTable`: loading/unloading
curves with hysteresis) fits the interface of :class:`reduced.couplers.base.CouplerLaw`
memorylessly: the closure rate selects the curve (loading while the closure magnitude
grows, unloading while it shrinks).

Here: :class:`HystereticTable`, its table checks (``_check_table``) and the
piecewise-linear helpers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .base import Branch, CouplerTangent


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
    in the limit ``v_s → 0`` (``tests/reduced/couplers/test_table.py``, with the energy
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
        """The friction draft-gear envelope of one published train simulator (docs/design.md §8).

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


__all__ = ["HystereticTable"]
