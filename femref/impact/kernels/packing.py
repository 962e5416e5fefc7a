"""Packing the cars into the pool (:mod:`femref.impact.kernels.pool`): once per system, then once per run.

:func:`prepared_car` packs one car alone and :func:`~femref.impact.kernels.cars.factorise` factorises it
and precomputes its gains in compiled code, once per system, step and coupler maps (kept beside the
system, so the runs of a sweep, a study or the bench reuse it); :func:`pack_cars` copies the prepared
cars into a run's pool, sets their initial state and calls :func:`~femref.impact.kernels.cars.start`
(the consistent initial acceleration). A second-order car's matrices go in as row bands (a dense modal
or rigid car is a banded one whose band is the whole matrix), its step matrix ``S`` and mass as the
lower band by columns that the compiled Cholesky factorises in place.
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from femref.fem.banded import entries
from femref.fem.transient import Integrator
from femref.impact.kernels.cars import factorise, start
from femref.impact.kernels.pool import (
    BAND, COUPLER_COUNT, COUPLER_LOADS, COUPLER_OUTPUTS, DOFS, END_COUNT, FIELDS, GAIN_U, GAIN_V, LOAD_COUNT, LOADS, SECOND_ORDER,
    SENSOR_START, STATE_SPACE, KIND, SENSOR_COUNT, TRANSLATION, V, X, CarPool, sparse_size,
)
from femref.impact.systems import CarSystem, SecondOrderSystem, StateSpaceSystem

FIELDS_AT = {name: f for f, name in enumerate(FIELDS, start=COUPLER_COUNT + 1)}
"""The layout column of each field by name."""
SPARSE_FIELDS = ("transition", "kinetic_form", "strain_form", "end_outputs", "end_rates", "sensor_outputs", "sensor_rates",
                 "sensor_accelerations")
"""A state-space car's matrices stored sparse (:func:`~femref.impact.kernels.pool.compress_rows`): its step's products
skip their zeros (a quasi-rigid car's 16 × 16 transition has 35 nonzeros). Packed dense at the end of its field (sized
for a full matrix, :func:`~femref.impact.kernels.pool.sparse_size`), each is compressed in place by
:func:`~femref.impact.kernels.cars.factorise`, in compiled code."""


def _bands(rows: NDArray[np.intp], cols: NDArray[np.intp], data: NDArray[np.float64], p: int, n: int) -> NDArray[np.float64]:
    """``bands[k, i] = A[i, i + k − p]`` of an n × n matrix of half-bandwidth at most p from its entries ``(i, j, A_ij)``."""
    bands = np.zeros((2 * p + 1, n))
    bands[cols - rows + p, rows] = data
    return bands


def _lower_columns(bands: NDArray[np.float64], p: int, n: int) -> NDArray[np.float64]:
    """The lower band by columns, ``low[k, j] = A[j + k, j]``, of a symmetric matrix in row bands."""
    low = np.zeros((p + 1, n))
    for k in range(p + 1):
        # A[j + k, j] = A[j, j + k] (symmetric) = bands[p + k, j]
        low[k, : n - k] = bands[p + k, : n - k]
    return low


@dataclass(frozen=True, eq=False)
class PreparedCar:
    """One car packed alone and factorised (:func:`factorise`): its layout row with offsets into its own
    ``values``, the shapes of its fields, and its share ``Cc G Bc`` of the coupler Schur gains.
    Constant for a system, integrator, step and coupler maps; a run copies it (:func:`pack_cars`)."""

    layout: NDArray[np.int64]  # (COUPLER_COUNT + 1 + len(FIELDS),), SENSOR_START 0
    values: NDArray[np.float64]
    shapes: dict[int, tuple[int, ...]]
    positive_definite: bool  # False: its mass or step matrix is not (the values are then meaningless)
    gain_u: NDArray[np.float64]  # (n_c, n_c) Cc G_u Bc: ∂(closures)/∂P over one step
    gain_v: NDArray[np.float64]  # (n_c, n_c) Cc G_v Bc: ∂(closure rates)/∂P


_prepared: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
PREPARED_PER_SYSTEM = 8
"""How many prepared forms (steps, integrators, coupler maps) are kept per system; as many factorised ones
(steps, integrators, map sizes)."""


def prepared_car(system: CarSystem, integrator: Integrator, dt: float, coupler_loads: NDArray, coupler_outputs: NDArray) -> PreparedCar:
    """``system`` packed and factorised for a step ``dt`` of ``integrator`` with its coupler maps ``(Bc, Cc)``:
    once per system and these arguments (a system is built once per geometry, so the runs of a sweep, a
    study or the bench factorise each car once, and the cars of one geometry in a line share one
    factorisation: it does not depend on the maps); the state fields are zero, :func:`pack_cars` sets them."""
    coupler_loads = np.ascontiguousarray(coupler_loads, dtype=float)
    coupler_outputs = np.ascontiguousarray(coupler_outputs, dtype=float)
    key = (integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma, float(dt),
           coupler_loads.shape, coupler_loads.tobytes(), coupler_outputs.shape, coupler_outputs.tobytes())
    forms = _prepared.setdefault(system, {})
    car = forms.get(key)
    if car is None:
        car = _with_maps(_factorised(system, integrator, dt, coupler_loads.shape, coupler_outputs.shape[1]), coupler_loads, coupler_outputs)
        _keep(forms, key, car)
    return car


def _keep(forms: dict, key: tuple, value: object) -> None:
    """``forms[key] = value``, the oldest dropped beyond :data:`PREPARED_PER_SYSTEM`."""
    forms[key] = value
    if len(forms) > PREPARED_PER_SYSTEM:
        del forms[next(iter(forms))]


_factorised_forms: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _factorised(system: CarSystem, integrator: Integrator, dt: float, loads_shape: tuple[int, int], outputs: int) -> PreparedCar:
    """The car packed alone and factorised, its coupler maps and gains zero: once per system, step, integrator and
    map sizes (``J × n_c`` loads, ``Y`` end outputs), which is all the factorisation depends on."""
    key = (integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma, float(dt), loads_shape, outputs)
    forms = _factorised_forms.setdefault(system, {})
    car = forms.get(key)
    if car is None:
        J, n_c = loads_shape
        sizes, fields = _car_fields(system, integrator, dt, J, outputs, n_c)
        template, shapes, slots = _layout(*(sizes[k] for k in (KIND, DOFS, BAND, LOAD_COUNT, END_COUNT, SENSOR_COUNT, COUPLER_COUNT)))
        layout = template.copy()
        layout[: COUPLER_COUNT + 1] = sizes
        values = np.zeros(slots[FIELDS[-1]].stop)  # written straight into: the fields that start at zero (the state, scratch) are left so
        for name, value in fields.items():
            flat, slot = np.asarray(value, dtype=float).ravel(), slots[name]
            if name in SPARSE_FIELDS:  # dense at the field's end, for factorise to compress
                slot = slice(slot.stop - flat.size, slot.stop)
            values[slot] = flat
        positive_definite = factorise(layout.reshape(1, -1), values, 0)
        layout.flags.writeable = values.flags.writeable = False
        car = PreparedCar(layout, values, shapes, bool(positive_definite), np.zeros((n_c, n_c)), np.zeros((n_c, n_c)))
        _keep(forms, key, car)
    return car


def _with_maps(factorised: PreparedCar, coupler_loads: NDArray, coupler_outputs: NDArray) -> PreparedCar:
    """The factorised car with its coupler maps ``(Bc, Cc)`` and its share ``Cc G Bc`` of the Schur gains."""
    layout, values = factorised.layout, factorised.values.copy()
    for f, value in ((COUPLER_LOADS, coupler_loads), (COUPLER_OUTPUTS, coupler_outputs)):
        values[layout[f]: layout[f] + value.size] = value.ravel()
    J = coupler_loads.shape[0]
    Y = coupler_outputs.shape[1]
    gains = [values[layout[f]: layout[f] + Y * J].reshape(Y, J) for f in (GAIN_U, GAIN_V)]
    return PreparedCar(layout, values, factorised.shapes, factorised.positive_definite,
                       coupler_outputs @ gains[0] @ coupler_loads, coupler_outputs @ gains[1] @ coupler_loads)


@functools.lru_cache(maxsize=256)
def _layout(kind: int, n: int, p: int, J: int, Y: int, S: int, n_c: int) -> tuple[NDArray[np.int64], dict[int, tuple[int, ...]], dict[str, slice]]:
    """A car's layout row with its fields' offsets (sizes zero), their shapes by column and their slices of the
    values by name (the last field's ends the values): once per kind and sizes (read-only, shared)."""
    if kind == STATE_SPACE:
        rows = {"transition": n, "kinetic_form": n, "strain_form": n, "end_outputs": Y, "end_rates": Y, "sensor_outputs": S,
                "sensor_rates": S, "sensor_accelerations": S}
        named = {"coefficients": (7,), "load": (n, J), "work_map": (J, Y), **{name: (sparse_size(rows[name], n),) for name in SPARSE_FIELDS},
                 **{name: (n,) for name in ("x", "x_free", "work1", "work2", "work3")}}
    else:
        bands, factor = (2 * p + 1, n), (p + 1, n)
        named = {"coefficients": (7,), **{name: bands for name in ("history_u", "history_v", "history_a", "damping", "stiffness", "mass")},
                 "effective_factor": factor, "mass_factor": factor, "load": (n, J), "response": (n, J), "translation": (n,),
                 "sensor_travel": (S,), "end_outputs": (Y, n), "sensor_outputs": (S, n), "end_feedthrough": (Y, J),
                 "sensor_feedthrough": (S, J), "feedthrough_energy": (J, J),
                 **{name: (n,) for name in ("u", "v", "a", "u_free", "v_free", "a_free", "work1", "work2", "work3")}}
    named.update({"gain_u": (Y, J), "gain_v": (Y, J), "coupler_loads": (J, n_c), "coupler_outputs": (n_c, Y),
                  **{name: (J,) for name in ("loads", "load_rate", "new_loads")},
                  **{name: (Y,) for name in ("end_free", "end_rate_free", "end_now")}, "scalars": (5,)})
    shapes, slots, start = {}, {}, 0
    for name, f in FIELDS_AT.items():  # the fields in column order
        shapes[f] = shape = named.get(name, (0,))
        size = math.prod(shape)
        slots[name] = slice(start, start + size)
        start += size
    layout = np.zeros(COUPLER_COUNT + 1 + len(FIELDS), dtype=np.int64)
    layout[COUPLER_COUNT + 1:] = [place.start for place in slots.values()]
    layout.flags.writeable = False
    return layout, shapes, slots


def forget_layouts() -> None:
    """Drop the layouts kept per kind and sizes (:func:`femref.models.base.forget_built`: a cold run lays out its own)."""
    _layout.cache_clear()


def pack_cars(
    systems: list[CarSystem],
    prepared: list[PreparedCar],
    velocities: list[float],
    loads: list[NDArray[np.float64]],
    sensor_starts: list[int],
) -> CarPool:
    """The pool of the cars ``systems`` (each :func:`prepared_car`) with their state at t = 0: each
    undeformed at its velocity under its end loads ``loads[c]``, its sensors from column ``sensor_starts[c]``."""
    layout = np.array([car.layout for car in prepared], dtype=np.int64).reshape(len(prepared), -1)
    values = np.concatenate([car.values for car in prepared]) if prepared else np.zeros(0)
    base = 0
    for c, car in enumerate(prepared):
        layout[c, COUPLER_COUNT + 1:] += base
        layout[c, SENSOR_START] = sensor_starts[c]
        base += car.values.size
        at = layout[c]
        loads_at = int(at[LOADS])
        values[loads_at: loads_at + int(at[LOAD_COUNT])] = loads[c]
        n = int(at[DOFS])
        if isinstance(systems[c], StateSpaceSystem):
            values[int(at[X]): int(at[X]) + n] = systems[c].initial_state(velocities[c], loads[c])
        else:
            values[int(at[V]): int(at[V]) + n] = velocities[c] * values[int(at[TRANSLATION]): int(at[TRANSLATION]) + n]
        start(layout, values, c)
    return CarPool(layout, values, tuple(car.shapes for car in prepared))


def _car_fields(
    system: CarSystem, integrator: Integrator, dt: float, J: int, Y: int, n_c: int,
) -> tuple[list[int], dict[str, NDArray[np.float64]]]:
    """One car's sizes (the layout's first columns; ``J`` end loads, ``Y`` end outputs, ``n_c`` couplers) and the
    values of its fields that do not start at zero but the coupler maps, by name (each anything that ravels to the
    size :func:`_layout` gives it)."""
    if isinstance(system, StateSpaceSystem):
        system.check_step(dt)
        n = system.transition.shape[0]
        S = system.sensor_displacement.shape[0]
        sizes = [STATE_SPACE, n, 0, 0, 0, J, Y, S, n_c]
        matrices = (system.transition, system.kinetic_form, system.strain_form, system.end_displacement, system.end_velocity,
                    system.sensor_displacement, system.sensor_velocity, system.sensor_acceleration)
        fields = {"coefficients": np.array([dt, 0, 0, 0, 0, 0, 0], dtype=float), "load": system.input, "work_map": system.work_map,
                  **dict(zip(SPARSE_FIELDS, matrices))}
    else:
        sizes, fields = _second_order_fields(system, integrator, dt, J, Y, n_c)
    return sizes, {name: value for name, value in fields.items() if value is not None}


_banded_forms: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _banded_form(system: SecondOrderSystem) -> tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(p, M, C, K)`` in row bands, p the half-bandwidth: once per system, since a system is built
    once per geometry and every run of it reuses them (a fem car's conversion costs milliseconds;
    the arrays are only read); a system that carries its bands (a fem rod) gives them."""
    form = _banded_forms.get(system)
    if form is None:
        form = system.bands if system.bands is not None else _bands_of(system.dofs, (system.mass, system.damping, system.stiffness))
        _banded_forms[system] = form
    return form


def _bands_of(n: int, given: tuple) -> tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(p, M, C, K)`` in row bands of the three n × n matrices ``given`` (sparse or dense), p their widest stored
    (sparse) or nonzero (dense) half-bandwidth."""
    if n == 1:  # a point mass: its one entry is its band
        return (0, *(np.asarray(m.toarray() if sp.issparse(m) else m, dtype=float).reshape(1, 1) for m in given))
    if any(sp.issparse(m) for m in given):
        matrices = [entries(m) for m in given]
    else:  # a small dense car: one pattern for the three
        dense = [np.asarray(m, dtype=float) for m in given]
        rows, cols = np.nonzero((dense[0] != 0.0) | (dense[1] != 0.0) | (dense[2] != 0.0))
        matrices = [(rows, cols, m[rows, cols]) for m in dense]
    p = max((int(np.max(np.abs(rows - cols))) if rows.size else 0) for rows, cols, _ in matrices)
    return (p, *(_bands(*m, p, n) for m in matrices))


def _second_order_fields(
    system: SecondOrderSystem, integrator: Integrator, dt: float, J: int, Y: int, n_c: int,
) -> tuple[list[int], dict[str, NDArray[np.float64] | None]]:
    n = system.dofs
    S = system.sensor_outputs.shape[0]
    p, mass, damping, stiffness = _banded_form(system)
    am, af, beta, gamma = integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma
    effective = (1.0 - am) * mass + (1.0 - af) * gamma * dt * damping + (1.0 - af) * beta * dt * dt * stiffness
    translation = np.asarray(system.translation, dtype=float)
    sensor_outputs = np.asarray(system.sensor_outputs, dtype=float).reshape(S, n)
    sizes = [SECOND_ORDER, n, p, int(np.argmax(np.abs(translation))), 0, J, Y, S, n_c]
    return sizes, {
        "coefficients": np.array([dt, af, dt * dt * (0.5 - beta), dt * dt * beta, dt * (1.0 - gamma), dt * gamma,
                                  float(integrator.alpha_m != integrator.alpha_f)]),
        "history_u": -stiffness,
        "history_v": -(damping + (1.0 - af) * dt * stiffness),
        "history_a": -(am * mass + (1.0 - af) * (1.0 - gamma) * dt * damping + (1.0 - af) * (0.5 - beta) * dt * dt * stiffness),
        "damping": damping, "stiffness": stiffness, "mass": mass,
        "effective_factor": _lower_columns(effective, p, n), "mass_factor": _lower_columns(mass, p, n),
        "load": system.load_matrix, "translation": translation, "sensor_travel": sensor_outputs @ translation,
        "end_outputs": system.end_outputs, "sensor_outputs": sensor_outputs, "end_feedthrough": system.end_feedthrough,
        "sensor_feedthrough": system.sensor_feedthrough, "feedthrough_energy": system.feedthrough_energy,
    }


__all__ = ["PREPARED_PER_SYSTEM", "SPARSE_FIELDS", "PreparedCar", "forget_layouts", "pack_cars", "prepared_car"]
