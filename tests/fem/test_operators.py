"""Consistency of the assembled operators: symmetry, positivity, total mass, rigid modes, band."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import quad
from skfem import Basis, BilinearForm, ElementLineHermite, MeshLine
from skfem.helpers import dd

from femref.fem import assemble_beam, assemble_rod, body_nodes, graded_nodes
from femref.fem.banded import BandedCholesky, half_bandwidth
from femref.core.profiles import Linear, Piecewise, Table, Uniform

L = 8.0
MASS = Piecewise(breaks=(-3.0, 2.5), values=(3000.0, 9000.0, 4000.0))
STIFF = Linear(2.0e9, 3.0e9, L)
VISC = Table(x=(-8.0, 0.0, 8.0), values=(1.0e6, 4.0e6, 1.0e6))


def body(kind: str, n: int = 24, order: int = 2):
    nodes = body_nodes(L, n, jumps=MASS.jumps + VISC.kinks)
    if kind == "rod":
        return assemble_rod(nodes, order, MASS, STIFF, VISC)
    return assemble_beam(nodes, MASS, STIFF, VISC)


@pytest.mark.parametrize("kind,order", [("rod", 1), ("rod", 2), ("beam", 3)])
def test_matrices_symmetric_and_rigid_modes_free(kind, order):
    """M is symmetric positive definite; K and C are symmetric and annihilate the rigid modes."""
    ops = body(kind, order=order)
    for matrix in (ops.mass, ops.stiffness, ops.damping):
        assert abs(matrix - matrix.T).max() <= 1e-12 * abs(matrix).max()
    BandedCholesky(ops.mass)  # raises unless positive definite
    for matrix in (ops.stiffness, ops.damping):
        residual = np.abs(matrix @ ops.rigid_modes).max()
        assert residual <= 1e-9 * abs(matrix).max() * L
    eig_min = np.linalg.eigvalsh(ops.stiffness.toarray())[ops.rigid_modes.shape[1]]
    assert eig_min > 0.0


@pytest.mark.parametrize("kind,order", [("rod", 1), ("rod", 2), ("beam", 3)])
def test_total_mass_and_moment_of_inertia(kind, order):
    """φ₀ᵀMφ₀ = ∫ m dx exactly (mesh nodes on the jumps); for beams φ₁ᵀMφ₁ = ∫ x² m dx."""
    ops = body(kind, order=order)
    exact_mass = sum(quad(lambda x: MASS(x), a, b)[0] for a, b in [(-L, -3.0), (-3.0, 2.5), (2.5, L)])
    assert ops.total_mass == pytest.approx(exact_mass, rel=1e-13)
    if kind == "beam":
        phi = ops.rigid_modes[:, 1]
        inertia = sum(quad(lambda x: x * x * MASS(x), a, b)[0] for a, b in [(-L, -3.0), (-3.0, 2.5), (2.5, L)])
        assert phi @ (ops.mass @ phi) == pytest.approx(inertia, rel=1e-12)


@pytest.mark.parametrize("kind,order,band", [("rod", 1, 1), ("rod", 2, 2), ("beam", 3, 3)])
def test_dofs_numbered_by_position_give_narrow_band(kind, order, band):
    ops = body(kind, n=50, order=order)
    assert half_bandwidth(ops.mass) == band
    assert half_bandwidth(ops.stiffness) == band


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("homogeneous", [True, False])
def test_rod_matrices_equal_scikit_fems_own_assembly(order, homogeneous):
    """The rod's reference-element tensors broadcast over the profile give what scikit-fem's basis and
    assembler give for ``∫ m φᵢ φⱼ``, ``∫ EA φᵢ' φⱼ'``, ``∫ cA φᵢ' φⱼ'`` on the same rule, to round-off, in the
    position numbering (uniform; piecewise, linear and tabulated profiles)."""
    from skfem import ElementLineP1, ElementLineP2
    from skfem.helpers import grad

    from femref.core.quadrature import gauss_legendre

    mass, stiff, visc = (Uniform(5000.0), Uniform(2.5e9), Uniform(1.5e6)) if homogeneous else (MASS, STIFF, VISC)
    nodes = body_nodes(L, 24, jumps=MASS.jumps + VISC.kinks)
    ops = assemble_rod(nodes, order, mass, stiff, visc)
    xi, wi = gauss_legendre(order + 2)
    basis = Basis(MeshLine(nodes), (ElementLineP1, ElementLineP2)[order - 1](), quadrature=(0.5 * xi[None, :] + 0.5, 0.5 * wi))
    x = basis.global_coordinates()[0]
    position = np.argsort(basis.doflocs[0], kind="stable")  # scikit-fem DOF of each position
    forms = (
        (ops.mass, mass, BilinearForm(lambda u, v, w: w.c * u * v)),
        (ops.stiffness, stiff, BilinearForm(lambda u, v, w: w.c * grad(u)[0] * grad(v)[0])),
        (ops.damping, visc, BilinearForm(lambda u, v, w: w.c * grad(u)[0] * grad(v)[0])),
    )
    for mine, profile, form in forms:
        theirs = sp.csr_matrix(form.assemble(basis, c=profile(x)))[position][:, position]
        assert abs(mine - theirs).max() <= 1e-14 * abs(theirs).max()


@pytest.mark.parametrize("order", [1, 2])
def test_rod_matrices_equal_a_scikit_fem_basis_einsum_bit_for_bit(order):
    """The broadcast reference tables give, to the last bit, what the einsum over a ``skfem.Basis`` per car gave
    (the assembly before the tables): ``Σ_q c(x_q) dx_q φᵢ φⱼ`` with scikit-fem's ``x``, ``dx`` and shape values."""
    from skfem import ElementLineP1, ElementLineP2

    from femref.core.quadrature import gauss_legendre
    from femref.fem.reference import element_matrices

    nodes = body_nodes(L, 24, jumps=MASS.jumps + VISC.kinks)
    xi, wi = gauss_legendre(order + 2)
    basis = Basis(MeshLine(nodes), (ElementLineP1, ElementLineP2)[order - 1](), quadrature=(0.5 * xi[None, :] + 0.5, 0.5 * wi))
    x = basis.global_coordinates()[0]
    values = np.array([np.asarray(field[0]) for field in basis.basis])
    slopes = np.array([field[0].grad[0] for field in basis.basis])
    for profile, shapes, derivative in ((MASS, values, 0), (STIFF, slopes, 1), (VISC, slopes, 1)):
        theirs = np.einsum("eq,aeq,beq->eab", profile(x) * basis.dx, shapes, shapes)
        assert np.array_equal(element_matrices(f"P{order}", nodes, profile, derivative, order + 2), theirs)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("profiles", ["uniform", "jumps", "inviscid"])
