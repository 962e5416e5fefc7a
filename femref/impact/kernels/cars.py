"""The cars of the compiled loop: the line's car descriptions as one array pool, and their step in numba.

:func:`pack_cars` lays every car of a run — a :class:`~femref.impact.systems.SecondOrderSystem`
or a :class:`~femref.impact.systems.StateSpaceSystem` — into one :class:`CarPool`: a float
pool ``values`` holding every car's matrices and state, and an integer ``layout`` with one
row per car (its sizes, then the offset in ``values`` of each of its fields). The kernels
take ``(layout, values, c)`` and index the pool directly. This is a performance contract,
not a style: numba increments and decrements the reference count of every array a
function receives (about 20 ns each, measured) wherever its control flow keeps the counts
from being pruned, so a car passed as a record of some fifty arrays cost about a
microsecond per call — several times a rigid car's arithmetic. Two arrays cost nothing
measurable. The kernels, like the coupler kernels and the loop, are compiled without
numba's reference counting (``_nrt=False``, see :mod:`femref.impact.kernels.couplers`):
they never allocate, and a rigid run's step with every step recorded fell from 2.1 to
1.1 µs.

:func:`prepared_car` packs one car alone and :func:`factorise` factorises it and precomputes its
gains in compiled code, once per system, step and coupler maps (kept beside the system, so the runs
of a sweep, a study or the bench reuse it); :func:`pack_cars` copies the prepared cars into a run's
pool, sets their initial state and calls :func:`start` (the consistent initial acceleration). Each step the loop calls
:func:`predict` (the free step, read at the end outputs) and :func:`advance` (add the
response to the new end loads); :func:`observe` reads sensors and energies at the output
steps only. The arithmetic is that of the readable steppers of :mod:`femref.impact.cars`
(tests hold the two together to 1e-9):

* **second order** (kind 0), generalized-α on ``M ü + C u̇ + K u = B L`` with
  ``S a_{n+1} = −K u_n − (C + (1−αf) dt K) v_n − (αm M + (1−αf)(1−γ) dt C + (1−αf)(½−β) dt² K) a_n
  + αf B L_n + (1−αf) B L_{n+1}``, ``S = (1−αm) M + (1−αf) γ dt C + (1−αf) β dt² K``: the three
  history products are one fused banded sweep, S is factorised once (banded Cholesky), the
  response to the new loads is ``Z L_{n+1}`` with ``Z = (1−αf) S⁻¹ B``; the dissipated energy is
  ``Σ dt v̄ᵀ C v̄``, v̄ the step-mean velocity (one more banded product). A dense modal or rigid
  car is a banded one whose band is the whole matrix.
* **state space** (kind 1), ``x_{n+1} = A x_n + B L_{n+1}``: one dense product per step; the
  work of the end loads ``L̄ᵀ W Δy`` is booked every step for its dissipated energy.

Storage in the pool: dense matrices row-major; banded ones ``bands[k, i] = A[i, i + k − p]``
(p the half-bandwidth, 2p + 1 rows of n) and Cholesky factors ``low[k, j] = L[j + k, j]``
(p + 1 rows of n, the diagonal row holding ``1 / L[j, j]``), also row-major.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from femref.fem.banded import entries, half_bandwidth
from femref.fem.transient import Integrator
from femref.impact.systems import CarSystem, SecondOrderSystem, StateSpaceSystem

SECOND_ORDER, STATE_SPACE = 0, 1

# columns of CarPool.layout: the car's sizes ...
KIND, DOFS, BAND, PIVOT, SENSOR_START, LOAD_COUNT, END_COUNT, SENSOR_COUNT, COUPLER_COUNT = range(9)
# ... then the offset in CarPool.values of each field (shapes in FIELD_SHAPES)
FIELDS = (
    "coefficients",          # (7,) DT … EQUILIBRIUM
    "history_u",             # second order, banded: −K
    "history_v",             # −(C + (1−αf) dt K)
    "history_a",             # −(αm M + (1−αf)(1−γ) dt C + (1−αf)(½−β) dt² K)
    "damping", "stiffness", "mass",
    "effective_factor",      # Cholesky factor of S (factorised in place by factorise)
    "mass_factor",           # of M
    "load",                  # (n, J) B: loads to generalized forces, or the state-space input
    "response",              # (n, J) Z = (1−αf) S⁻¹ B
    "translation",           # (n,)
    "sensor_travel",         # (S,) what each sensor row reads of a unit rigid translation: O t (1 axial, 0 vertical, pitch)
    "transition",            # state space: (n, n) A
    "kinetic_form", "strain_form",  # (n, n)
    "work_map",              # (J, Y)
    "end_outputs",           # (Y, n) E, or the state-space end displacement map
    "end_rates",             # (Y, n) state-space end velocity map
    "sensor_outputs",        # (S, n) O, or the state-space sensor displacement map
    "sensor_rates",          # (S, n) state-space sensor velocity map
    "sensor_accelerations",  # (S, n) state-space sensor acceleration map
    "end_feedthrough",       # (Y, J)
    "sensor_feedthrough",    # (S, J)
    "feedthrough_energy",    # (J, J)
    "gain_u",                # (Y, J) ∂(end outputs)/∂L over one step
    "gain_v",                # (Y, J) ∂(end rates)/∂L
    "coupler_loads",         # (J, n_c) L = coupler_loads @ P
    "coupler_outputs",       # (n_c, Y) closure contributions
    # the state, updated in place
    "u", "v", "a",           # second order: displacement (less the rigid travel), velocity, acceleration
    "u_free", "v_free", "a_free",  # and the free step
    "x", "x_free",           # state space: the state and its free step
    "loads",                 # (J,) L_n
    "load_rate",             # (J,) (L_n − L_{n−1})/dt: the sensor feedthrough's velocity
    "new_loads",             # (J,) L_{n+1}, set by the loop
    "end_free",              # (Y,) free end outputs of the step being solved
    "end_rate_free",         # (Y,) and their rates
    "end_now",               # (Y,) end outputs now (state space: for the work)
    "scalars",               # (5,) OFFSET … INITIAL_ENERGY
    "work1", "work2", "work3",  # (n,) scratch
)
(COEFFICIENTS, HISTORY_U, HISTORY_V, HISTORY_A, DAMPING, STIFFNESS, MASS, EFFECTIVE_FACTOR, MASS_FACTOR,
 LOAD, RESPONSE, TRANSLATION, SENSOR_TRAVEL, TRANSITION, KINETIC_FORM, STRAIN_FORM, WORK_MAP, END_OUTPUTS, END_RATES,
 SENSOR_OUTPUTS, SENSOR_RATES, SENSOR_ACCELERATIONS, END_FEEDTHROUGH, SENSOR_FEEDTHROUGH, FEEDTHROUGH_ENERGY, GAIN_U,
 GAIN_V, COUPLER_LOADS, COUPLER_OUTPUTS, U, V, A, U_FREE, V_FREE, A_FREE, X, X_FREE, LOADS, LOAD_RATE, NEW_LOADS,
 END_FREE, END_RATE_FREE, END_NOW, SCALARS, WORK1, WORK2, WORK3) = range(COUPLER_COUNT + 1, COUPLER_COUNT + 1 + len(FIELDS))

# entries of the coefficients field
DT, ALPHA_F, CU, CA, CV_OLD, CV_NEW, EQUILIBRIUM = range(7)
# entries of the scalars field
OFFSET, DISSIPATED, SUM_LOAD2, SUM_RATE2, INITIAL_ENERGY = range(5)


@dataclass(frozen=True)
class CarPool:
    """Every car of a run in two arrays (module docstring); ``shapes[c][field]`` for reading a field back."""

    layout: NDArray[np.int64]  # (cars, COUPLER_COUNT + 1 + len(FIELDS))
    values: NDArray[np.float64]
    shapes: tuple[dict[int, tuple[int, ...]], ...]

    def field(self, c: int, field: int) -> NDArray[np.float64]:
        """Car ``c``'s ``field`` (a column constant) as a view of the pool, in its shape."""
        shape = self.shapes[c][field]
        start = int(self.layout[c, field])
        return self.values[start: start + math.prod(shape)].reshape(shape)


