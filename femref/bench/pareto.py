"""The Pareto front of a speed–accuracy trade: configurations no other beats on both cost and error.

Rule (weak dominance, both quantities to be minimised): configuration ``j`` *dominates*
``i`` when

    t_j ≤ t_i  and  e_j ≤ e_i,  with at least one of the two strict,

and ``i`` is *Pareto-optimal* when no configuration dominates it. So of two
configurations with the same time the more accurate one wins (the other is not
optimal), and exact duplicates dominate neither each other: both are optimal. A
configuration whose time or error is NaN (failed, or not scored) is never optimal and
dominates nothing — an unknown error is no claim to be on the front. Infinite values
take part like any other number.

A pure function of two arrays, O(n log n): sort by (time, error) and sweep, keeping the
best error seen so far among strictly faster points.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["pareto_mask"]


def pareto_mask(times: ArrayLike, errors: ArrayLike) -> NDArray[np.bool_]:
    """``mask[i]`` True when configuration ``i`` is Pareto-optimal (module docstring).

    ``times`` and ``errors`` are 1-D of one length (any positive or zero scale; units do
    not matter). Raises ValueError when they are not.
    """
    t = np.asarray(times, dtype=float)
    e = np.asarray(errors, dtype=float)
    if t.ndim != 1 or e.shape != t.shape:
        raise ValueError(f"times and errors must be 1-D arrays of one length, got shapes {t.shape} and {e.shape}")
    mask = np.zeros(t.size, dtype=bool)
    known = np.flatnonzero(~(np.isnan(t) | np.isnan(e)))
    if known.size == 0:
        return mask
    order = known[np.lexsort((e[known], t[known]))]  # by time, then error
    best_faster = np.inf  # least error among points strictly faster than the current time group
    start = 0
    while start < order.size:
        stop = start
        while stop < order.size and t[order[stop]] == t[order[start]]:
            stop += 1
        group = order[start:stop]  # one time, errors ascending
        least = e[group[0]]
        # in the group only the least error survives (ties with it included); it must beat every faster point
        mask[group] = (e[group] == least) & (least < best_faster)
        best_faster = min(best_faster, least)
        start = stop
    return mask
