"""What a run costs and the rule that refuses it: :class:`Cost` (work units and bytes), the limits and ``FEMREF_BUDGET``
(:func:`budget_factor`), :func:`check_costs`. The predictions are :mod:`femref.run.budget`'s (models) and
:mod:`femref.run.event_budget`'s (measured scenes)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

from femref.case.errors import CaseError, Problem

#: Work units (≈ seconds on the reference machine) a scene may take.
WORK_BUDGET = 3600.0
#: Bytes of histories, fields and matrices a scene may hold.
MEMORY_BUDGET = 8e9
#: The environment variable that multiplies both limits.
BUDGET_VARIABLE = "FEMREF_BUDGET"


@dataclass
class Cost:
    """One model run's predicted work (work units) and memory (bytes), the size that drives it, and how far
    each case key it depends on lies beyond a typical run (``factors``: key → (ratio, value))."""

    model: str
    work: float
    memory: float
    size: str
    factors: dict[str, tuple[float, object]] = field(default_factory=dict)
    #: What the run is, for messages (default ``the <model> run``), and why it runs when that is not plain.
    what: str = ""
    why: str = ""

    @property
    def title(self) -> str:
        """``what``, or ``the <model> run``: how a refusal names the run."""
        return self.what or f"the {self.model} run"

    def driver(self) -> tuple[str, object]:
        """The key lying furthest beyond a typical run, and its value."""
        key = max(self.factors, key=lambda k: self.factors[k][0])
        return key, self.factors[key][1]


def budget_factor() -> float:
    """``FEMREF_BUDGET`` (default 1); a CaseError when it is not a positive number."""
    text = os.environ.get(BUDGET_VARIABLE, "").strip()
    if not text:
        return 1.0
    try:
        factor = float(text)
    except ValueError:
        factor = math.nan
    if not (math.isfinite(factor) and factor > 0.0):
        raise CaseError(Problem((), f"environment variable {BUDGET_VARIABLE} must be a positive number (a factor on the work budget)", text))
    return factor


def check_costs(costs: list[Cost], source: str = "<case>", whole: str = "the scene") -> list[Cost]:
    """Refuse when ``Σ work > WORK_BUDGET × f`` or ``Σ memory > MEMORY_BUDGET × f`` over ``costs``, every run a command
    will make (``f`` = ``FEMREF_BUDGET``; module docstring): raise :class:`CaseError` at ``source`` naming the key that
    drives the costliest run, that run (and why it runs) and its predicted size, and the total of ``whole``; return
    ``costs`` otherwise (also when empty)."""
    if not costs:
        return costs
    factor = budget_factor()
    work = sum(c.work for c in costs)
    memory = sum(c.memory for c in costs)
    if work <= WORK_BUDGET * factor and memory <= MEMORY_BUDGET * factor:
        return costs
    worst = max(costs, key=lambda c: max(c.work / WORK_BUDGET, c.memory / MEMORY_BUDGET))
    key, value = worst.driver()
    why = f" ({worst.why})" if worst.why else ""
    rule = (f"{worst.title}{why} is predicted at {worst.size} ≈ {duration_text(worst.work)} of work and {bytes_text(worst.memory)} of histories "
            f"and matrices ({whole}: {duration_text(work)}, {bytes_text(memory)}); the budget is {duration_text(WORK_BUDGET * factor)} and "
            f"{bytes_text(MEMORY_BUDGET * factor)}: reduce {key}, or raise the budget on purpose with the environment variable "
            f"{BUDGET_VARIABLE}=<factor> (now {factor:g})")
    raise CaseError(Problem(tuple(key.split(".")), rule, value), source)


def duration_text(seconds: float) -> str:
    """``5400`` s as ``1.5 h``."""
    return _in_units(seconds, (("days", 86400.0), ("h", 3600.0), ("min", 60.0), ("s", 1.0)))


def bytes_text(n: float) -> str:
    """``1.6e10`` bytes as ``16 GB``."""
    return _in_units(n, (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3), ("B", 1.0)))


def _in_units(value: float, units: tuple[tuple[str, float], ...]) -> str:
    """``value`` in the first (largest) of ``units`` it reaches, else the last."""
    unit, size = next(((unit, size) for unit, size in units if value >= size), units[-1])
    return f"{value / size:.3g} {unit}"


__all__ = ["BUDGET_VARIABLE", "MEMORY_BUDGET", "WORK_BUDGET", "Cost", "budget_factor", "bytes_text", "check_costs", "duration_text"]