@pytest.mark.parametrize("elements,grading", [(1, 1.0), (2, 1.0), (24, 1.0), (24, 3.0)])
def test_rod_bands_are_its_sparse_matrices_bands_bit_for_bit(order, profiles, elements, grading):
    """The row bands the assembly keeps (``bands[p + j − i, i] = A[i, j]``) are, to the bit, what the packing read off
    the CSR matrices before (the banded conversion of their stored entries, femref.impact.kernels.packing), with the
    same half-bandwidth: P1/P2, one to 24 elements, uniform and graded meshes; uniform profiles, piecewise/linear/
    tabulated ones with jumps and kinks on nodes, and a rod without Voigt viscosity (C = 0, its entries dropped)."""
    from femref.impact.kernels.packing import _bands_of

    mass, stiff, visc = {"uniform": (Uniform(5000.0), Uniform(2.5e9), Uniform(1.5e6)), "jumps": (MASS, STIFF, VISC),
                         "inviscid": (MASS, STIFF, Uniform(0.0))}[profiles]
    nodes = body_nodes(L, elements, jumps=(mass.jumps + visc.kinks) if profiles != "uniform" else (), grading=grading)
    ops = assemble_rod(nodes, order, mass, stiff, visc)
    p, *bands = ops.bands
    theirs_p, *theirs = _bands_of(ops.ndof, (ops.mass, ops.damping, ops.stiffness))
    assert p == theirs_p == order
    for mine, expected, matrix in zip(bands, theirs, (ops.mass, ops.damping, ops.stiffness)):
        assert mine.shape == (2 * p + 1, ops.ndof) and not mine.flags.writeable
        assert np.array_equal(mine, expected)
        dense = matrix.toarray()
        for k in range(2 * p + 1):  # and the band layout itself, against the dense matrix
            i = np.arange(max(0, p - k), min(ops.ndof, ops.ndof + p - k))
            assert np.array_equal(mine[k, i], dense[i, i + k - p])


@pytest.mark.parametrize("element", ["P1", "P2"])
@pytest.mark.parametrize("elements", [1, 2, 5, 64])
def test_pattern_is_the_sorted_set_of_element_entries(element, elements):
    """The pattern read off the band map equals the one by sorting the element entries' keys ``i·ndof + j``
    (``np.unique``: CSR rows and columns sorted, ``slot`` the inverse)."""
    from femref.fem.reference import element_dofs, pattern

    dofs = element_dofs(element, elements)
    n, ndof = dofs.shape[1], int(dofs.max()) + 1
    rows, cols = np.repeat(dofs, n, axis=1).ravel(), np.tile(dofs, (1, n)).ravel()
    keys, slot = np.unique(rows * ndof + cols, return_inverse=True)
    mine = pattern(element, elements)
    assert mine.ndof == ndof
    assert np.array_equal(mine.slot, slot.ravel())
    assert np.array_equal(mine.indices, keys % ndof)
    assert np.array_equal(mine.indptr, np.searchsorted(keys, np.arange(ndof + 1) * ndof))


