"""The energy balance of a simulated system: the work done on it equals the change of what it holds plus what
it dissipated — one definition for every model run (impact lines and single bodies)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def energy_balance_error(energy: ArrayLike, work: ArrayLike | None = None) -> float:
    """``max_t |E(t) − E(0) − W(t)| / max_t max(|E(t)|, |W(t)|)``: the work done on a system equals the change
    of the energy it holds (kinetic, strain, stored) plus the energy it has dissipated.

    ``energy`` is ``E(t)``, the sum of the system's accounts at the output times (J); ``work`` is
    ``W(t)``, the work done on it from outside since ``t = 0`` (J; None: a closed system, ``W = 0``).
    NaN samples (after a failed step) are left out; 0 when both vanish (nothing moves). The one
    definition of an energy balance, an impact run's and a single body's alike.
    """
    e = np.asarray(energy, dtype=float)
    w = None if work is None else np.asarray(work, dtype=float)
    if e.ndim != 1 or (w is not None and e.shape != w.shape):
        raise ValueError(f"energy and work must be 1-D histories of one length, got shapes {e.shape} and {e.shape if w is None else w.shape}")
    known = np.isfinite(e) if w is None else np.isfinite(e) & np.isfinite(w)
    if known.all():  # (a run that reached its end: no NaN to leave out; a closed system's W = 0 adds nothing)
        e0 = e[0]
    elif not known.any():
        return 0.0
    else:
        e0 = e[0] if np.isfinite(e[0]) else 0.0
        e, w = e[known], None if w is None else w[known]
    scale = float(np.abs(e).max()) if w is None else float(max(np.abs(e).max(), np.abs(w).max()))
    if scale <= 0.0:
        return 0.0
    return float(np.abs(e - e0 if w is None else e - e0 - w).max() / scale)


__all__ = ["energy_balance_error"]
