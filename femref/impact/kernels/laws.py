"""The coupler laws compiled: each law module's functions jitted unchanged, one dispatcher per operation.

The laws' arithmetic lives once, as plain functions, in their modules of
:mod:`reduced.couplers` (interface in :mod:`reduced.couplers.base`). Here every function of
:data:`~reduced.couplers.base.OPERATIONS` of every registered law module
(:data:`reduced.couplers.COUPLER_LAWS`) is jitted — a copy of the function whose globals map
the plain functions it calls to their jitted copies (:func:`jitted`), so the law module never
imports numba — and one dispatcher per operation is generated from the registry: an if-chain
on :attr:`CouplerLaw.kind`, the law module's index in :data:`LAW_MODULES`. No law is named here.

The dispatchers take one coupler's :class:`CouplerLaw` (:func:`law_of`: its scalars and its
rows of :class:`CouplerLaws`) and pass the law functions its parameter row and table::

    law_piece(law, δ, s, strict)                  law_force(law, δ, δ̇, s, piece)
    law_state_rate(law, δ, δ̇, s, P, piece)        law_tangent(law, δ, δ̇, s, P, piece)
    law_stored_energy(law, δ, s, engaged, piece)  law_dissipation_rate(law, δ, δ̇, s, P, engaged, piece)

and are inlined into their callers (``inline="always"``: a call copies every array of its
arguments, :mod:`femref.impact.kernels.couplers`). :func:`pack_laws` packs a scene's couplings
into :class:`CouplerLaws`; ``laws.params[j]`` is the law's ``pack()`` vector, ``laws.table[j]``
its table (both zero-padded to the widest law).

numba's on-disk cache checks only the file of a cached function, and the generated
dispatchers and the law copies have none: the cached kernels that call them are kept true by
the stamp over :func:`~femref.impact.kernels.sources.engine_sources` (:mod:`femref.impact.kernels.cache`).
"""

from __future__ import annotations

import types
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from femref.impact.couplers import BRACKET_EXPANSIONS, JUMP_FRACTION, MAX_NEWTON_ITERATIONS, MAX_SWEEPS, NEWTON_ITERATIONS, STATE_TOLERANCE
from femref.impact.kernels.sources import LAW_MODULES, engine_sources, reachable_functions
from reduced.couplers import CONTACT_KINDS, OPERATIONS, Coupling, compiled_form_rule, law_module

_JIT = dict(cache=True, _nrt=False)  # every cached kernel's options (femref.impact.kernels.couplers: no reference counting)

COMPRESSION_ONLY, BILATERAL = 0, 1
"""Values of :attr:`CouplerLaws.contact` (the order of :data:`reduced.couplers.CONTACT_KINDS`)."""

ARGUMENTS = {
    "piece": "closure, state, strict",
    "force": "closure, rate, state, piece",
    "state_rate": "closure, rate, state, transmitted, piece",
    "tangent": "closure, rate, state, transmitted, piece",
    "stored_energy": "closure, state, engaged, piece",
    "dissipation_rate": "closure, rate, state, transmitted, engaged, piece",
}
"""Each operation's arguments after the law's ``(p, table)``: its one signature (reduced.couplers.base)."""


def jitted(func: types.FunctionType, done: dict) -> object:
    """A numba copy of the plain ``func`` whose globals map the plain functions it calls to their copies."""
    if func in done:
        return done[func]
    namespace = dict(func.__globals__)
    copy = types.FunctionType(func.__code__, namespace, func.__name__, func.__defaults__, func.__closure__)
    done[func] = compiled = njit(_nrt=False)(copy)
    for name in func.__code__.co_names:
        if isinstance(callee := namespace.get(name), types.FunctionType):
            namespace[name] = jitted(callee, done)
    return compiled


def _dispatcher(operation: str, modules: Sequence[types.ModuleType], done: dict) -> object:
    """``law_<operation>(law, …)``: an if-chain on ``law.kind`` calling each module's jitted function."""
    arguments = ARGUMENTS[operation]
    call = f"(law.params, law.table, {arguments})"
    lines = [f"def law_{operation}(law, {arguments}):", "    kind = law.kind"]
    for kind in range(len(modules) - 1):
        lines += [f"    if kind == {kind}:", f"        return law{kind}{call}"]
    lines.append(f"    return law{len(modules) - 1}{call}")
    namespace = {f"law{kind}": jitted(getattr(module, operation), done) for kind, module in enumerate(modules)}
    exec("\n".join(lines), namespace)  # noqa: S102 (generated from the registry above, no outside text)
    return njit(inline="always", _nrt=False)(namespace[f"law_{operation}"])


_DONE: dict = {}
law_piece, law_force, law_state_rate, law_tangent, law_stored_energy, law_dissipation_rate = (
    _dispatcher(operation, LAW_MODULES, _DONE) for operation in OPERATIONS
)


