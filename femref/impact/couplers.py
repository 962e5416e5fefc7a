"""The coupler unknowns of one impact step: Newton on the coupler forces through the cars' Schur complement.

Each step, every car predicts its end motion at ``t_{n+1}`` as an affine function of its
end loads (its free end motion and 2 × 2 end gains). The coupler closures and rates
are then affine in the coupler forces ``P``,

    δ = δ_free + D_u P,     δ̇ = δ̇_free + D_v P,

with ``D_u``, ``D_v`` (n_c × n_c, tridiagonal) assembled from the cars' 2 × 2 end gains —
the Schur complement of the cars onto the coupler unknowns. Newton solves the few
coupler equations with the couplers' internal states ``s`` (draft-gear compression):

    P = T(δ, δ̇, s)                            (transmitted force, contact included)
    s = s_n + dt/2 (ṡ_n + ṡ(δ, δ̇, s, P))      (trapezoidal state update)

(semi-smooth across contact changes: the transmitted force is monotone in P, so the
iteration settles the contact mode in a few passes), with a bracketed Gauss–Seidel
fallback where a law is nearly discontinuous. A step where neither converges raises
:class:`CouplerConvergenceError` naming the coupler; the solver turns it into a failed
status with the time.

The fallback's scalar root needs a sign change of
``f(P_j) = P_j − T_j`` in its bracket. ``[P − f(P), P]`` holds one where ``f`` rises with
slope ≥ 1, but not where a table's unloading curve falls steeply (``T`` then rises as
``P`` pushes the ends apart) nor, by round-off, where ``T`` hardly depends on ``P``; the
bracket is then widened, doubling its step, until ``f`` changes sign (it must: ``f → ±∞``
as ``P → ±∞``). A stateful coupler (the draft gear) whose own Newton cycles (its force jumps
where a contact engages with the gear compressed from the other side: the safeguard for a law
that jumps) is solved the same way in ``P`` alone, its state following each trial force
through the trapezoidal state equation; ``f`` then rises with slope ≥ 1, jumps included, and
the root sits at the jump when ``T`` jumps over ``P`` (a set-valued contact force).

A bilateral draft gear with slack carries its *sided* state
(:meth:`reduced.couplers.Coupling.state_mirrored`): the step that ends beyond the other side's
slack boundary starts from the mirrored state::

    (s_n, ṡ_n) → σ (s_n, ṡ_n),   σ = −1 there, else +1
    s = σ s_n + dt/2 (σ ṡ_n + ṡ(δ, δ̇, s, P))

— exact for the open contact, whose relaxation is odd (the trapezoidal map commutes with the
mirror), and with ``σ`` taken from the trial closure it follows the iteration. The
dissipation's midpoint state is ``(s + σ s_n)/2`` likewise.

Coupler dissipation is the midpoint rule of the law's dissipation rate while the contact
mode holds and the force is the law's; on a step where the contact opens or closes, or
that starts or ends held at a jump of the law (force off the law by more than
:data:`JUMP_FRACTION` of it: :func:`held_at_jump`), it is the coupler's absorbed work
``P̄ Δδ`` less the change of its stored energy (a memoryless cushion separating while
compressed loses its stored energy — the cushion's own relaxation). Every step also adds
``P̄ Δδ`` to the coupler's ``work``: the work the cars did on it, against which their own
energy change is checked (:attr:`femref.impact.response.ImpactResponse.car_energy_balance_error`).

The iteration is compiled (:mod:`femref.impact.kernels.couplers`); here are its limits and
tolerances, the rule :func:`held_at_jump`, the failure details and :class:`CouplerConvergenceError`.
"""

from __future__ import annotations

import math

import numpy as np

from femref.scene import ImpactScene

NEWTON_ITERATIONS = 12  # then the Gauss–Seidel fallback
MAX_NEWTON_ITERATIONS = 40
MAX_SWEEPS = 200
STATE_TOLERANCE = 1e-13  # m of draft-gear travel
BRACKET_EXPANSIONS = 64  # doublings of the scalar root's bracket step before giving up
JUMP_FRACTION = 1e-6  # |P − T| above this fraction of the force: the step ends at a jump of the law


def sweeps_detail(change: float) -> str:
    """The failure detail when the Gauss–Seidel sweeps run out: ``change`` the last sweep's largest change in P (N)."""
    return f"Newton cycled and {MAX_SWEEPS} Gauss–Seidel sweeps left a change of {change:.3g} N"


def coupler_newton_detail() -> str:
    """The failure detail when a stateful coupler's own Newton cycles and its state under a held force does not settle."""
    return (
        f"Newton on its force and state did not converge in {MAX_NEWTON_ITERATIONS} iterations, "
        f"nor its state equation under a held force"
    )


def bracket_detail() -> str:
    """The failure detail when ``P − T(P)`` keeps its sign over every widening of the scalar root's bracket."""
    return f"P − T(P) kept its sign over {BRACKET_EXPANSIONS} doublings of the root's bracket"


def held_at_jump(force: float, force_residual: float, tolerance: float) -> bool:
    """``|P − T| > max(tolerance, JUMP_FRACTION · max(|P|, |T|))``: the committed force ``P`` is off the law's
    ``T`` by more than a converged root leaves (Brent's tolerance times the slope of ``P − T``), so the step
    ended at a jump of T, the contact held at its boundary, and only the absorbed work books its energy."""
    law_force = force - force_residual
    return abs(force_residual) > max(tolerance, JUMP_FRACTION * max(abs(force), abs(law_force)))


def force_tolerance(scene: ImpactScene) -> float:
    """The force tolerance (N) of the coupler iteration: ``1e-10`` of the rigid peak force.

    The largest rigid peak force ``Δv √(k M_eff)`` over the couplers sets the scale
    (``Δv`` the spread of the initial car velocities, ``k`` the coupler law's reference
    stiffness, ``M_eff`` the reduced mass of the two cars it joins), taken as at least 1 N.
    The compiled iteration (:mod:`femref.impact.kernels.couplers`) takes it from here.
    """
    rear = np.array([c.rear for c in scene.couplers])
    front = rear + 1
    velocity = np.array([car.velocity for car in scene.cars])
    masses = np.array([car.mass for car in scene.cars])
    scale = 0.0
    for j, c in enumerate(scene.couplers):
        m_eff = masses[rear[j]] * masses[front[j]] / (masses[rear[j]] + masses[front[j]])
        scale = max(scale, math.sqrt(c.coupling.law.reference_stiffness * m_eff) * float(np.ptp(velocity)))
    return 1e-10 * max(scale, 1.0)  # N: the rigid peak force v√(k M_eff) sets the scale


class CouplerConvergenceError(RuntimeError):
    """The coupler iteration did not converge on a step: ``coupler`` is the index of the worst coupler."""

    def __init__(self, coupler: int, detail: str) -> None:
        super().__init__(f"coupler {coupler}: {detail}")
        self.coupler = coupler
        self.detail = detail


__all__ = [
    "BRACKET_EXPANSIONS",
    "JUMP_FRACTION",
    "MAX_NEWTON_ITERATIONS",
    "MAX_SWEEPS",
    "NEWTON_ITERATIONS",
    "STATE_TOLERANCE",
    "CouplerConvergenceError",
    "bracket_detail",
    "coupler_newton_detail",
    "force_tolerance",
    "held_at_jump",
    "sweeps_detail",
]
