"""Mass, stiffness and Voigt damping operators of rods and beams.

Rod (P1/P2 Lagrange, from reference-element tables kept per family, :mod:`femref.fem.reference`):

    ∫ m u_tt v dx + ∫ (EA u_x + cA u_xt) v_x dx = F2 v(l) − F1 v(−l)

Beam (Hermite cubics, assembled in element-local coordinates, see below):

    ∫ m w_tt v dx + ∫ (EI w_xx + cI w_xxt) v_xx dx
        = N1 v(−l) − N2 v(l) − G1 v'(−l) + G2 v'(l)

(integrate ``N_x + m w_tt = 0`` by parts twice with ``N = G_x``). With ``v = 1`` and
``v = x`` these give the rigid-body laws ``M a = F2 − F1`` (rod),
``M a_v = N1 − N2`` and ``J Ω = G2 − G1 − l(N1 + N2)`` (beam) of docs/design.md §2.

All DOFs are numbered in order of position, so the matrices are banded (half-bandwidth
1 for P1, 2 for P2, 3 for Hermite) and :mod:`femref.fem.banded` factorises them in O(n).

Why the beam is not assembled with ``skfem.ElementLineHermite``: that element builds a
global monomial basis per element, whose Vandermonde matrix loses digits as elements
shrink (measured: 3e-7 relative error in the strain energy of w = x² with 1e3 elements
on [−1, 1], 8e-4 with 1e4). Local Hermite shape functions have no such loss; the tests
check both assemblies agree on small meshes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from femref.core.profiles import Profile
from femref.core.quadrature import gauss_legendre
from femref.fem.reference import assemble_forms, pattern
from femref.fem.shapes import SHAPES

ROD_LOADS = ("F1", "F2")
BEAM_LOADS = ("N1", "N2", "G1", "G2")


@dataclass(frozen=True, eq=False)
class Operators:
    """Discrete body: ``M ü + C u̇ + K u = B f(t)`` with DOFs numbered by position.

    ``load_matrix`` B maps the end loads (``load_names``, e.g. F1, F2) to nodal forces;
    ``rigid_modes`` are the columns Φ with ``K Φ = C Φ = 0`` (translation; and rotation
    for beams). ``element_dofs[e]`` lists the local DOFs of element e in the order of
    :mod:`femref.fem.shapes`. A rod also keeps ``bands = (p, M, C, K)``, its matrices as row
    bands ``A[i, i + k − p]`` at ``[k, i]`` (read-only; :func:`femref.fem.reference.assemble_forms`).
    """

    kind: str
    element: str
    nodes: NDArray[np.float64]
    mass: sp.csr_matrix
    stiffness: sp.csr_matrix
    damping: sp.csr_matrix
    load_names: tuple[str, ...]
    load_matrix: sp.csr_matrix
    rigid_modes: NDArray[np.float64]
    element_dofs: NDArray[np.int64]
    stiffness_profile: Profile
    viscosity_profile: Profile
    mass_profile: Profile
    bands: tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None

    @property
    def ndof(self) -> int:
        return self.mass.shape[0]

    @property
    def half_length(self) -> float:
        return 0.5 * float(self.nodes[-1] - self.nodes[0])

    @property
    def elements(self) -> int:
        return self.nodes.size - 1

    @property
    def total_mass(self) -> float:
        """``M = ∫ m dx`` from the mass matrix: ``φ₀ᵀ M φ₀`` with the translation mode."""
        phi = self.rigid_modes[:, 0]
        return float(phi @ (self.mass @ phi))

    def interpolation(self, x: NDArray[np.float64], derivative: int = 0) -> sp.csr_matrix:
        """Sparse matrix P with ``(P u)[k] = dⁿu/dxⁿ(x[k])`` for the field u of DOF vector u."""
        x, dofs, values = element_values(self.element, self.nodes, self.element_dofs, x, derivative)
        row_starts = np.arange(0, values.size + 1, values.shape[0])  # row k: the nb DOFs of its element
        return sp.csr_matrix((values.T.ravel(), dofs.ravel(), row_starts), shape=(x.size, self.ndof))

    def sampling(self, x: NDArray[np.float64], derivative: int = 0) -> NDArray[np.float64]:
        """:meth:`interpolation` as a dense array ``(len(x), ndof)``, for a few points (:func:`sampling`)."""
        return sampling(self.element, self.nodes, self.element_dofs, self.ndof, x, derivative)


def element_values(element: str, nodes: NDArray[np.float64], element_dofs: NDArray[np.int64], x: NDArray[np.float64],
                   derivative: int) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """``x`` as an array, the DOFs of the element holding each point ``(npoints, nb)`` and the shape functions' n-th
    derivatives there ``(nb, npoints)``, on the mesh ``nodes`` of ``element``s (ValueError for a point off it)."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    margin = 1e-12 * (0.5 * float(nodes[-1] - nodes[0]))  # 1e-12 of the half-length
    if np.any(x < nodes[0] - margin) or np.any(x > nodes[-1] + margin):
        raise ValueError(f"positions {x} lie outside the body [{nodes[0]}, {nodes[-1]}]")
    # np.minimum(np.maximum(…)) is np.clip without its wrappers' microseconds
    e = np.minimum(np.maximum(np.searchsorted(nodes, x, side="right") - 1, 0), nodes.size - 2)
    h = nodes[e + 1] - nodes[e]
    xi = np.minimum(np.maximum((x - nodes[e]) / h, 0.0), 1.0)
    return x, element_dofs[e], SHAPES[element](xi, h, derivative)


