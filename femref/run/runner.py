"""The one runner: every model of a scene, of any kind, then the estimators, then the scores.

:func:`run_scene` serves ``femref run``, sweeps and studies; :func:`run_model` runs one
model (one impact run at a given step) for the choice ladder and the bench. Every model
goes through :func:`femref.run.capture.capture`: a failure is recorded as the model's
status with its message, and the other models still run.

* **Single body** (harmonic, transient): every model on the same axis — the frequencies,
  or the time grid of the one resolved step (:func:`femref.run.timestep.single_body_time_step`)
  — so the scores compare sample by sample; the reference is ``exact`` where it runs, else ``fem``.
* **Impact**: each run's cars are built by their models (:func:`femref.models.model_form`)
  and stepped together (:func:`femref.impact.solve_impact`), each run at the step its own
  cars need (:func:`femref.run.timestep.impact_time_step`); a run whose coupler iteration
  fails keeps its histories up to the failing step. The estimators (:mod:`femref.estimators`)
  read the fem run's records, through the measurement chain when the scene has one.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from femref.core import catalog
from femref.core.threads import one_blas_thread
from femref.impact import ImpactResponse, solve_impact
from femref.models import Progress, ProgressFor, model_form
from femref.estimators import Recorded, capture as capture_estimates, plug_ins
from femref.results import ModelResult
from femref.run.budget import SELF_CHECK_VARIABLE, check_budget, resolution_warnings, self_check_levels
from femref.run.capture import capture
from femref.run.scoring import PeakError, reference_error_estimate, score_results
from femref.run.timestep import impact_time_step, single_body_time_step
from femref.run.validity import quasi_rigid_range
from femref.scene import ImpactScene, ModelRun, Scene
from femref.sensing.measurement import measure
from femref.sensing.records import acceleration_histories


@dataclass
class RunOutcome:
    """The scene as run (its step resolved), every result in run order, and the scores against the reference."""

    scene: Scene | ImpactScene
    results: list[ModelResult]
    scores: dict[str, dict[str, Any]]

    @property
    def failed(self) -> list[ModelResult]:
        return [r for r in self.results if not r.ok]


def run_scene(scene: Scene | ImpactScene, progress_for: ProgressFor | None = None, *, source: str = "<case>", budget_checked: bool = False) -> RunOutcome:
    """Run every model of a simulated scene in order (then, for impacts, the estimators) and score them.

    Parameters
    ----------
    scene : femref.scene.Scene or femref.scene.ImpactScene
        A resolved single-body or impact scene (:func:`femref.scene.build.scene_from_case`).
    progress_for : callable, optional
        ``progress_for(model)`` → a progress callback for that model, or None.
    source : str
        The case's name in a refusal message.
    budget_checked : bool
        The caller has checked the scene's work budget already (``femref run`` does, before its output check:
        once per command); otherwise it is checked here first (:func:`femref.run.budget.check_budget`: its runs
        and the reference's self-check).

    Returns
    -------
    RunOutcome
        Every model's and estimator's result (a failed one is a result with ``status == "failed"``) and the
        scores against the reference.

    Raises
    ------
    femref.case.CaseError
        The scene is over the work budget (naming ``source``), before any work.
    TypeError
        A measured scene (:func:`femref.run.measured.run_measured` runs those).
    """

    def progress(name: str) -> Progress | None:
        return progress_for(name) if progress_for else None

    if not budget_checked:
        check_budget(scene, source)  # before any work: a case over the work budget is a CaseError (femref.run.budget)
    if isinstance(scene, ImpactScene):
        return _run_impact(scene, progress)
    if scene.kind not in catalog.SINGLE_BODY_KINDS:
        raise TypeError(f"run_scene simulates models; a {scene.kind} scene is run by femref.run.measured.run_measured")
    return _run_single_body(scene, progress)


def _run_impact(scene: ImpactScene, progress: ProgressFor) -> RunOutcome:
    load_compiled_loop(scene)
    load_one_off_imports(scene.kind, scene.estimators)
    results = [run_model(scene, run, progress=progress(run.name)) for run in scene.runs]
    for run, result in zip(scene.runs, results):
        if result.ok:
            forces = {c: out["force"] for c, out in result.couplers.items()}
            marked = quasi_rigid_range(scene, run, result.axes["time"], forces)
            if marked is not None:
                result.settings["quasi_rigid_range"] = marked
    if scene.measurement is not None:
        for result in results:
            if result.ok:
                add_measured_records(scene, result)
    reference = next((r for r in results if r.model == catalog.REFERENCES["impact"][0] and r.ok), None)
    if reference is not None:
        results.extend(run_estimators(scene, reference))
        results.extend(run_networks(scene, reference))
    scores = score_results(scene.kind, results)
    if reference is not None:
        merge_scores(scores, check_reference(scene, reference))
    return RunOutcome(scene, results, scores)


#: A two-level self-check estimate above this (relative) calls for the third level even when no warning fired.
THIRD_LEVEL_ABOVE = 0.01


def check_reference(scene: Scene | ImpactScene, reference: ModelResult, warnings: list[str] | None = None) -> dict[str, dict[str, Any]]:
    """The fem run checks itself when the case's ``time.dt`` or ``fem.elements`` under-resolves it (``warnings``,
    default :func:`femref.run.budget.resolution_warnings` of ``scene``, the scene as the case gave it) or
    ``FEMREF_SELF_CHECK=1`` asks: the fem run again at ``dt/2`` and, when a warning fired or the two-level estimate
    exceeds :data:`THIRD_LEVEL_ABOVE`, at ``dt/4`` (:func:`femref.run.budget.self_check_levels`), giving
    :func:`femref.run.scoring.reference_error_estimate` (a lower bound outside the asymptotic range:
    ``reference_error_bound = "lower"``). Returns ``{"fem": scores}`` — the worst item's estimate, basis and observed
    order, each item's, the check's runs (``reference``, ``self_check``) and wall time — and records them in the fem
    result's settings (``reference_check``). ``{}`` when there is nothing to check. Never raises."""
    warnings = resolution_warnings(scene) if warnings is None else warnings
    levels = self_check_levels(scene, warnings)
    if not levels:
        return {}
    dt = float(reference.settings["dt"])
    text = "; ".join(warnings) or f"asked by {SELF_CHECK_VARIABLE}"
    finer: list[ModelResult] = []
    estimates: dict[str, PeakError] = {}
    failure: dict[str, str] = {}
    for divisor, factor in levels:
        if finer and not warnings and not any(abs(e.estimate) > THIRD_LEVEL_ABOVE for e in estimates.values()):
            break
        check = _finer_reference(scene, reference, dt / divisor, scene.fem.elements * factor, f"the reference's step / {divisor}")
        if not check.ok:
            failure = {"message": f"the fem run at dt/{divisor} failed: {check.message}"}
            reference.settings["reference_check"] = {"warning": text, **failure}
            if not finer:
                runs = f"{reference.model} at dt/{divisor}"
                return {reference.model: {"reference": runs, "self_check": runs, "reference_warning": text}}
            break
        finer.append(check)
        estimates = reference_error_estimate(reference, *finer)
    labels = [f"dt/{divisor}" + (f" and {factor}× elements" if factor > 1 else "") for divisor, factor in levels[: len(finer)]]
    runs = f"{reference.model} at " + ", ".join(labels)
    worst_item = max(estimates, key=lambda item: abs(estimates[item].estimate) if math.isfinite(estimates[item].estimate) else -1.0, default=None)
    worst = estimates[worst_item] if worst_item is not None else PeakError(math.nan, basis="no item to check")
    lower = any(e.lower_bound for e in estimates.values())
    wall = sum(r.wall_time_s for r in finer)
    scores: dict[str, Any] = {"reference": runs, "self_check": runs, "reference_warning": text, "reference_error_estimate": worst.estimate,
                              "reference_error_basis": (f"{worst_item}: " if worst_item else "") + worst.basis,
                              "wall_time_s": wall, "self_check_wall_time_s": wall}
    if len(finer) > 1:
        scores["reference_observed_order"] = worst.order
    if lower:
        scores["reference_error_bound"] = "lower"
    scores.update({f"reference_error_estimate_{item}": e.estimate for item, e in estimates.items()})
    scores.update({f"reference_observed_order_{item}": e.order for item, e in estimates.items() if len(finer) > 1})
    reference.settings["reference_check"] = {
        "warning": text,
        "refined": [{"dt": r.settings["dt"], "elements": scene.fem.elements * factor, "wall_time_s": r.wall_time_s}
                    for r, (_, factor) in zip(finer, levels)],
        "reference_error_estimate": worst.estimate,
        "basis": scores["reference_error_basis"],
        **({"observed_order": worst.order} if len(finer) > 1 else {}),
        **({"bound": "lower"} if lower else {}),
        **failure,
    }
    return {reference.model: scores}


