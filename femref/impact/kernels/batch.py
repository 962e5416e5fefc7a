"""Runs of one scene structure stepped together in one compiled call per chunk of steps: side by side on one copy of
their cars' matrices when those are the same numbers (:mod:`femref.impact.kernels.batch_shared`), else
:func:`~femref.impact.kernels.loop.run_steps` looped over their B pools (:func:`run_batch`).

A sweep's samples often differ only in values — velocities, masses, coupler parameters — not in what the kernel's
arrays look like. Runs whose pools share their layout, their number of steps and outputs, their step and their
coupler count (:func:`structure_of`) are stepped together. Those whose cars' matrices are equal too (a values-only
sweep: :func:`~femref.impact.kernels.batch_shared.shares_matrices`) step side by side, each band product and solve
walking a matrix once for all of them; the others by :func:`run_batch`, each run on its own pool, coupler laws and
state, tolerance and gains, exactly as :func:`~femref.impact.kernels.loop.solve_compiled` steps it alone: the same
kernel on the same arrays, so the histories are the same numbers (and side by side too: the same sums in the same
order). What :func:`run_batch` saves is the Python between the kernel calls — a call per run and chunk, each typing
its NamedTuple arguments field by field.

:func:`solve_batch` steps runs packed as ``solve_compiled`` packs one (:func:`~femref.impact.kernels.loop.prepare_run`)
and gives each its :class:`~femref.impact.response.ImpactResponse` (:func:`~femref.impact.kernels.loop.response_of`),
its stepping time the batch's share per run.
"""

from __future__ import annotations

import time as _time
from collections.abc import Sequence

import numpy as np
from numba import njit

from femref.impact.kernels.loop import (
    FIRST_CHUNK,
    HISTORIES,
    OUTPUT,
    STEP,
    WORST,
    PreparedRun,
    chunk_after,
    new_histories,
    response_of,
    run_steps,
)
from femref.impact.kernels.batch_shared import copy_into, rows_of, shares_matrices, solve_shared
from femref.impact.kernels.pool import CarPool
from femref.impact.response import ImpactResponse

__all__ = ["run_batch", "solve_batch", "structure_of"]


def structure_of(run: PreparedRun) -> tuple:
    """What runs stepped together must share: the pool's layout and size, the step, the output steps, the sensor count
    and the shapes of the gains and of the coupler laws' and state's arrays."""
    return (run.pool.layout.shape, run.pool.layout.tobytes(), run.pool.values.size, run.dt, run.steps, run.outputs.tobytes(),
            run.line.sensors, run.gain_u.shape, run.gain_v.shape, tuple((a.shape, a.dtype.str) for a in (*run.line.laws, *run.couplers)))


def solve_batch(runs: Sequence[PreparedRun]) -> list[ImpactResponse]:
    """Step ``runs`` (one :func:`structure_of`) together from contact to their end, side by side if they share their
    matrices (module docstring); each response as ``solve_compiled`` gives it, its ``wall_time`` the batch's stepping
    time over ``len(runs)``."""
    first = runs[0]
    if any(structure_of(run) != structure_of(first) for run in runs[1:]):
        raise ValueError("runs stepped together must share their structure (structure_of)")
    if shares_matrices(runs):
        return solve_shared(runs)
    started = _time.perf_counter()
    b, n_c = len(runs), first.couplers.force.size
    values = np.stack([run.pool.values for run in runs])
    laws, law_rows = rows_of([run.line.laws for run in runs])
    couplers, coupler_rows = rows_of([run.couplers for run in runs])
    history = new_histories(first, b)
    counters = np.zeros((b, 8), dtype=np.int64)
    counters[:, STEP], counters[:, WORST] = 1, -1  # run_steps records row 0 first
    change = np.zeros((b, 1))
    tolerance = np.array([run.line.force_tolerance for run in runs])
    gain_u, gain_v = np.stack([run.gain_u for run in runs]), np.stack([run.gain_v for run in runs])
    scratch = (np.zeros((b, n_c)), np.zeros((b, n_c)), np.zeros((b, n_c), dtype=np.int64))
    steps, chunk = first.steps, min(FIRST_CHUNK, first.steps)
    while np.any(((counters[:, STEP] <= steps) | (counters[:, OUTPUT] == 0)) & (counters[:, WORST] < 0)):
        stop = min(steps, int(np.min(counters[counters[:, WORST] < 0, STEP])) + chunk - 1)
        chunk_started = _time.perf_counter()
        run_batch(first.pool.layout, values, laws, *law_rows, couplers, *coupler_rows, first.dt, tolerance, gain_u, gain_v, first.outputs, stop,
                  counters, change, *(history[name] for name in HISTORIES), *scratch)
        chunk = min(steps, chunk_after(chunk, _time.perf_counter() - chunk_started))
    share = (_time.perf_counter() - started) / b
    return [response_of(run, CarPool(run.pool.layout, values[k], run.pool.shapes), counters[k], float(change[k, 0]),
                        {name: history[name][k] for name in HISTORIES}, share) for k, run in enumerate(runs)]


@njit(cache=True, _nrt=False)
def run_batch(layout, values, laws, law_floats, law_ints, law_float_rows, law_int_rows, couplers, state_floats, state_ints, state_float_rows,
              state_int_rows, dt, tolerance, gain_u, gain_v, outputs, stop, counters, change,
              displacement, velocity, acceleration, force, closure, energy, coupler_work, closure_free, rate_free, previous_modes) -> None:
    """:func:`~femref.impact.kernels.loop.run_steps` up to ``stop`` for each run ``b`` still going: its pool
    ``values[b]`` (one ``layout``), its coupler laws and state (rows ``[b]`` copied into the buffers that ``laws`` and
    ``couplers`` view, the state copied back after: :func:`_rows_of`), ``tolerance[b]``, gains, counters, histories
    and scratch rows ``[b]``."""
    for b in range(values.shape[0]):
        if counters[b, WORST] >= 0 or (counters[b, STEP] > stop and counters[b, OUTPUT] > 0):
            continue
        copy_into(law_float_rows[b], law_floats)
        copy_into(law_int_rows[b], law_ints)
        copy_into(state_float_rows[b], state_floats)
        copy_into(state_int_rows[b], state_ints)
        run_steps(layout, values[b], laws, couplers, dt, tolerance[b], gain_u[b], gain_v[b], outputs, stop, counters[b], change[b],
                  displacement[b], velocity[b], acceleration[b], force[b], closure[b], energy[b], coupler_work[b],
                  closure_free[b], rate_free[b], previous_modes[b])
        copy_into(state_floats, state_float_rows[b])
        copy_into(state_ints, state_int_rows[b])
