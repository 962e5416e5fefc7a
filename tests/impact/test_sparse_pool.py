"""The pool's sparse matrices (a state-space car's step, :data:`femref.impact.kernels.packing.SPARSE_FIELDS`) against
the dense products they replace: the same sums but their zero terms, so the same values bit for bit."""

from __future__ import annotations

import numpy as np

from femref.impact.kernels.pool import (
    compress_rows, dense_of, matvec, quadratic, sparse_matvec, sparse_quadratic, sparse_row, sparse_size,
)


def sparse_matrix(rows: int, cols: int, seed: int) -> np.ndarray:
    """A random matrix with about a fifth of its entries nonzero, an empty row and an empty column."""
    rng = np.random.default_rng(seed)
    matrix = rng.standard_normal((rows, cols)) * (rng.random((rows, cols)) < 0.2)
    matrix[0, 0] = 1.5  # one entry at least
    matrix[rows // 2, :] = 0.0
    matrix[:, cols - 1] = 0.0
    return matrix


def compressed(matrix: np.ndarray) -> np.ndarray:
    """The field of ``matrix`` as factorise leaves it: packed dense at the field's end, compressed in place."""
    rows, cols = matrix.shape
    field = np.full(sparse_size(rows, cols), -7.0)  # what is there before must not matter
    field[field.size - matrix.size:] = matrix.ravel()
    compress_rows(field, 0, rows, cols)
    return field


def test_compressed_rows_hold_each_row_in_column_order_and_read_back():
    """``[starts, columns, values]``: 3 rows with entries at (0, 1), (0, 3), (2, 0) give starts 0 2 2 3, columns
    1 3 0, values 2 −1 4; a full matrix (the field's worst case) and an empty one read back too."""
    matrix = np.array([[0.0, 2.0, 0.0, -1.0], [0.0, 0.0, 0.0, 0.0], [4.0, 0.0, 0.0, 0.0]])
    field = compressed(matrix)
    np.testing.assert_array_equal(field[:10], [0, 2, 2, 3, 1, 3, 0, 2.0, -1.0, 4.0])
    np.testing.assert_array_equal(dense_of(field, 3, 4), matrix)
    full = np.arange(1.0, 13.0).reshape(3, 4)
    np.testing.assert_array_equal(dense_of(compressed(full), 3, 4), full)
    np.testing.assert_array_equal(dense_of(compressed(np.zeros((2, 4))), 2, 4), np.zeros((2, 4)))


def test_sparse_products_equal_the_dense_ones_bit_for_bit():
    """``A x``, row i of ``A x`` (also with a stride: a column of a row-major matrix) and ``xᵀ A x`` over the stored
    entries equal the dense loops' results exactly, on random 16 × 16 and 3 × 16 matrices."""
    rng = np.random.default_rng(7)
    for seed, (rows, cols) in enumerate([(16, 16), (3, 16)]):
        matrix = sparse_matrix(rows, cols, seed)
        x = rng.standard_normal(cols)
        stored = compressed(matrix)
        w = np.concatenate([matrix.ravel(), stored, x, np.zeros(rows), np.zeros(rows)])
        dense_at, sparse_at, x_at = 0, matrix.size, matrix.size + stored.size
        out_dense, out_sparse = x_at + cols, x_at + cols + rows
        matvec(w, dense_at, rows, cols, x_at, out_dense)
        sparse_matvec(w, sparse_at, rows, x_at, out_sparse)
        assert np.array_equal(w[out_sparse: out_sparse + rows], w[out_dense: out_dense + rows])
        np.testing.assert_allclose(w[out_sparse: out_sparse + rows], matrix @ x, rtol=1e-13, atol=1e-13)
        for i in range(rows):
            assert sparse_row(w, sparse_at, rows, i, x_at) == w[out_dense + i]
        if rows == cols:
            assert sparse_quadratic(w, sparse_at, rows, x_at) == quadratic(w, dense_at, rows, x_at)
    columns = rng.standard_normal((16, 2))  # row i of E times column j of a row-major 16 × 2 B: stride 2
    matrix = sparse_matrix(3, 16, 5)
    w = np.concatenate([compressed(matrix), columns.ravel()])
    for j in range(2):
        for i in range(3):
            expected = 0.0
            for k in range(16):
                expected += matrix[i, k] * columns[k, j]
            assert sparse_row(w, 0, 3, i, w.size - columns.size + j, 2) == expected
