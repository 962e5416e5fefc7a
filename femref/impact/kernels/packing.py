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

import math
import weakref
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from femref.fem.banded import entries
from femref.fem.transient import Integrator
from femref.impact.kernels.cars import factorise, start
from femref.impact.kernels.pool import (
    COUPLER_COUNT, DOFS, FIELDS, GAIN_U, GAIN_V, LOAD_COUNT, LOADS, SECOND_ORDER, SENSOR_START, STATE_SPACE,
    TRANSLATION, V, X, CarPool,
)
from femref.impact.systems import CarSystem, SecondOrderSystem, StateSpaceSystem

FIELDS_AT = {name: f for f, name in enumerate(FIELDS, start=COUPLER_COUNT + 1)}
"""The layout column of each field by name."""


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
"""How many prepared forms (steps, integrators, coupler maps) are kept per system."""


def prepared_car(system: CarSystem, integrator: Integrator, dt: float, coupler_loads: NDArray, coupler_outputs: NDArray) -> PreparedCar:
    """``system`` packed and factorised for a step ``dt`` of ``integrator`` with its coupler maps ``(Bc, Cc)``:
    once per system and these arguments (a system is built once per geometry, so the runs of a sweep, a
    study or the bench factorise each car once); the state fields are zero, :func:`pack_cars` sets them."""
    coupler_loads = np.ascontiguousarray(coupler_loads, dtype=float)
    coupler_outputs = np.ascontiguousarray(coupler_outputs, dtype=float)
    key = (integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma, float(dt),
           coupler_loads.shape, coupler_loads.tobytes(), coupler_outputs.shape, coupler_outputs.tobytes())
    forms = _prepared.setdefault(system, {})
    car = forms.get(key)
    if car is None:
        car = _prepare(system, integrator, dt, coupler_loads, coupler_outputs)
        forms[key] = car
        if len(forms) > PREPARED_PER_SYSTEM:
            del forms[next(iter(forms))]
    return car


def _prepare(system: CarSystem, integrator: Integrator, dt: float, coupler_loads: NDArray, coupler_outputs: NDArray) -> PreparedCar:
    sizes, fields = _car_fields(system, integrator, dt, coupler_loads, coupler_outputs)
    layout = np.zeros(COUPLER_COUNT + 1 + len(FIELDS), dtype=np.int64)
    layout[: COUPLER_COUNT + 1] = sizes
    shapes = {}
    offset = 0
    for f, name in enumerate(FIELDS, start=COUPLER_COUNT + 1):
        shape = fields[name][0] if name in fields else (0,)
        layout[f] = offset
        shapes[f] = shape
        offset += math.prod(shape)
    values = np.zeros(offset)  # written straight into: the fields that start at zero (the state, scratch) are left so
    for name, (shape, value) in fields.items():
        if value is not None:
            f = FIELDS_AT[name]
            values[layout[f]: layout[f] + math.prod(shape)] = np.ravel(value)
    positive_definite = factorise(layout.reshape(1, -1), values, 0)
    J, n_c = coupler_loads.shape
    Y = coupler_outputs.shape[1]
    gains = [values[layout[f]: layout[f] + Y * J].reshape(Y, J) for f in (GAIN_U, GAIN_V)]
    return PreparedCar(layout, values, shapes, bool(positive_definite),
                       coupler_outputs @ gains[0] @ coupler_loads, coupler_outputs @ gains[1] @ coupler_loads)


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


Field = tuple[tuple[int, ...], "NDArray[np.float64] | float | None"]
"""A field's shape and its value (anything that ravels to its size; None: zeros)."""