def _bands(matrix, p: int, n: int) -> NDArray[np.float64]:
    """``bands[k, i] = A[i, i + k − p]`` of a sparse or dense n × n matrix of half-bandwidth at most p."""
    rows, cols, data = entries(matrix)
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


def _matrix(value, shape: tuple[int, ...]) -> NDArray[np.float64]:
    return np.zeros(shape) if value is None else np.asarray(value, dtype=float).reshape(shape)


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
    for f, array in enumerate(fields, start=COUPLER_COUNT + 1):
        layout[f] = offset
        shapes[f] = array.shape
        offset += array.size
    values = np.concatenate([array.ravel() for array in fields])
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


def _car_fields(
    system: CarSystem, integrator: Integrator, dt: float, coupler_loads: NDArray, coupler_outputs: NDArray,
) -> tuple[list[int], list[NDArray[np.float64]]]:
    """One car's sizes (the layout's first columns) and its fields in the order of FIELDS, its state zero."""
    J, n_c = coupler_loads.shape
    Y = coupler_outputs.shape[1]
    if isinstance(system, StateSpaceSystem):
        system.check_step(dt)
        n = system.transition.shape[0]
        S = system.sensor_displacement.shape[0]
        sizes = [STATE_SPACE, n, 0, 0, 0, J, Y, S, n_c]
        fields = {
            "coefficients": np.array([dt, 0, 0, 0, 0, 0, 0], dtype=float),
            "load": _matrix(system.input, (n, J)),
            "transition": _matrix(system.transition, (n, n)),
            "kinetic_form": _matrix(system.kinetic_form, (n, n)),
            "strain_form": _matrix(system.strain_form, (n, n)),
            "work_map": _matrix(system.work_map, (J, Y)),
            "end_outputs": _matrix(system.end_displacement, (Y, n)),
            "end_rates": _matrix(system.end_velocity, (Y, n)),
            "sensor_outputs": _matrix(system.sensor_displacement, (S, n)),
            "sensor_rates": _matrix(system.sensor_velocity, (S, n)),
            "sensor_accelerations": _matrix(system.sensor_acceleration, (S, n)),
            "x": np.zeros(n), "x_free": np.zeros(n),
            "work1": np.zeros(n), "work2": np.zeros(n), "work3": np.zeros(n),
        }
    else:
        sizes, fields = _second_order_fields(system, integrator, dt, J, Y, n_c)
    fields.update({
        "gain_u": np.zeros((Y, J)), "gain_v": np.zeros((Y, J)),
        "coupler_loads": coupler_loads, "coupler_outputs": coupler_outputs,
        "loads": np.zeros(J), "load_rate": np.zeros(J), "new_loads": np.zeros(J),
        "end_free": np.zeros(Y), "end_rate_free": np.zeros(Y), "end_now": np.zeros(Y), "scalars": np.zeros(5),
    })
    empty = np.zeros(0)
    return sizes, [np.asarray(fields.get(name, empty), dtype=float) for name in FIELDS]