def _finer_reference(scene: Scene | ImpactScene, reference: ModelResult, dt: float, elements: int, rule: str) -> ModelResult:
    """The reference run again at step ``dt`` on ``elements`` elements (per body or car), without fields, as a result;
    never raises."""
    finer = dataclasses.replace(scene, dt=dt, fem=dataclasses.replace(scene.fem, elements=elements, fields=False))
    if isinstance(scene, ImpactScene):
        run = next(r for r in scene.runs if r.name == reference.model)
        return run_model(finer, run, dt, rule)
    return run_single_body_model(finer, reference.model)


def merge_scores(scores: dict[str, dict[str, Any]], checked: dict[str, dict[str, Any]]) -> None:
    """Add the self-check's scores (:func:`check_reference`) to ``scores``: a model scored against another reference
    (fem against exact) keeps its own ``reference``, ``wall_time_s`` and metrics and gains the check's keys."""
    for model, extra in checked.items():
        scores[model] = {**extra, **scores[model]} if model in scores else extra


def _run_single_body(scene: Scene, progress: ProgressFor) -> RunOutcome:
    """Every model on one axis: a transient scene's step is resolved once and recorded with its rule; then its fem
    run checks itself (:func:`check_reference`)."""
    dt_rule = None
    warnings = resolution_warnings(scene)  # of the scene as the case gives it, before its step is resolved
    load_one_off_imports(scene.kind, scene.models)
    if scene.kind == "transient":
        dt, dt_rule = single_body_time_step(scene)
        scene = dataclasses.replace(scene, dt=dt)
    results = []
    for name in scene.models:
        result = run_single_body_model(scene, name, progress(name))
        if dt_rule and result.ok:
            result.settings.setdefault("dt", scene.dt)
            result.settings["dt_rule"] = dt_rule
        results.append(result)
    scores = score_results(scene.kind, results)
    fem = next((r for r in results if r.model == "fem" and r.ok), None)
    if scene.kind == "transient" and fem is not None:
        merge_scores(scores, check_reference(scene, fem, warnings))
    return RunOutcome(scene, results, scores)


