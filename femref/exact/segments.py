"""Piecewise-constant bodies for the exact solutions, and input checks shared by them.

A body occupies ``x ∈ [−l, l]`` (docs/design.md §2) and is cut into ``n`` segments
``(edges[k], edges[k+1])`` on which the mass per length ``m`` (kg/m), the stiffness
(``EA`` in N for rods, ``EI`` in N·m² for beams) and the Kelvin-Voigt viscosity
(``cA`` in N·s, ``cI`` in N·m²·s) are constant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.core.profiles import Profile, common_edges, segment_values

#: Positions within this fraction of ``l`` outside the body are taken as its ends.
POSITION_TOLERANCE = 1e-12


@dataclass(frozen=True, eq=False)
class Segments:
    """A body of piecewise-constant section properties on ``x ∈ [edges[0], edges[-1]] = [−l, l]``.

    ``mass_per_length[k]`` (kg/m), ``stiffness[k]`` (EA [N] or EI [N·m²]) and
    ``viscosity[k]`` (cA [N·s] or cI [N·m²·s]) hold on ``edges[k] < x < edges[k+1]``.
    The body must be centred (``edges[0] = −edges[-1]``) because the end loads and the
    rigid-body laws of docs/design.md §2 are written about ``x = 0``.
    """

    edges: NDArray[np.float64]
    mass_per_length: NDArray[np.float64]
    stiffness: NDArray[np.float64]
    viscosity: NDArray[np.float64]

    def __post_init__(self) -> None:
        edges = np.atleast_1d(np.asarray(self.edges, dtype=float))
        if edges.ndim != 1 or edges.size < 2:
            raise ValueError(f"Segments.edges must be a 1-D array of two or more positions, got shape {edges.shape}")
        if not np.all(np.isfinite(edges)):
            raise ValueError("Segments.edges must be finite")
        if np.any(np.diff(edges) <= 0.0):
            raise ValueError(f"Segments.edges must increase strictly, got {edges.tolist()}")
        half = 0.5 * (edges[-1] - edges[0])
        if abs(edges[0] + edges[-1]) > POSITION_TOLERANCE * half * 10:
            raise ValueError(f"Segments.edges must run from −l to +l (centred body), got [{edges[0]}, {edges[-1]}]")
        n = edges.size - 1
        values = {}
        for name in ("mass_per_length", "stiffness", "viscosity"):
            v = np.asarray(getattr(self, name), dtype=float)
            if v.ndim == 0:
                v = np.full(n, float(v))
            if v.shape != (n,):
                raise ValueError(f"Segments.{name} must have one value per segment ({n}), got shape {v.shape}")
            if not np.all(np.isfinite(v)):
                raise ValueError(f"Segments.{name} must be finite")
            values[name] = v
        if np.any(values["mass_per_length"] <= 0.0):
            raise ValueError("Segments.mass_per_length must be > 0 on every segment")
        if np.any(values["stiffness"] <= 0.0):
            raise ValueError("Segments.stiffness must be > 0 on every segment")
        if np.any(values["viscosity"] < 0.0):
            raise ValueError("Segments.viscosity must be >= 0 on every segment")
        edges = edges.copy()
        edges[0], edges[-1] = -half, half
        for name, v in (("edges", edges), *values.items()):
            v = v.copy()
            v.setflags(write=False)
            object.__setattr__(self, name, v)

    @classmethod
    def uniform(cls, length: float, mass_per_length: float, stiffness: float, viscosity: float = 0.0) -> "Segments":
        """A homogeneous body of total length ``length = 2l`` (m)."""
        if not length > 0.0:
            raise ValueError(f"length must be > 0, got {length}")
        half = 0.5 * float(length)
        return cls(np.array([-half, half]), np.array([mass_per_length]), np.array([stiffness]), np.array([viscosity]))

    @classmethod
    def from_profiles(
        cls, half_length: float, mass_per_length: Profile, stiffness: Profile, viscosity: Profile
    ) -> "Segments":
        """Segments from piecewise-constant profiles (``femref.core.profiles``), cut at all their jumps."""
        if not half_length > 0.0:
            raise ValueError(f"half_length must be > 0, got {half_length}")
        profiles = (mass_per_length, stiffness, viscosity)
        edges = common_edges(half_length, profiles)
        return cls(edges, *(segment_values(p, edges) for p in profiles))

    @property
    def n_segments(self) -> int:
        return self.edges.size - 1

    @property
    def half_length(self) -> float:
        """``l`` (m)."""
        return float(self.edges[-1])

    @property
    def lengths(self) -> NDArray[np.float64]:
        """Segment lengths (m)."""
        return np.diff(self.edges)

    @property
    def mass(self) -> float:
        """``M = ∫ m dx`` (kg)."""
        return float(np.sum(self.mass_per_length * self.lengths))

    @property
    def rotary_inertia(self) -> float:
        """``J = ∫ x² m dx`` (kg·m²) about the centre ``x = 0``."""
        a, b = self.edges[:-1], self.edges[1:]
        return float(np.sum(self.mass_per_length * (b**3 - a**3) / 3.0))

    @property
    def is_homogeneous(self) -> bool:
        return all(np.all(v == v[0]) for v in (self.mass_per_length, self.stiffness, self.viscosity))

    def homogeneous(self) -> "Segments":
        """The same body as one segment (raises ``ValueError`` unless it is homogeneous)."""
        if not self.is_homogeneous:
            raise ValueError("the closed-form solutions need a homogeneous body (one value of m, stiffness, viscosity)")
        return Segments.uniform(2.0 * self.half_length, self.mass_per_length[0], self.stiffness[0], self.viscosity[0])

    def mirrored(self) -> "Segments":
        """The body seen from the other end: ``x → −x``."""
        return Segments(-self.edges[::-1], self.mass_per_length[::-1], self.stiffness[::-1], self.viscosity[::-1])

    def segment_index(self, x: NDArray[np.float64]) -> NDArray[np.intp]:
        """Index of the segment holding each position (a position on an inner edge goes right)."""
        return np.clip(np.searchsorted(self.edges, x, side="right") - 1, 0, self.n_segments - 1)


def check_positions(segments: Segments, x: ArrayLike) -> NDArray[np.float64]:
    """``x`` as a 1-D float array inside ``[−l, l]`` (roundoff beyond the ends is clipped)."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    if x.ndim != 1:
        raise ValueError(f"positions x must be a scalar or a 1-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("positions x must be finite")
    half = segments.half_length
    outside = np.abs(x) > half * (1.0 + POSITION_TOLERANCE)
    if np.any(outside):
        raise ValueError(f"positions x must lie in the body [−l, l] = [{-half}, {half}] m; got {x[outside][:5].tolist()}")
    return np.clip(x, -half, half)


def check_frequencies(omega: ArrayLike) -> NDArray[np.float64]:
    """``omega`` as a 1-D float array of finite values > 0 (rad/s)."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if omega.ndim != 1:
        raise ValueError(f"omega must be a scalar or a 1-D array, got shape {omega.shape}")
    if not np.all(np.isfinite(omega)) or np.any(omega <= 0.0):
        raise ValueError("omega must be finite and > 0 rad/s (the free body has no static response)")
    return omega


def check_amplitude(value: ArrayLike, n_frequencies: int, name: str) -> NDArray[np.complex128]:
    """A load amplitude, scalar or one per frequency, as a complex ``(Nw,)`` array."""
    v = np.asarray(value, dtype=complex)
    if v.ndim == 0:
        return np.full(n_frequencies, complex(v))
    if v.shape != (n_frequencies,):
        raise ValueError(f"{name} must be a scalar or have one value per frequency ({n_frequencies}), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite")
    return v


def check_laplace(s: ArrayLike) -> NDArray[np.complex128]:
    """Laplace variables as a 1-D complex array, finite, nonzero, ``Re s ≥ 0`` (1/s)."""
    s = np.atleast_1d(np.asarray(s, dtype=complex))
    if s.ndim != 1:
        raise ValueError(f"Laplace variables s must be a scalar or a 1-D array, got shape {s.shape}")
    if not np.all(np.isfinite(s)) or np.any(s == 0.0) or np.any(s.real < 0.0):
        raise ValueError("Laplace variables s must be finite, nonzero, with Re s >= 0")
    return s
