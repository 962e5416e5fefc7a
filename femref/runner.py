"""Run every requested model on a scene and score each against the reference.

The reference is ``exact`` where it serves the scene, else ``fem``. Every model runs on
the same output axis (frequencies, or the time grid of the resolved step), so scores
compare sample by sample. A model that raises is recorded as failed with its message;
the others still run. Impact scenes go to :func:`femref.impact.runner.run_impact_scene`.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from femref.models import Progress, registry
from femref.models.fem import build_operators
from femref.fem.transient import automatic_time_step
from femref.results import ModelResult
from femref.scene import Scene

if TYPE_CHECKING:  # pragma: no cover - typing only
    from femref.impact.scene import ImpactScene

REFERENCE_ORDER = ("exact", "fem")


@dataclass
class RunOutcome:
    scene: "Scene | ImpactScene"
    results: list[ModelResult]
    scores: dict[str, dict[str, Any]]
    dt_rule: str | None = None

    @property
    def failed(self) -> list[ModelResult]:
        return [r for r in self.results if not r.ok]


def resolve_time_step(scene: Scene) -> tuple[Scene, str | None]:
    """Fill in ``dt`` for a transient scene that left it open; return the rule used."""
    if scene.kind != "transient" or scene.dt is not None:
        return scene, None if scene.dt is None else "given in the case"
    ops = build_operators(scene.body, scene.fem)
    dt, rule = automatic_time_step(ops, scene.load_time_scale, scene.end)
    return dataclasses.replace(scene, dt=dt), f"automatic: {rule}"


def run_scene(scene: "Scene | ImpactScene", progress_for: Callable[[str], Progress | None] | None = None) -> RunOutcome:
    """Run ``scene.models`` in order; ``progress_for(model)`` may supply a progress callback."""
    if scene.kind == "impact":
        from femref.impact.runner import run_impact_scene

        return run_impact_scene(scene, progress_for)
    scene, dt_rule = resolve_time_step(scene)
    models = registry()
    results = []
    for name in scene.models:
        model = models[name]
        started = time.perf_counter()
        try:
            result = model.run(scene, progress_for(name) if progress_for else None)
        except Exception as error:  # recorded as the model's status, never swallowed silently
            result = ModelResult.failed(name, f"{type(error).__name__}: {error}", time.perf_counter() - started)
        if dt_rule and result.ok:
            result.settings.setdefault("dt", scene.dt)
            result.settings["dt_rule"] = dt_rule
        results.append(result)
    return RunOutcome(scene, results, score_results(results), dt_rule)


def score_results(results: list[ModelResult]) -> dict[str, dict[str, Any]]:
    """Relative errors of each model against the reference, per probe and overall.

    ``acceleration_error_<probe> = max|a − a_ref| / max|a_ref|`` over the axis (time or
    frequency), normalised by the reference's peak over all probes (a free end's force is
    zero); ``…_rms_error_<probe>`` is ``rms(a − a_ref)/rms(a_ref)``; the same for the rod's
    axial force; ``speedup`` = reference wall time /
    model wall time.
    """
    by_name = {r.model: r for r in results if r.ok}
    reference = next((by_name[name] for name in REFERENCE_ORDER if name in by_name), None)
    if reference is None:
        return {}
    scores: dict[str, dict[str, Any]] = {}
    for result in by_name.values():
        if result is reference:
            continue
        metrics: dict[str, Any] = {"reference": reference.model, "wall_time_s": result.wall_time_s}
        if result.wall_time_s > 0.0:
            metrics["speedup"] = reference.wall_time_s / result.wall_time_s
        worst = worst_rms = 0.0
        scale = {
            quantity: max((float(np.max(np.abs(out[quantity]))) for out in reference.probes.values() if quantity in out), default=0.0)
            for quantity in ("acceleration", "axial_force")
        }
        for probe, outputs in reference.probes.items():
            for quantity in ("acceleration", "axial_force"):
                if quantity in outputs and quantity in result.probes.get(probe, {}):
                    ref = outputs[quantity]
                    error = float(np.max(np.abs(result.probes[probe][quantity] - ref)) / max(scale[quantity], 1e-300))
                    metrics[f"{quantity}_error_{probe}"] = error
                    difference = result.probes[probe][quantity] - ref
                    metrics[f"{quantity}_rms_error_{probe}"] = float(
                        np.sqrt(np.mean(np.abs(difference) ** 2) / max(np.mean(np.abs(ref) ** 2), 1e-300))
                    )
                    if quantity == "acceleration":
                        worst = max(worst, error)
                        worst_rms = max(worst_rms, metrics[f"acceleration_rms_error_{probe}"])
        metrics["acceleration_error_max"] = worst
        metrics["acceleration_rms_error_max"] = worst_rms
        scores[result.model] = metrics
    return scores
