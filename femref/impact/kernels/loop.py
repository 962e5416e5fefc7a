"""The compiled impact loop: every step of a run in numba, Python only between chunks of steps.

:func:`solve_compiled` packs the run — the cars into one pool
(:func:`femref.impact.kernels.packing.pack_cars`), the couplers, the line's coupler maps and
the Schur gains — and calls :func:`run_steps`, which does per step what the readable loop
of the reference engine (``tests/support/reference_engine``) does (the tests hold them together):

    every car predicts its free end outputs y_free and rates ẏ_free (no new loads);
    δ_free = Σ_cars Cc y_free,  δ̇_free = Σ_cars Cc ẏ_free;
    the coupler iteration finds P with δ = δ_free + D_u P, δ̇ = δ̇_free + D_v P
        (D_u = Σ_cars Cc G_u Bc, D_v likewise: fixed for a fixed step);
    every car advances with its end loads L = Bc P;
    at an output step, sensors, coupler forces and closures, and energies are recorded.

``Bc`` (J × n_c, the car's end loads per coupler force) and ``Cc`` (n_c × Y, the closure
per end output) are the only place the line's geometry enters: a coupler ``j`` between
the ``+l`` end of car ``r`` and the ``−l`` end of car ``r + 1`` loads ``F2 = −P`` on r and
``F1 = −P`` on r + 1, and closes by ``u_r(+l) − u_{r+1}(−l)``. A car with more end loads
or outputs (a beam with its coupler below the neutral axis) changes these maps, not the loop.

What a run packs is made once where it can be: what depends only on the scene (the packed
laws, :func:`coupler_maps`, the couplers' forces at contact, the force tolerance) once per
scene (:func:`line_plan`), what depends on a car's system and step (its factorised form) once
per system, and its coupler maps once per system and maps
(:func:`~femref.impact.kernels.packing.prepared_car`). A run then copies them: a rigid run's
set-up is about 0.1 ms.

The steps run in chunks of about :data:`CHUNK_SECONDS` of work (:func:`chunk_after`: the first
chunk short — :func:`first_chunk`, a small run's whole length — each next one sized by the speed of
the last), so that Python runs between them: a
signal (Ctrl-C, SIGTERM: ``KeyboardInterrupt``) stops a run within that time rather than at its
end, and a progress callback is called (with one, a chunk is at most a hundredth of the run). A call
costs microseconds: the chunks do not slow a run.
"""

from __future__ import annotations

import time as _time
import weakref
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit
from numpy.typing import NDArray

from femref.core.timegrid import output_steps, steps_to
from femref.fem.transient import Integrator
from femref.impact.couplers import force_tolerance
from femref.impact.kernels import cars as car_kernels
from femref.impact.kernels import couplers as coupler_kernels
from femref.impact.kernels.laws import CouplerLaws, pack_laws
from femref.impact.kernels.packing import pack_cars, prepared_car
from femref.impact.kernels.pool import (
    COUPLER_LOADS, COUPLER_OUTPUTS, END_COUNT, END_FREE, END_RATE_FREE, LOAD_COUNT, NEW_LOADS, SCALARS,
    SUM_LOAD2, SUM_RATE2, CarPool,
)
from femref.impact.response import ImpactResponse, failure_message, sensor_histories
from femref.impact.systems import CarSystem, car_settings_after
from femref.scene import ImpactScene

#: Seconds of stepping between two returns to Python (signals, progress): :func:`chunk_after`.
CHUNK_SECONDS = 0.1
#: Fewest steps of a run's first chunk, before its speed is known (:func:`first_chunk`).
FIRST_CHUNK = 64
#: Pool values × steps of a run's first chunk (:func:`first_chunk`): a step costs a few ns per value of the
#: pool (banded cars' products and solves, state-space cars' sparse products) or, for a few values, the
#: couplers' iteration, under a µs; so this is milliseconds, a small part of :data:`CHUNK_SECONDS`.
FIRST_CHUNK_WORK = 2**20

# entries of the loop's counters
STEP, OUTPUT, ITERATIONS, ITERATIONS_MAX, CHANGES, FAILED_STEP, WORST, FAILURE_KIND = range(8)
ENERGY_NAMES = ("kinetic", "strain", "body_dissipated", "coupler_stored", "coupler_dissipated")