def sampling(element: str, nodes: NDArray[np.float64], element_dofs: NDArray[np.int64], ndof: int, x: NDArray[np.float64],
             derivative: int = 0) -> NDArray[np.float64]:
    """Dense ``P`` (``len(x) × ndof``) with ``(P u)[k] = dⁿu/dxⁿ(x[k])`` on the mesh ``nodes`` of ``element``s."""
    x, dofs, values = element_values(element, nodes, element_dofs, x, derivative)
    dense = np.zeros((x.size, ndof))
    dense[np.arange(x.size)[:, None], dofs] = values.T
    return dense


def assemble_rod(
    nodes: NDArray[np.float64],
    order: int,
    mass_per_length: Profile,
    axial_stiffness: Profile,
    axial_viscosity: Profile,
) -> Operators:
    """Rod operators with P1 or P2 Lagrange elements on the given (sorted) nodes.

    ``M = ∫ m φᵢ φⱼ``, ``K = ∫ EA φᵢ' φⱼ'``, ``C = ∫ cA φᵢ' φⱼ'``; ``order + 2`` Gauss points
    per element, exact for linear coefficients (degree ``2·order + 1``); tabulated profiles
    have nodes on their kinks, piecewise profiles on their jumps (see
    :func:`femref.fem.mesh.body_nodes`). Each matrix is the profile at the quadrature points times
    the family's reference-element tensor, computed once per process (:mod:`femref.fem.reference`;
    a test holds it to scikit-fem's own assembly).
    """
    element = {1: "P1", 2: "P2"}.get(order)
    if element is None:
        raise ValueError(f"rod elements are P1 or P2, got order {order}")
    nodes = np.array(nodes, dtype=float)
    structure = pattern(element, nodes.size - 1)
    assembled = assemble_forms(element, nodes, ((mass_per_length, 0), (axial_stiffness, 1), (axial_viscosity, 1)), order + 2)
    mass, stiffness, damping = assembled.matrices
    ndof = structure.ndof
    index = structure.indices.dtype
    load_matrix = sp.csr_matrix((np.array([-1.0, 1.0]), np.array([0, 1], dtype=index), np.array([0, 1, *([1] * (ndof - 2)), 2], dtype=index)),
                                shape=(ndof, 2))
    return Operators(
        kind="rod",
        element=element,
        nodes=nodes,
        mass=mass,
        stiffness=stiffness,
        damping=damping,
        load_names=ROD_LOADS,
        load_matrix=load_matrix,
        rigid_modes=np.ones((ndof, 1)),
        element_dofs=structure.element_dofs,
        stiffness_profile=axial_stiffness,
        viscosity_profile=axial_viscosity,
        mass_profile=mass_per_length,
        bands=(assembled.half_bandwidth, assembled.bands[0], assembled.bands[2], assembled.bands[1]),
    )


def _hermite_matrix(nodes: NDArray, coefficient: Profile, derivative: int, points: int = 5) -> sp.csr_matrix:
    """``∫ c(x) dᵏφᵢ dᵏφⱼ dx`` over all elements at once (Gauss–Legendre, element-local)."""
    xg, wg = gauss_legendre(points)
    xi, wq = 0.5 * (xg + 1.0), 0.5 * wg
    h = np.diff(nodes)[:, None]  # (ne, 1)
    c = coefficient(nodes[:-1, None] + h * xi[None, :])  # (ne, nq)
    B = SHAPES["hermite"](xi[None, :], h, derivative)  # (4, ne, nq)
    local = np.einsum("q,eq,aeq,beq->eab", wq, c * h, B, B)
    dofs = _hermite_element_dofs(nodes.size - 1)
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    ndof = 2 * nodes.size
    return sp.csr_matrix((local.ravel(), (rows, cols)), shape=(ndof, ndof))


def _hermite_element_dofs(elements: int) -> NDArray[np.int64]:
    first = 2 * np.arange(elements)
    return np.stack([first, first + 1, first + 2, first + 3], axis=1)


def assemble_beam(
    nodes: NDArray[np.float64],
    mass_per_length: Profile,
    bending_stiffness: Profile,
    bending_viscosity: Profile,
) -> Operators:
    """Euler-Bernoulli beam operators with Hermite cubic elements, DOFs ``(w_i, w_i')`` interleaved.

    ``M = ∫ m φᵢ φⱼ``, ``K = ∫ EI φᵢ'' φⱼ''``, ``C = ∫ cI φᵢ'' φⱼ''`` with 5-point Gauss
    quadrature per element (exact for coefficients up to degree 3 in M).
    """
    nodes = np.asarray(nodes, dtype=float)
    ndof = 2 * nodes.size
    l = 0.5 * (nodes[-1] - nodes[0])
    w_left, t_left, w_right, t_right = 0, 1, ndof - 2, ndof - 1
    # columns: N1, N2, G1, G2 -> N1 v(−l) − N2 v(l) − G1 v'(−l) + G2 v'(l)
    load_matrix = sp.csr_matrix(
        ([1.0, -1.0, -1.0, 1.0], ([w_left, w_right, t_left, t_right], [0, 1, 2, 3])), shape=(ndof, 4)
    )
    rigid = np.zeros((ndof, 2))
    rigid[0::2, 0] = 1.0
    rigid[0::2, 1] = nodes - (nodes[0] + l)
    rigid[1::2, 1] = 1.0
    return Operators(
        kind="beam",
        element="hermite",
        nodes=nodes,
        mass=_hermite_matrix(nodes, mass_per_length, 0),
        stiffness=_hermite_matrix(nodes, bending_stiffness, 2),
        damping=_hermite_matrix(nodes, bending_viscosity, 2),
        load_names=BEAM_LOADS,
        load_matrix=load_matrix,
        rigid_modes=rigid,
        element_dofs=_hermite_element_dofs(nodes.size - 1),
        stiffness_profile=bending_stiffness,
        viscosity_profile=bending_viscosity,
        mass_profile=mass_per_length,
    )
