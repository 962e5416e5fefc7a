"""Exact transient response of a piecewise-constant Voigt rod to end-force histories.

From rest (``u = u_t = 0`` at ``t = 0``), with loads ``F(−l, t) = F1(t)``, ``F(l, t) = F2(t)``
that start at ``t ≥ 0``, the Laplace transform of the solution is the rod's transfer
function (``femref.exact.rod``, ``s`` in place of ``−iω``, stiffness ``EA + s cA``) times
the loads' transforms::

    a(x, s) = H_a1(x, s) F1(s) + H_a2(x, s) F2(s),   F(x, s) = H_F1 F1(s) + H_F2 F2(s),   u = a/s²

and the time histories come from the numerical inverse transform of de Hoog, Knight &
Stokes (``femref.exact.laplace``).

Accuracy (tests/exact/test_transient.py, against modal superposition and ``∫ m a dx = F2 − F1``):

* viscous rods: acceleration and force errors 1e-10 … 1e-7 of their peak over a few pulse lengths;
* elastic rods (``β = 0``): the accelerations jump at every wave front and the inversion rings
  there; forces and displacements stay good. Add viscosity, or compare away from the fronts,
  when pointwise elastic accelerations matter;
* loads are split at their corners (:func:`delayed_parts`); a ``Tabulated`` record of more than
  :data:`MAX_TABULATED_CORNERS` samples is inverted whole, its corners resolved only to ``≈ T/M``;
* at ``t = 0`` the fields are the initial state (zero): a load that jumps at ``t = 0``
  (``Constant``) acts from ``t = 0⁺``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from femref.exact.laplace import Transform, invert_laplace
from femref.exact.rod import rod_unit_response
from femref.exact.segments import Segments, check_positions
from femref.core.signals import Constant, HalfSine, RampStep, Signal, Tabulated


@dataclass(frozen=True, eq=False)
class RodTransient:
    """Time histories ``(Nt, Nx)`` of a rod from rest: ``displacement`` u (m),
    ``acceleration`` u_tt (m/s²), ``axial_force`` F = EA u_x + cA u_xt (N, tension positive)."""

    time: NDArray[np.float64]
    x: NDArray[np.float64]
    displacement: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    axial_force: NDArray[np.float64]


def rod_transient(
    segments: Segments,
    t: ArrayLike,
    x: ArrayLike,
    F1: Signal | None,
    F2: Signal | None,
    *,
    terms: int | None = None,
) -> RodTransient:
    """Response of a free-free Voigt rod, at rest at ``t = 0``, to end forces ``F1(t)`` at ``−l``
    and ``F2(t)`` at ``+l`` (N, internal force, tension positive; ``None`` = no load).

    ``t`` (s, ``(Nt,)``, ``≥ 0``), ``x`` (m, ``(Nx,)`` in ``[−l, l]``). ``terms`` is the
    de Hoog order ``M`` (``2M + 1`` transform values per time window); by default
    :func:`default_terms` of each window.

    Each load is split into delayed parts ``F(s) = Σ_j w_j e^{−s t_j} G(s)`` at the times
    where it is not smooth (:func:`delayed_parts`: a half-sine's start and end, a ramp's
    corners); the response to ``G`` is inverted once and summed at ``t − t_j``, so every
    kink sits at the origin of its own inversion, where the geometric time windows resolve it.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or not np.all(np.isfinite(t)) or np.any(t < 0.0):
        raise ValueError("times t must be a 1-D array of finite values >= 0 s")
    if terms is not None and terms < 2:
        raise ValueError(f"terms must be >= 2, got {terms}")
    x = check_positions(segments, x)
    order = terms if terms is not None else (lambda window_end: default_terms(segments, window_end))
    fields = np.zeros((t.size, 3, x.size))
    for signal, side in ((F1, "left"), (F2, "right")):
        if signal is None:
            continue
        for base, shifts in delayed_parts(signal):
            if any(delay < 0.0 for delay, _ in shifts):
                raise ValueError(f"load {'F1' if side == 'left' else 'F2'} must start at t >= 0 (the rod is at rest at t = 0)")
            fields += _shifted_response(segments, x, side, base, shifts, t, order)
    u, a, F = np.moveaxis(fields, 1, 0)
    return RodTransient(t, x, u, a, F)


#: Bounds and factor of the automatic de Hoog order ``M = c √(t/τ)``.
MIN_TERMS, MAX_TERMS, TERMS_FACTOR = 32, 192, 1.7


