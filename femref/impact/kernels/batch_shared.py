"""Runs whose cars are the same matrices stepped side by side: one pool of matrices, the B runs' states as the columns
of one array (samples innermost), each step's band products and solves walking a matrix once for all runs.

A values-only sweep (speeds, measurement) packs B runs whose pools differ only in their state — the cars' matrices,
factors, maps and the step are the same numbers (:func:`shares_matrices`). :func:`run_shared` steps them as
:func:`~femref.impact.kernels.loop.run_steps` steps each: per step every car predicts for all runs
(:func:`femref.impact.kernels.batch_cars.predict`), then each run's free closures and rates and its own coupler
iteration (its laws, state, tolerance and gains: O(couplers)), then every car advances for all runs with the new end
loads, and at an output step the histories are recorded. The arithmetic of each run is that of the run alone, in the
same order (:mod:`femref.impact.kernels.batch_cars`), so its histories are the same numbers, bit for bit.

A run whose coupler iteration fails stops at that step as alone: its counters say where, its state is kept as it
was then (``frozen``), its histories stay NaN after it; its column is still stepped with the others (the columns do
not mix), but nothing of it is read. Only second-order cars step this way (:func:`shares_matrices`).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Sequence

import numpy as np
from numba import njit
from numpy.typing import NDArray

from femref.impact.kernels import batch_cars
from femref.impact.kernels import couplers as coupler_kernels
from femref.impact.kernels.batch_cars import SPARE_ROWS, STATE_FIELDS
from femref.impact.kernels.loop import (
    CHANGES, FAILED_STEP, FAILURE_KIND, FIRST_CHUNK, HISTORIES, ITERATIONS, ITERATIONS_MAX, OUTPUT, STEP, WORST,
    PreparedRun, chunk_after, new_histories, response_of,
)
from femref.impact.kernels.pool import (
    COUPLER_LOADS, COUPLER_OUTPUTS, END_COUNT, END_FREE, END_RATE_FREE, KIND, LOAD_COUNT, NEW_LOADS, SECOND_ORDER,
    CarPool,
)
from femref.impact.response import ImpactResponse

__all__ = ["copy_into", "rows_of", "run_shared", "shares_matrices", "solve_shared", "state_rows"]


def state_rows(run: PreparedRun) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``(layout, index)``: the run's layout with each :data:`~femref.impact.kernels.batch_cars.STATE_FIELDS` column
    re-pointed to the field's first row of the states' array, and the positions in the pool's ``values`` of those
    rows, in row order (``states[:, b] = values_b[index]``)."""
    layout, shapes = run.pool.layout.copy(), run.pool.shapes
    index, row = [], 0
    for c in range(layout.shape[0]):
        for field in STATE_FIELDS:
            size = math.prod(shapes[c][field])
            index.append(np.arange(run.pool.layout[c, field], run.pool.layout[c, field] + size))
            layout[c, field] = row
            row += size
    return layout, np.concatenate(index).astype(np.int64)


def shares_matrices(runs: Sequence[PreparedRun]) -> bool:
    """Whether ``runs`` (one :func:`~femref.impact.kernels.batch.structure_of`) can step side by side: more than one,
    every car second order, and their pools equal outside the state fields (every matrix, factor, map and
    coefficient the same number) and their gains equal."""
    first = runs[0]
    if len(runs) < 2 or np.any(first.pool.layout[:, KIND] != SECOND_ORDER):
        return False
    shared = np.ones(first.pool.values.size, dtype=bool)
    shared[state_rows(first)[1]] = False
    matrices = first.pool.values[shared]
    return all(np.array_equal(run.pool.values[shared], matrices) and np.array_equal(run.gain_u, first.gain_u)
               and np.array_equal(run.gain_v, first.gain_v) for run in runs[1:])


