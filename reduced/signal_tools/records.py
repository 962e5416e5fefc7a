"""Fixed-length network inputs and their scaling (saved as plain arrays).

:func:`resample_record` (linear interpolation, anti-aliased by :class:`SpectralLowPass`),
:func:`peak_normalise` and :class:`FeatureScaler`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks

from .smoothing import SpectralLowPass


def resample_record(
    time: ArrayLike,
    values: ArrayLike,
    n_samples: int,
    *,
    start: float | None = None,
    stop: float | None = None,
    antialias: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The record on ``n_samples`` equally spaced times from ``start`` to ``stop``.

    Linear interpolation; when the new step is longer than the old one and the record
    is uniform, ``antialias`` first low-passes it at 0.8 of the new Nyquist frequency
    (:class:`SpectralLowPass`). Outside the record the end values are held.
    Returns ``(new_time, new_values)``.
    """
    t = _checks.time_grid("time", time)
    y = _checks.record("values", values)
    _checks.same_length(time=t, values=y)
    if int(n_samples) != n_samples or n_samples < 2:
        raise ValueError(f"n_samples must be an integer >= 2, got {n_samples!r}")
    a = float(t[0]) if start is None else _checks.finite("start", start)
    b = float(t[-1]) if stop is None else _checks.finite("stop", stop)
    if not b > a:
        raise ValueError(f"stop must be after start (start={a!r}, stop={b!r})")
    new_t = np.linspace(a, b, int(n_samples))
    new_dt = (b - a) / (n_samples - 1)
    steps = np.diff(t)
    uniform = np.allclose(steps, steps[0], rtol=1e-6, atol=0.0)
    if antialias and uniform and new_dt > steps[0] and y.size >= 4:
        y = SpectralLowPass(cutoff_hz=0.8 * 0.5 / new_dt).smooth(y, float(steps[0]))
    return new_t, np.interp(new_t, t, y)


def peak_normalise(records: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each record (row) divided by its peak magnitude ``max|a|``; returns ``(normalised, peaks)``.

    The source study's "normalised acceleration input"; keep ``peaks`` to restore units.
    """
    x = np.asarray(records, dtype=float)
    if x.ndim not in (1, 2) or x.size == 0:
        raise ValueError(f"records must be a non-empty 1-D or 2-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("records contain non-finite values (NaN or inf)")
    x2 = np.atleast_2d(x)
    peaks = np.max(np.abs(x2), axis=1)
    if np.any(peaks == 0.0):
        raise ValueError(f"records {np.flatnonzero(peaks == 0.0).tolist()} are identically zero")
    out = x2 / peaks[:, None]
    return (out[0], peaks) if x.ndim == 1 else (out, peaks)


SCALER_KINDS: tuple[str, ...] = ("standard", "minmax")


@dataclass(frozen=True, eq=False)
class FeatureScaler:
    """Per-feature affine scaling ``z = (x − offset)/scale`` fitted on training data.

    ``standard``: offset = mean, scale = standard deviation; ``minmax``: offset = min,
    scale = max − min (to [0, 1]). A constant feature gets scale 1. Saved with a
    network as plain arrays (:meth:`to_arrays` / :meth:`from_arrays`), never pickled.
    """

    kind: str
    offset: NDArray[np.float64]
    scale: NDArray[np.float64]

    def __post_init__(self) -> None:
        _checks.choice("kind", self.kind, SCALER_KINDS)
        if self.offset.shape != self.scale.shape or self.offset.ndim != 1:
            raise ValueError("offset and scale must be 1-D arrays of the same length")
        if not (np.all(np.isfinite(self.offset)) and np.all(np.isfinite(self.scale)) and np.all(self.scale > 0.0)):
            raise ValueError("offset must be finite and scale finite and > 0")

    @classmethod
    def fit(cls, features: ArrayLike, kind: str = "standard") -> FeatureScaler:
        """Fit on ``features`` of shape (n_samples, n_features)."""
        _checks.choice("kind", kind, SCALER_KINDS)
        x = np.asarray(features, dtype=float)
        if x.ndim != 2 or x.shape[0] < 1:
            raise ValueError(f"features must have shape (n_samples, n_features), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("features contain non-finite values (NaN or inf)")
        if kind == "standard":
            offset, scale = x.mean(axis=0), x.std(axis=0)
        else:
            offset, scale = x.min(axis=0), x.max(axis=0) - x.min(axis=0)
        scale = np.where(scale > 0.0, scale, 1.0)
        return cls(kind, offset, scale)

    def _check(self, features: ArrayLike) -> NDArray[np.float64]:
        x = np.asarray(features, dtype=float)
        if x.shape[-1] != self.offset.size:
            raise ValueError(f"features have {x.shape[-1]} columns, the scaler was fitted on {self.offset.size}")
        return x

    def transform(self, features: ArrayLike) -> NDArray[np.float64]:
        return (self._check(features) - self.offset) / self.scale

    def inverse_transform(self, scaled: ArrayLike) -> NDArray[np.float64]:
        return self._check(scaled) * self.scale + self.offset

    def to_arrays(self) -> dict[str, NDArray]:
        """Plain arrays for HDF5/npz: ``kind`` (as a 0-d string array), ``offset``, ``scale``."""
        return {"kind": np.array(self.kind), "offset": self.offset.copy(), "scale": self.scale.copy()}

    @classmethod
    def from_arrays(cls, arrays: dict[str, NDArray]) -> FeatureScaler:
        return cls(str(arrays["kind"]), np.asarray(arrays["offset"], dtype=float), np.asarray(arrays["scale"], dtype=float))


__all__ = ["SCALER_KINDS", "FeatureScaler", "peak_normalise", "resample_record"]