def default_terms(segments: Segments, window_end: float) -> int:
    """de Hoog order for a window ending at ``window_end`` (s): ``M = 1.7 √(t/τ)`` in ``[32, 192]``,
    ``τ = min cA/EA`` the shortest viscous time of the rod.

    Wave fronts of a Voigt rod spread over ``≈ √(τ t)``; a window of length ``t`` then holds
    ``≈ √(t/τ)`` features to resolve. The factor 1.7 was fitted on the homogeneous rod
    (errors ≲ 1e-5 of the peak for β = 0.01 … 0.05 up to 60 travel times).
    """
    tau = float(np.min(segments.viscosity / segments.stiffness))
    if tau <= 0.0:
        return MAX_TERMS
    return int(np.clip(np.ceil(TERMS_FACTOR * np.sqrt(window_end / tau)), MIN_TERMS, MAX_TERMS))


def delayed_parts(signal: Signal) -> list[tuple[Transform, list[tuple[float, float]]]]:
    """``signal.laplace(s) = Σ_parts Σ_(t_j, w_j) w_j e^{−s t_j} G(s)`` as ``[(G, [(t_j, w_j), …]), …]``.

    Known signal types are split at their corners (:data:`DELAYED_PARTS`); any other signal
    is one part ``(signal.laplace, [(0, 1)])``.
    """
    split = DELAYED_PARTS.get(type(signal))
    return split(signal) if split is not None else [(signal.laplace, [(0.0, 1.0)])]


def _half_sine_parts(f: HalfSine) -> list[tuple[Transform, list[tuple[float, float]]]]:
    # A sin(Ω(t − t0)) H(t − t0) + A sin(Ω(t − t0 − T)) H(t − t0 − T),  Ω = π/T
    w = np.pi / f.duration
    return [(lambda s: f.amplitude * w / (s * s + w * w), [(f.start, 1.0), (f.start + f.duration, 1.0)])]


def _ramp_step_parts(f: RampStep) -> list[tuple[Transform, list[tuple[float, float]]]]:
    if f.rise == 0.0:
        return [(lambda s: f.amplitude / s, [(f.start, 1.0)])]
    return [(lambda s: f.amplitude / (f.rise * s * s), [(f.start, 1.0), (f.start + f.rise, -1.0)])]


def _constant_parts(f: Constant) -> list[tuple[Transform, list[tuple[float, float]]]]:
    return [(lambda s: f.value / s, [(0.0, 1.0)])]


def _tabulated_parts(f: Tabulated) -> list[tuple[Transform, list[tuple[float, float]]]]:
    # Σ_j [jump_j H(t − t_j) + Δslope_j (t − t_j) H(t − t_j)]; long records keep their
    # own transform (one inversion; the kinks are then resolved only to the window's T/M)
    if f.times.size > MAX_TABULATED_CORNERS:
        return [(f.laplace, [(min(0.0, float(f.times[0])), 1.0)])]
    slopes = np.diff(f.values) / np.diff(f.times)
    kinks = np.diff(np.concatenate([[0.0], slopes, [0.0]]))
    jumps = [(float(f.times[0]), float(f.values[0])), (float(f.times[-1]), -float(f.values[-1]))]
    ramps = [(float(tj), float(k)) for tj, k in zip(f.times, kinks) if k != 0.0]
    steps = [(tj, v) for tj, v in jumps if v != 0.0]
    parts: list[tuple[Transform, list[tuple[float, float]]]] = []
    if steps:
        parts.append((lambda s: 1.0 / s, steps))
    if ramps:
        parts.append((lambda s: 1.0 / (s * s), ramps))
    return parts


#: Tabulated records with more samples than this are inverted whole.
MAX_TABULATED_CORNERS = 64

#: Signal type → its split into delayed smooth parts.
DELAYED_PARTS: dict[type, Callable[[Signal], list[tuple[Transform, list[tuple[float, float]]]]]] = {
    HalfSine: _half_sine_parts,
    RampStep: _ramp_step_parts,
    Constant: _constant_parts,
    Tabulated: _tabulated_parts,
}


def _shifted_response(
    segments: Segments,
    x: NDArray,
    side: str,
    base: Transform,
    shifts: list[tuple[float, float]],
    t: NDArray,
    terms: int | Callable[[float], int],
) -> NDArray:
    """``Σ_j w_j r(t − t_j)`` with ``r`` the inverse of ``H_side(x, s) G(s)``; ``(Nt, 3, Nx)`` for (u, a, F)."""

    def transform(s: NDArray[np.complex128]) -> NDArray[np.complex128]:
        r = rod_unit_response(segments, s, x)
        load = np.asarray(base(s), dtype=complex)[:, None]
        acc = getattr(r, f"acceleration_{side}") * load
        force = getattr(r, f"force_{side}") * load
        return np.stack([acc / (s * s)[:, None], acc, force], axis=1)

    local = [(t - delay, weight, t > delay) for delay, weight in shifts]
    tau = np.concatenate([lt[after] for lt, _, after in local])
    out = np.zeros((t.size, 3, x.size))
    if tau.size == 0:
        return out
    values = invert_laplace(transform, tau, terms=terms)
    start = 0
    for _, weight, after in local:
        n = int(np.count_nonzero(after))
        out[after] += weight * values[start : start + n]
        start += n
    return out
