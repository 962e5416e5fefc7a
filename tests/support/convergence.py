"""Observed convergence orders: the one helper every convergence test uses.

The order is the slope of ``log|error|`` against ``log x`` by least squares
(``numpy.polyfit``), where ``x`` is what the error should scale with: the element size
``h`` (use ``1/elements``), the step ``dt``, a small parameter ``ε`` or ``λ``. A test
asserts the slope inside a window *and* an absolute bound on its finest level, so a
method that converges at the right rate to the wrong answer still fails.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def observed_order(x: ArrayLike, errors: ArrayLike) -> float:
    """Least-squares slope of ``log|errors|`` against ``log x``."""
    return float(np.polyfit(np.log(np.asarray(x, dtype=float)), np.log(np.abs(np.asarray(errors))), 1)[0])

