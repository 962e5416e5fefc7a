"""The time grid of a run: how many steps reach the end time, and which steps are output.

A run steps ``t_n = n·dt`` for ``n = 0 … N`` with ``N = ⌈end/dt⌉`` (at least one step;
a ratio within 1e-9 of an integer counts as that integer) and records every
``stride``-th step and always the last.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray


def steps_to(end: float, dt: float) -> int:
    """Number of steps of size ``dt`` that reach ``end`` (at least one)."""
    return max(1, int(math.ceil(end / dt - 1e-9)))


def output_steps(steps: int, stride: int) -> NDArray[np.int64]:
    """Steps ``0, stride, 2·stride, …`` and always the last one."""
    indices = np.arange(0, steps + 1, stride)
    return indices if indices[-1] == steps else np.append(indices, steps)
