"""Runs of one scene structure stepped together: :func:`~femref.impact.kernels.loop.run_steps` looped over B pools in one
compiled call.

A sweep's samples often differ only in values — velocities, masses, coupler parameters — not in what the kernel's
arrays look like. Runs whose pools share their layout, their number of steps and outputs, their step and their
coupler count (:func:`structure_of`) are stepped by :func:`run_batch` in one call per chunk of steps, each run on its
own pool, coupler laws and state, tolerance and gains, exactly as :func:`~femref.impact.kernels.loop.solve_compiled`
steps it alone: the same kernel on the same arrays, so the histories are the same numbers. What a batch saves is the
Python between the kernel calls — a call per run and chunk, each typing its NamedTuple arguments field by field.

:func:`solve_batch` steps runs packed as ``solve_compiled`` packs one (:func:`~femref.impact.kernels.loop.prepare_run`)
and gives each its :class:`~femref.impact.response.ImpactResponse` (:func:`~femref.impact.kernels.loop.response_of`),
its stepping time the batch's share per run.
"""

from __future__ import annotations

import time as _time
from collections.abc import Sequence

import numpy as np
from numba import njit
from numpy.typing import NDArray

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
from femref.impact.kernels.pool import CarPool
from femref.impact.response import ImpactResponse

__all__ = ["run_batch", "solve_batch", "structure_of"]


def structure_of(run: PreparedRun) -> tuple:
    """What runs stepped together must share: the pool's layout and size, the step, the output steps, the sensor count
    and the shapes of the gains and of the coupler laws' and state's arrays."""
    return (run.pool.layout.shape, run.pool.layout.tobytes(), run.pool.values.size, run.dt, run.steps, run.outputs.tobytes(),
            run.line.sensors, run.gain_u.shape, run.gain_v.shape, tuple((a.shape, a.dtype.str) for a in (*run.line.laws, *run.couplers)))


def solve_batch(runs: Sequence[PreparedRun]) -> list[ImpactResponse]:
    """Step ``runs`` (one :func:`structure_of`) together from contact to their end (module docstring); each response as
    ``solve_compiled`` gives it, its ``wall_time`` the batch's stepping time over ``len(runs)``."""
    first = runs[0]
    if any(structure_of(run) != structure_of(first) for run in runs[1:]):
        raise ValueError("runs stepped together must share their structure (structure_of)")
    started = _time.perf_counter()
    b, n_c = len(runs), first.couplers.force.size
    values = np.stack([run.pool.values for run in runs])
    laws, law_rows = _rows_of([run.line.laws for run in runs])
    couplers, coupler_rows = _rows_of([run.couplers for run in runs])
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


_Rows = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]


def _rows_of(tuples: Sequence[tuple]) -> tuple[tuple, _Rows]:
    """NamedTuples of arrays of one shape (each run's coupler laws or state) as one working NamedTuple whose arrays are
    views of two flat buffers (float64, int64), and each run's values as a row of two stacked arrays: ``(working,
    (floats, ints, float rows, int rows))``. :func:`run_batch` copies a run's rows into the buffers before its steps
    and back after them, whatever the fields (no typed list of NamedTuples: its methods compile in every process)."""
    first = tuples[0]
    kinds = [np.dtype(np.float64) if array.dtype == np.float64 else np.dtype(np.int64) for array in first]
    if any(array.dtype not in (np.float64, np.int64) for array in first):
        raise TypeError(f"{type(first).__name__}: only float64 and int64 arrays can be stepped in a batch")
    buffers = {kind: np.zeros(sum(a.size for a, k in zip(first, kinds) if k == kind), dtype=kind) for kind in set(kinds) | {np.dtype(np.float64), np.dtype(np.int64)}}
    offsets = dict.fromkeys(buffers, 0)
    views = []
    for array, kind in zip(first, kinds):
        views.append(buffers[kind][offsets[kind]: offsets[kind] + array.size].reshape(array.shape))
        offsets[kind] += array.size
    rows = {kind: np.stack([np.concatenate([np.ravel(a) for a, k in zip(t, kinds) if k == kind] or [np.zeros(0, dtype=kind)]).astype(kind, copy=False)
                            for t in tuples]) for kind in buffers}
    float64, int64 = np.dtype(np.float64), np.dtype(np.int64)
    return type(first)(*views), (buffers[float64], buffers[int64], rows[float64], rows[int64])


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
        _copy(law_float_rows[b], law_floats)
        _copy(law_int_rows[b], law_ints)
        _copy(state_float_rows[b], state_floats)
        _copy(state_int_rows[b], state_ints)
        run_steps(layout, values[b], laws, couplers, dt, tolerance[b], gain_u[b], gain_v[b], outputs, stop, counters[b], change[b],
                  displacement[b], velocity[b], acceleration[b], force[b], closure[b], energy[b], coupler_work[b],
                  closure_free[b], rate_free[b], previous_modes[b])
        _copy(state_floats, state_float_rows[b])
        _copy(state_ints, state_int_rows[b])


@njit(cache=True, _nrt=False, inline="always")
def _copy(source, target) -> None:
    """``target[:] = source`` without a temporary (no allocation in the loop)."""
    for i in range(source.size):
        target[i] = source[i]
