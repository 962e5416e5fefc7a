"""Coupler-law interface: ``P = P(δ, δ̇, s)`` (N, compression positive), ``ṡ = q(δ, δ̇, s, P)``.

Sign conventions (docs/design.md §2, §8)
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
* ``guard_events`` — names of the events when each guard turns positive/negative;
* optionally ``signed_state = True`` and ``mirror_state(s)`` (the draft gear): the state is
  one signed compression (``s > 0`` buff, ``s < 0`` draft) of an odd law, so that
  mirroring it, ``s → −s``, keeps its stored energy and commutes with its relaxation
  while the contact is open. A bilateral contact with slack mirrors it when the open
  contact passes into the other side (:meth:`reduced.couplers.Coupling.state_mirrored`);
  laws without the attribute are never mirrored.

Here: :class:`CouplerTangent`, the :class:`CouplerLaw` protocol, the ``Branch`` type
and ``select_branch``, the branch helper of the piecewise laws.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

Branch = tuple[int, ...]
"""One sign (+1/−1) per guard of a law: freezes the piece of a piecewise law."""

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


def select_branch(guards: NDArray[np.float64], branch: Branch | None) -> Branch:
    """The frozen branch, or the signs of the guards (a zero counts as positive)."""
    if branch is not None:
        return branch
    return tuple(1 if g >= 0.0 else -1 for g in guards)


__all__ = ["Branch", "CouplerLaw", "CouplerTangent"]
