"""Reference-element tables of the rod's Lagrange elements and the assembly that broadcasts them over a mesh.

An element matrix of ``∫ c(x) dᵏφᵢ dᵏφⱼ dx`` (k = 0, 1) on an element ``[x₀, x₀ + h]`` is, with Gauss–Legendre
points ``ξ_q`` and weights ``w_q`` on the reference element ``[0, 1]``::

    Aᵉᵢⱼ = Σ_q c(x₀ + h ξ_q) · h w_q · (h⁻ᵏ Rᵢ(ξ_q)) (h⁻ᵏ Rⱼ(ξ_q))

``R`` the k-th ξ-derivatives of the shape functions. ``R`` at the points depend only on the element family and the
rule: :func:`reference_shapes` tabulates them once per process, with scikit-fem's own formulas (a test holds them
to ``skfem.ElementLineP1/P2.lbasis`` bit for bit), and :func:`assemble_forms` broadcasts them over the elements in the
order of operations of scikit-fem's basis, so the matrices are those a ``skfem.Basis`` per car gave, to the last
bit, without building one. The sum into the global matrix goes through a sparsity pattern also kept per family
and element count (:func:`pattern`); the same sums land in the matrix's row bands, which the impact kernels take
as they are (DOFs numbered by position, half-bandwidth 1 for P1 and 2 for P2).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Sequence

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
    """The sparsity pattern of a mesh of ``elements`` elements of the family ``element`` (read-only, shared): the
    cells of the row-major band map ``(ndof, 2p + 1)`` that some element touches, ``p`` the DOF distance of an
    element's vertices; counted in row-major order they are the CSR positions (columns sorted within a row)."""
    dofs = element_dofs(element, elements)
    ndof = int(dofs[-1, 1]) + 1
    p = int(dofs[0].max() - dofs[0].min())
    width = 2 * p + 1
    cell = (((width - 1) * dofs + p)[:, :, None] + dofs[:, None, :]).ravel()  # entry (e, i, j): row dofs[e, i], band p + dofs[e, j] − dofs[e, i]
    occupied = np.zeros(ndof * width, dtype=bool)
    occupied[cell] = True
    slot = np.cumsum(occupied)[cell] - 1
    stored = np.flatnonzero(occupied)
    row, band = stored // width, stored % width
    indptr = np.zeros(ndof + 1, dtype=np.int64)
    np.cumsum(np.count_nonzero(occupied.reshape(ndof, width), axis=1), out=indptr[1:])
    index = index_dtype(ndof, stored.size)
    return Pattern(_read_only(dofs), _read_only(slot), _read_only(indptr.astype(index)), _read_only((row + band - p).astype(index)), ndof)


def forget_patterns() -> None:
    """Drop the kept patterns (:func:`femref.models.base.forget_built`: a cold run builds its own)."""
    pattern.cache_clear()


def element_matrices(element: str, nodes: NDArray[np.float64], coefficient: Profile, derivative: int, points: int) -> NDArray[np.float64]:
    """``Aᵉ`` of every element (module docstring), shape ``(elements, n, n)``: :func:`element_matrices_of` for one form."""
    return element_matrices_of(element, nodes, ((coefficient, derivative),), points)[0]


def element_matrices_of(element: str, nodes: NDArray[np.float64], forms: Sequence[tuple[Profile, int]], points: int) -> list[NDArray[np.float64]]:
    """``Aᵉ`` of every element for each ``(c, k)`` of ``forms`` (module docstring), shape ``(elements, n, n)`` each:
    ``x = h ξ + x₀``, ``dx = |h| w``, slopes ``(1/h) dR/dξ`` (shared by the forms), and one ``einsum`` per form over
    the elements — scikit-fem's basis's arithmetic, op for op."""
    xi, wq = reference_points(points)
    values, slopes = reference_shapes(element, points)
    h = np.diff(nodes)
    x = h[:, None] * xi[None, :] + nodes[:-1, None]
    dx = np.abs(h)[:, None] * wq[None, :]
    shapes: dict[int, NDArray[np.float64]] = {}
    for _, derivative in forms:
        if derivative not in shapes:
            shapes[derivative] = (np.ascontiguousarray(np.broadcast_to(values[:, None, :], (values.shape[0], h.size, xi.size))) if derivative == 0
                                  else (1.0 / h)[None, :, None] * slopes[:, None, :])
    return [np.einsum("eq,aeq,beq->eab", coefficient(x) * dx, shapes[derivative], shapes[derivative]) for coefficient, derivative in forms]