def run_single_body_model(scene: Scene, name: str, progress: Progress | None = None) -> ModelResult:
    """Model ``name`` on a single-body scene whose step is resolved (a transient one stepped on one BLAS
    thread); never raises."""
    if scene.kind == "harmonic":
        return capture(name, lambda: model_form(name, scene.kind)(scene))
    with one_blas_thread():
        return capture(name, lambda: model_form(name, scene.kind)(scene, progress))


def run_model(scene: ImpactScene, run: ModelRun, dt: float | None = None, dt_rule: str = "", progress: Progress | None = None) -> ModelResult:
    """One impact run stepped at ``dt`` (None: :func:`impact_time_step`), as a result; never raises."""

    def work() -> ModelResult:
        step, rule = (dt, dt_rule) if dt is not None else impact_time_step(scene, run)
        return model_result(scene, run, step_cars(scene, run, step, progress), step, rule)

    return capture(run.name, work)


def step_cars(scene: ImpactScene, run: ModelRun, dt: float, progress: Progress | None = None) -> ImpactResponse:
    """Build every car at its fidelity in ``run`` (its model's car form, reused across runs of the same
    geometry) and step them together, on one BLAS thread; the response carries both times, building
    (``setup_time``) and stepping (``wall_time``)."""
    with one_blas_thread():  # the builds too: their small BLAS calls pay a thread hand-off with two
        started = time.perf_counter()
        systems = [model_form(fidelity, "impact")(car, scene, dt) for car, fidelity in zip(scene.cars, run.fidelity)]
        setup_time = time.perf_counter() - started
        response = solve_impact(scene, systems, dt, progress)
    response.setup_time += setup_time
    return response


