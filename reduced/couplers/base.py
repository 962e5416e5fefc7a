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
A law is a module ``reduced/couplers/<law>.py`` with its arithmetic written once, as plain
functions (no numba: the compiled engine, :mod:`femref.impact.kernels.laws`, jits the same
functions) on the law's packed parameter vector ``p`` and table ``table`` (a 2-D array; empty
for laws without one), the closure ``δ``, rate ``δ̇`` and state ``s`` as floats (at most one
state variable), the transmitted force ``P`` and the law's ``piece`` (an int: which smooth
piece of a piecewise law), one signature per operation (:data:`OPERATIONS`)::

    piece(p, table, δ, s, strict) -> int            from the guards' signs (strict: > 0, else >= 0)
    force(p, table, δ, δ̇, s, piece) -> P            the engaged law force (may be < 0 = tension)
    state_rate(p, table, δ, δ̇, s, P, piece) -> ṡ    given the transmitted P (0 for memoryless laws)
    tangent(p, table, δ, δ̇, s, P, piece) -> (∂P/∂δ, ∂P/∂δ̇, ∂P/∂s, ∂ṡ/∂δ, ∂ṡ/∂δ̇, ∂ṡ/∂s, ∂ṡ/∂P)
    stored_energy(p, table, δ, s, engaged, piece) -> J
    dissipation_rate(p, table, δ, δ̇, s, P, engaged, piece) -> W

plus, for a law with guards (functions whose sign selects the piece: gear open/closed, the
sign of ``δ`` for a preloaded gear), ``guards(p, table, δ, s) -> tuple`` and
``piece_of_signs(signs) -> int``. The functions may call other plain module-level
functions and ``math``; they must not allocate. The law's class is a frozen dataclass
deriving from :class:`PackedLaw` (the methods the ODE driver calls, from its ``pack()``);
the module also names ``LAW = <class>`` and ``NAMES = (<case-file names>,)`` for the
registry (:mod:`reduced.couplers.registry`).

Optionally ``signed_state = True`` and ``mirror_state(s)`` (the draft gear): the state is
one signed compression of an odd law, so that ``s → −s`` keeps its stored energy
(:meth:`reduced.couplers.Coupling.state_mirrored`).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from functools import cached_property
from types import ModuleType
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

Branch = tuple[int, ...]
"""One sign (+1/−1) per guard of a law: freezes the piece of a piecewise law."""

OPERATIONS: tuple[str, ...] = ("piece", "force", "state_rate", "tangent", "stored_energy", "dissipation_rate")
"""The functions every law module defines, one signature each (module docstring): its compiled form."""

_EMPTY = np.zeros(0)
_EMPTY2 = np.zeros((0, 0))


@dataclass(frozen=True, eq=False)
class CouplerTangent:
    """Partial derivatives of a coupler law at one point (SI units): ``force_closure = ∂P/∂δ``, ``force_rate
    = ∂P/∂δ̇``, ``force_state = ∂P/∂s``; of ``ṡ = q(δ, δ̇, s, P)``: ``rate_closure = ∂q/∂δ``, ``rate_rate =
    ∂q/∂δ̇``, ``rate_state = ∂q/∂s``, ``rate_force = ∂q/∂P``."""

    force_closure: float
    force_rate: float
    force_state: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)
    rate_closure: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)
    rate_rate: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)
    rate_state: NDArray[np.float64] = field(default_factory=lambda: _EMPTY2)
    rate_force: NDArray[np.float64] = field(default_factory=lambda: _EMPTY)

    @classmethod
    def of(cls, values: tuple[float, ...], state_size: int) -> CouplerTangent:
        """From a law's ``tangent`` 7-tuple ``(∂P/∂δ, ∂P/∂δ̇, ∂P/∂s, ∂ṡ/∂δ, ∂ṡ/∂δ̇, ∂ṡ/∂s, ∂ṡ/∂P)``."""
        fcl, frt, fst, rcl, rrt, rst, rfo = (float(v) for v in values)
        if not state_size:
            return cls(fcl, frt)
        return cls(fcl, frt, np.array([fst]), np.array([rcl]), np.array([rrt]), np.array([[rst]]), np.array([rfo]))