_banded_forms: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _banded_form(system: SecondOrderSystem) -> tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(p, M, C, K)`` in row bands, p the half-bandwidth: once per system, since a system is built
    once per geometry and every run of it reuses them (a fem car's conversion costs milliseconds;
    the arrays are only read)."""
    form = _banded_forms.get(system)
    if form is None:
        M, C, K = system.mass, system.damping, system.stiffness
        p = max(half_bandwidth(m) for m in (M, C, K))
        form = (p, *(_bands(m, p, system.dofs) for m in (M, C, K)))
        _banded_forms[system] = form
    return form


def _second_order_fields(
    system: SecondOrderSystem, integrator: Integrator, dt: float, J: int, Y: int, n_c: int,
) -> tuple[list[int], dict[str, NDArray[np.float64]]]:
    n = system.dofs
    S = system.sensor_outputs.shape[0]
    p, mass, damping, stiffness = _banded_form(system)
    am, af, beta, gamma = integrator.alpha_m, integrator.alpha_f, integrator.beta, integrator.gamma
    effective = (1.0 - am) * mass + (1.0 - af) * gamma * dt * damping + (1.0 - af) * beta * dt * dt * stiffness
    translation = np.asarray(system.translation, dtype=float)
    sizes = [SECOND_ORDER, n, p, int(np.argmax(np.abs(translation))), 0, J, Y, S, n_c]
    return sizes, {
        "coefficients": np.array([dt, af, dt * dt * (0.5 - beta), dt * dt * beta, dt * (1.0 - gamma), dt * gamma,
                                  float(integrator.alpha_m != integrator.alpha_f)]),
        "history_u": -stiffness,
        "history_v": -(damping + (1.0 - af) * dt * stiffness),
        "history_a": -(am * mass + (1.0 - af) * (1.0 - gamma) * dt * damping + (1.0 - af) * (0.5 - beta) * dt * dt * stiffness),
        "damping": damping, "stiffness": stiffness, "mass": mass,
        "effective_factor": _lower_columns(effective, p, n), "mass_factor": _lower_columns(mass, p, n),
        "load": _matrix(system.load_matrix, (n, J)), "response": np.zeros((n, J)), "translation": translation,
        "sensor_travel": _matrix(system.sensor_outputs, (S, n)) @ translation,
        "end_outputs": _matrix(system.end_outputs, (Y, n)), "sensor_outputs": _matrix(system.sensor_outputs, (S, n)),
        "end_feedthrough": _matrix(system.end_feedthrough, (Y, J)),
        "sensor_feedthrough": _matrix(system.sensor_feedthrough, (S, J)),
        "feedthrough_energy": _matrix(system.feedthrough_energy, (J, J)),
        "u": np.zeros(n), "v": np.zeros(n), "a": np.zeros(n),
        "u_free": np.zeros(n), "v_free": np.zeros(n), "a_free": np.zeros(n),
        "work1": np.zeros(n), "work2": np.zeros(n), "work3": np.zeros(n),
    }


# -- linear algebra on the pool: every operand is an offset into ``w`` -----------------------


@njit(cache=True, _nrt=False)
def band_cholesky(w: NDArray, low: int, p: int, n: int) -> bool:
    """In place: ``low[k, j] = A[j + k, j]`` becomes ``L[j + k, j]`` (k ≥ 1) with ``A = L Lᵀ``, and
    ``low[0, j] = 1 / L[j, j]`` (the solves multiply); False if A is not positive definite."""
    for j in range(n):
        s = w[low + j]
        for k in range(max(0, j - p), j):
            s -= w[low + (j - k) * n + k] ** 2
        if not s > 0.0:
            return False
        reciprocal = 1.0 / math.sqrt(s)
        w[low + j] = reciprocal
        for i in range(j + 1, min(n, j + p + 1)):
            s = w[low + (i - j) * n + j]
            for k in range(max(0, i - p), j):
                s -= w[low + (i - k) * n + k] * w[low + (j - k) * n + k]
            w[low + (i - j) * n + j] = s * reciprocal
    return True


@njit(cache=True, _nrt=False)
def band_solve(w: NDArray, low: int, p: int, n: int, rhs: int) -> None:
    """In place: ``rhs ← A⁻¹ rhs`` with the factor of :func:`band_cholesky`, both sweeps by columns
    (each finished unknown updates the p after it: the dependency chain is one product per row)."""
    for j in range(n):  # L y = b
        xj = w[rhs + j] * w[low + j]
        w[rhs + j] = xj
        for i in range(j + 1, min(n, j + p + 1)):
            w[rhs + i] -= w[low + (i - j) * n + j] * xj
    for i in range(n - 1, -1, -1):  # Lᵀ x = y
        xi = w[rhs + i] * w[low + i]
        w[rhs + i] = xi
        for k in range(max(0, i - p), i):
            w[rhs + k] -= w[low + (i - k) * n + k] * xi


@njit(cache=True, _nrt=False)
def band_product(w: NDArray, bands: int, p: int, n: int, x: int, out: int) -> None:
    """``out = A x`` for ``bands[k, i] = A[i, i + k − p]``, diagonal by diagonal: each row still sums
    its diagonals in order k = 0 … 2p, and the inner loop, over views with a zero-based index (so
    numba adds no negative-index test), vectorises — three times faster than row by row."""
    result = w[out: out + n]
    result[:] = 0.0
    for k in range(2 * p + 1):
        first, last = max(0, p - k), min(n, n + p - k)  # rows i whose column i + k − p exists
        band = w[bands + k * n + first: bands + k * n + last]
        shifted = w[x + first + k - p: x + last + k - p]
        rows = result[first:last]
        for i in range(last - first):
            rows[i] += band[i] * shifted[i]


@njit(cache=True, _nrt=False)
def dot(w: NDArray, x: int, y: int, n: int) -> float:
    """``xᵀ y``."""
    s = 0.0
    for i in range(n):
        s += w[x + i] * w[y + i]
    return s


@njit(cache=True, _nrt=False)
def matvec(w: NDArray, A: int, rows: int, cols: int, x: int, out: int) -> None:
    """``out = A x`` (small or sparse-in-effect dense maps: a loop beats a BLAS call here)."""
    for i in range(rows):
        s = 0.0
        for j in range(cols):
            s += w[A + i * cols + j] * w[x + j]
        w[out + i] = s


@njit(cache=True, _nrt=False)
def matvec_add(w: NDArray, A: int, rows: int, cols: int, x: int, factor: float, out: int) -> None:
    """``out += factor · A x``."""
    for i in range(rows):
        s = 0.0
        for j in range(cols):
            s += w[A + i * cols + j] * w[x + j]
        w[out + i] += factor * s


@njit(cache=True, _nrt=False)
def quadratic(w: NDArray, A: int, n: int, x: int) -> float:
    """``xᵀ A x`` (A n × n)."""
    s = 0.0
    for i in range(n):
        row = 0.0
        for j in range(n):
            row += w[A + i * n + j] * w[x + j]
        s += w[x + i] * row
    return s


# -- set-up ------------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def factorise(layout: NDArray, w: NDArray, c: int) -> bool:
    """Factorise car ``c`` and precompute its response and gains (constant for its step); False if S or M
    is not positive definite."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    gain_u, gain_v, load = at[GAIN_U], at[GAIN_V], at[LOAD]
    if at[KIND] == STATE_SPACE:
        for i in range(Y):  # gains: end maps times the input
            for j in range(J):
                su = 0.0
                sv = 0.0
                for k in range(n):
                    su += w[at[END_OUTPUTS] + i * n + k] * w[load + k * J + j]
                    sv += w[at[END_RATES] + i * n + k] * w[load + k * J + j]
                w[gain_u + i * J + j] = su
                w[gain_v + i * J + j] = sv
        return True
    if not band_cholesky(w, at[EFFECTIVE_FACTOR], p, n) or not band_cholesky(w, at[MASS_FACTOR], p, n):
        return False
    cf = at[COEFFICIENTS]
    column, response, end_feedthrough = at[WORK1], at[RESPONSE], at[END_FEEDTHROUGH]
    for j in range(J):  # Z = (1−αf) S⁻¹ B, column by column
        for i in range(n):
            w[column + i] = w[load + i * J + j]
        band_solve(w, at[EFFECTIVE_FACTOR], p, n, column)
        for i in range(n):
            w[response + i * J + j] = (1.0 - w[cf + ALPHA_F]) * w[column + i]
    for i in range(Y):
        for j in range(J):
            ez = 0.0  # (E Z)[i, j]
            for k in range(n):
                ez += w[at[END_OUTPUTS] + i * n + k] * w[response + k * J + j]
            w[gain_u + i * J + j] = w[cf + CA] * ez + w[end_feedthrough + i * J + j]
            w[gain_v + i * J + j] = w[cf + CV_NEW] * ez + w[end_feedthrough + i * J + j] / w[cf + DT]
    return True