def solve_shared(runs: Sequence[PreparedRun]) -> list[ImpactResponse]:
    """Step ``runs`` (:func:`shares_matrices`) side by side from contact to their end (module docstring); each
    response as :func:`~femref.impact.kernels.loop.solve_compiled` gives it, its ``wall_time`` the batch's stepping
    time over ``len(runs)``."""
    started = _time.perf_counter()
    first = runs[0]
    b, n_c = len(runs), first.couplers.force.size
    layout, index = state_rows(first)
    rows = index.size
    states = np.zeros((rows + SPARE_ROWS, b))
    states[:rows] = np.stack([run.pool.values[index] for run in runs], axis=1)
    frozen = np.zeros((b, rows))
    laws, law_rows = rows_of([run.line.laws for run in runs])
    same_laws = bool(np.all(law_rows[2] == law_rows[2][0]) and np.all(law_rows[3] == law_rows[3][0]))
    couplers, coupler_rows = rows_of([run.couplers for run in runs])
    history = new_histories(first, b)
    counters = np.zeros((b, 8), dtype=np.int64)
    counters[:, STEP], counters[:, WORST] = 1, -1
    change = np.zeros((b, 1))
    tolerance = np.array([run.line.force_tolerance for run in runs])
    scratch = (np.zeros(n_c), np.zeros(n_c), np.zeros(n_c, dtype=np.int64), np.zeros((n_c, b)), np.ones(b, dtype=np.bool_))
    steps, chunk = first.steps, min(FIRST_CHUNK, first.steps)
    while np.any(counters[:, WORST] < 0):
        going = counters[np.argmax(counters[:, WORST] < 0)]
        if going[STEP] > steps and going[OUTPUT] > 0:
            break
        stop = min(steps, int(going[STEP]) + chunk - 1)
        chunk_started = _time.perf_counter()
        run_shared(layout, first.pool.values, states, laws, *law_rows, same_laws, couplers, *coupler_rows, first.dt, tolerance, first.gain_u,
                   first.gain_v, first.outputs, stop, counters, change, frozen, *(history[name] for name in HISTORIES), *scratch)
        chunk = min(steps, chunk_after(chunk, _time.perf_counter() - chunk_started))
    share = (_time.perf_counter() - started) / b
    responses = []
    for k, run in enumerate(runs):
        values = first.pool.values.copy()
        values[index] = frozen[k] if counters[k, WORST] >= 0 else states[:rows, k]
        responses.append(response_of(run, CarPool(run.pool.layout, values, run.pool.shapes), counters[k], float(change[k, 0]),
                                     {name: history[name][k] for name in HISTORIES}, share))
    return responses


_Rows = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]


def rows_of(tuples: Sequence[tuple]) -> tuple[tuple, _Rows]:
    """NamedTuples of arrays of one shape (each run's coupler laws or state) as one working NamedTuple whose arrays are
    views of two flat buffers (float64, int64), and each run's values as a row of two stacked arrays: ``(working,
    (floats, ints, float rows, int rows))``. A batched kernel copies a run's rows into the buffers before its steps
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


@njit(cache=True, _nrt=False, inline="always")
def copy_into(source, target) -> None:
    """``target[:] = source`` without a temporary (no allocation in the loop)."""
    for i in range(source.size):
        target[i] = source[i]


@njit(cache=True, _nrt=False)
def _record_couplers(couplers, b: int, k: int, force, closure, energy, coupler_work) -> None:
    """Row ``k`` of run ``b``'s coupler histories, its energies and work zeroed first (as
    :func:`~femref.impact.kernels.loop.record`; the cars' shares are added by ``batch_cars.observe``)."""
    for e in range(energy.shape[2]):
        energy[b, k, e] = 0.0
    coupler_work[b, k] = 0.0
    for j in range(couplers.force.size):
        force[b, k, j] = couplers.force[j]
        closure[b, k, j] = couplers.closure[j]
        energy[b, k, 3] += couplers.stored[j]
        energy[b, k, 4] += couplers.dissipated[j]
        coupler_work[b, k] += couplers.work[j]


