"""Choose the cheapest model expected to meet a tolerance: climb the ladder, estimating as it goes.

:func:`choose_model` takes the rungs of :func:`femref.choice.ladder.model_ladder` cheapest
first. For each it runs the rung and its Richardson partner (if not run yet), then
estimates the error of every run so far (:mod:`femref.choice.estimates`):

* the two terms of the expansion in ε (:attr:`femref.choice.ladder.Ladder.expansion`: rigid,
  quasi-rigid): ``SAFETY`` times the asymptotic estimates from their difference and
  ``ε_load`` of the zeroth-order run's coupler forces, plus (peak output) the peak's
  sampling error at their step, when ``ε_load ≤ EPS_LOAD_VALID``;
* every other rung: Richardson against the partner (e.g. ``2k`` modes, ``2n`` elements at
  half the step), ``SAFETY/(1 − 2^−p)·Δ``; the finest of a family against the one below,
  ``SAFETY/(2^p − 1)·Δ``;
* then every run through every run with a smaller estimate, ``d(i, j) + e_j``, until
  nothing changes.

The climb stops at the first rung after which some run has an estimate within the
tolerance; the choice is the cheapest such run (possibly cheaper than the rung that
stopped the climb: a rigid run is priced once a fem run exists). When no run meets the
tolerance the whole ladder has run and the choice is the run with the smallest
estimate, marked ``met = False``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from femref.choice.estimates import (
    ASSUMED_ORDER,
    EPS_LOAD_VALID,
    OUTPUTS,
    SAFETY,
    asymptotic_errors,
    hierarchical_bound,
    load_epsilon,
    output_distance,
    peak_sampling_error,
    richardson_error,
)
from femref.choice.ladder import Ladder, Rung, check_ladder_budget, model_ladder
from femref.results import ModelResult
from femref.run import load_compiled_loop, run_model
from femref.scene import ImpactScene

__all__ = ["DEFAULT_OUTPUT", "ModelChoice", "RungEstimate", "choose_model", "run_rung"]

DEFAULT_OUTPUT = "peak_coupler_force"

Runner = Callable[[Rung], ModelResult]


@dataclass
class RungEstimate:
    """A rung, its run (None when the climb did not need it), its error estimate (inf: none) and how it was made."""

    rung: Rung
    result: ModelResult | None = None
    estimate: float = math.inf
    basis: str = "not run"

    @property
    def ran(self) -> bool:
        return self.result is not None and self.result.ok


@dataclass
class ModelChoice:
    """The outcome of a choice: every rung of the ladder with its estimate, the chosen label, whether it meets the tolerance."""

    tolerance: float
    output: str
    ladder: Ladder
    rows: list[RungEstimate]
    chosen: str
    met: bool
    epsilon_load: float

    @property
    def chosen_row(self) -> RungEstimate:
        return next(row for row in self.rows if row.rung.label == self.chosen)

    @property
    def results(self) -> list[ModelResult]:
        """Every run made (failed ones too), cheapest rung first."""
        return [row.result for row in self.rows if row.result is not None]


def run_rung(rung: Rung, progress: Callable[[int, int], None] | None = None) -> ModelResult:
    """Step the rung's scene at its step; a failure is returned as a failed result, never raised."""
    result = run_model(rung.scene, rung.run, rung.dt, rung.dt_rule, progress)
    if result.ok:
        result.settings["rung"] = {"family": rung.family, "resolution": rung.resolution, "predicted_cost": rung.cost}
    return result


def choose_model(scene: ImpactScene, tolerance: float, output: str = DEFAULT_OUTPUT, runner: Runner | None = None, *,
                 source: str = "<case>", budget_checked: bool = False) -> ModelChoice:
    """Climb the ladder of ``scene`` until a run is expected within ``tolerance`` on ``output`` (module docstring).

    Before any rung runs, the budget of the whole ladder (the worst case: every rung) is checked
    (:func:`femref.choice.ladder.check_ladder_budget`; a CaseError naming ``source`` when over it) — unless
    ``budget_checked`` says the caller has (``femref run`` does, before its output check)."""
    if not (0.0 < tolerance < math.inf):
        raise ValueError(f"tolerance must be a positive relative error, got {tolerance}")
    if output not in OUTPUTS:
        raise ValueError(f"unknown output {output!r}; one of {', '.join(OUTPUTS)}")
    if not budget_checked:
        check_ladder_budget(scene, source)
    runner = runner or run_rung
    load_compiled_loop(scene)
    ladder = model_ladder(scene)
    climb = _Climb(scene, ladder, output, runner)
    for rung in ladder.rungs:
        climb.run(rung.label)
        partner = ladder.partner(rung.label)
        if partner is not None:
            climb.run(partner)
        climb.estimate()
        passing = [row for row in climb.rows if row.ran and row.estimate <= tolerance]
        if passing:
            return climb.outcome(tolerance, passing[0].rung.label, met=True)
    estimated = [row for row in climb.rows if row.ran and math.isfinite(row.estimate)]
    if not estimated:
        raise RuntimeError("no rung of the ladder ran: " + "; ".join(f"{r.rung.label}: {r.result.message}" for r in climb.rows if r.result))
    best = min(estimated, key=lambda row: row.estimate)
    return climb.outcome(tolerance, best.rung.label, met=False)


