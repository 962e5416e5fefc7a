"""The coupler-law registry: :data:`COUPLER_LAWS` (case-file name → law class), found in the law modules.

Every module of this package that names a law — ``LAW = <class>`` and ``NAMES = (<case-file
names>,)`` (:mod:`reduced.couplers.base`) — is registered, in module-name order, so a new law
is one module. :func:`compiled_form_rule` says why a law class has no compiled form (its module
lacks a function of :data:`reduced.couplers.base.OPERATIONS`, or it carries more than one state
variable); :func:`coupling_from_name` builds a :class:`Coupling` from a registry name.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
import types
from pathlib import Path

from reduced import _checks

from .base import OPERATIONS
from .coupling import Coupling


def _law_modules() -> list[types.ModuleType]:
    package = __name__.rpartition(".")[0]
    found = []
    for info in sorted(pkgutil.iter_modules([str(Path(__file__).parent)]), key=lambda m: m.name):
        module = importlib.import_module(f"{package}.{info.name}")
        if hasattr(module, "LAW") and hasattr(module, "NAMES"):
            found.append(module)
    return found


COUPLER_LAWS: dict[str, type] = {name: module.LAW for module in _law_modules() for name in module.NAMES}
"""Case-file name → law class (the schema and its error messages share this map; ``draft_gear`` and
``standard_linear`` both name :class:`reduced.couplers.StandardLinearDraftGear`)."""


def law_module(law_class: type) -> types.ModuleType:
    """The module that holds ``law_class``'s functions (the one defining it)."""
    return sys.modules[law_class.__module__]


def compiled_form_rule(law_class: type) -> str | None:
    """Why ``law_class`` cannot be compiled, or None: it carries at most one state variable, its module defines
    every function of :data:`~reduced.couplers.base.OPERATIONS` as a plain function, and it is registered."""
    size = getattr(law_class, "state_size", 0)
    if not isinstance(size, int) or size > 1:
        return f"law {law_class.__name__} carries {size} state variables; the compiled coupler iteration handles at most one"
    module = law_module(law_class)
    missing = [name for name in OPERATIONS if not isinstance(getattr(module, name, None), types.FunctionType)]
    if missing:
        return (
            f"law {law_class.__name__} has no compiled form: its module {module.__name__} lacks the plain "
            f"function{'s' if len(missing) > 1 else ''} {', '.join(missing)} (a law module defines {', '.join(OPERATIONS)})"
        )
    if law_class not in COUPLER_LAWS.values():
        return f"law {law_class.__name__} is not registered: its module {module.__name__} names no LAW and NAMES (reduced.couplers.registry)"
    return None


def coupling_from_name(name: str, parameters: dict[str, float], **contact: float | str) -> Coupling:
    """Build a :class:`Coupling` from a registry name and law parameters (case-file form)."""
    _checks.choice("coupler law", name, tuple(COUPLER_LAWS))
    law = COUPLER_LAWS[name](**parameters)
    return Coupling(law, **contact)  # type: ignore[arg-type]


__all__ = ["COUPLER_LAWS", "compiled_form_rule", "coupling_from_name", "law_module"]