@njit(cache=True, _nrt=False)
def run_shared(layout, w, s, laws, law_floats, law_ints, law_float_rows, law_int_rows, same_laws, couplers, state_floats, state_ints,
               state_float_rows, state_int_rows, dt, tolerance, gain_u, gain_v, outputs, stop, counters, change, frozen,
               displacement, velocity, acceleration, force, closure, energy, coupler_work, closure_free, rate_free, previous_modes,
               forces, live) -> None:
    """Steps ``counters[:, STEP]`` (one for all runs) … ``stop`` of the runs side by side (module docstring), after
    recording row 0 if ``counters[:, OUTPUT]`` is 0: ``w`` the shared pool, ``layout`` its layout with the state fields
    at rows of ``s`` (run ``b`` its column), the coupler laws and states rows ``[b]`` (:func:`rows_of`; the laws copied
    once if ``same_laws``), ``forces`` (n_c × B) and ``live`` (B) scratch."""
    B, n_c, cars = s.shape[1], couplers.force.size, layout.shape[0]
    spare = s.shape[0] - SPARE_ROWS
    going = -1  # a run still going: the live runs share their step and output counters
    for b in range(B):
        live[b] = counters[b, WORST] < 0
        if live[b] and going < 0:
            going = b
    if going < 0:
        return
    if same_laws:
        copy_into(law_float_rows[0], law_floats)
        copy_into(law_int_rows[0], law_ints)
    if counters[going, OUTPUT] == 0:
        for b in range(B):
            copy_into(state_float_rows[b], state_floats)
            copy_into(state_int_rows[b], state_ints)
            _record_couplers(couplers, b, 0, force, closure, energy, coupler_work)
            counters[b, OUTPUT] = 1
        for c in range(cars):
            batch_cars.observe(layout, w, s, c, spare, live, 0, displacement, velocity, acceleration, energy)
    k = counters[going, OUTPUT]  # the next output row (the runs that stop keep theirs)
    for step in range(counters[going, STEP], stop + 1):
        for c in range(cars):
            batch_cars.predict(layout, w, s, c, spare)
        output = k < outputs.size and step == outputs[k]
        for b in range(B):
            if not live[b]:
                continue
            for j in range(n_c):
                closure_free[j] = 0.0
                rate_free[j] = 0.0
            for c in range(cars):
                Y, outputs_map = layout[c, END_COUNT], layout[c, COUPLER_OUTPUTS]
                end_free, end_rate_free = layout[c, END_FREE], layout[c, END_RATE_FREE]
                for j in range(n_c):
                    for i in range(Y):
                        closure_free[j] += w[outputs_map + j * Y + i] * s[end_free + i, b]
                        rate_free[j] += w[outputs_map + j * Y + i] * s[end_rate_free + i, b]
            if not same_laws:
                copy_into(law_float_rows[b], law_floats)
                copy_into(law_int_rows[b], law_ints)
            copy_into(state_float_rows[b], state_floats)
            copy_into(state_int_rows[b], state_ints)
            for j in range(n_c):
                previous_modes[j] = couplers.mode[j]
            iterations, worst, kind, last_change = coupler_kernels.solve(
                laws, couplers, dt, tolerance[b], closure_free, rate_free, gain_u, gain_v
            )
            if worst >= 0:  # this run stops here, as alone: its state kept as it is now
                counters[b, FAILED_STEP], counters[b, WORST], counters[b, FAILURE_KIND] = step, worst, kind
                change[b, 0] = last_change
                counters[b, STEP] = step
                live[b] = False
                for row in range(frozen.shape[1]):
                    frozen[b, row] = s[row, b]
                continue
            counters[b, ITERATIONS] += iterations
            counters[b, ITERATIONS_MAX] = max(counters[b, ITERATIONS_MAX], iterations)
            for j in range(n_c):
                if couplers.mode[j] != previous_modes[j]:
                    counters[b, CHANGES] += 1
                forces[j, b] = couplers.force[j]
            if output:
                _record_couplers(couplers, b, k, force, closure, energy, coupler_work)
                counters[b, OUTPUT] = k + 1
            copy_into(state_floats, state_float_rows[b])
            copy_into(state_ints, state_int_rows[b])
        for c in range(cars):
            J, loads_map, new_loads = layout[c, LOAD_COUNT], layout[c, COUPLER_LOADS], layout[c, NEW_LOADS]
            for i in range(J):
                target = s[new_loads + i]
                for b in range(B):
                    target[b] = 0.0
                for j in range(n_c):
                    factor, source = w[loads_map + i * n_c + j], forces[j]
                    for b in range(B):
                        target[b] += factor * source[b]
            batch_cars.advance(layout, w, s, c, spare)
        if output:
            for c in range(cars):
                batch_cars.observe(layout, w, s, c, spare, live, k, displacement, velocity, acceleration, energy)
            k += 1
    for b in range(B):
        if live[b]:
            counters[b, STEP] = stop + 1
