"""Run every model of an impact scene, the estimators on the fem records, and score them.

Each run steps at the case's ``time.dt`` or, by default, at the step its own cars need
(:func:`automatic_time_step`): a rigid run does not pay for the fem mesh. The scores
interpolate the reference ``fem`` histories onto each run's time axis. Sensor records go
through the measurement chain (:mod:`femref.impact.measurement`) when the case asks for
one; the estimators read the fem run's records — measured if so — as a railroad's
accelerometers would deliver them (:func:`femref.impact.records.acceleration_histories`):
the inverse estimators (:mod:`femref.impact.estimators`) return coupler force histories,
the network estimators (:mod:`femref.impact.ann_estimator`) the peak force of one coupler,
``couplers[c]["peak_force"]`` (no time axis), scored on that peak alone.
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable

import numpy as np

from femref.fem.mesh import body_nodes
from femref.impact.records import acceleration_histories
from femref.impact.scene import ImpactScene, ModelRun
from femref.impact.solver import ImpactResponse, solve_impact
from femref.results import ModelResult

REFERENCE = "fem"


def automatic_time_step(scene: ImpactScene, run: ModelRun) -> tuple[float, str]:
    """The step a run's own fidelities need, ``min(T_contact/100, T_cars, end/20)``, and the rule.

    ``T_contact`` is the shortest rigid-body contact time of the couplers
    (:meth:`ImpactScene.contact_time`): it is all a run of rigid and quasi-rigid cars
    needs. A fem car adds ``T_h = h/c_max``, the wave transit time of an average element
    (``h = 2l/elements``): the shortest wave its mesh resolves. (An element shortened to
    put a node on a profile jump resolves no shorter waves than its neighbours, so
    ``h_min`` would only cost steps.) A modal car adds a twentieth of the period of its
    highest kept mode, ``4l/(k c_max)`` for a free rod. Each run thus pays only for what it
    models; the scores interpolate the reference onto each run's time axis.
    """
    candidates = {"coupler contact time / 100": scene.contact_time() / 100.0, "end time / 20": scene.end / 20.0}
    for i, fidelity in enumerate(run.fidelity):
        body = scene.cars[i].body
        if fidelity not in ("fem", "modal"):
            continue
        nodes = body_nodes(body.half_length, scene.fem.elements, body.jumps, scene.fem.grading)
        speed = float(np.max(np.sqrt(body.stiffness(nodes) / body.mass_per_length(nodes))))
        if fidelity == "fem":
            rule, value = "mesh wave period", 2.0 * body.half_length / scene.fem.elements / speed
        else:
            rule, value = "highest modal period / 20", 4.0 * body.half_length / (scene.modal_modes * speed) / 20.0
        candidates[rule] = min(candidates.get(rule, math.inf), value)
    value, rule = min((v, k) for k, v in candidates.items() if math.isfinite(v))
    return value, rule


def time_step_for(scene: ImpactScene, run: ModelRun) -> tuple[float, str]:
    """The case's ``time.dt`` for every run, or each run's automatic step."""
    if scene.dt is not None:
        return scene.dt, "given in the case"
    dt, rule = automatic_time_step(scene, run)
    return dt, f"automatic: {rule}"


def model_result(scene: ImpactScene, run: ModelRun, response: ImpactResponse, dt: float, dt_rule: str) -> ModelResult:
    """The response as the result file's model group (DESIGN.md §4)."""
    settings: dict[str, Any] = {
        "fidelity": dict(zip((car.name for car in scene.cars), run.fidelity)),
        "dt": dt,
        "dt_rule": dt_rule,
        "integrator": scene.integrator,
        "rho_inf": scene.rho_inf,
        "steps": response.steps,
        "newton_iterations": response.newton_iterations,
        "newton_iterations_max": response.newton_iterations_max,
        "contact_changes": response.contact_changes,
        "energy_balance_error": response.energy_balance_error,
        "cars": {car.name: _public(s) for car, s in zip(scene.cars, response.car_settings)},
    }
    result = ModelResult(run.name, settings=settings, wall_time_s=response.wall_time)
    result.axes = {"time": response.time}
    result.probes = response.sensors
    result.couplers = response.couplers
    result.energy = response.energy
    return result


def _public(settings: dict[str, Any]) -> dict[str, Any]:
    """Car settings without bulky arrays (node coordinates)."""
    return {k: v for k, v in settings.items() if not (isinstance(v, np.ndarray) and v.size > 16)}


def run_model(
    scene: ImpactScene, run: ModelRun, dt: float | None = None, dt_rule: str = "", progress: Callable[[int, int], None] | None = None
) -> ModelResult:
    """One model run stepped at ``dt`` (None: :func:`time_step_for`), as a result; a failure is
    returned as a failed result, never raised, so the other runs still go."""
    started = time.perf_counter()
    try:
        if dt is None:
            dt, dt_rule = time_step_for(scene, run)
        response, _ = solve_impact(scene, run, dt, progress)
        return model_result(scene, run, response, dt, dt_rule)
    except Exception as error:  # recorded as the model's status
        return ModelResult.failed(run.name, f"{type(error).__name__}: {error}", time.perf_counter() - started)


