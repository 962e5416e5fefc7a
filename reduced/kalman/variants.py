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
passes one to one into the force. A line: the envelope per coupler over the same models, the mass
tolerance a common scale of every car's mass (each car's own mass corner is not taken).
"""

from __future__ import annotations

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
            corners.append(CoupledCars(*cars, model.sensor_filter) if isinstance(model, CoupledCars) else ConsistCars(cars, model.sensor_filter))
    return corners


def estimate_forces_with_variants(
    models: Sequence[CoupledCars | ConsistCars],
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    *,
    variant_force_rate: str = "own",
    mass_tolerance: float = 0.0,
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
    return tuple(_envelope((nominal[c], *(v[c] for v in variants)), mass_tolerance) for c in range(len(nominal)))


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
    "corner_models",
    "estimate_force_with_variants",
    "estimate_forces_with_variants",
]