@njit(cache=True, _nrt=False)
def start(layout: NDArray, w: NDArray, c: int) -> None:
    """Car ``c`` at t = 0, its velocities (or state) and loads set: for a second-order car the consistent
    initial acceleration ``M a₀ = B L₀ − C v₀``, for a state-space car its end outputs and energy."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    if at[KIND] == STATE_SPACE:
        x = at[X]
        matvec(w, at[END_OUTPUTS], Y, n, x, at[END_NOW])
        w[at[SCALARS] + INITIAL_ENERGY] = 0.5 * quadratic(w, at[KINETIC_FORM], n, x) + 0.5 * quadratic(w, at[STRAIN_FORM], n, x)
        return
    a = at[A]
    band_product(w, at[DAMPING], p, n, at[V], a)
    for i in range(n):
        w[a + i] = -w[a + i]
    matvec_add(w, at[LOAD], n, J, at[LOADS], 1.0, a)
    band_solve(w, at[MASS_FACTOR], p, n, a)


# -- one step ----------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def predict(layout: NDArray, w: NDArray, c: int) -> None:
    """Car ``c``'s step with the new end loads left out; its end outputs and rates into its
    ``end_free``, ``end_rate_free``."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    end_free, end_rate_free = at[END_FREE], at[END_RATE_FREE]
    if at[KIND] == STATE_SPACE:
        x_free = at[X_FREE]
        matvec(w, at[TRANSITION], n, n, at[X], x_free)
        matvec(w, at[END_OUTPUTS], Y, n, x_free, end_free)
        matvec(w, at[END_RATES], Y, n, x_free, end_rate_free)
        return
    cf = at[COEFFICIENTS]
    u, v, a, u_free, v_free, a_free = at[U], at[V], at[A], at[U_FREE], at[V_FREE], at[A_FREE]
    hu, hv, ha = at[HISTORY_U], at[HISTORY_V], at[HISTORY_A]
    result = w[a_free: a_free + n]  # the three history products in one sweep, diagonal by diagonal (see band_product)
    result[:] = 0.0
    for k in range(2 * p + 1):
        first, last = max(0, p - k), min(n, n + p - k)
        start, shift = k * n + first, first + k - p
        bu, bv, ba = w[hu + start: hu + start + last - first], w[hv + start: hv + start + last - first], w[ha + start: ha + start + last - first]
        su, sv, sa = w[u + shift: u + shift + last - first], w[v + shift: v + shift + last - first], w[a + shift: a + shift + last - first]
        rows = result[first:last]
        for i in range(last - first):
            rows[i] += bu[i] * su[i] + bv[i] * sv[i] + ba[i] * sa[i]
    if w[cf + ALPHA_F] != 0.0:
        matvec_add(w, at[LOAD], n, J, at[LOADS], w[cf + ALPHA_F], a_free)
    band_solve(w, at[EFFECTIVE_FACTOR], p, n, a_free)
    dt, cu, ca, cv_old, cv_new = w[cf + DT], w[cf + CU], w[cf + CA], w[cf + CV_OLD], w[cf + CV_NEW]
    for i in range(n):
        w[u_free + i] = w[u + i] + dt * w[v + i] + cu * w[a + i] + ca * w[a_free + i]
        w[v_free + i] = w[v + i] + cv_old * w[a + i] + cv_new * w[a_free + i]
    matvec(w, at[END_OUTPUTS], Y, n, u_free, end_free)
    matvec(w, at[END_OUTPUTS], Y, n, v_free, end_rate_free)
    matvec_add(w, at[END_FEEDTHROUGH], Y, J, at[LOADS], -1.0 / dt, end_rate_free)
    offset = w[at[SCALARS] + OFFSET]
    for i in range(Y):
        w[end_free + i] += offset


