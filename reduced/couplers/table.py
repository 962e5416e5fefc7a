"""Tabulated hysteretic friction gear, memoryless: the closure rate selects the curve (:class:`HystereticTable`).

Packed ``p = [c_v, v_s, m]`` and the table's rows closure, L, U, ``∫₀L``, ``∫₀U`` at its
``m`` points; the functions are its arithmetic, once (:mod:`reduced.couplers.base`). Here
also the table checks (``_check_table``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .base import PackedLaw


def curve(p, table, row, a):
    """Value, slope and ``∫₀^a`` of table row 1 (L) or 2 (U) at ``a ≥ 0`` (linear extrapolation with the last
    segment beyond the table; the slope at a table point is the right one)."""
    m = int(p[2])
    x = table[0]
    y = table[row]
    integral = table[row + 2]
    low, high = 0, m  # the points x <= a: np.searchsorted(x, a, side="right")
    while low < high:
        middle = (low + high) // 2
        if x[middle] <= a:
            low = middle + 1
        else:
            high = middle
    i = min(max(low - 1, 0), m - 2)
    slope = (y[i + 1] - y[i]) / (x[i + 1] - x[i])
    h = a - x[i]
    return y[i] + slope * h, slope, integral[i] + y[i] * h + 0.5 * slope * h * h


def switch(p, closure, rate):
    """``σ = sgn δ`` (at δ = 0: ``sgn δ̇``, +1 at rest), ``s(σδ̇) = clip(σδ̇/v_s, 0, 1)`` and its right derivative."""
    if closure != 0.0:
        sigma = 1.0 if closure > 0.0 else -1.0
    else:
        sigma = 1.0 if rate >= 0.0 else -1.0
    r = sigma * rate
    vs = p[1]
    s = min(max(r / vs, 0.0), 1.0)
    ds = 1.0 / vs if 0.0 <= r < vs else 0.0
    return sigma, s, ds


def piece(p, table, closure, state, strict):
    """No guards: one piece (0)."""
    return 0


def force(p, table, closure, rate, state, piece):
    """``P = σ [U + (L − U) s(σδ̇)](|δ|) + c_v δ̇``."""
    a = abs(closure)
    lo = curve(p, table, 1, a)[0]
    un = curve(p, table, 2, a)[0]
    sigma, s, _ = switch(p, closure, rate)
    return sigma * (un + (lo - un) * s) + p[0] * rate


def state_rate(p, table, closure, rate, state, transmitted, piece):
    """Memoryless: 0."""
    return 0.0


def tangent(p, table, closure, rate, state, transmitted, piece):
    """``∂P/∂δ = U' + (L' − U') s``, ``∂P/∂δ̇ = (L − U) s' + c_v``."""
    a = abs(closure)
    lo, dlo, _ = curve(p, table, 1, a)
    un, dun, _ = curve(p, table, 2, a)
    _, s, ds = switch(p, closure, rate)
    return dun + (dlo - dun) * s, (lo - un) * ds + p[0], 0.0, 0.0, 0.0, 0.0, 0.0


def stored_energy(p, table, closure, state, engaged, piece):
    """``∫₀^{|δ|} U`` while engaged."""
    return curve(p, table, 2, abs(closure))[2] if engaged else 0.0


def dissipation_rate(p, table, closure, rate, state, transmitted, engaged, piece):
    """``(L − U)(|δ|) s(σδ̇) σ δ̇ + c_v δ̇²`` while engaged."""
    if not engaged:
        return 0.0
    a = abs(closure)
    lo = curve(p, table, 1, a)[0]
    un = curve(p, table, 2, a)[0]
    sigma, s, _ = switch(p, closure, rate)
    return (lo - un) * s * sigma * rate + p[0] * rate**2


def _float_tuple(name: str, values: object) -> tuple[float, ...]:
    """``values`` as a tuple of finite floats (at least two), naming a bad entry."""
    try:
        items = list(values)  # type: ignore[call-overload]
    except TypeError:
        raise ValueError(f"{name} must be a sequence of numbers, got {values!r}") from None
    if len(items) < 2:
        raise ValueError(f"{name} needs at least 2 points, got {len(items)}")
    return tuple(_checks.finite(f"{name}[{k}]", v) for k, v in enumerate(items))


def _cumulative_trapezoid(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(x))])


@dataclass(frozen=True)
class HystereticTable(PackedLaw):
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

    Implicit coupled solves: across a turning point the force drops by ``L − U`` within a
    force band of about ``v_s/g_v`` (``g_v`` the car ends' velocity gain per newton over one
    step; for FE car ends a few kN against ~1 MN): a plain Newton iteration cycles between
    the curves, so it needs a safeguard (the residual is monotone in P: bracketing works).

    Energy: ``stored = ∫₀^{|δ|} U`` (the part given back on unloading), dissipation
    rate ``(P − σU(|δ|)) δ̇ = (L − U)(|δ|) s(σδ̇) σδ̇ + c_v δ̇² ≥ 0`` because ``s > 0``
    only while ``σδ̇ > 0`` and ``L ≥ U`` everywhere (table checks, plus the last
    slopes ``0 ≤ U' ≤ L'`` so that it stays so beyond the table). A slow closed
    cycle ``0 → δ_m → 0`` dissipates the loop area ``∫₀^{δ_m} (L − U)`` as ``v_s → 0``
    (``tests/reduced/couplers/test_table.py``).

    Tangent: ``∂P/∂δ = U' + (L' − U') s``, ``∂P/∂δ̇ = (L − U) s' + c_v`` with
    ``s' = 1/v_s`` for ``0 ≤ σδ̇ < v_s`` and 0 outside (right derivatives at the kinks;
    checked against central differences away from them).
    """

    closure: tuple[float, ...]
    loading: tuple[float, ...]
    unloading: tuple[float, ...]
    damping: float = 0.0
    switch_velocity: float = 0.01

    FRICTION_GEAR_SLACK: ClassVar[float] = 0.0119
    """Slack (m) of :meth:`friction_gear_envelope`, for ``Coupling(slack=…)``."""

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

    def pack(self) -> tuple[list[float], list[list[float]]]:
        x, lo, un = np.array(self.closure), np.array(self.loading), np.array(self.unloading)
        rows = [x, lo, un, _cumulative_trapezoid(x, lo), _cumulative_trapezoid(x, un)]
        return [self.damping, self.switch_velocity, float(x.size)], [row.tolist() for row in rows]

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
        a slow full cycle returns 30 % of the work (friction gears give back the smaller
        part). On the solid segment unloading runs parallel to loading: the solid gear
        unloads elastically.

        The 11.9 mm slack is in the table (zero force on both curves): with a
        ``compression_only`` coupling that plateau leaves the contact guard at exactly
        zero (spurious contact/separation events); there, prefer ``Coupling(friction_gear_envelope(slack_in_table=False),
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
        return float(self.loading[-1] / self.closure[-1])

    def curves(self, closure: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """``(L, L', ∫₀L)`` and ``(U, U', ∫₀U)`` at ``|δ|`` (N, N/m, J; the curves of the
        buff side, extrapolated beyond the table)."""
        p, table = self.packed
        a = abs(float(closure))
        return curve(p, table, 1, a), curve(p, table, 2, a)


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


LAW = HystereticTable
NAMES = ("table",)

__all__ = ["HystereticTable"]