#: ``(scene kind, model or estimator) → module`` that its first run in a process imports (scipy's signal tools and
#: solvers are imported where they are used: 0.2–0.5 s of CPU each): the quasi-rigid transient response's filter, the
#: rigid transient's integration.
ONE_OFF_IMPORTS = {("transient", "quasi_rigid"): "scipy.signal", ("transient", "rigid"): "scipy.integrate"}


def load_one_off_imports(kind: str, names: Iterable[str]) -> None:
    """Import what the runs ``names`` (models or estimators) of a ``kind`` scene will import (:data:`ONE_OFF_IMPORTS`),
    so that no run's timing pays the one-off import (as :func:`load_compiled_loop` for the compiled loop)."""
    for module in sorted({ONE_OFF_IMPORTS[kind, name] for name in names if (kind, name) in ONE_OFF_IMPORTS}):
        importlib.import_module(module)


_loop_loaded = False


def compiled_loop_cached() -> bool:
    """Whether :func:`load_compiled_loop` would load the compiled loop rather than compile it: loaded already in this
    process, or numba's cache holds every entry point (:func:`femref.impact.kernels.cache.cached`)."""
    if _loop_loaded:
        return True
    from femref.impact.kernels import cache  # noqa: PLC0415 (numba only where an impact is stepped)
    from femref.impact.kernels.loop import ENTRY_POINTS  # noqa: PLC0415

    return cache.cached(ENTRY_POINTS)


def loading_step(scene: ImpactScene) -> tuple[ImpactScene, float]:
    """``(one_step, dt)``: ``scene`` cut to one step ``dt`` (its coupler contact time / 100, else 1 ms), every step
    recorded — what a load of compiled kernels steps (:func:`load_compiled_loop`,
    :func:`femref.sweep.batch.load_batch_kernels`)."""
    dt = scene.contact_time() / 100.0 if math.isfinite(scene.contact_time()) else 1e-3
    return dataclasses.replace(scene, end=dt, output_stride=1), dt


def load_compiled_loop(scene: ImpactScene) -> None:
    """Load the compiled impact loop (compiling it, the first time after an install) by stepping
    ``scene``'s cars once as rigid bodies, so that no model's timing pays the one-off loading (about
    a second per process). Callers that time runs call it first; after the first call in a process
    (the loop's argument types are the same for every scene) it does nothing.

    Before a compile it logs why the process waits — "compiling femref's impact kernels, once (about
    N s; cached in DIR)" — at INFO on the logger ``femref.compile`` (the library never prints; the
    CLI shows it), N the last compile time on this machine (:func:`femref.impact.kernels.cache.compile_seconds`)."""
    global _loop_loaded
    if _loop_loaded:
        return
    import logging  # noqa: PLC0415 (only where the loop is loaded)

    from femref.impact.kernels import cache  # noqa: PLC0415 (numba only where an impact is stepped)

    compiling = not compiled_loop_cached()
    if compiling:
        logging.getLogger("femref.compile").info(
            "compiling femref's impact kernels, once (about %.0f s; cached in %s)", cache.compile_seconds(), cache.cache_directory())
    started = time.perf_counter()
    one_step, dt = loading_step(scene)
    step_cars(one_step, ModelRun("load", ("rigid",) * len(scene.cars)), dt)
    if compiling and compiled_loop_cached():  # compiled now: how long it took is the next notice's estimate
        cache.record_compile_seconds(time.perf_counter() - started)
    _loop_loaded = True


def model_result(scene: ImpactScene, run: ModelRun, response: ImpactResponse, dt: float, dt_rule: str) -> ModelResult:
    """The response as the result file's model group (docs/design.md §4); a failed step makes a failed
    result that keeps its histories (NaN after the failing step)."""
    settings: dict[str, Any] = {
        "fidelity": dict(zip((car.name for car in scene.cars), run.fidelity)),
        "dt": dt,
        "dt_rule": dt_rule,
        "integrator": scene.integrator,
        "rho_inf": scene.rho_inf,
        "steps": response.steps,
        "setup_time_s": response.setup_time,
        "stepping_time_s": response.wall_time,
        "newton_iterations": response.newton_iterations,
        "newton_iterations_max": response.newton_iterations_max,
        "contact_changes": response.contact_changes,
        "energy_balance_error": response.energy_balance_error,
        "car_energy_balance_error": response.car_energy_balance_error,
        "cars": {car.name: _public(s) for car, s in zip(scene.cars, response.car_settings)},
    }
    return ModelResult(run.name, "ok" if response.ok else "failed", "" if response.ok else response.message, settings=settings,
                       axes={"time": response.time}, probes=response.sensors, couplers=response.couplers, energy=response.energy)