class CouplerLaw(Protocol):
    """What the rigid-body ODE driver and the coupler iterations need of a law object."""

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
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, engaged: bool, branch: Branch | None = None
    ) -> float: ...

    @property
    def reference_stiffness(self) -> float: ...


def guard_sign(value: float, strict: bool) -> int:
    """+1 where the guard ``value`` is positive (``> 0`` if ``strict``, else ``>= 0``), else −1."""
    positive = value > 0.0 if strict else value >= 0.0
    return 1 if positive else -1


class PackedLaw:
    """The methods of :class:`CouplerLaw` from the law module's functions on the law's packed parameters;
    ``branch`` (one sign per guard) freezes the piece, None picks it by the ``>= 0`` rule."""

    state_size: ClassVar[int] = 0
    guard_events: ClassVar[tuple[tuple[str, str], ...]] = ()

    def pack(self) -> tuple[list[float], list[list[float]]]:
        """The parameter vector ``p`` and the table (rows of equal length; ``[]`` for none)."""
        raise NotImplementedError

    @property
    def functions(self) -> ModuleType:
        """The module holding the law's arithmetic (the class's own module)."""
        return sys.modules[type(self).__module__]

    @cached_property
    def packed(self) -> tuple[tuple[float, ...], tuple[tuple[float, ...], ...]]:
        """``pack()`` as tuples of floats (what the methods pass to the functions)."""
        params, table = self.pack()
        return tuple(float(v) for v in params), tuple(tuple(float(v) for v in row) for row in table)

    def _args(self, state: Any) -> tuple[Any, Any, float]:
        p, table = self.packed
        return p, table, float(state[0]) if self.state_size else 0.0

    def _piece(self, p: Any, table: Any, closure: float, s: float, branch: Branch | None) -> int:
        if branch is None:
            return int(self.functions.piece(p, table, closure, s, False))
        signs = getattr(self.functions, "piece_of_signs", None)
        return 0 if signs is None else int(signs(tuple(branch)))

    def initial_state(self) -> NDArray[np.float64]:
        return np.zeros(self.state_size)

    def guards(self, closure: float, closure_rate: float, state: NDArray[np.float64]) -> NDArray[np.float64]:
        values = getattr(self.functions, "guards", None)
        if values is None:
            return np.zeros(0)
        p, table, s = self._args(state)
        return np.array(values(p, table, closure, s), dtype=float)

    def force(self, closure: float, closure_rate: float, state: NDArray[np.float64], branch: Branch | None = None) -> float:
        p, table, s = self._args(state)
        return float(self.functions.force(p, table, closure, closure_rate, s, self._piece(p, table, closure, s, branch)))

    def state_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> NDArray[np.float64]:
        if not self.state_size:
            return np.zeros(0)
        p, table, s = self._args(state)
        return np.array([self.functions.state_rate(p, table, closure, closure_rate, s, force, self._piece(p, table, closure, s, branch))])

    def tangent(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, branch: Branch | None = None
    ) -> CouplerTangent:
        p, table, s = self._args(state)
        values = self.functions.tangent(p, table, closure, closure_rate, s, force, self._piece(p, table, closure, s, branch))
        return CouplerTangent.of(values, self.state_size)

    def stored_energy(self, closure: float, state: NDArray[np.float64], engaged: bool, branch: Branch | None = None) -> float:
        p, table, s = self._args(state)
        return float(self.functions.stored_energy(p, table, closure, s, engaged, self._piece(p, table, closure, s, branch)))

    def dissipation_rate(
        self, closure: float, closure_rate: float, state: NDArray[np.float64], force: float, engaged: bool, branch: Branch | None = None
    ) -> float:
        p, table, s = self._args(state)
        piece = self._piece(p, table, closure, s, branch)
        return float(self.functions.dissipation_rate(p, table, closure, closure_rate, s, force, engaged, piece))


__all__ = ["OPERATIONS", "Branch", "CouplerLaw", "CouplerTangent", "PackedLaw"]