@pytest.mark.parametrize("homogeneous", [True, False])
def test_local_hermite_matches_scikit_fem_on_small_mesh(homogeneous):
    """Element-local Hermite assembly equals skfem's ElementLineHermite where the latter is accurate, for
    ``∫ m φᵢ φⱼ``, ``∫ EI φᵢ'' φⱼ''`` and ``∫ cI φᵢ'' φⱼ''`` on the same 5-point rule (uniform and
    piecewise/linear/tabulated coefficients)."""
    from femref.core.quadrature import gauss_legendre

    nodes = np.linspace(-1.0, 1.0, 9) if homogeneous else body_nodes(L, 8, jumps=MASS.jumps + VISC.kinks)
    mass, stiff, visc = (Uniform(1.0), Uniform(1.0), Uniform(1.0)) if homogeneous else (MASS, STIFF, VISC)
    ops = assemble_beam(nodes, mass, stiff, visc)
    xi, wi = gauss_legendre(5)
    basis = Basis(MeshLine(nodes), ElementLineHermite(), quadrature=(0.5 * xi[None, :] + 0.5, 0.5 * wi))
    x = basis.global_coordinates()[0]
    # skfem numbers DOFs (w_i, w_i') by node as nodal_dofs[0], nodal_dofs[1]
    order = np.empty(2 * nodes.size, dtype=int)
    order[0::2], order[1::2] = basis.nodal_dofs[0], basis.nodal_dofs[1]
    forms = (
        (ops.mass, mass, BilinearForm(lambda u, v, w: w.c * u * v)),
        (ops.stiffness, stiff, BilinearForm(lambda u, v, w: w.c * dd(u)[0, 0] * dd(v)[0, 0])),
        (ops.damping, visc, BilinearForm(lambda u, v, w: w.c * dd(u)[0, 0] * dd(v)[0, 0])),
    )
    for mine, profile, form in forms:
        theirs = sp.csr_matrix(form.assemble(basis, c=profile(x)))[order][:, order]
        assert abs(mine - theirs).max() <= 1e-10 * abs(theirs).max()


def test_reference_shapes_are_scikit_fems_bit_for_bit_and_give_the_closed_form_element_matrices():
    """The tabulated P1/P2 shapes and ξ-slopes equal ``skfem.ElementLineP1/P2.lbasis`` at the rule's points exactly;
    uniform coefficient 1 on one element of length h gives P1 ``K = (1/h)[[1, −1], [−1, 1]]``, ``M = (h/6)[[2, 1], [1, 2]]``
    and P2 ``K = (1/3h)[[7, 1, −8], [1, 7, −8], [−8, −8, 16]]``. Tables are kept per (family, rule): another family or
    rule gives its own."""
    from skfem import ElementLineP1, ElementLineP2

    from femref.fem.reference import element_matrices, pattern, reference_points, reference_shapes

    for name, element, points in (("P1", ElementLineP1(), 3), ("P2", ElementLineP2(), 4)):
        xi, _ = reference_points(points)
        values, slopes = reference_shapes(name, points)
        for i in range(values.shape[0]):
            phi, dphi = element.lbasis(xi[None, :], i)
            assert np.array_equal(values[i], phi) and np.array_equal(slopes[i], dphi[0])
    h = 0.7
    nodes = np.array([0.3, 0.3 + h])
    one = Uniform(1.0)
    assert np.allclose(element_matrices("P1", nodes, one, 1, 3)[0], np.array([[1, -1], [-1, 1]]) / h, rtol=1e-14)
    assert np.allclose(element_matrices("P1", nodes, one, 0, 3)[0], np.array([[2, 1], [1, 2]]) * h / 6, rtol=1e-14)
    p2 = np.array([[7, 1, -8], [1, 7, -8], [-8, -8, 16]]) / (3 * h)
    assert np.allclose(element_matrices("P2", nodes, one, 1, 4)[0], p2, rtol=1e-14)
    assert reference_shapes("P2", 4) is reference_shapes("P2", 4)
    assert reference_shapes("P2", 5)[0].shape == (3, 5) and reference_shapes("P1", 4)[0].shape == (2, 4)
    assert pattern("P2", 3).ndof == 7 and pattern("P2", 4).ndof == 9 and pattern("P1", 4).ndof == 5