def _car_fields(
    system: CarSystem, integrator: Integrator, dt: float, coupler_loads: NDArray, coupler_outputs: NDArray,
) -> tuple[list[int], dict[str, Field]]:
    """One car's sizes (the layout's first columns) and its fields by name, each its shape and value (state zero);
    a field not named is empty."""
    J, n_c = coupler_loads.shape
    Y = coupler_outputs.shape[1]
    if isinstance(system, StateSpaceSystem):
        system.check_step(dt)
        n = system.transition.shape[0]
        S = system.sensor_displacement.shape[0]
        sizes = [STATE_SPACE, n, 0, 0, 0, J, Y, S, n_c]
        fields: dict[str, Field] = {
            "coefficients": ((7,), np.array([dt, 0, 0, 0, 0, 0, 0], dtype=float)),
            "load": ((n, J), system.input),
            "transition": ((n, n), system.transition),
            "kinetic_form": ((n, n), system.kinetic_form),
            "strain_form": ((n, n), system.strain_form),
            "work_map": ((J, Y), system.work_map),
            "end_outputs": ((Y, n), system.end_displacement),
            "end_rates": ((Y, n), system.end_velocity),
            "sensor_outputs": ((S, n), system.sensor_displacement),
            "sensor_rates": ((S, n), system.sensor_velocity),
            "sensor_accelerations": ((S, n), system.sensor_acceleration),
            **{name: ((n,), None) for name in ("x", "x_free", "work1", "work2", "work3")},
        }
    else:
        sizes, fields = _second_order_fields(system, integrator, dt, J, Y, n_c)
    fields.update({
        "gain_u": ((Y, J), None), "gain_v": ((Y, J), None),
        "coupler_loads": ((J, n_c), coupler_loads), "coupler_outputs": ((n_c, Y), coupler_outputs),
        "loads": ((J,), None), "load_rate": ((J,), None), "new_loads": ((J,), None),
        "end_free": ((Y,), None), "end_rate_free": ((Y,), None), "end_now": ((Y,), None), "scalars": ((5,), None),
    })
    return sizes, fields


_banded_forms: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _banded_form(system: SecondOrderSystem) -> tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(p, M, C, K)`` in row bands, p the half-bandwidth: once per system, since a system is built
    once per geometry and every run of it reuses them (a fem car's conversion costs milliseconds;
    the arrays are only read)."""
    form = _banded_forms.get(system)
    if form is None:
        matrices = [entries(m) for m in (system.mass, system.damping, system.stiffness)]
        p = max((int(np.max(np.abs(rows - cols))) if rows.size else 0) for rows, cols, _ in matrices)
        form = (p, *(_bands(*m, p, system.dofs) for m in matrices))
        _banded_forms[system] = form
    return form


def _second_order_fields(
    system: SecondOrderSystem, integrator: Integrator, dt: float, J: int, Y: int, n_c: int,
) -> tuple[list[int], dict[str, Field]]:
    n = system.dofs
    S = system.sensor_outputs.shape[0]
    p, mass, damping, stiffness = _banded_form(system)
    am, af, beta, gamma = integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma
    effective = (1.0 - am) * mass + (1.0 - af) * gamma * dt * damping + (1.0 - af) * beta * dt * dt * stiffness
    translation = np.asarray(system.translation, dtype=float)
    sensor_outputs = np.asarray(system.sensor_outputs, dtype=float).reshape(S, n)
    bands, factor = (2 * p + 1, n), (p + 1, n)
    sizes = [SECOND_ORDER, n, p, int(np.argmax(np.abs(translation))), 0, J, Y, S, n_c]
    return sizes, {
        "coefficients": ((7,), np.array([dt, af, dt * dt * (0.5 - beta), dt * dt * beta, dt * (1.0 - gamma), dt * gamma,
                                         float(integrator.alpha_m != integrator.alpha_f)])),
        "history_u": (bands, -stiffness),
        "history_v": (bands, -(damping + (1.0 - af) * dt * stiffness)),
        "history_a": (bands, -(am * mass + (1.0 - af) * (1.0 - gamma) * dt * damping + (1.0 - af) * (0.5 - beta) * dt * dt * stiffness)),
        "damping": (bands, damping), "stiffness": (bands, stiffness), "mass": (bands, mass),
        "effective_factor": (factor, _lower_columns(effective, p, n)), "mass_factor": (factor, _lower_columns(mass, p, n)),
        "load": ((n, J), system.load_matrix), "response": ((n, J), None), "translation": ((n,), translation),
        "sensor_travel": ((S,), sensor_outputs @ translation),
        "end_outputs": ((Y, n), system.end_outputs), "sensor_outputs": ((S, n), sensor_outputs),
        "end_feedthrough": ((Y, J), system.end_feedthrough),
        "sensor_feedthrough": ((S, J), system.sensor_feedthrough),
        "feedthrough_energy": ((J, J), system.feedthrough_energy),
        **{name: ((n,), None) for name in ("u", "v", "a", "u_free", "v_free", "a_free", "work1", "work2", "work3")},
    }


__all__ = ["PREPARED_PER_SYSTEM", "PreparedCar", "pack_cars", "prepared_car"]