def coupler_maps(scene: ImpactScene) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """``(Bc, Cc)`` of every car of a line of rods (module docstring): ``L = Bc P``, ``δ = Σ Cc y``."""
    n_c = len(scene.couplers)
    maps = [(np.zeros((2, n_c)), np.zeros((n_c, 2))) for _ in scene.cars]
    for j, coupler in enumerate(scene.couplers):
        rear_loads, rear_outputs = maps[coupler.rear]
        front_loads, front_outputs = maps[coupler.front]
        rear_loads[1, j] = -1.0     # F2 of the rear car
        rear_outputs[j, 1] = 1.0    # + u_rear(+l)
        front_loads[0, j] = -1.0    # F1 of the front car
        front_outputs[j, 0] = -1.0  # − u_front(−l)
    return maps


@dataclass(frozen=True, eq=False)
class LinePlan:
    """What every run of a scene shares, whatever its cars' fidelities: the packed coupler laws, the
    coupler maps, the couplers at contact (forces from the initial closure rates) and the end loads
    they put on each car, the sensor columns, the coupler iteration's force tolerance. Read only."""

    laws: CouplerLaws
    maps: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
    couplers_at_contact: coupler_kernels.CouplerState  # copied by each run
    loads_at_contact: list[NDArray[np.float64]]  # L₀ = Bc P₀ of each car
    velocities: list[float]
    sensor_starts: list[int]  # each car's first sensor column
    sensors: int
    force_tolerance: float


_line_plans: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def line_plan(scene: ImpactScene) -> LinePlan:
    """The scene's :class:`LinePlan`, made on its first run (a scene is immutable)."""
    plan = _line_plans.get(scene)
    if plan is None:
        laws = pack_laws([c.coupling for c in scene.couplers])
        couplers = coupler_kernels.new_state(laws)
        velocities = [float(car.velocity) for car in scene.cars]
        maps = coupler_maps(scene)
        closure_rate = np.zeros(len(scene.couplers))
        for (_, outputs), v in zip(maps, velocities):
            closure_rate += outputs @ np.full(outputs.shape[1], v)  # every end of a car at rest in shape moves at v
        coupler_kernels.start(laws, couplers, closure_rate)
        sensor_starts = [0]
        for car in scene.cars:
            sensor_starts.append(sensor_starts[-1] + len(car.channels))
        plan = LinePlan(laws, maps, couplers, [loads @ couplers.force for loads, _ in maps], velocities,
                        sensor_starts[:-1], sensor_starts[-1], force_tolerance(scene))
        _line_plans[scene] = plan
    return plan


@dataclass(frozen=True, eq=False)
class PreparedRun:
    """One run packed for the kernel: its pool at t = 0, its coupler laws and state, gains, tolerance and output steps,
    and the time its packing took (``setup_time``)."""

    scene: ImpactScene
    systems: list[CarSystem]
    dt: float
    line: LinePlan
    couplers: coupler_kernels.CouplerState
    pool: CarPool
    gain_u: NDArray[np.float64]
    gain_v: NDArray[np.float64]
    steps: int
    outputs: NDArray[np.int64]
    setup_time: float


def prepare_run(scene: ImpactScene, systems: list[CarSystem], integrator: Integrator, dt: float) -> PreparedRun:
    """The run of ``systems`` (line order) in ``scene`` at step ``dt`` packed: the line plan once per scene, each car's
    factorised form once per system (:func:`prepared_car`), a pool of their own; ValueError for a car whose mass or step
    matrix is not positive definite."""
    started = _time.perf_counter()
    line = line_plan(scene)
    couplers = coupler_kernels.CouplerState(*(array.copy() for array in line.couplers_at_contact))
    prepared = [prepared_car(system, integrator, dt, *car_maps) for system, car_maps in zip(systems, line.maps)]
    for spec, car in zip(scene.cars, prepared):
        if not car.positive_definite:
            raise ValueError(f"car {spec.name}: its mass or step matrix is not positive definite")
    pool = pack_cars(systems, prepared, line.velocities, line.loads_at_contact, line.sensor_starts)
    steps = steps_to(scene.end, dt)
    return PreparedRun(scene, systems, dt, line, couplers, pool, sum(car.gain_u for car in prepared), sum(car.gain_v for car in prepared),
                       steps, output_steps(steps, scene.output_stride), _time.perf_counter() - started)


HISTORIES = ("displacement", "velocity", "acceleration", "force", "closure", "energy", "coupler_work")
"""The histories :func:`run_steps` records, in its argument order."""


def new_histories(run: PreparedRun, *batch: int) -> dict[str, NDArray[np.float64]]:
    """The run's :data:`HISTORIES`, NaN until recorded; ``batch`` leading axes for runs stepped together."""
    n_out, sensors, n_c = run.outputs.size, run.line.sensors, run.couplers.force.size
    shapes = ((sensors,), (sensors,), (sensors,), (n_c,), (n_c,), (len(ENERGY_NAMES),), ())
    return {name: np.full((*batch, n_out, *shape), np.nan) for name, shape in zip(HISTORIES, shapes)}