@njit(cache=True, _nrt=False)
def advance(layout: NDArray, w: NDArray, c: int) -> None:
    """Commit car ``c``'s step with its new end loads ``new_loads`` (``L_{n+1}``, linear within the step)."""
    at = layout[c]
    n, p, J, Y = at[DOFS], at[BAND], at[LOAD_COUNT], at[END_COUNT]
    scalars = at[SCALARS]
    dt = w[at[COEFFICIENTS] + DT]
    L0, L1, load_rate = at[LOADS], at[NEW_LOADS], at[LOAD_RATE]
    rate2 = 0.0
    load2 = 0.0
    for j in range(J):
        slope = (w[L1 + j] - w[L0 + j]) / dt
        w[load_rate + j] = slope
        rate2 += slope * slope
        load2 += w[L0 + j] * w[L0 + j] + w[L1 + j] * w[L1 + j]
    w[scalars + SUM_LOAD2] += 0.5 * dt * load2
    w[scalars + SUM_RATE2] += dt * rate2
    if at[KIND] == STATE_SPACE:
        x, end_outputs, end_now, work_map = at[X], at[END_OUTPUTS], at[END_NOW], at[WORK_MAP]
        for i in range(n):
            w[x + i] = w[at[X_FREE] + i]
        matvec_add(w, at[LOAD], n, J, L1, 1.0, x)
        work = 0.0
        for i in range(Y):
            after = 0.0
            for k in range(n):
                after += w[end_outputs + i * n + k] * w[x + k]
            change = after - w[end_now + i]
            w[end_now + i] = after
            for j in range(J):
                work += 0.5 * (w[L0 + j] + w[L1 + j]) * w[work_map + j * Y + i] * change
        w[scalars + DISSIPATED] += work
    else:
        cf = at[COEFFICIENTS]
        ca, cv_new = w[cf + CA], w[cf + CV_NEW]
        u, v, a, u_free, v_free, a_free = at[U], at[V], at[A], at[U_FREE], at[V_FREE], at[A_FREE]
        response, v_mid, damped = at[WORK1], at[WORK2], at[WORK3]
        matvec(w, at[RESPONSE], n, J, L1, response)
        for i in range(n):
            w[v_mid + i] = 0.5 * w[v + i]
            w[a + i] = w[a_free + i] + w[response + i]
            w[u + i] = w[u_free + i] + ca * w[response + i]
            w[v + i] = w[v_free + i] + cv_new * w[response + i]
            w[v_mid + i] += 0.5 * w[v + i]
        # move the rigid travel out of u (K t = C t = 0: the dynamics are unchanged)
        t = at[TRANSLATION]
        shift = w[u + at[PIVOT]] / w[t + at[PIVOT]]
        for i in range(n):
            w[u + i] -= shift * w[t + i]
        w[scalars + OFFSET] += shift
        band_product(w, at[DAMPING], p, n, v_mid, damped)
        w[scalars + DISSIPATED] += dt * dot(w, v_mid, damped, n)
    for j in range(J):
        w[L0 + j] = w[L1 + j]


