"""Time and score every configuration of a bench plan (:mod:`femref.bench.configurations`).

The rules (time: the median of ``repeats`` wall times, also as ``t / t_rigid``, since only such ratios
compare across machines; error against the reference; Pareto flag; failed rows): docs/design.md §7.1.
An estimator's wall time is what ``femref run`` records for it, the estimator on the records already
made. Solves are deterministic, so the last repeat's response is the one scored.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from femref.bench.configurations import ESTIMATOR, BenchPlan, Configuration, bench_plan
from femref.bench.pareto import pareto_mask
from femref.results import ModelResult
from femref.run.runner import add_measured_records, load_compiled_loop, run_estimators, run_model, run_networks
from femref.run.scoring import score_impact
from femref.scene import ImpactScene

__all__ = ["PRIMARY_ERROR", "SECONDARY_ERROR", "BenchOutcome", "BenchRow", "ReferenceFailed", "run_bench", "run_plan"]

PRIMARY_ERROR = "coupler_force_peak_error_max"
SECONDARY_ERROR = "coupler_force_rms_error_max"
VERTICAL_ERROR = "vertical_acceleration_rms_error_max"
"""On cars that bend, the worst sensor's vertical-acceleration rms error (NaN on rods)."""
RATIO_BASE = "rigid"
"""The family whose median time every time is divided by."""

Progress = Callable[[str], None]


class ReferenceFailed(RuntimeError):
    """The reference fem run failed: there is nothing to score the configurations against."""


@dataclass
class BenchRow:
    """One configuration's outcome: status, work, the repeats' wall times (s), errors, ratio, Pareto flag."""

    configuration: Configuration
    status: str = "ok"
    message: str = ""
    steps: int = 0
    wall_times_s: tuple[float, ...] = ()
    peak_error: float = math.nan
    rms_error: float = math.nan
    vertical_error: float = math.nan
    time_ratio_rigid: float = math.nan
    pareto: bool = False

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def wall_time_s(self) -> float:
        """Median of the repeats' wall times (s); NaN when none was measured."""
        return float(np.median(self.wall_times_s)) if self.wall_times_s else math.nan


@dataclass
class BenchOutcome:
    """The rows in plan order, the plan, the reference's (single) wall time and the repeat count."""

    plan: BenchPlan
    rows: list[BenchRow]
    repeats: int
    reference_wall_time_s: float
    reference_steps: int
    notes: list[str] = field(default_factory=list)

    @property
    def failed(self) -> list[BenchRow]:
        return [row for row in self.rows if not row.ok]

    @property
    def pareto_rows(self) -> list[BenchRow]:
        """The Pareto-optimal rows, fastest first."""
        return sorted((row for row in self.rows if row.pareto), key=lambda row: row.wall_time_s)


def run_bench(scene: ImpactScene, repeats: int = 3, progress: Progress | None = None) -> BenchOutcome:
    """Plan the configurations of ``scene`` (:func:`bench_plan`) and run them (:func:`run_plan`)."""
    return run_plan(bench_plan(scene), scene, repeats, progress)


def run_plan(plan: BenchPlan, scene: ImpactScene, repeats: int = 3, progress: Progress | None = None) -> BenchOutcome:
    """The reference once, every configuration ``repeats`` times; scores, ratios and Pareto flags (module docstring)."""
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    load_compiled_loop(scene)
    if progress:
        progress("reference")
    reference, _ = _solve(plan.reference, repeats=1)
    if not reference.ok:
        raise ReferenceFailed(f"the reference run ({plan.reference_description}) failed: {reference.message}")
    records: ModelResult | None = None
    rows: list[BenchRow] = []
    for index, configuration in enumerate(plan.configurations):
        if progress:
            progress(configuration.label)
        if configuration.kind == ESTIMATOR:
            row = _estimator_row(configuration, scene, records, reference, repeats)
        else:
            row, result = _solve_row(configuration, reference, repeats)
            if index == plan.records_from and result is not None:
                if scene.measurement is not None:
                    add_measured_records(configuration.scene, result)
                records = result
        rows.append(row)
    _add_ratios(rows)
    for row, optimal in zip(rows, pareto_mask([r.wall_time_s for r in rows], [r.peak_error for r in rows])):
        row.pareto = bool(optimal)
    notes = [f"estimators read the records of {plan.configurations[plan.records_from].label}"] if any(c.kind == ESTIMATOR for c in plan.configurations) else []
    return BenchOutcome(plan, rows, repeats, reference.wall_time_s, int(reference.settings["steps"]), notes)


def _solve(configuration: Configuration, repeats: int) -> tuple[ModelResult, tuple[float, ...]]:
    """Run the configuration up to ``repeats`` times (:func:`femref.run.run_model`, never raising); the
    last result and every wall time (s). A failed run ends the repeats."""
    assert configuration.scene is not None and configuration.run is not None  # internal contract: a solve
    times = []
    for _ in range(repeats):
        result = run_model(configuration.scene, configuration.run, configuration.dt, configuration.dt_rule)
        if not result.ok:
            break
        times.append(result.wall_time_s)
    return result, tuple(times)


def _solve_row(configuration: Configuration, reference: ModelResult, repeats: int) -> tuple[BenchRow, ModelResult | None]:
    result, times = _solve(configuration, repeats)
    if not result.ok:  # kept as a failed row; the other configurations still run
        return BenchRow(configuration, status="failed", message=result.message), None
    row = _scored_row(configuration, reference, result, times, int(result.settings["steps"]))
    return row, result if row.ok else None


def _estimator_row(
    configuration: Configuration, scene: ImpactScene, records: ModelResult | None, reference: ModelResult, repeats: int
) -> BenchRow:
    """Run one estimator ``repeats`` times on the records, as ``femref run`` does, and score its last result."""
    if records is None:
        return BenchRow(configuration, status="failed", message="no records: the fem run they are read from failed")
    name = configuration.family
    networks = tuple(n for n in scene.networks if n.name == name)
    alone = dataclasses.replace(scene, estimators=tuple(e for e in scene.estimators if e == name), networks=networks)
    runner = run_networks if networks else run_estimators
    times = []
    for _ in range(repeats):
        (result,) = runner(alone, records)
        if not result.ok:
            return BenchRow(configuration, status="failed", message=result.message)
        times.append(result.wall_time_s)
    return _scored_row(configuration, reference, result, tuple(times), vertical=False)


def _scored_row(configuration: Configuration, reference: ModelResult, result: ModelResult, times: tuple[float, ...], steps: int = 0,
                vertical: bool = True) -> BenchRow:
    """The row of a run that went: its errors against ``reference`` (an estimator's: no vertical error), or failed
    when it cannot be scored."""
    try:
        metrics = score_impact(reference, result)
    except ValueError as error:
        return BenchRow(configuration, status="failed", message=f"cannot score: {error}")
    return BenchRow(configuration, steps=steps, wall_times_s=times, peak_error=float(metrics.get(PRIMARY_ERROR, math.nan)),
                    rms_error=float(metrics.get(SECONDARY_ERROR, math.nan)),
                    vertical_error=float(metrics.get(VERTICAL_ERROR, math.nan)) if vertical else math.nan)


def _add_ratios(rows: list[BenchRow]) -> None:
    """``time_ratio_rigid = t / t_rigid`` for every row with a time (NaN without a rigid time)."""
    base = next((row.wall_time_s for row in rows if row.configuration.family == RATIO_BASE and row.ok), math.nan)
    for row in rows:
        if row.ok and math.isfinite(base) and base > 0.0:
            row.time_ratio_rigid = row.wall_time_s / base
