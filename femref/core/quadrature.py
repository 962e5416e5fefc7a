"""Gauss–Legendre rules, computed once per order.

``numpy.polynomial.legendre.leggauss`` solves a companion-matrix eigenproblem on every call
(a fraction of a millisecond); the body integrals and the element assembly ask for the
same few orders again and again.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray


@functools.cache
def gauss_legendre(points: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nodes ``ξᵢ`` and weights ``wᵢ`` of ``∫_{−1}^{1} f dξ ≈ Σ wᵢ f(ξᵢ)`` (exact to degree 2·points − 1); read-only, shared."""
    nodes, weights = np.polynomial.legendre.leggauss(points)
    nodes.flags.writeable = weights.flags.writeable = False
    return nodes, weights


__all__ = ["gauss_legendre"]