def run_impact_scene(scene: ImpactScene, progress_for: Callable[[str], Any] | None = None):
    """Every run of ``scene.runs``, then the inverse and network estimators, then the scores against ``fem``."""
    from femref.runner import RunOutcome

    results = [run_model(scene, run, progress=progress_for(run.name) if progress_for else None) for run in scene.runs]
    if scene.measurement is not None:
        for result in results:
            if result.ok:
                add_measured_records(scene, result)
    reference = next((r for r in results if r.model == REFERENCE and r.ok), None)
    if reference is not None:
        results.extend(run_estimators(scene, reference))
        results.extend(run_networks(scene, reference))
    return RunOutcome(scene, results, score_impact_results(results))


def add_measured_records(scene: ImpactScene, result: ModelResult) -> None:
    """Sensor accelerations as the measurement chain delivers them, under ``result.measured``."""
    from femref.impact.measurement import measure

    probes = list(result.probes)
    accelerations = np.column_stack([result.probes[p]["acceleration"] for p in probes])
    t, records = measure(result.axes["time"], accelerations, scene.measurement)
    result.measured = {"time": t, **{p: records[:, k] for k, p in enumerate(probes)}}


def run_estimators(scene: ImpactScene, reference: ModelResult) -> list[ModelResult]:
    """Each inverse estimator on the fem run's (measured) records, as a result with coupler forces only."""
    from femref.impact.estimators import ESTIMATORS

    t, records = acceleration_histories(reference)
    results = []
    for name in scene.estimators:
        started = time.perf_counter()
        try:
            forces = ESTIMATORS[name](scene, t, records)
            result = ModelResult(name, settings={"records": _records_source(reference)})
            result.axes = {"time": t}
            result.couplers = {c: {"force": f} for c, f in forces.items()}
            result.wall_time_s = time.perf_counter() - started
        except Exception as error:
            result = ModelResult.failed(name, f"{type(error).__name__}: {error}", time.perf_counter() - started)
        results.append(result)
    return results


def run_networks(scene: ImpactScene, reference: ModelResult) -> list[ModelResult]:
    """Each network estimator on the fem run's (measured) records: a result holding only the peak
    force of its coupler, ``couplers[c]["peak_force"]`` (0-d, N), and no time axis.

    The records are made as the sweep files that trained it store them
    (:meth:`femref.impact.ann_estimator.AnnEstimator.peak_force`); the wall time covers
    making them and the prediction.
    """
    t, records = acceleration_histories(reference)
    results = []
    for network in scene.networks:
        started = time.perf_counter()
        try:
            peak = network.peak_force(t, records, {car.name: car.mass for car in scene.cars})
            result = ModelResult(network.name, settings={"records": _records_source(reference), **network.settings})
            result.couplers = {network.coupler: {"peak_force": np.array(peak)}}
            result.wall_time_s = time.perf_counter() - started
        except Exception as error:
            result = ModelResult.failed(network.name, f"{type(error).__name__}: {error}", time.perf_counter() - started)
        results.append(result)
    return results


def _records_source(reference: ModelResult) -> str:
    return f"{REFERENCE} ({'measured' if reference.measured else 'model'})"


def _measured_view(result: ModelResult) -> ModelResult:
    """The measured records of a result as a result of their own (time axis, probe accelerations)."""
    view = ModelResult(result.model)
    view.axes = {"time": result.measured["time"]}
    view.probes = {p: {"acceleration": a} for p, a in result.measured.items() if p != "time"}
    return view


def score_impact_results(results: list[ModelResult]) -> dict[str, dict[str, Any]]:
    """Scores of every ok result against the ``fem`` run, with wall time and speed-up.

    With a measurement chain the sensor accelerations are also scored as measured
    (``measured_acceleration_rms_error_<probe>`` …): in the band the records keep, where
    the cheaper models are meant to be compared.
    """
    from femref.impact.scoring import score_impact

    reference = next((r for r in results if r.model == REFERENCE and r.ok), None)
    if reference is None:
        return {}
    scores: dict[str, dict[str, Any]] = {}
    for result in results:
        if result is reference or not result.ok:
            continue
        metrics: dict[str, Any] = {"reference": REFERENCE, "wall_time_s": result.wall_time_s}
        metrics.update(score_impact(reference, result))
        if reference.measured and result.measured:
            measured = score_impact(_measured_view(reference), _measured_view(result))
            metrics.update({f"measured_{name}": value for name, value in measured.items()})
        if result.wall_time_s > 0.0:
            metrics["speedup"] = reference.wall_time_s / result.wall_time_s
        scores[result.model] = metrics
    return scores
