"""Boundary validation shared by the reduced models (private).

Every public function of ``reduced`` validates its inputs here and raises
``ValueError`` with a message naming the argument, the bad value and the rule;
``assert`` is kept for internal contracts only.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray


def finite(name: str, value: float) -> float:
    """``value`` as a float; ValueError unless finite."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return x


def positive(name: str, value: float) -> float:
    """``value`` as a float; ValueError unless finite and > 0."""
    x = finite(name, value)
    if x <= 0.0:
        raise ValueError(f"{name} must be > 0, got {x!r}")
    return x


def non_negative(name: str, value: float) -> float:
    """``value`` as a float; ValueError unless finite and ≥ 0."""
    x = finite(name, value)
    if x < 0.0:
        raise ValueError(f"{name} must be >= 0, got {x!r}")
    return x


def choice(name: str, value: str, allowed: tuple[str, ...]) -> str:
    """``value`` unchanged; ValueError unless it is one of ``allowed``."""
    if value not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(repr(a) for a in allowed)}; got {value!r}")
    return value


def record(name: str, values: ArrayLike, *, min_length: int = 2) -> NDArray[np.float64]:
    """A 1-D finite float array of at least ``min_length`` samples."""
    a = np.asarray(values, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array, got shape {a.shape}")
    if a.size < min_length:
        raise ValueError(f"{name} needs at least {min_length} samples, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values (NaN or inf)")
    return a


def same_length(**records: NDArray[np.float64]) -> None:
    """ValueError unless all the named 1-D records have the same length."""
    lengths = {k: v.shape[0] for k, v in records.items()}
    if len(set(lengths.values())) > 1:
        detail = ", ".join(f"{k}: {n}" for k, n in lengths.items())
        raise ValueError(f"records must have the same length ({detail})")


def time_grid(name: str, time: ArrayLike, *, uniform: bool = False, min_length: int = 2) -> NDArray[np.float64]:
    """A strictly increasing finite 1-D time array (s); with ``uniform`` also equally spaced."""
    t = record(name, time, min_length=min_length)
    steps = np.diff(t)
    if np.any(steps <= 0.0):
        raise ValueError(f"{name} must increase strictly")
    if uniform and not np.allclose(steps, steps[0], rtol=1e-6, atol=0.0):
        raise ValueError(f"{name} must be uniformly sampled (steps between {steps.min():.6g} and {steps.max():.6g} s)")
    return t


def sample_step(name: str, dt: float) -> float:
    """A sampling interval (s) > 0."""
    return positive(name, dt)
