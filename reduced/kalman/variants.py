"""The nominal estimate with its band widened to the envelope over perturbed models
(:func:`estimate_force_with_variants`, for a line :func:`estimate_forces_with_variants`,
:class:`VariantForceEstimate`).

Model uncertainty (:func:`estimate_force_with_variants`): the caller builds perturbed
models (e.g. :func:`corner_models`: modal frequencies ±15 %, damping ×0.6–1.6); each is
estimated with its own ``q_P`` (or at the nominal's, ``variant_force_rate="nominal"``, as a
measured case's kalman estimator does) and — by default — its own noise scale, and the band is the
union (envelope) of their 95 % bands, widened by a mass tolerance if given. The noise scale is
needed: with the declared noise every wrong model biases the peak *up* (:mod:`.estimate`), so
the corners would not bracket a truth inside the box. Not ``mean ± 1.96 √(std² + spread²)``:
the variants are extremes chosen by the caller, not draws from a known distribution; the
envelope claims only what it shows. A heuristic: the estimate is not monotone in the
parameters. No likelihood weighting either: with thousands of samples it picks one variant
with near certainty even when none is right. The mass the data cannot discriminate: scaling
every mass and the force by one factor leaves all accelerations unchanged, so a mass error
passes one to one into the force. A line: the envelope per coupler over the same models; the mass
tolerance both a common scale of every car's mass (exact, as above) and, with ``car_mass_corners``, each
car's own mass (:func:`car_mass_models`: car ``i``'s ``M, C, K`` × ``(1 ± m_i)``, its frequencies kept; ``m_i``
that car's own tolerance where the cars' masses were measured to different ones), the corners of the box
``Π_i [1 − m_i, 1 + m_i]`` taken to first order: the estimate is linear in each car's
perturbation around the nominal, ``P(s) ≈ P + Σ_i δ_i(s_i)``, so its extremes over the box are
``P + Σ_i max(0, δ_i⁺, δ_i⁻)`` and ``P + Σ_i min(0, δ_i⁺, δ_i⁻)`` — 2N runs for 2^N corners. With every ``δ_i``
of one sign the sum is the common scale's ``m P``; in a line it is not (a coupler read through a car between
two forces, ``P_2 = P_1 − M_1 a_1``, moves against the others' masses).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .cars import CarDynamics, ConsistCars, CoupledCars
from .estimate import KalmanForce, estimate_forces

FloatArray = NDArray[np.float64]

VARIANT_FORCE_RATES: tuple[str, ...] = ("own", "nominal")


@dataclass(frozen=True, eq=False)
class VariantForceEstimate:
    """The nominal estimate with its band widened to cover perturbed models (module docstring).

    ``estimates[0]`` is the nominal model's :class:`KalmanForce`, the others the
    variants'. ``force`` and ``peak_force``/``peak_time`` are the nominal's; ``lower``/``upper``
    the envelope of all 95 % bands; ``peak_lower``/``peak_upper`` the envelope of all peak
    bands. ``status`` is the nominal's; ``variant_status`` every model's.
    """

    time: FloatArray
    force: FloatArray
    lower: FloatArray
    upper: FloatArray
    peak_force: float
    peak_time: float
    peak_lower: float
    peak_upper: float
    status: str
    variant_status: tuple[str, ...]
    estimates: tuple[KalmanForce, ...] = field(repr=False)

    @property
    def nominal(self) -> KalmanForce:
        return self.estimates[0]


def corner_models(model: CoupledCars | ConsistCars, frequency_tolerance: float,
                  damping_factors: Sequence[float]) -> list[CoupledCars | ConsistCars]:
    """The corners of the declared cars' tolerances: mode frequencies × ``(1 ± frequency_tolerance)`` (``K → f² K``)
    and viscosity × each of ``damping_factors`` (``C → d C``), each pair once, every car of the model alike."""
    corners: list[CoupledCars | ConsistCars] = []
    for frequency in {1.0 - frequency_tolerance, 1.0 + frequency_tolerance}:
        for damping in set(damping_factors):
            cars = tuple(CarDynamics(c.mass, damping * c.damping, frequency**2 * c.stiffness, c.load_map, c.sensor_map, c.coupler_load)
                         for c in model.cars)
            corners.append(model.with_cars(cars))
    return corners


def estimate_forces_with_variants(
    models: Sequence[CoupledCars | ConsistCars],
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    *,
    variant_force_rate: str = "own",
    mass_tolerance: float = 0.0,
    car_mass_corners: bool | Sequence[float] = False,
    **options: object,
) -> tuple[VariantForceEstimate, ...]:
    """:func:`.estimate_forces` on each model (``models[0]`` nominal, all over the same couplers); per coupler,
    band = envelope of the bands.

    ``options`` are passed to :func:`.estimate_forces`; each model gets, unless ``noise_scale`` is given, its own
    noise scale (``noise_scale="estimated"``: a variant is by construction not the true model, and its misfit must
    show as noise, not as force — module docstring). ``variant_force_rate``: ``"own"`` — each model its own ``q_P``;
    ``"nominal"`` — every variant at the nominal's rate per unit of the declared noise variance (``q_P/λ̂``), and no
    variant of a nominal whose status is not ok. ``mass_tolerance`` ``m``: scaling every mass by ``s`` scales the
    forces the accelerations imply by exactly ``s``, so each envelope widens to ``[lower (1 ∓ m), upper (1 ± m)]``.
    ``car_mass_corners``: also each car's own mass corners (:func:`car_mass_models`, at the nominal's rate level per
    unit of the declared noise variance, module docstring), the band the envelope of both widenings; True: every
    car ± ``mass_tolerance``, a sequence: car ``i`` ± its own ``car_mass_corners[i]`` (a car at 0 needs no run); no
    mass corner of a nominal whose status is not ok.
    """
    if len(models) < 1:
        raise ValueError("models must hold at least the nominal model")
    if variant_force_rate not in VARIANT_FORCE_RATES:
        raise ValueError(f"variant_force_rate must be one of {', '.join(VARIANT_FORCE_RATES)}, got {variant_force_rate!r}")
    if len({m.couplers for m in models}) != 1:
        raise ValueError(f"models: every model over the same couplers, got {[m.couplers for m in models]}")
    options = {"noise_scale": "estimated", **options}
    nominal = estimate_forces(models[0], time, accelerations, noise_std, **options)  # type: ignore[arg-type]
    if variant_force_rate == "nominal":
        level = nominal[0].force_rate / nominal[0].noise_scale**2
        variants = [] if nominal[0].status != "ok" else [
            estimate_forces(mdl, time, accelerations, noise_std, **{**options, "force_rate": level})  # type: ignore[arg-type]
            for mdl in models[1:]]
    else:
        variants = [estimate_forces(mdl, time, accelerations, noise_std, **options) for mdl in models[1:]]  # type: ignore[arg-type]
    banded = [_envelope((nominal[c], *(v[c] for v in variants)), mass_tolerance) for c in range(len(nominal))]
    if car_mass_corners is False:
        return tuple(banded)
    tolerances = [mass_tolerance] * len(models[0].cars) if car_mass_corners is True else list(car_mass_corners)
    if len(tolerances) != len(models[0].cars):
        raise ValueError(f"car_mass_corners: one tolerance per car of the model ({len(models[0].cars)}), got {len(tolerances)}")
    if not any(tolerances) or nominal[0].status != "ok":
        return tuple(banded)
    level = nominal[0].force_rate / nominal[0].noise_scale**2
    corners = [[estimate_forces(mdl, time, accelerations, noise_std, **{**options, "force_rate": level})  # type: ignore[arg-type]
                for mdl in pair] for pair, m in zip(car_mass_models(models[0], tolerances), tolerances) if m > 0.0]
    return tuple(_with_car_masses(band, [[pair[0][c], pair[1][c]] for pair in corners]) for c, band in enumerate(banded))


def car_mass_models(model: CoupledCars | ConsistCars, mass_tolerance: float | Sequence[float]) -> list[tuple[CoupledCars | ConsistCars, ...]]:
    """Per car ``i``, the model with that car's ``M, C, K`` × ``1 − m_i`` and × ``1 + m_i`` (``m_i = mass_tolerance``,
    or its ``i``-th entry; its mode frequencies and damping ratios kept, the other cars as declared)."""
    tolerances = [mass_tolerance] * len(model.cars) if isinstance(mass_tolerance, (int, float)) else list(mass_tolerance)
    pairs = []
    for i, m in enumerate(tolerances):
        pair = []
        for s in (1.0 - m, 1.0 + m):
            cars = tuple(CarDynamics(s * c.mass, s * c.damping, s * c.stiffness, c.load_map, c.sensor_map, c.coupler_load) if j == i else c
                         for j, c in enumerate(model.cars))
            pair.append(model.with_cars(cars))
        pairs.append(tuple(pair))
    return pairs


def _with_car_masses(band: VariantForceEstimate, corners: list[list[KalmanForce]]) -> VariantForceEstimate:
    """``band`` widened to the first-order extremes over every car's mass corners (module docstring): the nominal's
    band moved by ``Σ_i max(0, δ_i⁺, δ_i⁻)`` up and ``Σ_i min(0, δ_i⁺, δ_i⁻)`` down, enveloped with ``band``."""
    nominal = band.nominal
    shifts = np.array([[e.force - nominal.force for e in pair] for pair in corners])  # (cars, 2, N)
    up = np.sum(np.maximum(shifts.max(axis=1), 0.0), axis=0)
    down = np.sum(np.minimum(shifts.min(axis=1), 0.0), axis=0)
    k = int(np.argmax(nominal.force))
    return dataclasses.replace(
        band,
        lower=np.minimum(band.lower, nominal.lower + down),
        upper=np.maximum(band.upper, nominal.upper + up),
        peak_lower=min(band.peak_lower, nominal.peak_lower + float(down[k])),
        peak_upper=max(band.peak_upper, nominal.peak_upper + float(up[k])),
        variant_status=(*band.variant_status, *(e.status for pair in corners for e in pair)),
    )


def estimate_force_with_variants(
    models: Sequence[CoupledCars | ConsistCars],
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    *,
    variant_force_rate: str = "own",
    mass_tolerance: float = 0.0,
    **options: object,
) -> VariantForceEstimate:
    """The one coupler force of two cars with its band over the models (:func:`estimate_forces_with_variants`)."""
    if len(models) >= 1 and models[0].couplers != 1:
        raise ValueError(f"models: estimate_force_with_variants estimates one coupler force, the model has {models[0].couplers}")
    return estimate_forces_with_variants(models, time, accelerations, noise_std, variant_force_rate=variant_force_rate,
                                         mass_tolerance=mass_tolerance, **options)[0]


def _envelope(estimates: tuple[KalmanForce, ...], mass_tolerance: float) -> VariantForceEstimate:
    """The nominal (``estimates[0]``) with the envelope of every estimate's bands, widened by the mass tolerance."""
    nominal = estimates[0]
    low, high = 1.0 - mass_tolerance, 1.0 + mass_tolerance
    lower, upper = np.min([e.lower for e in estimates], axis=0), np.max([e.upper for e in estimates], axis=0)
    peak_lower, peak_upper = min(e.peak_lower for e in estimates), max(e.peak_upper for e in estimates)
    return VariantForceEstimate(
        time=nominal.time,
        force=nominal.force,
        lower=np.minimum(lower * low, lower * high),
        upper=np.maximum(upper * low, upper * high),
        peak_force=nominal.peak_force,
        peak_time=nominal.peak_time,
        peak_lower=min(peak_lower * low, peak_lower * high),
        peak_upper=max(peak_upper * low, peak_upper * high),
        status=nominal.status,
        variant_status=tuple(e.status for e in estimates),
        estimates=estimates,
    )


__all__ = [
    "VariantForceEstimate",
    "car_mass_models",
    "corner_models",
    "estimate_force_with_variants",
    "estimate_forces_with_variants",
]
