"""Two rigid cars through a nonlinear coupler: stiff ODE with contact and closure events.

docs/formulas.md §A3–A4. State ``y = (δ, δ̇, x_c, v_c, s, E_d, W_e)`` with the closure
``δ = x1 − x2``, the centre of mass ``x_c``, the coupler law's internal state ``s``
(the draft gear's ``x_g``), the dissipated energy ``E_d`` and the external work
``W_e``::

    m1 ẍ1 = f1(t) − P,   m2 ẍ2 = f2(t) + P          (P: coupler force, compression +)
    δ̈ = (f1 − P)/m1 − (f2 + P)/m2,   M v̇_c = f1 + f2
    ṡ = q(δ_e, δ̇, s, P),   Ė_d = dissipation rate,   Ẇ_e = f1 v1 + f2 v2

Working with ``δ`` instead of ``x1``, ``x2`` keeps the closure accurate to its own
tolerance however far the cars roll. The force comes from a
:class:`reduced.couplers.Coupling` (law + contact + slack).

Events and restarts. Every guard of the coupling is a terminal ``solve_ivp`` event watching
the crossing *out of* its current side; between events the law's piece and the contact
mode are frozen, so each segment is smooth. At an event the sides of all guards are
re-read a tiny step (1e-9 of the coupler's time scale) ahead, so guards crossing at the
same instant switch together, and the integration restarts (:class:`ImpactEvent`).

Sided gear state: where an open contact passes into the other side's slack boundary with
the gear still compressed from the first side, ``x_g → −x_g``
(:meth:`reduced.couplers.Coupling.state_mirrored`, a ``gear_mirrored`` event), so the
other side engages continuously; the mirror keeps ``|x_g|`` and ``∫F_g``, so the energy
books are unchanged by it.

Solver: ``LSODA`` by default (the draft gear's series springs make the problem stiff:
``μD`` ≈ 1e-3 s against a 0.1 s pulse; 8–30× fewer evaluations than ``Radau`` here),
tolerances in :class:`IntegratorSettings`. Verified: ``tests/reduced/test_nonlinear.py``
(the closed form of :mod:`reduced.rigid`, the energy balance, a brute-force gear closure,
no tension through a compression-only contact).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from reduced import _checks
from reduced.couplers import Branch, Coupling
from reduced.history import TwoMassHistory
from reduced.rigid import ImpactPair

ExternalForce = Callable[[float], tuple[float, float]]
"""``t ↦ (f_hammer, f_anvil)`` (N, positive along the direction of travel)."""

SOLVER_METHODS: tuple[str, ...] = ("Radau", "BDF", "LSODA", "DOP853", "RK45")


@dataclass(frozen=True)
class IntegratorSettings:
    """``solve_ivp`` settings. Tolerances: ``rtol`` relative; absolute per component
    (closure m, speeds m/s, centre-of-mass position m, energies J); ``max_segments``
    caps the number of event restarts (chattering is reported, not looped on)."""

    method: str = "LSODA"
    rtol: float = 1e-10
    closure_atol: float = 1e-13
    velocity_atol: float = 1e-12
    position_atol: float = 1e-10
    energy_atol: float = 1e-6
    max_step: float = math.inf
    max_segments: int = 500

    def __post_init__(self) -> None:
        _checks.choice("method", self.method, SOLVER_METHODS)
        _checks.positive("rtol", self.rtol)
        for name in ("closure_atol", "velocity_atol", "position_atol", "energy_atol", "max_step"):
            v = float(getattr(self, name))
            if not v > 0.0:
                raise ValueError(f"{name} must be > 0, got {v!r}")
        if int(self.max_segments) < 1:
            raise ValueError(f"max_segments must be >= 1, got {self.max_segments!r}")


@dataclass(frozen=True)
class ImpactEvent:
    """A mode change: ``kind`` (contact, separation, gear_closed, …, and ``gear_mirrored`` where a
    bilateral gear's state is mirrored at the other side's slack boundary), ``time`` (s),
    ``closure`` δ (m), the coupler force just after it (N, compression +) and the
    coupler law's internal state there (e.g. the gear compression ``x_g``, m)."""

    kind: str
    time: float
    closure: float
    coupler_force: float
    coupler_state: tuple[float, ...] = ()


