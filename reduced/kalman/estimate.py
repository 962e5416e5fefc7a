"""The public force estimators: :func:`estimate_force` (two cars, one coupler) and
:func:`estimate_forces` (a line, one result per coupler), their result :class:`KalmanForce` — the
force-rate search, the noise scale, the peak and its band, the status.

A line's couplers share one force-rate level ``q_P`` (N²/s, each ``P_c`` a random walk of that
intensity) and one likelihood; each coupler gets its own smoothed force, band and peak.

Force-rate level: the innovation log-likelihood ℓ(q_P) (:mod:`.steady`) is maximised over a log grid
(default 1e8 … 1e18 N²/s, 15 points, one batched pass) and refined by two rounds of a
three-times finer grid around the best point and a parabolic step (the golden-section/
parabolic idea of Brent, batched: four batched passes in all). An optimum on the coarse
grid's edge is flagged (``at_edge``): the estimate is then not trusted. Consistency:
``NIS = (1/(N m)) Σ ν_kᵀ S_k⁻¹ ν_k`` is ≈ 1 when the declared noise and the model are right;
outside ``nis_range`` the status says so.

Noise scale (``noise_scale="estimated"``): all covariances ``R``, ``Q``, ``P_0`` times a common
``λ`` leaves the gains, the innovations and the smoothed mean unchanged and scales every
``S_k`` by ``λ``, so ``ℓ`` is maximised over λ in closed form, ``λ̂ = NIS`` (Harvey 1989, §3.4),
and the likelihood concentrated over it, ``ℓ_c = −½ (N m log λ̂ + Σ log det S̃_k + N m)``,
is maximised over ``q_P/λ`` as above; the smoothed variances are multiplied by ``λ̂``. It
matters under model error: a wrong model leaves vibration it cannot explain, which with the
declared noise the likelihood explains by the force (``q_P`` runs to the top of the range,
the peak is biased up); with the scale estimated the misfit shows as noise instead.

Peak: the maximum of the smoothed mean (compression positive) and the pointwise 95 % band
``mean ± 1.96 std`` at that sample. This ignores the uncertainty of *where* the peak is: a
fair band when the std is small against the force's change around the peak, as for impact
pulses; otherwise slightly optimistic.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks

from .augmented import AugmentedModel, augmented_model, forced_samples
from .cars import ConsistCars, CoupledCars
from .steady import likelihoods, reference_force, smoothed_force, steady_filter

DEFAULT_FORCE_RATE_RANGE: tuple[float, float] = (1.0e8, 1.0e18)  # N²/s
Z95 = 1.959963984540054  # two-sided 95 % normal quantile

FloatArray = NDArray[np.float64]


NOISE_SCALES: tuple[str, ...] = ("declared", "estimated")


@dataclass(frozen=True, eq=False)
class KalmanForce:
    """The smoothed coupler force (N, compression positive) and its diagnostics.

    ``force``/``force_std`` are the smoothed posterior mean and std at each sample,
    ``lower``/``upper`` the pointwise 95 % band ``force ∓ 1.96 force_std``. ``peak_force``
    is the maximum of ``force``, at ``peak_time``; ``peak_lower``/``peak_upper`` the band at
    that sample (module docstring). ``force_rate`` is the chosen ``q_P`` (N²/s),
    ``log_likelihood`` ``ℓ`` there (with its constants; concentrated over the noise scale
    if that was estimated), ``at_edge`` whether the likelihood optimum lies on the searched
    range's edge, ``nis`` the mean normalised innovation squared per channel of the filter
    used (≈ 1 if its noise is right; ≡ 1 when the noise scale is estimated),
    ``noise_scale`` the factor applied to the declared noise std (1 if declared,
    ``√λ̂`` if estimated), ``status`` "ok" or the reasons not to trust the estimate.
    ``force_rate_grid``/``log_likelihood_grid`` are all the force rates tried and their ℓ
    (empty if ``q_P`` was given).
    """

    time: FloatArray
    force: FloatArray
    force_std: FloatArray
    lower: FloatArray
    upper: FloatArray
    peak_force: float
    peak_time: float
    peak_lower: float
    peak_upper: float
    force_rate: float
    log_likelihood: float
    at_edge: bool
    nis: float
    noise_scale: float
    status: str
    force_rate_range: tuple[float, float]
    force_rate_grid: FloatArray = field(repr=False)
    log_likelihood_grid: FloatArray = field(repr=False)


def _search(
    evaluate: Callable[[FloatArray], FloatArray], low: float, high: float, points: int
) -> tuple[float, bool, FloatArray, FloatArray]:
    """Maximise ``evaluate(log10 q)`` (batched): coarse grid, two 3× finer rounds, a parabolic step.

    Returns ``(log10 q*, at_edge, all log10 q tried (sorted), their values)``.
    """
    logs = np.linspace(math.log10(low), math.log10(high), points)
    values = evaluate(logs)
    best = int(np.argmax(values))
    if best in (0, points - 1):
        return float(logs[best]), True, logs, values
    tried = dict(zip(logs.tolist(), values.tolist()))
    centre, spacing = float(logs[best]), float(logs[1] - logs[0])
    for _ in range(2):
        spacing /= 3.0
        new = centre + spacing * np.array([-2.0, -1.0, 1.0, 2.0])
        tried.update(zip(new.tolist(), evaluate(new).tolist()))
        centre = max(tried, key=tried.__getitem__)
    keys = sorted(tried)
    at = keys.index(centre)
    if 0 < at < len(keys) - 1:  # parabola through the best point and its neighbours
        (a, fa), (b, fb), (c, fc) = ((x, tried[x]) for x in keys[at - 1 : at + 2])
        num = (b - a) ** 2 * (fb - fc) - (b - c) ** 2 * (fb - fa)
        den = (b - a) * (fb - fc) - (b - c) * (fb - fa)
        if den != 0.0:
            vertex = b - 0.5 * num / den
            if a < vertex < c and vertex not in tried:
                tried[vertex] = float(evaluate(np.array([vertex]))[0])
    keys = sorted(tried)
    vals = np.array([tried[k] for k in keys])
    return float(keys[int(np.argmax(vals))]), False, np.array(keys), vals


def _status(
    at_edge: bool, variance_ratio: float, estimated: bool, nis_range: tuple[float, float], aug: AugmentedModel, rates: tuple[float, float], q: float
) -> str:
    reasons = []
    if aug.undetectable:
        reasons.append(
            "force not detectable from these accelerations (PBH fails at λ = "
            + ", ".join(f"{lam:.3g}" for lam in aug.undetectable)
            + "): its variance grows without bound; a grounded model needs dummy displacement measurements"
        )
    if at_edge:
        name = "q_P/λ̂" if estimated else "q_P"
        reasons.append(f"likelihood optimum at the edge of the force-rate range [{rates[0]:.3g}, {rates[1]:.3g}] N²/s ({name} = {q:.3g})")
    if not nis_range[0] <= variance_ratio <= nis_range[1]:
        expected = f"expected in [{nis_range[0]:.3g}, {nis_range[1]:.3g}]"
        if estimated:
            reasons.append(
                f"innovations inconsistent with the declared noise: they need its variance ×{variance_ratio:.3g} ({expected}); "
                "model error or a wrong noise level"
            )
        else:
            reasons.append(
                f"innovations inconsistent with the declared noise (NIS = {variance_ratio:.3g}, {expected}); "
                "model error or a wrong noise level (see noise_scale='estimated' and model variants)"
            )
    return "; ".join(reasons) if reasons else "ok"


def estimate_forces(
    model: CoupledCars | ConsistCars,
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    *,
    force_rate: float | None = None,
    force_rate_range: tuple[float, float] = DEFAULT_FORCE_RATE_RANGE,
    grid_points: int = 15,
    initial_force_std: float = 1.0e5,
    noise_scale: str = "declared",
    nis_range: tuple[float, float] = (0.5, 2.0),
) -> tuple[KalmanForce, ...]:
    """Smoothed coupler forces ``P_1(t) … P_{n_c}(t)``, one :class:`KalmanForce` each, from the cars'
    accelerations (equations in :mod:`reduced.kalman` and its modules).

    ``time`` (s, uniform, N samples), ``accelerations`` (m/s², N × channels, car by car in
    the model's order), ``noise_std`` (m/s², scalar or per channel). ``force_rate`` fixes
    ``q_P`` (N²/s); otherwise the innovation likelihood is maximised over ``grid_points``
    log-spaced values in ``force_rate_range`` and refined. Prior: cars undeformed up to the
    stationary filter uncertainty, and initial forces ``~ N(0, initial_force_std²)`` (N, each coupler
    independently) in quasi-static equilibrium. ``noise_scale``: ``"declared"`` trusts ``noise_std``;
    ``"estimated"`` multiplies all covariances by the ML scale ``λ̂`` (the likelihood
    concentrated over it, module docstring) so that model error shows as noise instead
    of driving ``q_P``; ``force_rate``, ``force_rate_range`` and the grid then refer to
    ``q_P/λ̂`` (the rate per unit of the declared noise variance), the reported
    ``force_rate`` is ``q_P``. ``nis_range``: the NIS (or ``λ̂``) accepted as consistent.
    """
    t = _checks.time_grid("time", time, uniform=True)
    y = np.asarray(accelerations, dtype=float)
    y = y.reshape(-1, 1) if y.ndim == 1 else y
    if y.ndim != 2 or y.shape != (t.size, model.channels) or not np.all(np.isfinite(y)):
        raise ValueError(f"accelerations must be finite, N × channels = {(t.size, model.channels)}, got shape {y.shape}")
    lo = _checks.positive("force_rate_range[0]", force_rate_range[0])
    hi = _checks.positive("force_rate_range[1]", force_rate_range[1])
    if not lo < hi:
        raise ValueError(f"force_rate_range must be increasing, got {force_rate_range!r}")
    if int(grid_points) != grid_points or grid_points < 3:
        raise ValueError(f"grid_points must be an integer >= 3, got {grid_points!r}")
    force_std0 = _checks.positive("initial_force_std", initial_force_std)
    estimated = _checks.choice("noise_scale", noise_scale, NOISE_SCALES) == "estimated"
    if not 0.0 < nis_range[0] < nis_range[1]:
        raise ValueError(f"nis_range must satisfy 0 < low < high, got {nis_range!r}")

    aug = augmented_model(model, float(t[1] - t[0]), noise_std)
    yw = y / aug.noise_std[None, :]
    prior = force_std0**2  # N²: U's columns are the scaled states of one newton
    steps, m = y.shape
    count = steps * m
    constant = -0.5 * (count * math.log(2.0 * math.pi) + 2.0 * steps * float(np.sum(np.log(aug.noise_std))))
    detectable = not aug.undetectable

    def objective(ell_w: FloatArray, quad: FloatArray) -> FloatArray:
        """ℓ with constants; concentrated: ``λ̂ = Σ ν S̃⁻¹ ν/(N m)``, ``ℓ = −½ (N m log λ̂ + Σ log det S̃ + N m)``."""
        if not estimated:
            return ell_w + constant
        logdets = -2.0 * ell_w - quad
        return -0.5 * (count * np.log(quad / count) + logdets + count) + constant

    def evaluate(logs: FloatArray) -> FloatArray:
        rates = 10.0**logs
        if detectable:
            return objective(*likelihoods(aug, yw, rates, prior))
        pairs = np.array([reference_force(aug, yw, float(q), prior)[2:] for q in rates])
        return objective(pairs[:, 0], pairs[:, 1])

    grid, grid_ell, at_edge = np.empty(0), np.empty(0), False
    if force_rate is not None:
        q = _checks.positive("force_rate", force_rate)
    else:
        s_best, at_edge, grid_logs, grid_ell = _search(evaluate, lo, hi, int(grid_points))
        q, grid = 10.0**s_best, 10.0**grid_logs
    smoother = smoothed_force if detectable else reference_force
    mean, var, ell_w, quad = smoother(aug, yw, q, prior)
    ratio = quad / count  # NIS against the declared noise, = λ̂ when it is estimated
    scale = ratio if estimated else 1.0
    units = aug.state_unit[aug.force_slice]
    status = _status(at_edge, ratio, estimated, nis_range, aug, (lo, hi), q)
    log_likelihood = float(objective(np.array([ell_w]), np.array([quad]))[0])
    results = []
    for c, unit in enumerate(units):
        force, std = mean[:, c] * unit, np.sqrt(var[:, c] * scale) * unit
        k = int(np.argmax(force))
        results.append(KalmanForce(
            time=t,
            force=force,
            force_std=std,
            lower=force - Z95 * std,
            upper=force + Z95 * std,
            peak_force=float(force[k]),
            peak_time=float(t[k]),
            peak_lower=float(force[k] - Z95 * std[k]),
            peak_upper=float(force[k] + Z95 * std[k]),
            force_rate=float(q * scale),
            log_likelihood=log_likelihood,
            at_edge=bool(at_edge),
            nis=float(ratio / scale),
            noise_scale=float(math.sqrt(scale)),
            status=status,
            force_rate_range=(lo, hi),
            force_rate_grid=grid,
            log_likelihood_grid=grid_ell,
        ))
    return tuple(results)


def smoothed_responses(
    model: CoupledCars | ConsistCars,
    time: ArrayLike,
    forces: Sequence[ArrayLike],
    noise_std: float | ArrayLike,
    force_rate: float,
    *,
    initial_force_std: float = 1.0e5,
) -> list[FloatArray]:
    """For each of ``forces`` (N × n_c, N), the smoothed coupler forces (N × n_c, N) of the model's noise-free samples
    under it: ``estimate_forces(model, time, forced_response(model, time, f), noise_std, force_rate=force_rate)``
    (the declared noise), with one filter model and one stationary filter for all (the smoothed mean is linear in
    the records: the estimator's response to chosen forces)."""
    t = _checks.time_grid("time", time, uniform=True, min_length=2)
    q = _checks.positive("force_rate", force_rate)
    prior = _checks.positive("initial_force_std", initial_force_std) ** 2
    aug = augmented_model(model, float(t[1] - t[0]), noise_std)
    if aug.undetectable:
        def smoother(yw: FloatArray) -> FloatArray:
            return reference_force(aug, yw, q, prior)[0]
    else:
        steady = steady_filter(aug, q)

        def smoother(yw: FloatArray) -> FloatArray:
            return smoothed_force(aug, yw, q, prior, steady)[0]
    units = aug.state_unit[aug.force_slice]
    return [smoother(forced_samples(aug, t, force) / aug.noise_std[None, :]) * units[None, :] for force in forces]


def estimate_force(
    model: CoupledCars | ConsistCars,
    time: ArrayLike,
    accelerations: ArrayLike,
    noise_std: float | ArrayLike,
    *,
    force_rate: float | None = None,
    force_rate_range: tuple[float, float] = DEFAULT_FORCE_RATE_RANGE,
    grid_points: int = 15,
    initial_force_std: float = 1.0e5,
    noise_scale: str = "declared",
    nis_range: tuple[float, float] = (0.5, 2.0),
) -> KalmanForce:
    """The one coupler force ``P(t)`` of two cars, the rear car's channels first (:func:`estimate_forces`)."""
    if model.couplers != 1:
        raise ValueError(f"model: estimate_force estimates one coupler force, the model has {model.couplers} (estimate_forces)")
    return estimate_forces(model, time, accelerations, noise_std, force_rate=force_rate, force_rate_range=force_rate_range,
                           grid_points=grid_points, initial_force_std=initial_force_std, noise_scale=noise_scale,
                           nis_range=nis_range)[0]




__all__ = [
    "DEFAULT_FORCE_RATE_RANGE",
    "NOISE_SCALES",
    "KalmanForce",
    "estimate_force",
    "estimate_forces",
    "smoothed_responses",
]
