"""Reference-element tensors and the assembly that broadcasts them over a mesh.

An element matrix of ``∫ c(x) dᵏφᵢ dᵏφⱼ dx`` on an element ``[x₀, x₀ + h]`` is, with ``ξ = (x − x₀)/h`` and
Gauss–Legendre points ``ξ_q``, weights ``w_q`` on ``[0, 1]``::

    Aᵉᵢⱼ = h^(1−2k) sᵢ sⱼ Σ_q c(x₀ + h ξ_q) · w_q Rᵢ(ξ_q) Rⱼ(ξ_q)

where ``R`` are the k-th ξ-derivatives of the shape functions of :mod:`femref.fem.shapes` on an element of
length 1 and ``s`` the DOF scaling (1 for values, ``h`` for Hermite slopes). The tensor ``w_q Rᵢ Rⱼ`` depends
only on the element family, the derivative and the rule: :func:`reference_tensor` computes it once per process;
the assembly of a mesh is then one matrix product of the coefficient at the points with it
(:func:`element_matrices`), and the sum into the global matrix goes through a sparsity pattern also computed
once per family and element count (:func:`pattern`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from femref.core.profiles import Profile
from femref.core.quadrature import gauss_legendre
from femref.fem.shapes import SHAPES

SLOPE_SCALED = {"P1": (False, False), "P2": (False, False, False), "hermite": (False, True, False, True)}
"""Which local DOFs of each family carry the element length ``h`` (Hermite slopes: ``w' = (1/h) dw/dξ``)."""


def _read_only(array: NDArray) -> NDArray:
    array.flags.writeable = False
    return array


@functools.cache
def reference_points(points: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre points ``ξ_q`` and weights ``w_q`` on ``[0, 1]`` (read-only, shared)."""
    xi, wi = gauss_legendre(points)
    return _read_only(0.5 * xi + 0.5), _read_only(0.5 * wi)


@functools.cache
def reference_tensor(element: str, derivative: int, points: int) -> NDArray[np.float64]:
    """``T[q, i·n + j] = w_q Rᵢ(ξ_q) Rⱼ(ξ_q)`` (module docstring), shape ``(points, n²)`` for ``n`` local DOFs;
    read-only, once per (family, derivative, rule) in a process."""
    xi, wq = reference_points(points)
    shapes = SHAPES[element](xi, np.ones_like(xi), derivative)  # (n, points) on an element of length 1
    tensor = wq[:, None, None] * shapes.T[:, :, None] * shapes.T[:, None, :]
    return _read_only(tensor.reshape(points, -1))


@dataclass(frozen=True, eq=False)
class Pattern:
    """Where element entries go in the global CSR matrix: ``slot[e·n² + i·n + j]`` is the position in ``indices``
    of entry ``(dofs[e, i], dofs[e, j])``; ``indptr``, ``indices`` the CSR structure (rows and columns sorted)."""

    element_dofs: NDArray[np.int64]
    slot: NDArray[np.int64]
    indptr: NDArray[np.int64]
    indices: NDArray[np.int64]
    ndof: int


def element_dofs(element: str, elements: int) -> NDArray[np.int64]:
    """Global DOFs of each element's local DOFs, numbered by position along the body: P1 ``[e, e+1]``, P2
    ``[2e, 2e+2, 2e+1]`` (vertices, then the midpoint), Hermite ``[2e, 2e+1, 2e+2, 2e+3]`` (``w, w'`` per node)."""
    e = np.arange(elements, dtype=np.int64)[:, None]
    local = {"P1": (0, 1), "P2": (0, 2, 1), "hermite": (0, 1, 2, 3)}[element]
    step = 1 if element == "P1" else 2
    return step * e + np.array(local, dtype=np.int64)


@functools.lru_cache(maxsize=64)
def pattern(element: str, elements: int) -> Pattern:
    """The sparsity pattern of a mesh of ``elements`` elements of the family ``element`` (read-only, shared)."""
    dofs = element_dofs(element, elements)
    n = dofs.shape[1]
    ndof = int(dofs[-1, -1 if element == "hermite" else 1]) + 1
    rows = np.repeat(dofs, n, axis=1).ravel()
    cols = np.tile(dofs, (1, n)).ravel()
    keys, slot = np.unique(rows * ndof + cols, return_inverse=True)  # row-major, columns sorted
    indptr = np.searchsorted(keys, np.arange(ndof + 1) * ndof)
    return Pattern(_read_only(dofs), _read_only(slot.ravel()), _read_only(indptr), _read_only(keys % ndof), ndof)


def quadrature_points(nodes: NDArray[np.float64], points: int) -> NDArray[np.float64]:
    """``x₀ + h ξ_q`` of every element, shape ``(elements, points)``."""
    xi, _ = reference_points(points)
    h = np.diff(nodes)
    return nodes[:-1, None] + h[:, None] * xi[None, :]


def element_matrices(element: str, nodes: NDArray[np.float64], coefficient: Profile, derivative: int, points: int) -> NDArray[np.float64]:
    """``Aᵉ`` of every element (module docstring), shape ``(elements, n²)``."""
    h = np.diff(nodes)
    c = coefficient(quadrature_points(nodes, points))  # (elements, points)
    local = (c * h[:, None] ** (1 - 2 * derivative)) @ reference_tensor(element, derivative, points)
    scaled = SLOPE_SCALED[element]
    if any(scaled):
        s = np.where(np.array(scaled)[None, :], h[:, None], 1.0)  # (elements, n)
        local *= (s[:, :, None] * s[:, None, :]).reshape(h.size, -1)
    return local


def assemble(element: str, nodes: NDArray[np.float64], coefficient: Profile, derivative: int, points: int) -> sp.csr_matrix:
    """The global matrix ``Σₑ Aᵉ`` (CSR, DOFs by position; entries that sum to exactly zero dropped)."""
    structure = pattern(element, nodes.size - 1)
    local = element_matrices(element, nodes, coefficient, derivative, points)
    data = np.bincount(structure.slot, weights=local.ravel(), minlength=structure.indices.size)
    matrix = sp.csr_matrix((data, structure.indices.copy(), structure.indptr.copy()), shape=(structure.ndof, structure.ndof))
    if not np.all(matrix.data):
        matrix.eliminate_zeros()
    return matrix


__all__ = ["Pattern", "assemble", "element_dofs", "element_matrices", "pattern", "quadrature_points", "reference_points",
           "reference_tensor"]
