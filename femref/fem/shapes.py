"""Element shape functions on one element ``[x0, x0 + h]`` in the local coordinate ``ξ ∈ [0, 1]``.

Used to interpolate solutions at probes (values and x-derivatives) and to assemble
the Hermite beam in element-local coordinates. Local DOF order matches the global
numbering of :mod:`femref.fem.operators`: Lagrange ``[v0, v1, (midpoint)]``, Hermite
``[w0, w0', w1, w1']``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from numpy.typing import NDArray

ShapeFunction = Callable[[NDArray, NDArray, int], NDArray]


def _broadcast(xi: NDArray, h: NDArray) -> tuple[NDArray, NDArray]:
    """``xi`` and ``h`` as float arrays of one shape (``np.broadcast_arrays`` only when their shapes differ: it costs a
    few µs, a sixth of sampling a car at its ends)."""
    xi, h = np.asarray(xi, dtype=float), np.asarray(h, dtype=float)
    return (xi, h) if xi.shape == h.shape else np.broadcast_arrays(xi, h)


def lagrange_p1(xi: NDArray, h: NDArray, derivative: int) -> NDArray:
    """P1: ``N = [1 − ξ, ξ]``; x-derivatives by ``d/dx = (1/h) d/dξ``. Shape ``(2, *xi.shape)``."""
    xi, h = _broadcast(xi, h)
    if derivative == 0:
        return np.array([1.0 - xi, xi])
    if derivative == 1:
        return np.array([-np.ones_like(xi), np.ones_like(xi)]) / h
    return np.zeros((2, *np.shape(xi)))


def lagrange_p2(xi: NDArray, h: NDArray, derivative: int) -> NDArray:
    """P2: ``N = [(1−ξ)(1−2ξ), ξ(2ξ−1), 4ξ(1−ξ)]`` (vertices, then midpoint)."""
    xi, h = _broadcast(xi, h)
    if derivative == 0:  # np.array of equal shapes is np.stack without its checks' microseconds
        return np.array([(1.0 - xi) * (1.0 - 2.0 * xi), xi * (2.0 * xi - 1.0), 4.0 * xi * (1.0 - xi)])
    if derivative == 1:
        return np.array([4.0 * xi - 3.0, 4.0 * xi - 1.0, 4.0 - 8.0 * xi]) / h
    if derivative == 2:
        one = np.ones_like(xi)
        return np.stack([4.0 * one, 4.0 * one, -8.0 * one]) / h**2
    return np.zeros((3, *np.shape(xi)))


def hermite_cubic(xi: NDArray, h: NDArray, derivative: int) -> NDArray:
    """Hermite cubics ``[1 − 3ξ² + 2ξ³, h(ξ − 2ξ² + ξ³), 3ξ² − 2ξ³, h(ξ³ − ξ²)]``.

    Slope DOFs carry the factor ``h`` so that the DOFs are ``w`` and ``dw/dx``.
    """
    xi, h = _broadcast(xi, h)
    if derivative == 0:
        return np.stack([1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, h * (xi**3 - xi**2)])
    if derivative == 1:
        return np.stack([(-6 * xi + 6 * xi**2) / h, 1 - 4 * xi + 3 * xi**2, (6 * xi - 6 * xi**2) / h, 3 * xi**2 - 2 * xi])
    if derivative == 2:
        return np.stack([(-6 + 12 * xi) / h**2, (-4 + 6 * xi) / h, (6 - 12 * xi) / h**2, (6 * xi - 2) / h])
    if derivative == 3:
        one = np.ones_like(xi)
        return np.stack([12 * one / h**3, 6 * one / h**2, -12 * one / h**3, 6 * one / h**2])
    return np.zeros((4, *np.shape(xi)))


SHAPES: dict[str, ShapeFunction] = {"P1": lagrange_p1, "P2": lagrange_p2, "hermite": hermite_cubic}
