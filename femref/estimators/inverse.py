"""Inverse estimators: coupler forces of a line of cars from their acceleration records.

An estimator reads what a railroad has — accelerometer records of the cars, the car
masses and body profiles — and returns the compression-positive force of every coupler
(docs/design.md §2), on the records' time axis::

    forces(line, time (Nm,), records {"<car>/<sensor>": (Nm,)}) -> {coupler: (Nm,)}

``line`` is anything with the ``cars`` and ``couplers`` of an impact scene (a scene, a measured scene,
a :class:`femref.estimators.protocol.Recorded`); :class:`InverseEstimator` makes each one a plug-in of
the estimator protocol (:mod:`femref.estimators.protocol`).

Signs and geometry (:mod:`femref.scene.impact`): cars in line order, coupler ``j``
between the front (+l) of car ``j = Coupler.rear`` and the back (−l) of car ``j + 1``.
A compressed coupler pushes the car ahead of it forward and the car behind it back,
so rigid car ``k`` obeys ``M_k a_k = P_{k−1} − P_k`` (its rear coupler ``P_{k−1}``, its
front coupler ``P_k``; an absent coupler counts 0).

Registry :data:`ESTIMATORS` (names of :data:`femref.core.catalog.ESTIMATORS`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.core import catalog
from femref.core.body import Body
from femref.core.profiles import Profile
from femref.core.quadrature import gauss_legendre
from femref.estimators.protocol import Recorded
from femref.events import ForceEstimate
from femref.scene import Car
from reduced.inverse import CoupledImpactInversion, rigid_coupler_force

Records = dict[str, NDArray[np.float64]]
InverseForces = Callable[[Any, ArrayLike, dict[str, ArrayLike]], Records]
"""``(line, time (Nm,), records) -> {coupler name: force (Nm,)}`` (N, compression positive)."""


def inverse_rigid(scene: Any, time: ArrayLike, records: dict[str, ArrayLike]) -> Records:
    """Rigid cars: coupler ``j`` from the inertia of the cars ahead of it.

    Summing ``M_k a_k = P_{k−1} − P_k`` over the cars ``k = j+1 … n`` ahead of coupler
    ``j`` telescopes to ``P_j − P_n``, and the last car of that run has no front coupler
    (``P_n = 0``)::

        P_j = Σ_{k=j+1}^{n} M_k a_k

    where ``n`` is the first car ahead without a front coupler (a gap in the line ends
    the sum: cars beyond it do not push on coupler ``j``). ``M_k a_k`` is
    :func:`reduced.inverse.rigid_coupler_force` (coupler at the car's −l end), ``M_k``
    is :attr:`Car.mass` and ``a_k`` the record of the car's sensor nearest its centre
    ``x = 0`` (on an elastic car the rigid-body part is the centre-of-mass acceleration,
    and ``x = 0`` is a node of the first free-free axial mode of a symmetric car).

    Checked exactly (1e-10) on rigid two-car Kelvin-Voigt closed forms and on a rigid
    4-car line with a gap (``tests/models/test_inverse.py``); on elastic fem cars its
    error is the body vibration at the sensor, which this estimator cannot remove.
    """
    t = _time_axis(time)
    ahead = {c.rear: c for c in scene.couplers}
    inertia = [rigid_coupler_force(car.mass, _record(records, car, _central_sensor(car), t.size), "left") for car in scene.cars]
    forces: Records = {}
    for coupler in scene.couplers:
        total = np.zeros(t.size)
        k = coupler.front
        while True:
            total = total + inertia[k]
            if k not in ahead:
                break
            k = ahead[k].front
        forces[coupler.name] = total
    return forces


def inverse_quasi_rigid(scene: Any, time: ArrayLike, records: dict[str, ArrayLike]) -> Records:
    """Quasi-rigid car body: coupler ``j`` from the two end accelerations of the car ahead of it.

    The car ahead (``j + 1``) carries ``F1 = −P_j`` at its −l end (internal force,
    tension positive). :class:`reduced.inverse.CoupledImpactInversion` (docs/formulas.md §F,
    corrected and re-derived for variable profiles) gives, from ``a1 = a(−l)`` and
    ``a2 = a(+l)``::

        F1'' = k1 (a2 − a1) + k2 a1'',   k1 = 1/∫dx/EA,   k2 = −∫(μ/EA)dx / ∫dx/EA,
        μ(x) = ∫_{−l}^{x} m,   integrated twice from rest:
        P_j = −F1(t) = −[k1 ∬₀ᵗ (a2 − a1) + k2 a1(t)]

    with ``k1``, ``k2`` from the car's profiles (:func:`quasi_rigid_inversion`), integrated over the span between
    the sensors with the smallest and the largest x that stand in for ``a1`` and ``a2`` (with the end coefficients,
    sensors at ``±0.9 l`` on a 17 m car gave a force ≈ 5 % low, with the span's 0.6 %). The car's own front coupler
    is not needed: ``(F2 − F1)'' = M a1''`` to the order kept. The records must start at rest before the impact, and
    ``time`` must be uniform. Its truncation error is O(ε) of the pulse (:mod:`reduced.inverse`): on a two-term
    quasi-rigid 17 m, 119 t car driven by a sin² pulse of length T, 2.7 % (T = 0.3 s), 0.70 % (0.6 s) and 0.19 %
    (1.2 s) of the peak (``tests/models/test_inverse.py``). Fed rigid records (``a1 = a2``) it returns ``−k2 a`` —
    half the rigid ``M a`` for an even car: it needs elastic records.
    """
    t = _time_axis(time)
    forces: Records = {}
    for coupler in scene.couplers:
        car = scene.cars[coupler.front]
        rear_sensor, front_sensor = _end_sensors(car)
        inversion = _inversion_of(car, (car.sensors[rear_sensor], car.sensors[front_sensor]))
        a1 = _record(records, car, rear_sensor, t.size)
        a2 = _record(records, car, front_sensor, t.size)
        forces[coupler.name] = inversion.coupler_force(t, a1, a2)
    return forces


ESTIMATORS: dict[str, InverseForces] = {"inverse_rigid": inverse_rigid, "inverse_quasi_rigid": inverse_quasi_rigid}
"""Estimator name → function; the names are :data:`femref.core.catalog.ESTIMATORS`."""

assert tuple(ESTIMATORS) == catalog.ESTIMATORS  # internal contract: one registry, one list of names


@dataclass(frozen=True)
class InverseEstimator:
    """Inverse estimator ``name`` (:data:`ESTIMATORS`, looked up when it runs) as a plug-in: every coupler's force
    history, ``bound = none`` (a measured case's calibration file may give it a band)."""

    name: str
    coupler: None = None
    history: bool = True

    def estimate(self, recorded: Recorded) -> list[ForceEstimate]:
        nan = np.full(recorded.time.size, np.nan)
        forces = ESTIMATORS[self.name](recorded, recorded.time, dict(recorded.records))
        return [ForceEstimate(self.name, coupler, recorded.time, force, nan, nan.copy(), message="no calibration of this estimator's error: no band")
                for coupler, force in forces.items()]


def _time_axis(time: ArrayLike) -> NDArray[np.float64]:
    t = np.asarray(time, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"time must be a 1-D array of at least 2 samples, got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError("time must be finite and increase strictly")
    return t


def _central_sensor(car: Car) -> str:
    """The sensor nearest ``x = 0`` (the first listed on a tie)."""
    if not car.sensors:
        raise ValueError(f"car {car.name!r} has no sensors: the rigid estimator needs one acceleration record per car")
    return min(car.sensors, key=lambda name: abs(car.sensors[name]))


def _end_sensors(car: Car) -> tuple[str, str]:
    """The sensors with the smallest and the largest x (standing in for ``a(−l)`` and ``a(+l)``)."""
    if len(car.sensors) < 2:
        raise ValueError(f"car {car.name!r} has {len(car.sensors)} sensor(s): the quasi-rigid estimator needs two, "
                         "near its ends (the smallest and the largest x are used)")
    rear = min(car.sensors, key=lambda name: car.sensors[name])
    front = max(car.sensors, key=lambda name: car.sensors[name])
    if car.sensors[rear] == car.sensors[front]:
        raise ValueError(f"car {car.name!r}: all sensors are at x = {car.sensors[rear]!r}; two distinct positions are needed")
    return rear, front


def _inversion_of(car: Car, span: tuple[float, float]) -> CoupledImpactInversion:
    body = car.body
    if body.kind != "rod":
        raise ValueError(f"car {car.name!r} is a {body.kind!r}: the quasi-rigid estimator needs an axial rod body")
    return quasi_rigid_inversion(body, span)


#: Gauss–Legendre points per panel of :func:`quasi_rigid_inversion`'s integrals.
PANEL_POINTS = 16

#: Largest ratio of ``EA`` between a panel's ends: a piece between jumps is cut into equal panels until each holds it.
PANEL_STIFFNESS_RATIO = 2.0


def quasi_rigid_inversion(body: Body, span: tuple[float, float]) -> CoupledImpactInversion:
    """``k1 = 1/C``, ``k2 = −(∫_{x1}^{x2} μ/EA dx)/C``, ``C = ∫_{x1}^{x2} dx/EA``, ``μ(x) = ∫_{−l}^{x} m``, ``M = μ(l)``
    of a rod body (:class:`reduced.inverse.CoupledImpactInversion`, its ``span = (x1, x2)`` form), by a fixed
    Gauss–Legendre rule.

    Panels end on the body's jumps and kinks and on ``x1``, ``x2``; between them every profile kind
    (:mod:`femref.core.profiles`) is linear, so ``m`` and ``μ`` are integrated exactly, and ``1/EA`` is analytic
    with its pole outside the panel: a piece is cut into equal panels until ``EA`` changes by at most
    :data:`PANEL_STIFFNESS_RATIO` across each (the pole then lies 3 half-panels from the panel's centre or
    farther), where :data:`PANEL_POINTS` points err by about ``(3 + √8)^(−32)`` ≈ 1e-24 relative.
    tests/estimators/test_profile_quadrature.py checks it against ``scipy.integrate.quad``
    (:meth:`CoupledImpactInversion.from_profiles`, relative 1e-12 and better) on uniform, stepped, linear and
    tabulated cars, ``EA`` varying up to 100 to 1: the same coefficients without importing scipy.integrate
    (about 0.2 s of CPU, benchmarks/bench_startup.py).
    """
    l = body.half_length
    x1, x2 = (float(span[0]), float(span[1]))
    if not -l <= x1 < x2 <= l:
        raise ValueError(f"span must satisfy -l <= x1 < x2 <= l with l = {l!r}, got {span!r}")
    edges = np.unique(np.array([-l, *(j for j in body.jumps if -l < j < l), x1, x2, l], dtype=float))
    starts, ends, piece = _panels(body.stiffness, edges)
    xi, weights = gauss_legendre(PANEL_POINTS)
    half = 0.5 * (ends - starts)
    x = 0.5 * (starts + ends)[:, None] + half[:, None] * xi  # (panels, points)
    # μ at every point: the mass of the panels before it, plus the panel's own part from its start (the rule on [start, x]).
    panel_mass = half * (body.mass_per_length(x) @ weights)
    before = np.concatenate([[0.0], np.cumsum(panel_mass)[:-1]])
    reach = 0.5 * (x - starts[:, None])  # (panels, points): half the length of [start, x]
    inner = starts[:, None, None] + reach[:, :, None] * (1.0 + xi)  # (panels, points, points)
    mu = before[:, None] + reach * (body.mass_per_length(inner) @ weights)
    flex = 1.0 / body.stiffness(x)
    inside = (edges[piece] >= x1) & (edges[piece + 1] <= x2)
    compliance = float(np.sum(half[inside] * (flex[inside] @ weights)))
    weighted = float(np.sum(half[inside] * ((mu * flex)[inside] @ weights)))
    return CoupledImpactInversion(k1=1.0 / compliance, k2=-weighted / compliance, total_mass=float(np.sum(panel_mass)))


def _panels(stiffness: Profile, edges: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
    """Starts, ends and pieces of the panels: each piece ``(edges[k], edges[k+1])`` in equal parts, as many as keep
    the ratio of ``EA`` (linear on the piece) between a part's ends within :data:`PANEL_STIFFNESS_RATIO`."""
    left = stiffness(edges[:-1])  # at a jump a profile takes the value to its right
    right = stiffness(edges[1:] - 1e-12 * np.diff(edges))
    low, high = np.minimum(left, right), np.maximum(left, right)
    if not (np.all(np.isfinite(high)) and np.all(low > 0.0)):
        raise ValueError("the axial stiffness must be finite and > 0 on [-l, l]")
    # Equal parts of a linear EA from low to high: the part at the low end has the largest ratio, 1 + (high/low − 1)/parts.
    parts = np.maximum(1, np.ceil((high / low - 1.0) / (PANEL_STIFFNESS_RATIO - 1.0))).astype(int)
    cuts = [np.linspace(a, b, n + 1) for a, b, n in zip(edges[:-1], edges[1:], parts)]
    return (np.concatenate([c[:-1] for c in cuts]), np.concatenate([c[1:] for c in cuts]),
            np.repeat(np.arange(parts.size), parts))


def _record(records: dict[str, ArrayLike], car: Car, sensor: str, samples: int) -> NDArray[np.float64]:
    probe = f"{car.name}/{sensor}"
    if probe not in records:
        raise ValueError(f"no acceleration record for probe {probe!r} (records given: {', '.join(sorted(records)) or 'none'})")
    a = np.asarray(records[probe], dtype=float)
    if a.shape != (samples,):
        raise ValueError(f"record {probe!r} has shape {a.shape}, expected ({samples},) like the time axis")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"record {probe!r} contains non-finite values")
    return a


__all__ = ["ESTIMATORS", "InverseEstimator", "InverseForces", "inverse_quasi_rigid", "inverse_rigid", "quasi_rigid_inversion"]
