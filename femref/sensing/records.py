"""Fixed-length acceleration records: what a sweep stores and what a force network reads.

A network maps a stack of records ``(channels, length)`` at one sampling rate to a
coupler force, so every record it sees — in training (sweep files) and in use
(``femref run`` with an ``ann`` estimator) — must be made the same way. This module is
that one way:

    t_k = k · end / (length − 1),  k = 0 … length − 1
    record[c, k] = a_c(t_k)        (linear interpolation of the probe's history)

over ``[0, end]`` with ``end`` the scene's ``time.end``; the record rate is
``(length − 1)/end`` Hz. The input histories are the measured records (measurement
chain) when the scene has one, else the model's own sensor accelerations. A history
that ends before ``end`` (a measurement grid ``k/rate`` that stops short of it) is held
at its last value, as ``np.interp`` does; the gap is below one measurement sample.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray


def record_times(length: int, end: float) -> NDArray[np.float64]:
    """The ``length`` sample times ``k · end/(length − 1)`` (s) of a fixed-length record."""
    if int(length) != length or length < 2:
        raise ValueError(f"record length must be an integer >= 2, got {length!r}")
    if not (np.isfinite(end) and end > 0.0):
        raise ValueError(f"record end must be a positive time in s, got {end!r}")
    return np.linspace(0.0, float(end), int(length))


def record_rate(length: int, end: float) -> float:
    """Sampling rate ``(length − 1)/end`` (Hz) of a fixed-length record."""
    record_times(length, end)
    return (int(length) - 1) / float(end)


def fixed_length_records(time: ArrayLike, histories: Mapping[str, ArrayLike], probes: Sequence[str], length: int, end: float) -> NDArray[np.float64]:
    """Records ``(len(probes), length)`` of the named ``histories`` on their common axis ``time`` (s), on
    :func:`record_times`; ValueError for a missing probe, a history of another length than ``time``, or non-finite values."""
    t = np.asarray(time, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0.0):
        raise ValueError("time must be a 1-D, finite, strictly increasing axis of at least 2 samples")
    grid = record_times(length, end)
    out = np.empty((len(probes), grid.size))
    for c, probe in enumerate(probes):
        if probe not in histories:
            raise ValueError(f"no acceleration history for probe {probe!r} (have: {', '.join(sorted(histories)) or 'none'})")
        a = np.asarray(histories[probe], dtype=float)
        if a.shape != t.shape:
            raise ValueError(f"history of probe {probe!r} has shape {a.shape}, expected {t.shape} like the time axis")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"history of probe {probe!r} contains non-finite values")
        out[c] = np.interp(grid, t, a)
    return out


def acceleration_histories(result) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    """``(time, {probe: acceleration})`` of an impact run's :class:`femref.results.ModelResult`: its measured records
    if it has them."""
    if result.measured:
        return result.measured["time"], {p: a for p, a in result.measured.items() if p != "time"}
    return result.axes["time"], {p: out["acceleration"] for p, out in result.probes.items()}


__all__ = ["acceleration_histories", "fixed_length_records", "record_rate", "record_times"]