class CouplerLaws(NamedTuple):
    """The scene's coupler laws and contacts as arrays (constant)."""

    kind: NDArray[np.int64]  # (n,) index of the law's module in LAW_MODULES
    contact: NDArray[np.int64]  # (n,) 0 compression_only, 1 bilateral
    slack: NDArray[np.float64]  # (n,) m
    tension_slack: NDArray[np.float64]  # (n,) m
    signed: NDArray[np.int64]  # (n,) 1 if the law's state is signed (law.signed_state: mirrored across the slack)
    stateful: NDArray[np.int64]  # (n,) 1 if the law carries one state variable (the draft gear's x_g), else 0
    params: NDArray[np.float64]  # (n, P) the laws' pack() vectors, zero-padded
    initial_state: NDArray[np.float64]  # (n,) the law's initial state (0 for stateless laws)
    table: NDArray[np.float64]  # (n, R, M) the laws' tables, zero-padded
    limits: NDArray[np.int64]  # (4,) NEWTON_ITERATIONS, MAX_NEWTON_ITERATIONS, MAX_SWEEPS, BRACKET_EXPANSIONS
    state_tolerance: NDArray[np.float64]  # (1,) STATE_TOLERANCE (m)
    jump_fraction: NDArray[np.float64]  # (1,) JUMP_FRACTION (femref.impact.couplers.held_at_jump)
    state_row: NDArray[np.int64]  # (n,) row of the coupler's state among the Newton unknowns (P, s); −1 stateless


class CouplerLaw(NamedTuple):
    """Coupler j's law and contact (:func:`law_of`): scalars and views of :class:`CouplerLaws`' rows."""

    kind: int
    contact: int
    slack: float
    tension_slack: float
    signed: int
    params: NDArray[np.float64]  # (P,) row j of CouplerLaws.params
    table: NDArray[np.float64]  # (R, M) table j


@njit(**_JIT)
def law_of(laws, j):
    """Coupler j's :class:`CouplerLaw` (the kernels pass it rather than ``laws`` and ``j``: a few words, not all
    the arrays). Its arrays are views without a reference of their own: for kernels compiled without reference
    counting only (:mod:`femref.impact.kernels.couplers`)."""
    return CouplerLaw(laws.kind[j], laws.contact[j], laws.slack[j], laws.tension_slack[j], laws.signed[j], laws.params[j], laws.table[j])


def pack_laws(couplings: Sequence[Coupling]) -> CouplerLaws:
    """The laws and contacts of ``couplings`` as :class:`CouplerLaws` (ValueError for a law without a compiled form).

    The iteration limits and the state tolerance travel here (from :mod:`femref.impact.couplers`): a cached
    compilation would keep stale compile-time constants.
    """
    n = len(couplings)
    laws = [c.law for c in couplings]
    for j, law in enumerate(laws):
        rule = compiled_form_rule(type(law))
        if rule is None and law_module(type(law)) not in LAW_MODULES:
            rule = f"law {type(law).__name__} was registered after the compiled engine was built"
        if rule is not None:
            raise ValueError(f"coupler {j}: {rule}")
    packed = [law.packed for law in laws]
    params = np.zeros((n, max((len(p) for p, _ in packed), default=1)))
    rows = max((len(t) for _, t in packed), default=0)
    table = np.zeros((n, max(rows, 1), max((len(r) for _, t in packed for r in t), default=1)))
    for j, (p, t) in enumerate(packed):
        params[j, : len(p)] = p
        for r, values in enumerate(t):
            table[j, r, : len(values)] = values
    state_row = np.full(n, -1, dtype=np.int64)
    m = n
    for j, law in enumerate(laws):
        if law.state_size:
            state_row[j] = m
            m += 1
    return CouplerLaws(
        kind=np.array([LAW_MODULES.index(law_module(type(law))) for law in laws], dtype=np.int64),
        contact=np.array([CONTACT_KINDS.index(c.contact) for c in couplings], dtype=np.int64),
        slack=np.array([c.slack for c in couplings], dtype=float),
        tension_slack=np.array([c.tension_slack for c in couplings], dtype=float),
        signed=np.array([bool(getattr(law, "signed_state", False)) for law in laws], dtype=np.int64),
        stateful=np.array([law.state_size for law in laws], dtype=np.int64),
        params=params,
        initial_state=np.array([float(law.initial_state()[0]) if law.state_size else 0.0 for law in laws]),
        table=table,
        limits=np.array([NEWTON_ITERATIONS, MAX_NEWTON_ITERATIONS, MAX_SWEEPS, BRACKET_EXPANSIONS], dtype=np.int64),
        state_tolerance=np.array([STATE_TOLERANCE]),
        jump_fraction=np.array([JUMP_FRACTION]),
        state_row=state_row,
    )


@njit(**_JIT)
def law_stored_energy_at(law, closure, state, engaged):
    """The law's stored energy at the law closure, its piece by the ``>= 0`` rule (as ``branch=None``)."""
    return law_stored_energy(law, closure, state, engaged, law_piece(law, closure, state, False))


@njit(**_JIT)
def law_dissipation_rate_at(law, closure, rate, state, force, engaged):
    """The law's dissipation rate, its piece by the ``>= 0`` rule (as ``branch=None``)."""
    return law_dissipation_rate(law, closure, rate, state, force, engaged, law_piece(law, closure, state, False))


__all__ = [
    "ARGUMENTS",
    "BILATERAL",
    "COMPRESSION_ONLY",
    "CouplerLaw",
    "CouplerLaws",
    "LAW_MODULES",
    "engine_sources",
    "jitted",
    "law_dissipation_rate",
    "law_dissipation_rate_at",
    "law_force",
    "law_of",
    "law_piece",
    "law_state_rate",
    "law_stored_energy",
    "law_stored_energy_at",
    "law_tangent",
    "pack_laws",
    "reachable_functions",
]