@dataclass(frozen=True, eq=False)
class ImpactSimulation(TwoMassHistory):
    """Result of :func:`simulate_impact`: the :class:`~reduced.history.TwoMassHistory` and what the ODE
    driver adds: ``coupler_state`` (Nt, n_state); energies (J); ``status`` ``"ok"`` or ``"failed"`` with
    ``message`` (samples after a failure are NaN); work counters; ``settings`` as a dict."""

    coupler_state: NDArray[np.float64]
    kinetic_energy: NDArray[np.float64]
    stored_energy: NDArray[np.float64]
    dissipated_energy: NDArray[np.float64]
    external_work: NDArray[np.float64]
    events: tuple[ImpactEvent, ...]
    status: str
    message: str
    nfev: int
    njev: int
    nlu: int
    segments: int
    wall_time_s: float
    settings: dict[str, object]

    def event_times(self, kind: str) -> tuple[float, ...]:
        """Times (s) of all events of ``kind``."""
        return tuple(e.time for e in self.events if e.kind == kind)

    @property
    def closure_time(self) -> float | None:
        """First gear closure (s), None if the gear never closed."""
        times = self.event_times("gear_closed")
        return times[0] if times else None

    @property
    def energy_residual(self) -> NDArray[np.float64]:
        """``KE + stored + E_d − W_e − KE(0)`` (J): zero up to the integration error."""
        total = self.kinetic_energy + self.stored_energy + self.dissipated_energy - self.external_work
        return total - total[0]


class _Model:
    """The right-hand side, guards and outputs for one pair and coupling (internal)."""

    def __init__(self, pair: ImpactPair, coupling: Coupling, external_force: ExternalForce | None) -> None:
        self.pair = pair
        self.coupling = coupling
        self.law = coupling.law
        self.n = self.law.state_size
        self.external = external_force
        self.m1, self.m2, self.mt = pair.hammer_mass, pair.anvil_mass, pair.total_mass

    def forces(self, t: float) -> tuple[float, float]:
        if self.external is None:
            return 0.0, 0.0
        f1, f2 = self.external(t)
        f1, f2 = float(f1), float(f2)
        if not (math.isfinite(f1) and math.isfinite(f2)):
            raise ValueError(f"external_force returned non-finite values at t = {t!r}: ({f1!r}, {f2!r})")
        return f1, f2

    def split(self, sides: Branch) -> tuple[int, Branch]:
        return self.coupling.split_branch(sides)

    def coupler(self, y: NDArray[np.float64], sides: Branch) -> tuple[float, float, int, Branch]:
        """Transmitted force, effective closure, mode and law branch at state ``y``."""
        mode, branch = self.split(sides)
        d, dd, s = y[0], y[1], y[4 : 4 + self.n]
        p = self.coupling.transmitted_force(d, dd, s, mode, branch)
        return p, self.coupling.effective_closure(d, mode), mode, branch

    def rhs(self, t: float, y: NDArray[np.float64], sides: Branch) -> NDArray[np.float64]:
        p, de, mode, branch = self.coupler(y, sides)
        f1, f2 = self.forces(t)
        d_rate, vc = y[1], y[3]
        s = y[4 : 4 + self.n]
        a1 = (f1 - p) / self.m1
        a2 = (f2 + p) / self.m2
        v1 = vc + (self.m2 / self.mt) * d_rate
        v2 = vc - (self.m1 / self.mt) * d_rate
        out = np.empty_like(y)
        out[0] = d_rate
        out[1] = a1 - a2
        out[2] = vc
        out[3] = (f1 + f2) / self.mt
        out[4 : 4 + self.n] = self.law.state_rate(de, d_rate, s, p, branch)
        out[4 + self.n] = self.law.dissipation_rate(de, d_rate, s, p, mode != 0, branch)
        out[5 + self.n] = f1 * v1 + f2 * v2
        return out

    def guards(self, y: NDArray[np.float64], sides: Branch) -> NDArray[np.float64]:
        _, branch = self.split(sides)
        return self.coupling.guards(y[0], y[1], y[4 : 4 + self.n], branch)

    def stored(self, y: NDArray[np.float64], sides: Branch) -> float:
        _, de, mode, branch = self.coupler(y, sides)
        return self.law.stored_energy(de, y[4 : 4 + self.n], mode != 0, branch)

    def resolve_sides(self, t: float, y: NDArray[np.float64], provisional: Branch, h: float) -> Branch:
        """Guard signs at ``y``, looking a tiny step ``h`` ahead for guards at (or within
        rounding of) zero: a guard that is crossing at ``y`` takes the side it is moving
        into, so it cannot fire again at the restart; simultaneous crossings are
        resolved together."""
        sides = provisional
        for _ in range(2):
            g0 = self.guards(y, sides)
            gh = self.guards(y + h * self.rhs(t, y, sides), sides)
            sides = tuple(
                int(np.sign(b)) if b != 0.0 else (int(np.sign(a)) if a != 0.0 else s) for a, b, s in zip(g0, gh, sides)
            )
        return sides


