"""One-dimensional meshes of a body ``x ∈ [−l, l]`` with nodes on every profile jump."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def graded_nodes(half_length: float, elements: int, grading: float = 1.0) -> NDArray[np.float64]:
    """Nodes of ``elements`` elements on ``[−l, l]``, graded toward both ends.

    ``grading`` is the ratio of the largest to the smallest element (1 = uniform).
    Element sizes grow geometrically from each end to the centre, symmetric about x = 0.
    """
    if elements < 1:
        raise ValueError(f"a mesh needs at least one element, got {elements}")
    if grading < 1.0:
        raise ValueError(f"grading is the ratio largest/smallest element and must be >= 1, got {grading}")
    if grading == 1.0 or elements < 3:
        return np.linspace(-half_length, half_length, elements + 1)
    half = elements / 2.0
    k = np.arange(elements)
    # distance (in elements) of each element from the nearer end; sizes grow by q per element
    from_end = np.minimum(k, elements - 1 - k)
    q = grading ** (1.0 / max(np.ceil(half) - 1.0, 1.0))
    sizes = q**from_end
    nodes = np.concatenate(([0.0], np.cumsum(sizes)))
    return -half_length + 2.0 * half_length * nodes / nodes[-1]


def body_nodes(
    half_length: float,
    elements: int,
    jumps: tuple[float, ...] | list[float] = (),
    grading: float = 1.0,
) -> NDArray[np.float64]:
    """Graded nodes with every jump of the profiles inserted as a node.

    A base node closer than a third of its neighbouring element to a jump is moved onto
    the jump rather than kept beside it, so no sliver elements appear; the element count
    may grow by the number of jumps.
    """
    nodes = graded_nodes(half_length, elements, grading)
    inner = sorted({float(j) for j in jumps if -half_length < j < half_length})
    for jump in inner:
        i = int(np.argmin(np.abs(nodes - jump)))
        interior = 0 < i < nodes.size - 1
        size = min(nodes[i] - nodes[i - 1], nodes[i + 1] - nodes[i]) if interior else 0.0
        if interior and abs(nodes[i] - jump) < size / 3.0 and nodes[i] not in inner:
            nodes[i] = jump
        elif not np.any(np.abs(nodes - jump) <= 1e-12 * half_length):
            nodes = np.sort(np.append(nodes, jump))
    return nodes