def solve_compiled(
    scene: ImpactScene,
    systems: list[CarSystem],
    integrator: Integrator,
    dt: float,
    progress: Callable[[int, int], None] | None = None,
) -> ImpactResponse:
    """Step the cars of ``systems`` (line order) from contact to ``scene.end``, with the time of packing
    and factorising (``setup_time``) apart from the stepping (``wall_time``)."""
    run = prepare_run(scene, systems, integrator, dt)
    started = _time.perf_counter()
    pool, steps, n_c = run.pool, run.steps, run.couplers.force.size
    history = new_histories(run)
    counters = np.zeros(8, dtype=np.int64)
    counters[STEP], counters[OUTPUT], counters[WORST] = 1, 0, -1  # run_steps records row 0 first
    change = np.zeros(1)
    longest = steps if progress is None else max(1, steps // 100)  # a progress bar moves by hundredths at least
    chunk = min(first_chunk(pool.values.size), longest)
    while (counters[STEP] <= steps or counters[OUTPUT] == 0) and counters[WORST] < 0:
        stop = min(steps, int(counters[STEP]) + chunk - 1)
        chunk_started = _time.perf_counter()
        run_steps(pool.layout, pool.values, run.line.laws, run.couplers, dt, run.line.force_tolerance, run.gain_u, run.gain_v, run.outputs,
                  stop, counters, change, *(history[name] for name in HISTORIES), np.zeros(n_c), np.zeros(n_c), np.zeros(n_c, dtype=np.int64))
        chunk = min(longest, chunk_after(chunk, _time.perf_counter() - chunk_started))
        if progress is not None:
            progress(stop if counters[WORST] < 0 else int(counters[FAILED_STEP]) - 1, steps)
    return response_of(run, pool, counters, float(change[0]), history, _time.perf_counter() - started)


def response_of(run: PreparedRun, pool: CarPool, counters: NDArray[np.int64], change: float, history: dict[str, NDArray],
                wall_time: float) -> ImpactResponse:
    """The run's :class:`ImpactResponse` from its pool after the steps, its counters, the last force change of a failed
    iteration and its :data:`HISTORIES`; ``wall_time`` its stepping time."""
    scene, steps, dt = run.scene, run.steps, run.dt
    failed = counters[WORST] >= 0
    message = "reached the end time"
    if failed:
        name = scene.couplers[int(counters[WORST])].name
        detail = coupler_kernels.failure_detail(int(counters[FAILURE_KIND]), change)
        message = failure_message(name, int(counters[FAILED_STEP]), steps, dt, detail)
    energy = {name: history["energy"][:, k] for k, name in enumerate(ENERGY_NAMES)}
    energy["total"] = np.sum(history["energy"], axis=1)
    return ImpactResponse(
        dt * run.outputs,
        sensor_histories(scene.channels, history["displacement"], history["velocity"], history["acceleration"]),
        {c.name: {"force": history["force"][:, j], "closure": history["closure"][:, j]} for j, c in enumerate(scene.couplers)},
        energy,
        steps=steps if not failed else int(counters[FAILED_STEP]) - 1,
        newton_iterations=int(counters[ITERATIONS]),
        newton_iterations_max=int(counters[ITERATIONS_MAX]),
        contact_changes=int(counters[CHANGES]),
        wall_time=wall_time,
        setup_time=run.setup_time,
        car_settings=[car_settings_after(system, float(pool.values[scalars + SUM_LOAD2]), float(pool.values[scalars + SUM_RATE2]))
                      for system, scalars in zip(run.systems, pool.layout[:, SCALARS].tolist())],
        status=-1 if failed else 0,
        message=message,
        coupler_work=history["coupler_work"],
    )


def first_chunk(values: int) -> int:
    """Steps of a run's first chunk for a pool of ``values`` floats: ``FIRST_CHUNK_WORK / values``, at least
    :data:`FIRST_CHUNK` — so that a small run (a rigid line, a coarse mesh) is one call."""
    return max(FIRST_CHUNK, FIRST_CHUNK_WORK // max(values, 1))


def chunk_after(chunk: int, seconds: float) -> int:
    """Steps of the next chunk after ``chunk`` steps took ``seconds``: ``chunk · CHUNK_SECONDS / seconds``, at least
    1 and at most 8 times ``chunk`` (a chunk timed too short, e.g. at a clock tick, does not make the next one long)."""
    return max(1, min(8 * chunk, int(chunk * CHUNK_SECONDS / max(seconds, 1e-9))))


@njit(cache=True, _nrt=False, inline="always")
def record(layout, values, couplers, k: int, displacement, velocity, acceleration, force, closure, energy, coupler_work) -> None:
    """Row ``k`` of the histories: every car's sensors and energies, the couplers' forces and closures, the work
    the cars did on the couplers."""
    for e in range(energy.shape[1]):
        energy[k, e] = 0.0
    coupler_work[k] = 0.0
    for c in range(layout.shape[0]):
        car_kernels.observe(layout, values, c, k, displacement, velocity, acceleration, energy)
    for j in range(couplers.force.size):
        force[k, j] = couplers.force[j]
        closure[k, j] = couplers.closure[j]
        energy[k, 3] += couplers.stored[j]
        energy[k, 4] += couplers.dissipated[j]
        coupler_work[k] += couplers.work[j]


@njit(cache=True, _nrt=False)
def run_steps(layout, w, laws, couplers, dt, tolerance, gain_u, gain_v, outputs, stop, counters, change,
              displacement, velocity, acceleration, force, closure, energy, coupler_work, closure_free, rate_free, previous_modes) -> None:
    """Steps ``counters[STEP] … stop`` (module docstring), after recording row 0 (t = 0) if
    ``counters[OUTPUT]`` is 0; a failing coupler iteration stops the run with ``counters[FAILED_STEP]``,
    ``counters[WORST]`` (the coupler) and ``counters[FAILURE_KIND]`` set."""
    n_c = couplers.force.size
    if counters[OUTPUT] == 0:
        record(layout, w, couplers, counters[OUTPUT], displacement, velocity, acceleration, force, closure, energy, coupler_work)
        counters[OUTPUT] = 1
    for step in range(counters[STEP], stop + 1):
        for j in range(n_c):
            closure_free[j] = 0.0
            rate_free[j] = 0.0
        for c in range(layout.shape[0]):
            car_kernels.predict(layout, w, c)
            Y, outputs_map = layout[c, END_COUNT], layout[c, COUPLER_OUTPUTS]
            end_free, end_rate_free = layout[c, END_FREE], layout[c, END_RATE_FREE]
            for j in range(n_c):
                for i in range(Y):
                    closure_free[j] += w[outputs_map + j * Y + i] * w[end_free + i]
                    rate_free[j] += w[outputs_map + j * Y + i] * w[end_rate_free + i]
        for j in range(n_c):
            previous_modes[j] = couplers.mode[j]
        iterations, worst, kind, last_change = coupler_kernels.solve(
            laws, couplers, dt, tolerance, closure_free, rate_free, gain_u, gain_v
        )
        if worst >= 0:
            counters[FAILED_STEP], counters[WORST], counters[FAILURE_KIND] = step, worst, kind
            change[0] = last_change
            counters[STEP] = step
            return
        counters[ITERATIONS] += iterations
        counters[ITERATIONS_MAX] = max(counters[ITERATIONS_MAX], iterations)
        for j in range(n_c):
            if couplers.mode[j] != previous_modes[j]:
                counters[CHANGES] += 1
        for c in range(layout.shape[0]):
            J, loads_map, new_loads = layout[c, LOAD_COUNT], layout[c, COUPLER_LOADS], layout[c, NEW_LOADS]
            for i in range(J):
                s = 0.0
                for j in range(n_c):
                    s += w[loads_map + i * n_c + j] * couplers.force[j]
                w[new_loads + i] = s
            car_kernels.advance(layout, w, c)
        k = counters[OUTPUT]
        if k < outputs.size and step == outputs[k]:
            record(layout, w, couplers, k, displacement, velocity, acceleration, force, closure, energy, coupler_work)
            counters[OUTPUT] = k + 1
    counters[STEP] = stop + 1


ENTRY_POINTS = (run_steps, car_kernels.factorise, car_kernels.start, coupler_kernels.start)
"""The compiled functions a run calls from Python (:func:`solve_compiled`, :func:`line_plan`, :mod:`.packing`): cached, the loop only loads."""

__all__ = ["CHUNK_SECONDS", "ENTRY_POINTS", "FIRST_CHUNK", "FIRST_CHUNK_WORK", "HISTORIES", "LinePlan", "PreparedRun", "chunk_after", "coupler_maps",
           "first_chunk", "line_plan", "new_histories", "prepare_run", "record", "response_of", "run_steps", "solve_compiled"]
