"""Train / validation / test splits by sample.

A sample is one whole simulation or measured event; its records never straddle
two subsets (splitting the time steps of one run would leak the answer).
"""

from __future__ import annotations

import numpy as np


def split_indices(
    n: int, fractions: tuple[float, float, float] = (0.7, 0.15, 0.15), seed: int | None = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Disjoint, sorted index arrays ``(train, validation, test)`` covering ``range(n)``.

    Validation and test sizes are ``round(n * fraction)``; train takes the rest.
    The same ``n``, ``fractions`` and ``seed`` always give the same split
    (a seeded ``numpy.random.default_rng`` permutation, no global RNG state).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    fractions = tuple(float(f) for f in fractions)
    if len(fractions) != 3 or any(f < 0 for f in fractions) or not np.isclose(sum(fractions), 1.0):
        raise ValueError(f"fractions must be three non-negative numbers summing to 1, got {fractions!r}")
    n_validation = int(round(n * fractions[1]))
    n_test = int(round(n * fractions[2]))
    n_train = n - n_validation - n_test
    if n_train < (1 if fractions[0] > 0 else 0):
        raise ValueError(f"n = {n} is too small to split with fractions {fractions}")
    order = np.random.default_rng(seed).permutation(int(n))
    train = np.sort(order[:n_train])
    validation = np.sort(order[n_train : n_train + n_validation])
    test = np.sort(order[n_train + n_validation :])
    return train, validation, test
