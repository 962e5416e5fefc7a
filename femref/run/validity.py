"""Where the cars of an impact run whose fidelity has a range (``range_limit``,
:class:`femref.models.base.CarFidelity`: the quasi-rigid cars) are inside it: the end loads must change slope
slowly against the car's wave travel time (docs/design.md §4.2, "Where the quasi-rigid cars hold").

The quasi-rigid car carries no stress wave: where an end force changes slope within one wave travel time ``T`` (a
jump at contact, a kink, the gear going solid) a real car answers with a wave spread over about T, the quasi-rigid
car with a spike of order ``ΔṖ/dt`` at the sensors. The local parameter of an end force P (N) on the run's time axis::

    ε_loc(t) = |P(t + T) − 2 P(t) + P(t − T)| / max|P|,     P = 0 before the first sample (before contact),
                                                          held at its last value after the last

is a second difference over the car's own time scale, with no derivative of the samples, so it does not grow as
the step shrinks: ``T² |P̈| / max|P| ≈ ε`` for a smooth load (a sin² pulse of duration T_p: ``2π² (T/T_p)²`` at most,
``tests/run/test_validity.py``), ``ΔP/max|P|`` within T of a jump. Samples within T of any sample where ``ε_loc``
exceeds the fidelity's ``range_limit`` on an end force of such a car are outside the model's range; the runner
records their intervals (``settings["quasi_rigid_range"]``) and the report shades them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.models import CAR_FIDELITIES
from femref.scene import ImpactScene, ModelRun


def local_epsilon(time: NDArray[np.float64], force: NDArray[np.float64], wave_time: float) -> NDArray[np.float64]:
    """``ε_loc(t) = |P(t + T) − 2P(t) + P(t − T)| / max|P|`` on ``time`` (module docstring; linear between samples,
    zero before the first, the last held after it); zeros for a force that is zero."""
    t, p = np.asarray(time, dtype=float), np.nan_to_num(np.asarray(force, dtype=float))
    scale = float(np.max(np.abs(p))) if p.size else 0.0
    if scale == 0.0:
        return np.zeros(t.size)
    later, earlier = (np.interp(t + k * wave_time, t, p, left=0.0) for k in (1, -1))
    return np.abs(later - 2.0 * p + earlier) / scale


def within(time: NDArray[np.float64], flags: NDArray[np.bool_], reach: float) -> NDArray[np.bool_]:
    """The samples within ``reach`` (s) of a flagged sample."""
    t = np.asarray(time, dtype=float)
    marked = t[np.asarray(flags, dtype=bool)]
    if marked.size == 0:
        return np.zeros(t.size, dtype=bool)
    k = np.clip(np.searchsorted(marked, t), 1, marked.size) - 1  # the flagged time at or before t (or the first)
    nearest = np.minimum(np.abs(t - marked[k]), np.abs(t - marked[np.minimum(k + 1, marked.size - 1)]))
    return nearest <= reach


def outside_intervals(time: NDArray[np.float64], flags: NDArray[np.bool_]) -> list[list[float]]:
    """The ``[t_start, t_end]`` (s) of each run of flagged samples."""
    flags = np.asarray(flags, dtype=bool)
    if not flags.any():
        return []
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [[float(time[a]), float(time[b])] for a, b in zip(starts, ends)]


def quasi_rigid_range(scene: ImpactScene, run: ModelRun, time: NDArray[np.float64], forces: dict[str, NDArray[np.float64]]) -> dict[str, Any] | None:
    """Where the run's cars with a range are outside it: ``{"limit", "epsilon_max", "outside": [[t0, t1], …],
    "cars": {car: wave time}}`` from the coupler forces at their ends (N, on ``time``), or None when the run has no
    such car; ``limit`` the smallest of their fidelities'. A car's wave time is the longer of its axial ``l√(m/EA)``
    and, when it bends, ``l²√(m/EI)``."""
    limits = {c: CAR_FIDELITIES[fidelity].range_limit for c, fidelity in enumerate(run.fidelity)}
    cars = {c: limit for c, limit in limits.items() if limit is not None}
    if not cars:
        return None
    flags = np.zeros(np.asarray(time).size, dtype=bool)
    epsilon_max, wave_times = 0.0, {}
    for c, limit in cars.items():
        car = scene.cars[c]
        wave_time = max(car.body.wave_travel_time, car.bending.wave_travel_time if car.bending is not None else 0.0)
        wave_times[car.name] = wave_time
        for coupler in scene.couplers:
            if c in (coupler.rear, coupler.front) and coupler.name in forces:
                epsilon = local_epsilon(time, forces[coupler.name], wave_time)
                flags |= within(time, epsilon > limit, wave_time)
                epsilon_max = max(epsilon_max, float(np.max(epsilon)))
    return {"limit": min(cars.values()), "epsilon_max": epsilon_max, "outside": outside_intervals(time, flags), "cars": wave_times}


__all__ = ["local_epsilon", "outside_intervals", "quasi_rigid_range", "within"]
