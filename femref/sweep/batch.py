"""The model runs of a batch of samples, those of one scene structure stepped together.

    results[i][r] = run r of scene i,  as femref.run.runner.run_model gives it (but its wall time)

Each run is stepped at its own automatic step (:func:`femref.run.timestep.impact_time_step`), its cars built at their
fidelities (each model's car form, built once per geometry) and packed (:func:`femref.impact.kernels.loop.prepare_run`).
Runs whose packed arrays share a structure (:func:`~femref.impact.kernels.batch.structure_of`: the samples of a
velocity sweep do, a swept fidelity or a mass that changes a car's mesh does not) are stepped by one compiled call per
chunk of steps (:func:`~femref.impact.kernels.batch.solve_batch`); the kernel and its arrays are those of a run alone,
so every history is the same number (tests/sweep/test_batch.py). A run's ``wall_time_s`` is its own set-up and its
share of its batch's stepping. Never raises for a run: an exception in a run's set-up or its batch's stepping is
that run's failed result (:meth:`femref.results.ModelResult.failed`).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from femref.core.threads import one_blas_thread
from femref.fem import INTEGRATORS
from femref.impact.kernels import cache
from femref.impact.kernels.batch import run_batch, solve_batch, structure_of
from femref.impact.kernels.loop import PreparedRun, prepare_run
from femref.models import model_form
from femref.results import ModelResult
from femref.run.runner import loading_step, model_result
from femref.run.timestep import impact_time_step
from femref.scene import ImpactScene

__all__ = ["load_batch_kernels", "run_models"]


@dataclass(frozen=True)
class _Pending:
    """A run packed and waiting for its batch: where its result goes, its step and rule, its time so far (s)."""

    scene: int
    run: int
    prepared: PreparedRun
    dt_rule: str
    build_time: float
    elapsed: float


def run_models(scenes: list[ImpactScene]) -> list[list[ModelResult]]:
    """Every model run of every scene, in scene and run order (module docstring)."""
    results: list[list[ModelResult | None]] = [[None] * len(scene.runs) for scene in scenes]
    if not scenes:
        return []
    load_batch_kernels(scenes[0])
    batches: dict[tuple, list[_Pending]] = {}
    with one_blas_thread():  # as femref.run.runner.step_cars: the builds' small BLAS calls too
        for i, scene in enumerate(scenes):
            integrator = INTEGRATORS[scene.integrator](scene.rho_inf)
            for r, run in enumerate(scene.runs):
                started = time.perf_counter()
                try:
                    dt, rule = impact_time_step(scene, run)
                    building = time.perf_counter()
                    systems = [model_form(fidelity, "impact")(car, scene, dt) for car, fidelity in zip(scene.cars, run.fidelity)]
                    build_time = time.perf_counter() - building
                    prepared = prepare_run(scene, systems, integrator, dt)
                except Exception as error:  # the run's failure, as femref.run.capture.capture records it
                    results[i][r] = ModelResult.failed(run.name, f"{type(error).__name__}: {error}", time.perf_counter() - started)
                    continue
                pending = _Pending(i, r, prepared, rule, build_time, time.perf_counter() - started)
                batches.setdefault(structure_of(prepared), []).append(pending)
        for batch in batches.values():
            _step_batch(scenes, batch, results)
    return results  # type: ignore[return-value]


_loaded = False


def load_batch_kernels(scene: ImpactScene) -> None:
    """Load the compiled kernels of a batched run (compiling them, the first time after an install) by stepping
    ``scene``'s cars once as rigid bodies in a batch of one, so that no run's timing pays the one-off loading; after
    the first call in a process it does nothing. The single-run loop (:func:`femref.run.runner.load_compiled_loop`) is
    not loaded: :func:`~femref.impact.kernels.batch.run_batch` carries its own copy of ``run_steps``.

    Before a compile it logs why the process waits — "compiling femref's batched impact kernels, once (cached in
    DIR)" — at INFO on the logger ``femref.compile``, as the single-run loop does (the CLI shows it)."""
    global _loaded
    if _loaded:
        return
    if not cache.cached((run_batch,)):
        logging.getLogger("femref.compile").info("compiling femref's batched impact kernels, once (cached in %s)", cache.cache_directory())
    one_step, dt = loading_step(scene)
    systems = [model_form("rigid", "impact")(car, one_step, dt) for car in scene.cars]
    solve_batch([prepare_run(one_step, systems, INTEGRATORS[scene.integrator](scene.rho_inf), dt)])
    _loaded = True


def _step_batch(scenes: list[ImpactScene], batch: list[_Pending], results: list[list[ModelResult | None]]) -> None:
    """Step ``batch`` together and put each run's result in ``results``."""
    started = time.perf_counter()
    try:
        responses = solve_batch([pending.prepared for pending in batch])
    except Exception as error:  # each run of the batch failed with it
        share = (time.perf_counter() - started) / len(batch)
        for pending in batch:
            name = scenes[pending.scene].runs[pending.run].name
            results[pending.scene][pending.run] = ModelResult.failed(name, f"{type(error).__name__}: {error}", pending.elapsed + share)
        return
    for pending, response in zip(batch, responses):
        finishing = time.perf_counter()
        scene, prepared = scenes[pending.scene], pending.prepared
        response.setup_time += pending.build_time
        result = model_result(scene, scene.runs[pending.run], response, prepared.dt, pending.dt_rule)
        result.wall_time_s = pending.elapsed + response.wall_time + time.perf_counter() - finishing
        results[pending.scene][pending.run] = result