def _public(settings: dict[str, Any]) -> dict[str, Any]:
    """Car settings without bulky arrays (node coordinates)."""
    return {k: v for k, v in settings.items() if not (isinstance(v, np.ndarray) and v.size > 16)}


def add_measured_records(scene: ImpactScene, result: ModelResult) -> None:
    """Sensor accelerations as the measurement chain delivers them, under ``result.measured`` — and on cars
    that bend the vertical accelerations through the same chain and the pitch rates through the gyroscopes'
    (same filter and rate, their own noise), under ``result.measured_bending[probe]``."""
    probes = list(result.probes)
    bending = [p for p in probes if "vertical_acceleration" in result.probes[p]]
    accelerations = np.column_stack([result.probes[p]["acceleration"] for p in probes]
                                    + [result.probes[p]["vertical_acceleration"] for p in bending])
    t, records = measure(result.axes["time"], accelerations, scene.measurement)
    result.measured = {"time": t, **{p: records[:, k] for k, p in enumerate(probes)}}
    result.measured_bending = {p: {"vertical_acceleration": records[:, len(probes) + k]} for k, p in enumerate(bending)}
    if bending:
        _, rates = measure(result.axes["time"], np.column_stack([result.probes[p]["pitch_rate"] for p in bending]), scene.measurement, stream=1)
        for k, p in enumerate(bending):
            result.measured_bending[p]["pitch_rate"] = rates[:, k]


def run_estimators(scene: ImpactScene, reference: ModelResult) -> list[ModelResult]:
    """Each estimator of a force history (the inverse ones) on the fem run's (measured) records."""
    return _estimated(scene, reference, history=True)


def run_networks(scene: ImpactScene, reference: ModelResult) -> list[ModelResult]:
    """Each network estimator on the fem run's (measured) records: the peak force of its coupler,
    ``couplers[c]["peak_force"]`` (0-d, N), and no time axis."""
    return _estimated(scene, reference, history=False)


def _estimated(scene: ImpactScene, reference: ModelResult, history: bool) -> list[ModelResult]:
    """The scene's estimators that give a force ``history`` (or a peak) through :func:`femref.estimators.capture`, each
    as a result (failed with the message of the estimate that failed)."""
    t, records = acceleration_histories(reference)
    recorded = Recorded(t, records, scene.cars, scene.couplers)
    results = []
    for estimator in (e for e in plug_ins(scene) if e.history == history):
        estimates = capture_estimates(estimator, recorded)
        wall = sum(e.wall_time_s for e in estimates)
        refused = next((e for e in estimates if not e.ok and "not_finite" not in e.settings), None)
        if refused is not None:
            results.append(ModelResult.failed(estimator.name, refused.message, wall))
            continue
        settings = {k: v for e in estimates for k, v in e.settings.items() if k != "not_finite"}
        result = ModelResult(estimator.name, settings={"records": _records_source(reference), **settings}, wall_time_s=wall)
        if history:
            result.axes = {"time": t}
            result.couplers = {e.coupler: {"force": e.force} for e in estimates}
        else:
            result.couplers = {e.coupler: {"peak_force": np.array(e.force[0])} for e in estimates}
        bad = [f"{e.coupler} force ({count} value(s) from sample {first} of {e.force.size})" if history else f"{e.coupler} peak_force ({count} value(s))"
               for e in estimates if "not_finite" in e.settings for count, first in [e.settings["not_finite"]]]
        if bad:
            result.status, result.message = "failed", f"the estimate is not finite (NaN or infinity): {'; '.join(bad)}"
        results.append(result)
    return results


def _records_source(reference: ModelResult) -> str:
    return f"{reference.model} ({'measured' if reference.measured else 'model'})"


__all__ = ["ONE_OFF_IMPORTS", "RunOutcome", "add_measured_records", "compiled_loop_cached", "load_compiled_loop", "loading_step", "load_one_off_imports", "model_result", "run_estimators", "run_model", "run_networks", "run_scene", "step_cars", "check_reference", "merge_scores"]