class _Climb:
    """The runs made so far and their estimates, in ladder order."""

    def __init__(self, scene: ImpactScene, ladder: Ladder, output: str, runner: Runner) -> None:
        self.scene, self.ladder, self.output, self.runner = scene, ladder, output, runner
        self.rows = [RungEstimate(rung) for rung in ladder.rungs]
        self.by_label = {row.rung.label: row for row in self.rows}
        self.epsilon_load = math.nan
        self.distances: dict[tuple[str, str], float] = {}

    def run(self, label: str) -> None:
        row = self.by_label[label]
        if row.result is None:
            row.result = self.runner(row.rung)
            if not row.result.ok:
                row.basis = f"failed: {row.result.message}"

    def distance(self, a: str, b: str) -> float:
        """``output_distance`` of run ``a`` from run ``b``, computed once per pair (runs never change)."""
        if (a, b) not in self.distances:
            self.distances[a, b] = output_distance(self.by_label[a].result, self.by_label[b].result, self.output)
        return self.distances[a, b]

    def estimate(self) -> None:
        for row in self.rows:
            if row.ran:
                row.estimate, row.basis = self._own(row.rung)
        ran = [row for row in self.rows if row.ran]
        changed = True
        while changed:
            changed = False
            for row in ran:
                for other in ran:
                    if other is row or not other.estimate < row.estimate:
                        continue
                    bound = hierarchical_bound(self.distance(row.rung.label, other.rung.label), other.estimate)
                    if bound < row.estimate:
                        row.estimate, row.basis = bound, f"difference from {other.rung.label} + its estimate"
                        changed = True

    def _own(self, rung: Rung) -> tuple[float, str]:
        """The rung's own estimate: asymptotic (a term of the expansion in ε) or Richardson; inf when it has none."""
        if rung.label in self.ladder.expansion:
            return self._asymptotic(rung.label)
        partner = self.ladder.partner(rung.label)
        if partner is not None:
            if not self.by_label[partner].ran:
                return math.inf, f"no estimate: partner {partner} did not run"
            difference = self.distance(rung.label, partner)
            return SAFETY * richardson_error(difference, ASSUMED_ORDER), f"Richardson against {partner}"
        coarser = self.ladder.coarser(rung.label)
        if coarser is not None and self.by_label[coarser].ran:
            difference = self.distance(coarser, rung.label)
            return SAFETY * richardson_error(difference, ASSUMED_ORDER, finer=True), f"Richardson (finest) against {coarser}"
        return math.inf, "no estimate: nothing to refine against"

    def _asymptotic(self, label: str) -> tuple[float, str]:
        zeroth, first = self.ladder.expansion
        if not (self.by_label[zeroth].ran and self.by_label[first].ran):
            return math.inf, f"no estimate: {zeroth} and {first} must both run"
        wave_time = self.scene.wave_travel_time
        result = self.by_label[zeroth].result
        self.epsilon_load = max(load_epsilon(result.axes["time"], out["force"], wave_time) for out in result.couplers.values())
        if not self.epsilon_load <= EPS_LOAD_VALID:
            return math.inf, f"asymptotics not valid: ε_load = {self.epsilon_load:.3g} > {EPS_LOAD_VALID:g}"
        first_order = self.distance(zeroth, first)
        estimates = dict(zip((zeroth, first), asymptotic_errors(first_order, self.epsilon_load)))
        step = 0.0
        if self.output == "peak_coupler_force":
            step = max(peak_sampling_error(out["force"]) for out in self.by_label[label].result.couplers.values())
        return SAFETY * estimates[label] + step, f"asymptotic in ε_load = {self.epsilon_load:.3g}"

    def outcome(self, tolerance: float, chosen: str, met: bool) -> ModelChoice:
        return ModelChoice(tolerance, self.output, self.ladder, self.rows, chosen, met, self.epsilon_load)