def simulate_impact(
    pair: ImpactPair,
    coupling: Coupling,
    time: ArrayLike,
    *,
    external_force: ExternalForce | None = None,
    settings: IntegratorSettings | None = None,
) -> ImpactSimulation:
    """Integrate the two-car impact through ``coupling`` and sample it at ``time``.

    Impact (``δ = 0``) at ``t = 0``, speeds from ``pair``; ``time`` (s) increasing, ``time[0] ≥ 0``.
    ``external_force`` adds e.g. a locomotive's push. Solver failures and chattering (more than
    ``settings.max_segments`` restarts) come back as ``status='failed'``; samples not reached are NaN.
    """
    settings = IntegratorSettings() if settings is None else settings
    t_out = _checks.time_grid("time", time, min_length=1)
    if t_out[0] < 0.0:
        raise ValueError(f"time must start at or after the impact (t >= 0), got time[0] = {t_out[0]!r}")
    t_end = float(t_out[-1])
    if t_end <= 0.0:
        raise ValueError("time must end after t = 0")
    model = _Model(pair, coupling, external_force)
    n = model.n
    y0 = np.concatenate(
        [[0.0, pair.closing_speed, 0.0, pair.centre_of_mass_speed], coupling.law.initial_state(), [0.0, 0.0]]
    )
    atol = np.concatenate(
        [
            [settings.closure_atol, settings.velocity_atol, settings.position_atol, settings.velocity_atol],
            np.full(n, settings.closure_atol),
            [settings.energy_atol, settings.energy_atol],
        ]
    )
    t_char = math.sqrt(pair.reduced_mass / coupling.law.reference_stiffness)
    names = coupling.guard_events
    start = _time.perf_counter()
    h_look = 1e-9 * t_char
    g_start = model.guards(y0, tuple(1 for _ in names))
    sides = model.resolve_sides(0.0, y0, tuple(1 if g > 0.0 else -1 for g in g_start), h_look)
    events: list[ImpactEvent] = []
    if not coupling.always_engaged and model.split(sides)[0] != 0:
        events.append(ImpactEvent("contact", 0.0, 0.0, float(model.coupler(y0, sides)[0]), tuple(float(v) for v in y0[4 : 4 + n])))
    segments: list[tuple[float, float, object, Branch]] = []
    nfev = njev = nlu = 0
    status, message = "ok", "integration reached the end time"
    t0 = 0.0
    while True:
        if len(segments) >= settings.max_segments:
            status = "failed"
            message = f"more than {settings.max_segments} contact/closure events before t = {t0:.6g} s (chattering?)"
            break

        def fun(t: float, y: NDArray[np.float64], sides: Branch = sides) -> NDArray[np.float64]:
            return model.rhs(t, y, sides)

        event_functions = []
        for i, side in enumerate(sides):

            def event(t: float, y: NDArray[np.float64], i: int = i, sides: Branch = sides) -> float:
                return float(model.guards(y, sides)[i])

            event.terminal = True  # type: ignore[attr-defined]
            event.direction = -float(side)  # type: ignore[attr-defined]
            event_functions.append(event)
        sol = solve_ivp(
            fun,
            (t0, t_end),
            y0,
            method=settings.method,
            rtol=settings.rtol,
            atol=atol,
            max_step=settings.max_step,
            events=event_functions or None,
            dense_output=True,
        )
        nfev += int(sol.nfev)
        njev += int(sol.njev)
        nlu += int(sol.nlu)
        segments.append((t0, float(sol.t[-1]), sol.sol, sides))
        if sol.status == -1:
            status, message = "failed", f"solve_ivp failed at t = {sol.t[-1]:.6g} s: {sol.message}"
            break
        if sol.status != 1:
            break
        te = float(sol.t[-1])
        ye = sol.y[:, -1].copy()
        # the terminal event is the one whose last root is the stopping time
        last_roots = [float(sol.t_events[i][-1]) if sol.t_events[i].size else -math.inf for i in range(len(sides))]
        fired = int(np.argmin([abs(r - te) for r in last_roots]))
        flipped = tuple(-s if k == fired else s for k, s in enumerate(sides))
        stored_before = model.stored(ye, sides)
        # the sided gear state: an open contact passing into the other side's slack boundary with the
        # gear compressed from the first side mirrors it, x_g → −x_g (Coupling.state_mirrored), decided
        # a tiny step ahead like the sides (the stale state puts the contact guard's zero on the boundary)
        mirrored = coupling.state_mirrored(float(ye[0] + h_look * ye[1]), ye[4 : 4 + n])
        if mirrored:
            ye[4 : 4 + n] = coupling.sided_state(float(ye[0] + h_look * ye[1]), ye[4 : 4 + n])
        new_sides = model.resolve_sides(te, ye, flipped, h_look)
        # memoryless laws drop their stored energy at a separation: book it as dissipated (the mirror keeps it)
        ye[4 + n] += stored_before - model.stored(ye, new_sides)
        force_after = float(model.coupler(ye, new_sides)[0])
        state_after = tuple(float(v) for v in ye[4 : 4 + n])
        if mirrored:
            events.append(ImpactEvent("gear_mirrored", te, float(ye[0]), force_after, state_after))
        for k, (old, new) in enumerate(zip(sides, new_sides)):
            if old != new:
                kind = names[k][0] if new > 0 else names[k][1]
                events.append(ImpactEvent(kind, te, float(ye[0]), force_after, state_after))
        t0, y0, sides = te, ye, new_sides
        if t0 >= t_end:
            break
    wall = _time.perf_counter() - start
    return _collect(model, t_out, segments, events, status, message, nfev, njev, nlu, wall, settings)


