"""Coupler contact around a law ``F``: ``P = F(δ − slack)`` (compression), ``F(δ + tension_slack)`` (tension), 0 (open).

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

Sided gear state (bilateral with slack, a law with ``signed_state``: the draft gear).
The gear state ``x_g`` is a pack compression whose sign is the side it last engaged
(+ buff, − draft); on the open contact it relaxes, ``μ ẋ_g = −F_g(x_g)``. When the
closure passes into the other side's slack boundary with the state still of the
first side's sign, the state is mirrored::

    x_g → −x_g   when   x_g > 0 and δ + tension_slack < 0,   or   x_g < 0 and δ − slack > 0

(strict inequalities: never on the boundary itself; :meth:`Coupling.state_mirrored`). Same ``|x_g|``,
same ``∫F_g`` (F_g odd), ``P = 0`` on the open contact: no energy changes. The tension side then engages
where ``(δ + tension_slack + |x_g|)/D`` crosses zero, the force rising from zero (without the mirror it
jumped to ``−x_g/D`` and the stored ``x_g²/(2D)`` appeared from nothing). The rule applies only to a
bilateral contact with slack and a law with a signed state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from reduced import _checks

from .base import Branch, CouplerLaw, CouplerTangent

CONTACT_KINDS: tuple[str, ...] = ("compression_only", "bilateral")
"""Contact kinds: ``compression_only`` (free to roll) and ``bilateral`` (coupled)."""


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
    events. The memoryless laws drop their stored energy when a compression-only contact
    separates with ``δ − slack > 0``; the ODE driver books it as dissipated.

    :meth:`evaluate` and the guards take the law state as given; the drivers pass the sided
    state (module docstring): the ODE driver at the contact event on the boundary, the impact
    engines at the start of the step that ends beyond it.
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
    def mirrors_state(self) -> bool:
        """Bilateral with slack and a law with a signed state (``law.signed_state``): the sided-state rule applies."""
        return self.contact == "bilateral" and not self.always_engaged and bool(getattr(self.law, "signed_state", False))

    def state_mirrored(self, closure: float, state: NDArray[np.float64]) -> bool:
        """Whether the law state ``x_g = state[0]`` is to be mirrored at closure ``δ`` (module docstring)."""
        if not self.mirrors_state:
            return False
        x = float(state[0])
        return (x > 0.0 and closure + self.tension_slack < 0.0) or (x < 0.0 and closure - self.slack > 0.0)

    def sided_state(self, closure: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        """The law state at closure ``δ``: ``law.mirror_state(state)`` where :meth:`state_mirrored`, else ``state``."""
        s = np.asarray(state, dtype=float)
        return self.law.mirror_state(s) if self.state_mirrored(closure, s) else s  # type: ignore[attr-defined]

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
        if self.always_engaged or sides[0] > 0:
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
        """Force, mode, state rate and tangent with the branch and mode taken from the signs: the entry point
        for a coupler iteration outside the ODE driver. The state is taken as given (:meth:`sided_state`)."""
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


__all__ = ["CONTACT_KINDS", "CouplerResponse", "Coupling"]