def test_the_rod_matrices_keep_the_index_type_scipy_gives_them():
    """The pattern's indices are in scipy's own index type (scipy converts any other at every matrix built from them):
    the assembled mass and load matrices hold the type scipy gives the same matrices built from dense, and their
    arrays are their own (not the shared pattern's)."""
    from femref.fem.reference import pattern

    ops = assemble_rod(np.linspace(-1.0, 1.0, 5), 2, Uniform(1.0), Uniform(2.0), Uniform(0.5))
    for matrix in (ops.mass, ops.load_matrix):
        scratch = sp.csr_matrix(matrix.toarray())
        assert matrix.indices.dtype == scratch.indices.dtype and matrix.indptr.dtype == scratch.indptr.dtype
    shared = pattern("P2", 4)
    assert shared.indices.dtype == ops.mass.indices.dtype
    assert not np.shares_memory(ops.mass.indices, shared.indices) and not np.shares_memory(ops.stiffness.indptr, shared.indptr)


def test_local_hermite_keeps_digits_on_fine_mesh():
    """Every element of a 1e4-element mesh on [−1, 1] has the analytic stiffness EI/h³·[12, 6h, −12, 6h; …].

    skfem's global-monomial Hermite loses about half its digits here (docs/formulas.md §X);
    the element-local assembly is translation invariant and keeps them.
    """
    nodes = np.linspace(-1.0, 1.0, 10_001)
    h = np.diff(nodes)
    ops = assemble_beam(nodes, Uniform(1.0), Uniform(1.0), Uniform(0.0))
    K = ops.stiffness.tocsr()
    i = np.arange(1, nodes.size - 1)  # interior nodes: elements i-1 (left) and i (right)
    w, t = 2 * i, 2 * i + 1
    left, right = h[i - 1], h[i]
    assert np.allclose(K[w, w].A1, 12.0 / left**3 + 12.0 / right**3, rtol=1e-13, atol=0.0)
    assert np.allclose(K[t, t].A1, 4.0 / left + 4.0 / right, rtol=1e-13, atol=0.0)
    assert np.allclose(K[w, w + 2].A1, -12.0 / right**3, rtol=1e-13, atol=0.0)
    assert np.allclose(K[w, w + 3].A1, 6.0 / right**2, rtol=1e-13, atol=0.0)
    assert np.allclose(K[t, t + 2].A1, 2.0 / right, rtol=1e-13, atol=0.0)


def test_interpolation_reproduces_polynomials():
    """Values and slopes of fields in the element space are interpolated exactly at any x."""
    x = np.linspace(-L, L, 37)
    for order, poly in [(1, np.polynomial.Polynomial([1.0, 2.0])), (2, np.polynomial.Polynomial([1.0, -2.0, 0.5]))]:
        ops = body("rod", order=order)
        dof_x = np.sort(np.unique(np.concatenate([ops.nodes, 0.5 * (ops.nodes[1:] + ops.nodes[:-1])]))) if order == 2 else ops.nodes
        u = poly(dof_x)
        assert np.allclose(ops.interpolation(x) @ u, poly(x), rtol=1e-12, atol=1e-12)
        assert np.allclose(ops.interpolation(x, 1) @ u, poly.deriv()(x), rtol=1e-11, atol=1e-11)
    ops = body("beam")
    cubic = np.polynomial.Polynomial([0.3, -1.0, 0.2, 0.01])
    u = np.empty(ops.ndof)
    u[0::2], u[1::2] = cubic(ops.nodes), cubic.deriv()(ops.nodes)
    for k in range(3):
        assert np.allclose(ops.interpolation(x, k) @ u, cubic.deriv(k)(x), rtol=1e-10, atol=1e-10)
        assert np.array_equal(ops.sampling(x, k), ops.interpolation(x, k).toarray())  # the dense form, entry for entry


def test_mesh_has_nodes_on_jumps_and_grading():
    nodes = body_nodes(L, 16, jumps=(-3.0, 2.5, 9.0), grading=4.0)
    assert -3.0 in nodes and 2.5 in nodes
    assert np.all(np.diff(nodes) > 0.0)
    sizes = np.diff(graded_nodes(L, 20, grading=4.0))
    assert sizes.max() / sizes.min() == pytest.approx(4.0, rel=1e-12)
    assert sizes[0] == pytest.approx(sizes[-1], rel=1e-12)
    with pytest.raises(ValueError, match="at least one element"):
        graded_nodes(L, 0)
    with pytest.raises(ValueError, match="grading"):
        graded_nodes(L, 4, grading=0.5)


def test_banded_cholesky_solves_and_rejects_singular():
    ops = body("rod", n=40)
    matrix = (ops.mass + 1e-4 * ops.stiffness).tocsr()
    rhs = np.random.default_rng(1).standard_normal(ops.ndof)
    x = BandedCholesky(matrix).solve(rhs)
    assert np.allclose(matrix @ x, rhs, rtol=1e-10, atol=1e-10 * np.abs(rhs).max())
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        BandedCholesky(-ops.mass)
