"""Spatial profiles of section properties along a body ``x ∈ [−l, l]``.

A profile is a frozen value object, callable on positions (m) and returning the
property there (SI units of the property it stands for: kg/m, N, N·s, N·m², N·m²·s).
It also tells where it jumps, so meshes can put nodes there (a jump inside an
element drops P1 and P2 alike to first order), and whether it is piecewise
constant, so the exact transfer-matrix solutions can serve it.

Kinds (docs/design.md §3): :class:`Uniform`, :class:`Piecewise`, :class:`Linear`, :class:`Table`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray


class Profile(Protocol):
    """What the assembly, the exact solutions and the reduced models need of a profile."""

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]: ...

    @property
    def jumps(self) -> tuple[float, ...]:
        """Positions where the value jumps (mesh nodes go there)."""
        ...

    @property
    def kinks(self) -> tuple[float, ...]:
        """Positions where the slope changes (table nodes); nodes help there too."""
        ...

    @property
    def is_piecewise_constant(self) -> bool: ...


@dataclass(frozen=True)
class Uniform:
    """The same value everywhere."""

    value: float
    jumps = kinks = ()
    is_piecewise_constant = True

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        return np.full(np.shape(x), float(self.value))


@dataclass(frozen=True)
class Piecewise:
    """``values[k]`` on ``breaks[k−1] < x < breaks[k]`` (with ``breaks[−1] = −l``, ``breaks[n] = l``).

    ``len(values) == len(breaks) + 1``; at a break the value to the right is taken.
    """

    breaks: tuple[float, ...]
    values: tuple[float, ...]
    kinks = ()
    is_piecewise_constant = True

    def __post_init__(self) -> None:
        if len(self.values) != len(self.breaks) + 1:
            raise ValueError("a piecewise profile needs one more value than breaks")
        if any(b >= c for b, c in zip(self.breaks, self.breaks[1:])):
            raise ValueError("piecewise breaks must increase strictly")

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        index = np.searchsorted(np.asarray(self.breaks, dtype=float), np.asarray(x, dtype=float), side="right")
        return np.asarray(self.values, dtype=float)[index]

    @property
    def jumps(self) -> tuple[float, ...]:
        return tuple(float(b) for b in self.breaks)


@dataclass(frozen=True)
class Linear:
    """Linear from ``left`` at ``x = −l`` to ``right`` at ``x = +l``."""

    left: float
    right: float
    half_length: float
    jumps = kinks = ()

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        s = (np.asarray(x, dtype=float) + self.half_length) / (2.0 * self.half_length)
        return self.left + (self.right - self.left) * s

    @property
    def is_piecewise_constant(self) -> bool:
        return self.left == self.right


@dataclass(frozen=True)
class Table:
    """Linear interpolation of ``values`` at positions ``x`` (held constant beyond the ends)."""

    x: tuple[float, ...]
    values: tuple[float, ...]
    jumps = ()

    def __post_init__(self) -> None:
        if len(self.x) != len(self.values) or len(self.x) < 2:
            raise ValueError("a table profile needs two or more (x, value) pairs of equal count")
        if any(a >= b for a, b in zip(self.x, self.x[1:])):
            raise ValueError("table positions must increase strictly")

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        return np.interp(np.asarray(x, dtype=float), self.x, self.values)

    @property
    def kinks(self) -> tuple[float, ...]:
        return tuple(float(v) for v in self.x)

    @property
    def is_piecewise_constant(self) -> bool:
        return len(set(self.values)) == 1


def segment_values(profile: Profile, edges: NDArray[np.float64]) -> NDArray[np.float64]:
    """Value of a piecewise-constant profile on each segment ``(edges[k], edges[k+1])``."""
    if not profile.is_piecewise_constant:
        raise ValueError("only a piecewise-constant profile has one value per segment")
    edges = np.asarray(edges, dtype=float)
    return profile(0.5 * (edges[:-1] + edges[1:]))


def common_edges(half_length: float, profiles: list[Profile] | tuple[Profile, ...]) -> NDArray[np.float64]:
    """Segment edges ``[−l, jumps…, l]`` shared by several profiles (jumps inside the body only)."""
    inner = sorted({j for p in profiles for j in p.jumps if -half_length < j < half_length})
    return np.array([-half_length, *inner, half_length], dtype=float)
