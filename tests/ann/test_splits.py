"""Splits by sample: reproducible, disjoint, complete."""

from __future__ import annotations

import numpy as np
import pytest

from ann.splits import split_indices


def test_split_is_disjoint_complete_and_sized():
    train, validation, test = split_indices(100, seed=4)
    assert (len(train), len(validation), len(test)) == (70, 15, 15)
    together = np.concatenate([train, validation, test])
    np.testing.assert_array_equal(np.sort(together), np.arange(100))


def test_split_is_reproducible_and_seed_dependent():
    a, b = split_indices(50, seed=7), split_indices(50, seed=7)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(split_indices(50, seed=8)[0], a[0])


def test_custom_fractions():
    train, validation, test = split_indices(10, fractions=(0.5, 0.0, 0.5), seed=0)
    assert (len(train), len(validation), len(test)) == (5, 0, 5)


@pytest.mark.parametrize(
    ("n", "fractions", "match"),
    [
        (0, (0.7, 0.15, 0.15), "positive integer"),
        (10, (0.7, 0.2, 0.2), "summing to 1"),
        (10, (1.2, -0.1, -0.1), "non-negative"),
        (10, (0.5, 0.5), "three"),
        (2, (0.1, 0.45, 0.45), "too small"),
    ],
)
def test_bad_arguments(n, fractions, match):
    with pytest.raises(ValueError, match=match):
        split_indices(n, fractions=fractions, seed=0)
