"""Reference-element tables of the rod's Lagrange elements and the assembly that broadcasts them over a mesh.

An element matrix of ``∫ c(x) dᵏφᵢ dᵏφⱼ dx`` (k = 0, 1) on an element ``[x₀, x₀ + h]`` is, with Gauss–Legendre
points ``ξ_q`` and weights ``w_q`` on the reference element ``[0, 1]``::

    Aᵉᵢⱼ = Σ_q c(x₀ + h ξ_q) · h w_q · (h⁻ᵏ Rᵢ(ξ_q)) (h⁻ᵏ Rⱼ(ξ_q))

``R`` the k-th ξ-derivatives of the shape functions. ``R`` at the points depend only on the element family and the
rule: :func:`reference_shapes` tabulates them once per process, with scikit-fem's own formulas (a test holds them
to ``skfem.ElementLineP1/P2.lbasis`` bit for bit), and :func:`assemble` broadcasts them over the elements in the
order of operations of scikit-fem's basis, so the matrices are those a ``skfem.Basis`` per car gave, to the last
bit, without building one. The sum into the global matrix goes through a sparsity pattern also kept per family
and element count (:func:`pattern`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from femref.core.profiles import Profile
from femref.core.quadrature import gauss_legendre


def _read_only(array: NDArray) -> NDArray:
    array.flags.writeable = False
    return array


@functools.cache
def reference_points(points: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss–Legendre points ``ξ_q`` and weights ``w_q`` on ``[0, 1]`` (read-only, shared)."""
    xi, wi = gauss_legendre(points)
    return _read_only(0.5 * xi + 0.5), _read_only(0.5 * wi)


@functools.cache
def reference_shapes(element: str, points: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(R, dR/dξ)`` of the family's shape functions at the rule's points, ``(local DOFs, points)`` each, in
    scikit-fem's formulas (P1 ``1 − x, x``; P2 ``1 − 3x + 2x², −x + 2x², 4x − 4x²``, vertices then midpoint);
    read-only, once per (family, rule) in a process."""
    x, _ = reference_points(points)
    if element == "P1":
        values, slopes = [1 - x, x], [-1 + 0 * x, 1 + 0 * x]
    elif element == "P2":
        values, slopes = [1 - 3 * x + 2 * x**2, -x + 2 * x**2, 4 * x - 4 * x**2], [-3 + 4 * x, -1 + 4 * x, 4 - 8 * x]
    else:
        raise ValueError(f"reference shapes are tabulated for P1 and P2, got {element}")
    return _read_only(np.array(values)), _read_only(np.array(slopes))


@dataclass(frozen=True, eq=False)
class Pattern:
    """Where element entries go in the global CSR matrix: ``slot[e·n² + i·n + j]`` is the position in ``indices``
    of entry ``(dofs[e, i], dofs[e, j])``; ``indptr``, ``indices`` the CSR structure (rows and columns sorted), in
    scipy's index type (:func:`index_dtype`: given another, scipy converts them, a third of a small matrix's cost)."""

    element_dofs: NDArray[np.int64]
    slot: NDArray[np.int64]
    indptr: NDArray[np.int32 | np.int64]
    indices: NDArray[np.int32 | np.int64]
    ndof: int


def index_dtype(ndof: int, entries: int) -> type:
    """The index type scipy gives a CSR matrix of ``ndof`` rows and ``entries`` stored entries: int32 while both fit."""
    return np.int32 if max(ndof, entries) <= np.iinfo(np.int32).max else np.int64


def element_dofs(element: str, elements: int) -> NDArray[np.int64]:
    """Global DOFs of each element's local DOFs, numbered by position along the body: P1 ``[e, e+1]``, P2
    ``[2e, 2e+2, 2e+1]`` (vertices, then the midpoint)."""
    e = np.arange(elements, dtype=np.int64)[:, None]
    local, step = {"P1": ((0, 1), 1), "P2": ((0, 2, 1), 2)}[element]
    return step * e + np.array(local, dtype=np.int64)


@functools.lru_cache(maxsize=64)
def pattern(element: str, elements: int) -> Pattern:
    """The sparsity pattern of a mesh of ``elements`` elements of the family ``element`` (read-only, shared)."""
    dofs = element_dofs(element, elements)
    n = dofs.shape[1]
    ndof = int(dofs[-1, 1]) + 1
    rows = np.repeat(dofs, n, axis=1).ravel()
    cols = np.tile(dofs, (1, n)).ravel()
    keys, slot = np.unique(rows * ndof + cols, return_inverse=True)  # row-major, columns sorted
    indptr = np.searchsorted(keys, np.arange(ndof + 1) * ndof)
    index = index_dtype(ndof, keys.size)
    return Pattern(_read_only(dofs), _read_only(slot.ravel()), _read_only(indptr.astype(index)), _read_only((keys % ndof).astype(index)), ndof)


def forget_patterns() -> None:
    """Drop the kept patterns (:func:`femref.models.base.forget_built`: a cold run builds its own)."""
    pattern.cache_clear()


def element_matrices(element: str, nodes: NDArray[np.float64], coefficient: Profile, derivative: int, points: int) -> NDArray[np.float64]:
    """``Aᵉ`` of every element (module docstring), shape ``(elements, n, n)``: ``x = h ξ + x₀``, ``dx = |h| w``,
    slopes ``(1/h) dR/dξ``, and one ``einsum`` over the elements — scikit-fem's basis's arithmetic, op for op."""
    xi, wq = reference_points(points)
    values, slopes = reference_shapes(element, points)
    h = np.diff(nodes)
    x = h[:, None] * xi[None, :] + nodes[:-1, None]
    dx = np.abs(h)[:, None] * wq[None, :]
    if derivative == 0:
        shapes = np.ascontiguousarray(np.broadcast_to(values[:, None, :], (values.shape[0], h.size, xi.size)))
    else:
        shapes = (1.0 / h)[None, :, None] * slopes[:, None, :]
    return np.einsum("eq,aeq,beq->eab", coefficient(x) * dx, shapes, shapes)


def assemble(element: str, nodes: NDArray[np.float64], coefficient: Profile, derivative: int, points: int) -> sp.csr_matrix:
    """The global matrix ``Σₑ Aᵉ`` (CSR, DOFs by position; entries that sum to exactly zero dropped)."""
    structure = pattern(element, nodes.size - 1)
    local = element_matrices(element, nodes, coefficient, derivative, points)
    data = np.bincount(structure.slot, weights=local.ravel(), minlength=structure.indices.size)
    matrix = sp.csr_matrix((data, structure.indices.copy(), structure.indptr.copy()), shape=(structure.ndof, structure.ndof))
    if not np.all(matrix.data):
        matrix.eliminate_zeros()
    return matrix


__all__ = ["Pattern", "assemble", "element_dofs", "element_matrices", "forget_patterns", "index_dtype", "pattern", "reference_points", "reference_shapes"]
