"""A channel's noise before the trigger, and a noise gate that allows for the estimate's own sampling error
(docs/formulas.md §K3: the derivation, its measured checks, tests/measured/test_noise_gate.py).

**The estimate** (:func:`quiet_noise`, what a measured run weighs the channels by): over the ``n`` quiet samples
``y_i`` before the trigger, the median absolute deviation scaled to a Gaussian's standard deviation (robust to the
impact's first rise, which a channel near the coupler records before the trigger fires),

    σ̂ = 1.4826 · median_i |y_i − median y|        (m/s²;  1.4826 = 1/z,  z = Φ⁻¹(3/4))

For ``n`` independent Gaussian samples ``G(q̂) ~ Beta((n + 1)/2, (n + 1)/2)`` (``G`` the half-normal CDF of ``|y|``,
``q̂`` the sample median), so

    P(σ̂ > r σ) = 1 − I_{2Φ(r z) − 1}(a, a),   a = (n + 1)/2,    sd(σ̂/σ) ≈ 1.166/√n

**Correlated samples** (noise through the recorder's anti-alias filter): the count used is ``n_eff = n / τ̂``,
``τ̂ = 1 + 2 Σ_{k=1}^{K} ρ̂_k²`` (:func:`correlation_time`).

**The gate** (:func:`noise_limit`): a one-sided test of ``σ ≤ σ_cal`` per channel at level
``α_ch = 1 − (1 − α)^{1/m}`` for ``m`` channels (Šidák: an event at the calibrated noise on every channel is refused
with probability ``α`` = :data:`FALSE_REJECT`), refusing when

    σ̂ > r σ_cal,   r = Φ⁻¹((1 + B⁻¹(1 − α_ch; a, a))/2) / z,   a = (n_eff + 1)/2

(``r = 1.52`` at ``n_eff = 50`` and five channels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

MAD_SCALE = 1.4826
"""``1/Φ⁻¹(3/4)``: the median absolute deviation of a Gaussian is ``σ/1.4826``."""
FALSE_REJECT = 0.01
"""The gate's false-reject rate per event: the probability that an event recorded at exactly the calibrated
noise on every channel is refused."""


@dataclass(frozen=True)
class QuietNoise:
    """A channel's noise std ``std`` (m/s², :func:`quiet_noise`) from ``samples`` quiet samples worth
    ``effective_samples`` independent ones (0 samples: not measured, ``std`` NaN)."""

    std: float
    samples: int
    effective_samples: float

    @property
    def measured(self) -> bool:
        return self.samples > 0

    @property
    def correlation_time(self) -> float:
        """``τ̂ = samples / effective_samples`` (samples, ≥ 1; 1 when not measured): how many samples one independent
        one is worth."""
        return self.samples / self.effective_samples if self.effective_samples > 0.0 else 1.0


def quiet_noise(quiet: NDArray[np.float64]) -> QuietNoise:
    """``σ̂ = 1.4826 median|y − median y|`` of the quiet samples ``y`` (m/s²) with their effective count
    ``n / τ̂`` (module docstring)."""
    y = np.asarray(quiet, dtype=float)
    n = y.size
    if n == 0:
        return QuietNoise(math.nan, 0, 0.0)
    centred = y - float(np.median(y))
    std = MAD_SCALE * float(np.median(np.abs(centred)))
    return QuietNoise(std, n, n / correlation_time(y))


MIN_QUIET_SAMPLES = 10
"""Samples before the trigger needed to measure a channel's offset and noise."""


def quiet_corrected(time: NDArray[np.float64], records: dict[str, NDArray[np.float64]], trigger_time: float
                    ) -> tuple[dict[str, NDArray[np.float64]], dict[str, float], dict[str, QuietNoise]]:
    """Each channel less its median before ``trigger_time`` (its offset: the cars are at rest or rolling freely
    there), its noise std there (m/s²) as the estimators weigh it, and that noise with its effective sample count for
    the gate (:func:`quiet_noise`; a plain standard deviation read 0.37 m/s² there for 0.05 m/s² of noise). With fewer
    than :data:`MIN_QUIET_SAMPLES` quiet samples no offset is removed and the noise is taken equal on every channel."""
    quiet = time < trigger_time
    if np.count_nonzero(quiet) < MIN_QUIET_SAMPLES:
        return dict(records), {probe: 1.0 for probe in records}, {probe: QuietNoise(math.nan, 0, 0.0) for probe in records}
    corrected = {probe: a - float(np.median(a[quiet])) for probe, a in records.items()}
    measured = {probe: quiet_noise(a[quiet]) for probe, a in corrected.items()}
    floor = max(max(found.std for found in measured.values()), 1e-12) * 1e-3
    return corrected, {probe: max(found.std, floor) for probe, found in measured.items()}, measured


def correlation_time(y: NDArray[np.float64]) -> float:
    """``τ̂ = 1 + 2 Σ_{k=1}^{K} ρ̂_k²`` (samples, ≥ 1): the samples' autocorrelation summed while
    ``|ρ̂_k| ≥ 2/√n``."""
    x = np.asarray(y, dtype=float) - float(np.mean(y))
    n = x.size
    energy = float(x @ x)
    if n < 4 or energy <= 0.0:
        return 1.0
    tau = 1.0
    for lag in range(1, n // 2):
        rho = float(x[:-lag] @ x[lag:]) / energy
        if abs(rho) < 2.0 / math.sqrt(n):
            break
        tau += 2.0 * rho * rho
    return tau


def noise_limit(effective_samples: float, channels: int = 1, false_reject: float = FALSE_REJECT) -> float:
    """``r``: a channel's ``σ̂`` above ``r σ_cal`` refutes ``σ ≤ σ_cal`` (module docstring), for ``channels``
    channels tested together at ``false_reject`` per event."""
    if not effective_samples > 0.0:
        raise ValueError(f"the noise gate needs quiet samples; effective count {effective_samples!r}")
    from scipy.special import betaincinv, ndtri  # scipy.special costs ~0.2 s to import: only a noise gate needs it

    per_channel = 1.0 - (1.0 - false_reject) ** (1.0 / max(channels, 1))
    a = 0.5 * (effective_samples + 1.0)
    median_quantile = float(betaincinv(a, a, 1.0 - per_channel))
    return float(ndtri(0.5 * (1.0 + median_quantile))) / float(ndtri(0.75))


def exceedance(ratio: float, effective_samples: float) -> float:
    """``P(σ̂ > ratio · σ)`` for ``effective_samples`` independent Gaussian samples (module docstring): the
    p-value of a channel's noise ``ratio`` times the calibrated one."""
    from scipy.special import betainc, ndtr, ndtri

    a = 0.5 * (effective_samples + 1.0)
    return float(1.0 - betainc(a, a, 2.0 * ndtr(ratio * float(ndtri(0.75))) - 1.0))


__all__ = ["FALSE_REJECT", "MAD_SCALE", "MIN_QUIET_SAMPLES", "QuietNoise", "correlation_time", "exceedance", "noise_limit", "quiet_corrected",
           "quiet_noise"]