@njit(cache=True, _nrt=False)
def observe(layout: NDArray, w: NDArray, c: int, k: int, displacement: NDArray, velocity: NDArray, acceleration: NDArray,
            energy: NDArray) -> None:
    """Car ``c``'s sensor displacements, velocities and accelerations now into row ``k`` of the histories
    (its columns from its sensor start; a second-order car's velocities ``O v + R_s (L_n − L_{n−1})/dt``),
    and add its kinetic, strain and dissipated energy (J) to ``energy[k, 0:3]``."""
    at = layout[c]
    n, p, J, S = at[DOFS], at[BAND], at[LOAD_COUNT], at[SENSOR_COUNT]
    first = at[SENSOR_START]
    scalars = at[SCALARS]
    if at[KIND] == STATE_SPACE:
        x = at[X]
        kinetic = 0.5 * quadratic(w, at[KINETIC_FORM], n, x)
        strain = 0.5 * quadratic(w, at[STRAIN_FORM], n, x)
        for i in range(S):
            sd = 0.0
            sv = 0.0
            sa = 0.0
            for j in range(n):
                sd += w[at[SENSOR_OUTPUTS] + i * n + j] * w[x + j]
                sv += w[at[SENSOR_RATES] + i * n + j] * w[x + j]
                sa += w[at[SENSOR_ACCELERATIONS] + i * n + j] * w[x + j]
            displacement[k, first + i] = sd
            velocity[k, first + i] = sv
            acceleration[k, first + i] = sa
        energy[k, 0] += kinetic
        energy[k, 1] += strain
        energy[k, 2] += w[scalars + INITIAL_ENERGY] + w[scalars + DISSIPATED] - kinetic - strain
        return
    u, v, loads = at[U], at[V], at[LOADS]
    stiffness_u, mass_v = at[WORK1], at[WORK2]
    band_product(w, at[STIFFNESS], p, n, u, stiffness_u)
    band_product(w, at[MASS], p, n, v, mass_v)
    sensor_outputs, sensor_feedthrough, travel = at[SENSOR_OUTPUTS], at[SENSOR_FEEDTHROUGH], at[SENSOR_TRAVEL]
    load_rate = at[LOAD_RATE]
    for i in range(S):
        s = 0.0
        sv = 0.0
        for j in range(n):
            s += w[sensor_outputs + i * n + j] * w[u + j]
            sv += w[sensor_outputs + i * n + j] * w[v + j]
        feedthrough = 0.0
        feedthrough_rate = 0.0
        for j in range(J):
            feedthrough += w[sensor_feedthrough + i * J + j] * w[loads + j]
            feedthrough_rate += w[sensor_feedthrough + i * J + j] * w[load_rate + j]
        displacement[k, first + i] = s + feedthrough + w[travel + i] * w[scalars + OFFSET]
        velocity[k, first + i] = sv + feedthrough_rate
    strain = 0.5 * dot(w, u, stiffness_u, n) + 0.5 * quadratic(w, at[FEEDTHROUGH_ENERGY], J, loads)
    accelerations = at[A]
    if w[at[COEFFICIENTS] + EQUILIBRIUM] != 0.0:
        # M⁻¹(B L − C v − K u): generalized-α's own a_n lags by (αm − αf) dt
        accelerations = at[WORK3]
        band_product(w, at[DAMPING], p, n, v, accelerations)
        for i in range(n):
            w[accelerations + i] = -w[accelerations + i] - w[stiffness_u + i]
        matvec_add(w, at[LOAD], n, J, loads, 1.0, accelerations)
        band_solve(w, at[MASS_FACTOR], p, n, accelerations)
    for i in range(S):
        s = 0.0
        for j in range(n):
            s += w[sensor_outputs + i * n + j] * w[accelerations + j]
        acceleration[k, first + i] = s
    energy[k, 0] += 0.5 * dot(w, v, mass_v, n)
    energy[k, 1] += strain
    energy[k, 2] += w[scalars + DISSIPATED]


__all__ = ["CarPool", "PreparedCar", "advance", "factorise", "observe", "pack_cars", "predict", "prepared_car", "start"]
