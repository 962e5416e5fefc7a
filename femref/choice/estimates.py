"""Error estimates of the impact models on one output, without a reference solution.

**Outputs** (:data:`OUTPUTS`): ``peak_coupler_force``, the largest relative error of
the peak compression over the couplers, ``max_c |max P_c − max P_c,ref| / max P_c,ref``;
``coupler_force``, the largest relative rms error of the force histories
(:func:`femref.run.scoring.score_impact`'s ``coupler_force_rms_error_max``);
``vertical_acceleration``, the largest relative rms error of the vertical accelerations of
the sensors on cars that bend (``vertical_acceleration_rms_error_max``; the asymptotic
estimate then uses the bending ε, which the scene's wave travel time carries).
:func:`output_distance` measures either between two runs.

**Refinement (modal, fem).** A run whose error behaves like ``C h^p`` and the run with
``h/r`` differ by ``Δ = C h^p (1 − r^−p)``, so the coarser run's error is
``Δ / (1 − r^−p)`` and the finer's ``Δ / (r^p − 1)`` (Richardson;
:func:`richardson_error`). The estimate assumes ``p = 1`` (:data:`ASSUMED_ORDER`) and
multiplies by :data:`SAFETY`: the peak-force error of fem refined jointly in space and
time falls like ``p ≈ 2`` once converging (median true/Δ 1.33 = 4/3 over 120 random
scenes), but before that it does not (95th percentile of true/Δ 1.7–2.5, worst 20);
modal truncation converges like ``k^−1`` with Voigt viscosity (median 1.3, 95th
percentile 2.5–6).

**Asymptotics (rigid, quasi-rigid).** The quasi-rigid model is the first-order term of
an expansion in ``ε``; the rigid model is the zeroth. Their difference ``d`` is the
first-order term, so the rigid error is ``≈ d`` and the quasi-rigid error is the next
order, ``≈ ε d``. The ``ε`` must be the one of the load the cars actually see:
:func:`load_epsilon` measures ``ε_load = T_wave² max|P̈| / max P`` from the rigid run's
force up to its peak (``= π² ε`` for a half-sine pulse of the nominal contact time). A
coupler force that jumps at contact (a damper) or rises in a few milliseconds (a
draft gear's series springs) has ``ε_load ≫ 1`` however small the nominal ε: the
expansion does not hold and the asymptotic estimate is withheld
(:data:`EPS_LOAD_VALID`). Measured: over 120 random two-car scenes the quasi-rigid
peak error was worse than the rigid one in 27 (at nominal ε down to 2e-4), all but one
with ``ε_load > 1`` — that one, a damped spring at ``ε_load = 0.47``, had a quasi-rigid
error 3× its estimate; on undamped Kelvin-Voigt couplers (``ε_load = 0.01–0.3``) the
estimates, times :data:`SAFETY`, plus the peak's sampling error at the models' step
(:func:`peak_sampling_error`), bound the errors.

**Comparison.** Any run ``i`` is also bounded through a run ``j`` with a smaller
estimate: ``e_i ≤ |P_i − P_j|/|P_j| + e_j`` (:func:`hierarchical_bound`), which prices
the cheap rungs once an accurate run exists, whether or not their own estimate holds.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from femref.run.scoring import score_impact
from femref.results import ModelResult

__all__ = [
    "ASSUMED_ORDER",
    "EPS_LOAD_VALID",
    "OUTPUTS",
    "SAFETY",
    "asymptotic_errors",
    "hierarchical_bound",
    "load_epsilon",
    "output_distance",
    "peak_sampling_error",
    "richardson_error",
]

OUTPUTS: dict[str, str] = {
    "peak_coupler_force": "peak compression of each coupler, relative error, worst coupler",
    "coupler_force": "coupler force history, relative rms error, worst coupler",
    "vertical_acceleration": "vertical acceleration history of the sensors on cars that bend, relative rms error, worst sensor",
}
"""The outputs a tolerance may be set on, and what their error is."""
ASSUMED_ORDER = 1.0
"""Convergence order the Richardson estimates assume (module docstring)."""
SAFETY = 1.5
"""Factor on every Richardson estimate (module docstring)."""
EPS_LOAD_VALID = 0.3
"""Largest ``ε_load`` at which the asymptotic estimates of rigid and quasi-rigid are used."""


def richardson_error(difference: float, order: float = ASSUMED_ORDER, ratio: float = 2.0, finer: bool = False) -> float:
    """Error of one of two runs, resolutions ``h`` and ``h/ratio``, from their difference ``Δ``.

    With errors ``C h^p``: the coarser run's error is ``|Δ| / (1 − r^−p)``, the finer's
    ``|Δ| / (r^p − 1)`` (``finer=True``). Exact for errors that are exactly ``C h^p``.
    """
    if order <= 0.0 or ratio <= 1.0:
        raise ValueError(f"Richardson needs order > 0 and ratio > 1, got order {order}, ratio {ratio}")
    if finer:
        return abs(difference) / (ratio**order - 1.0)
    return abs(difference) / (1.0 - ratio**-order)


def load_epsilon(time: NDArray[np.float64], force: NDArray[np.float64], wave_travel_time: float) -> float:
    """``ε_load = T_wave² max|P̈| / max P`` over ``[0, t_peak]``, the force at rest before contact.

    ``P̈`` is the second difference on the run's (uniform) step, with ``P = 0`` at the two
    steps before ``t = 0`` so a jump at contact counts. A half-sine ``P = P₀ sin(πt/T)``
    gives ``π² (T_wave/T)²``. Returns 0 for a force that never compresses.
    """
    time, force = np.asarray(time, dtype=float), np.asarray(force, dtype=float)
    peak_index = int(np.argmax(force))
    peak = force[peak_index]
    if peak <= 0.0 or time.size < 2:
        return 0.0
    dt = float(time[1] - time[0])
    history = np.concatenate(([0.0, 0.0], force[: peak_index + 2]))
    curvature = np.max(np.abs(np.diff(history, 2))) / dt**2
    return float(wave_travel_time**2 * curvature / peak)


def asymptotic_errors(first_order_term: float, eps_load: float) -> tuple[float, float]:
    """Estimated errors ``(rigid, quasi_rigid)``: ``d (1 + ε_load)`` and ``ε_load d``, ``d = |P_qr − P_rigid|/|P_qr|``.

    The rigid run misses the first-order term and the rest; the quasi-rigid run the
    next order, ``ε_load`` times smaller. Only meaningful for ``ε_load ≤``
    :data:`EPS_LOAD_VALID` (module docstring).
    """
    quasi_rigid = eps_load * first_order_term
    return first_order_term + quasi_rigid, quasi_rigid


def peak_sampling_error(force: NDArray[np.float64]) -> float:
    """Bound on how far the largest sample of a smooth peak lies below the peak: ``|P̈| dt² / (8 P)``, relative.

    Between samples ``dt`` apart a peak of curvature ``P̈`` is missed by at most
    ``|P̈| (dt/2)² / 2``; ``P̈ dt²`` is the second difference at the largest sample. It is
    the time-step error of the peak that the asymptotic estimates leave out: ``1.2e-4``
    for a half-sine at the rigid model's ``dt = T/100`` (the quasi-rigid peak of an
    undamped Kelvin-Voigt impact was measured ``4e-5`` off at ε = 3e-5, all of it step
    error). 0 for a peak at either end of the history or a force that never compresses.
    """
    force = np.asarray(force, dtype=float)
    k = int(np.argmax(force))
    if force[k] <= 0.0 or k == 0 or k == force.size - 1:
        return 0.0
    return float(abs(force[k - 1] - 2.0 * force[k] + force[k + 1]) / (8.0 * force[k]))


def hierarchical_bound(distance: float, other_estimate: float) -> float:
    """``e_i ≤ d(i, j) + e_j``: the triangle inequality through a run ``j`` with estimate ``e_j``."""
    return distance + other_estimate


def output_distance(result: ModelResult, reference: ModelResult, output: str) -> float:
    """Relative difference of ``result`` from ``reference`` on ``output`` (:data:`OUTPUTS`), worst coupler.

    NaN when no coupler of the reference compresses (a relative error of nothing).
    """
    if output == "peak_coupler_force":
        worst = math.nan
        for name, outputs in reference.couplers.items():
            peak_ref = float(np.max(outputs["force"]))
            if peak_ref > 0.0 and name in result.couplers:
                error = abs(float(np.max(result.couplers[name]["force"])) - peak_ref) / peak_ref
                worst = error if math.isnan(worst) else max(worst, error)
        return worst
    if output == "coupler_force":
        return float(score_impact(reference, result).get("coupler_force_rms_error_max", math.nan))
    if output == "vertical_acceleration":
        return float(score_impact(reference, result).get("vertical_acceleration_rms_error_max", math.nan))
    raise ValueError(f"unknown output {output!r}; one of {', '.join(OUTPUTS)}")
