"""The compiled coupling: contact and slack around a compiled law (:mod:`femref.impact.kernels.laws`).

:func:`evaluate_law` mirrors :meth:`reduced.couplers.Coupling.evaluate`, with its branch and
mode rule: the guards' signs are strict (``> 0`` is +1, so a guard at exactly zero counts as
negative), while a law method called with ``branch=None`` (the contact guards' law force, the
stored energy, the dissipation rate, the engaged force at t = 0) picks its piece with the
``>= 0`` rule — ``law_piece(…, strict)`` takes the rule. :func:`mirror` mirrors
:meth:`reduced.couplers.Coupling.state_mirrored` (the sided state of a bilateral law with a
signed state and slack). The entry points on ``(laws, j)`` — :func:`evaluate`,
:func:`state_mirror`, :func:`piece_of`, :func:`force_of`, :func:`stored_energy_of`,
:func:`dissipation_rate_of` — are for the tests and Python callers; the kernels take one
coupler's :class:`~femref.impact.kernels.laws.CouplerLaw`.
"""

from __future__ import annotations

import math

from numba import njit

from femref.impact.kernels.laws import (
    BILATERAL,
    law_dissipation_rate_at,
    law_force,
    law_of,
    law_piece,
    law_state_rate,
    law_stored_energy_at,
    law_tangent,
)

_JIT = dict(cache=True, _nrt=False)  # every kernel's options (femref.impact.kernels.couplers: no reference counting)


@njit(inline="always", **_JIT)
def effective_closure(law, closure, mode):
    """``δ − slack`` in compression or open, ``δ + tension_slack`` in tension (mirrors Coupling.effective_closure)."""
    if mode < 0:
        return closure + law.tension_slack
    return closure - law.slack


@njit(inline="always", **_JIT)
def mirror(law, closure, state):
    """``σ = −1.0`` where the gear state is to be mirrored at ``closure``, else ``+1.0`` (mirrors
    Coupling.state_mirrored). A step to ``closure`` starts from ``σ (s_n, ṡ_n)`` (femref.impact.couplers)."""
    if law.signed == 0 or law.contact != BILATERAL or (law.slack == 0.0 and law.tension_slack == 0.0):
        return 1.0
    if (state > 0.0 and closure + law.tension_slack < 0.0) or (state < 0.0 and closure - law.slack > 0.0):
        return -1.0
    return 1.0


@njit(inline="always", **_JIT)
def transmitted_force(law, closure, rate, state, mode, branch):
    """``P`` in the contact mode: 0 open, else the law force at the effective closure (mirrors Coupling.transmitted_force)."""
    if mode == 0:
        return 0.0
    return law_force(law, effective_closure(law, closure, mode), rate, state, branch)


@njit(**_JIT)
def evaluate_law(law, closure, rate, state):
    """The coupler of ``law`` at ``(δ, δ̇, s)``, mode and branch from the guards' strict signs (mirrors Coupling.evaluate).

    Compression (+1) iff ``min(δ − slack, F(δ − slack)) > 0``; tension (−1, bilateral with
    slack) iff not, and ``max(δ + tension_slack, F(δ + tension_slack))`` is not ``> 0``;
    bilateral without slack: always +1; else open (0). The contact guards' ``F`` take the
    ``>= 0`` piece rule, the transmitted force the strict one of the law guards at ``δ − slack``.
    Returns ``(P, mode, ṡ, ∂P/∂δ, ∂P/∂δ̇, ∂P/∂s, ∂ṡ/∂δ, ∂ṡ/∂δ̇, ∂ṡ/∂s, ∂ṡ/∂P)``, the force
    derivatives zero while open.
    """
    if not math.isfinite(closure):
        raise ValueError("closure must be finite")
    if not math.isfinite(rate):
        raise ValueError("closure_rate must be finite")
    slack, tension_slack = law.slack, law.tension_slack
    bilateral = law.contact == BILATERAL
    branch = law_piece(law, closure - slack, state, True)
    if bilateral and slack == 0.0 and tension_slack == 0.0:
        mode = 1
    else:
        dc = closure - slack
        fc = law_force(law, dc, rate, state, law_piece(law, dc, state, False))
        guard = fc if fc < dc else dc  # Python's min(dc, F)
        if guard > 0.0:
            mode = 1
        elif bilateral:
            dt = closure + tension_slack
            ft = law_force(law, dt, rate, state, law_piece(law, dt, state, False))
            guard = ft if ft > dt else dt  # Python's max(dt, F)
            mode = 0 if guard > 0.0 else -1
        else:
            mode = 0
    p = transmitted_force(law, closure, rate, state, mode, branch)
    de = effective_closure(law, closure, mode)
    state_rate = law_state_rate(law, de, rate, state, p, branch)
    fcl, frt, fst, rcl, rrt, rst, rfo = law_tangent(law, de, rate, state, p, branch)
    if mode == 0:
        fcl, frt, fst = 0.0, 0.0, 0.0
    return p, mode, state_rate, fcl, frt, fst, rcl, rrt, rst, rfo


@njit(**_JIT)
def stored_energy(law, closure, state, mode):
    """The stored energy of the coupler of ``law`` in the contact mode (mirrors CouplerSolve._stored)."""
    return law_stored_energy_at(law, effective_closure(law, closure, mode), state, mode != 0)


@njit(**_JIT)
def state_mirror(laws, j, closure, state):
    """:func:`mirror` of coupler j's law (:func:`law_of`): −1.0 where Coupling.state_mirrored, else 1.0."""
    return mirror(law_of(laws, j), closure, state)


@njit(**_JIT)
def evaluate(laws, j, closure, rate, state):
    """Coupler j at ``(δ, δ̇, s)`` (mirrors Coupling.evaluate): :func:`evaluate_law` of its law (:func:`law_of`)."""
    return evaluate_law(law_of(laws, j), closure, rate, state)


@njit(**_JIT)
def piece_of(laws, j, closure, state, strict):
    """``law_piece`` of coupler j's law (:func:`law_of`)."""
    return law_piece(law_of(laws, j), closure, state, strict)


@njit(**_JIT)
def force_of(laws, j, closure, rate, state, piece):
    """``law_force`` of coupler j's law (:func:`law_of`)."""
    return law_force(law_of(laws, j), closure, rate, state, piece)


@njit(**_JIT)
def stored_energy_of(laws, j, closure, state, engaged):
    """``law_stored_energy_at`` of coupler j's law (:func:`law_of`)."""
    return law_stored_energy_at(law_of(laws, j), closure, state, engaged)


@njit(**_JIT)
def dissipation_rate_of(laws, j, closure, rate, state, force, engaged):
    """``law_dissipation_rate_at`` of coupler j's law (:func:`law_of`)."""
    return law_dissipation_rate_at(law_of(laws, j), closure, rate, state, force, engaged)


__all__ = [
    "dissipation_rate_of",
    "effective_closure",
    "evaluate",
    "evaluate_law",
    "force_of",
    "mirror",
    "piece_of",
    "state_mirror",
    "stored_energy",
    "stored_energy_of",
    "transmitted_force",
]
