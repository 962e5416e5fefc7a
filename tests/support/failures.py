"""Make a run fail where a test wants it to: the reference engine's coupler iteration of an impact, at a chosen step."""

from __future__ import annotations

import pytest

from femref.impact.couplers import CouplerConvergenceError
from support.reference_engine import couplers


def coupler_iteration_fails_at(monkeypatch: pytest.MonkeyPatch, step: int, detail: str = "synthetic: Newton cycled") -> None:
    """From now on in this test, the ``step``-th coupler solve of a reference run raises
    :class:`femref.impact.CouplerConvergenceError` for coupler 0 (the others solve as usual)."""
    solve = couplers.CouplerSolve.solve
    calls = {"n": 0}

    def fails_at_step(self, predictions):
        calls["n"] += 1
        if calls["n"] == step:
            raise CouplerConvergenceError(0, detail)
        return solve(self, predictions)

    monkeypatch.setattr(couplers.CouplerSolve, "solve", fails_at_step)
