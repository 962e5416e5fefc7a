"""What the compiled kernels are made of: the registered law modules and every source file behind them.

The stamp of the kernels' cache (:mod:`femref.impact.kernels.cache`) hashes this package's
sources and the law sources found here; nothing here imports numba, so the stamp is known
before the first kernel is decorated.
"""

from __future__ import annotations

import hashlib
import types
from collections.abc import Sequence
from functools import cache
from pathlib import Path

from reduced.couplers import COUPLER_LAWS, OPERATIONS, law_module

PACKAGE = Path(__file__).parent
"""The kernels' package folder."""

ROOT = PACKAGE.parents[2]
"""The folder femref and reduced are imported from (a checkout, or site-packages)."""

LAW_MODULES: tuple[types.ModuleType, ...] = tuple(dict.fromkeys(law_module(cls) for cls in COUPLER_LAWS.values()))
"""The registered law modules; a law's kind is its module's index here."""


def reachable_functions(functions: Sequence[types.FunctionType]) -> list[types.FunctionType]:
    """``functions`` and every plain function they call through their globals, transitively."""
    found: dict[types.FunctionType, None] = {}
    stack = list(functions)
    while stack:
        func = stack.pop()
        if func in found:
            continue
        found[func] = None
        stack += [g for name in func.__code__.co_names if isinstance(g := func.__globals__.get(name), types.FunctionType)]
    return list(found)


def engine_sources() -> list[Path]:
    """The source files of every function the compiled laws are made of (for the cache stamp)."""
    roots = [getattr(module, name) for module in LAW_MODULES for name in OPERATIONS]
    return sorted({Path(f.__code__.co_filename) for f in reachable_functions(roots)})


def stamp_name(path: Path) -> str:
    """``path`` as the stamp names it: relative to :data:`ROOT` when under it (so a wheel's compiled kernels, stamped
    where the wheel was built, match the installed package's), else absolute."""
    return path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)


@cache
def engine_stamp() -> str:
    """SHA-256 over (:func:`stamp_name`, content) of this package's ``*.py`` and of :func:`engine_sources`, once per process."""
    digest = hashlib.sha256()
    for path in sorted(set(PACKAGE.glob("*.py")) | set(engine_sources())):
        digest.update(stamp_name(path).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


__all__ = ["LAW_MODULES", "PACKAGE", "ROOT", "engine_sources", "engine_stamp", "reachable_functions", "stamp_name"]