def band_index(element: str, elements: int) -> tuple[NDArray[np.int64], int, int]:
    """``(index, p, ndof)``: where entry ``(i, j) = (dofs[e, a], dofs[e, b])`` of each element goes in the row bands
    raveled, ``bands[p + j − i, i]`` of shape ``(2p + 1, ndof)``, in the order ``e, a, b`` of the element matrices;
    ``p`` the DOF distance of an element's vertices (1 for P1, 2 for P2), its half-bandwidth."""
    dofs = element_dofs(element, elements)
    ndof = int(dofs[-1, 1]) + 1
    p = int(dofs[0].max() - dofs[0].min())
    return ((p * ndof + ndof * dofs)[:, None, :] + ((1 - ndof) * dofs)[:, :, None]).ravel(), p, ndof


def _bands(element: str, locals_: list[NDArray[np.float64]]) -> tuple[int, list[NDArray[np.float64]]]:
    """``(p, bands)`` of the global matrices of the element matrices ``locals_`` (read-only)."""
    index, p, ndof = band_index(element, locals_[0].shape[0])
    return p, [_read_only(np.bincount(index, weights=local.ravel(), minlength=(2 * p + 1) * ndof).reshape(2 * p + 1, ndof)) for local in locals_]


def assemble_bands(element: str, nodes: NDArray[np.float64], forms: Sequence[tuple[Profile, int]], points: int) -> tuple[int, list[NDArray[np.float64]]]:
    """``(p, bands)``: the global matrix ``Σₑ Aᵉ`` of each ``(c, k)`` of ``forms`` as row bands,
    ``bands[k][p + j − i, i] = A_k[i, j]`` (read-only) — each entry the sum of its elements' entries in element order,
    the additions of :func:`assemble_forms`' CSR data, so the same numbers to the bit."""
    return _bands(element, element_matrices_of(element, nodes, forms, points))


@dataclass(frozen=True, eq=False)
class Assembled:
    """Global matrices ``Σₑ Aᵉ`` of one mesh, one per form: CSR (DOFs by position; entries that sum to exactly zero
    dropped) and the same matrices as row bands (:func:`assemble_bands`), ``p`` the half-bandwidth."""

    matrices: list[sp.csr_matrix]
    bands: list[NDArray[np.float64]]
    half_bandwidth: int


def assemble_forms(element: str, nodes: NDArray[np.float64], forms: Sequence[tuple[Profile, int]], points: int) -> Assembled:
    """The global matrix of each ``(c, k)`` of ``forms`` (:class:`Assembled`), both storages from one set of element
    matrices."""
    structure = pattern(element, nodes.size - 1)
    locals_ = element_matrices_of(element, nodes, forms, points)
    matrices = []
    for local in locals_:
        data = np.bincount(structure.slot, weights=local.ravel(), minlength=structure.indices.size)
        matrix = sp.csr_matrix((data, structure.indices.copy(), structure.indptr.copy()), shape=(structure.ndof, structure.ndof))
        if not np.all(matrix.data):
            matrix.eliminate_zeros()
        matrices.append(matrix)
    p, bands = _bands(element, locals_)
    return Assembled(matrices, bands, p)


__all__ = ["Assembled", "Pattern", "assemble_bands", "assemble_forms", "band_index", "element_dofs", "element_matrices", "element_matrices_of", "forget_patterns", "index_dtype", "pattern", "reference_points", "reference_shapes"]