def _collect(
    model: _Model,
    t_out: NDArray[np.float64],
    segments: list[tuple[float, float, object, Branch]],
    events: list[ImpactEvent],
    status: str,
    message: str,
    nfev: int,
    njev: int,
    nlu: int,
    wall: float,
    settings: IntegratorSettings,
) -> ImpactSimulation:
    """Sample the segments at ``t_out`` and derive forces, accelerations and energies."""
    n = model.n
    nt = t_out.size
    y = np.full((6 + n, nt), np.nan)
    force, a1, a2, stored = (np.full(nt, np.nan) for _ in range(4))
    filled = np.zeros(nt, dtype=bool)
    for k, (ta, tb, dense, sides) in enumerate(segments):
        last = k == len(segments) - 1
        mask = (t_out >= ta) & ((t_out <= tb) if last else (t_out < tb)) & ~filled
        if not np.any(mask) or dense is None:
            continue
        ys = np.atleast_2d(dense(t_out[mask]))  # type: ignore[operator]
        if ys.shape[0] != 6 + n:
            ys = ys.T
        y[:, mask] = ys
        for j, idx in enumerate(np.flatnonzero(mask)):
            yj = ys[:, j]
            p = model.coupler(yj, sides)[0]
            f1, f2 = model.forces(float(t_out[idx]))
            force[idx] = p
            a1[idx] = (f1 - p) / model.m1
            a2[idx] = (f2 + p) / model.m2
            stored[idx] = model.stored(yj, sides)
        filled |= mask
    if status == "ok" and not np.all(filled):
        status, message = "failed", "some output times were not reached"
    d, dd, xc, vc = y[0], y[1], y[2], y[3]
    m1, m2, mt = model.m1, model.m2, model.mt
    kinetic = 0.5 * mt * vc**2 + 0.5 * model.pair.reduced_mass * dd**2
    separation = next((e.time for e in events if e.kind == "separation"), None)
    return ImpactSimulation(
        time=t_out,
        relative_displacement=-d,
        relative_velocity=-dd,
        relative_acceleration=a2 - a1,
        hammer_displacement=xc + (m2 / mt) * d,
        hammer_velocity=vc + (m2 / mt) * dd,
        hammer_acceleration=a1,
        anvil_displacement=xc - (m1 / mt) * d,
        anvil_velocity=vc - (m1 / mt) * dd,
        anvil_acceleration=a2,
        coupler_force=force,
        separation_time=separation,
        model=f"nonlinear_ode[{type(model.law).__name__}, {model.coupling.contact}]",
        coupler_state=y[4 : 4 + n].T.copy(),
        kinetic_energy=kinetic,
        stored_energy=stored,
        dissipated_energy=y[4 + n],
        external_work=y[5 + n],
        events=tuple(events),
        status=status,
        message=message,
        nfev=nfev,
        njev=njev,
        nlu=nlu,
        segments=len(segments),
        wall_time_s=wall,
        settings=asdict(settings),
    )


__all__ = [
    "SOLVER_METHODS",
    "ExternalForce",
    "ImpactEvent",
    "ImpactSimulation",
    "IntegratorSettings",
    "simulate_impact",
]
