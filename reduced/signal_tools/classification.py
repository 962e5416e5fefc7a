"""Impact-type classification: free to roll vs coupled from the zero-frequency content
of the relative acceleration spectrum, and not an impact when the cars' forces are not
internal to the line (docs/formulas.md §B).

:func:`zero_frequency_ratio` gives ``ρ = |A(0)| / max_f |A(f)|``; :func:`classify_impact`
thresholds it into an :class:`ImpactClassification`; :func:`momentum_evidence` gives the
momentum ratio ``R`` and the relative velocity change that tell a coupler impact from a
transient pushed from outside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from reduced import _checks

IMPACT_KINDS: tuple[str, ...] = ("free_to_roll", "coupled")
NOT_AN_IMPACT = "not_an_impact"
"""The class of a transient whose forces come from outside the line (a track joint, brakes, a knock, noise)."""
NOISE_ENERGY_FACTOR = 3.0
"""``k``: the threshold allows ``k`` times the expected noise energy (its chi-square spread over the window)."""
MAX_THRESHOLD = 0.5
"""An ``R`` threshold from here on (noise as strong as the event) tells no impact: halfway to the uncorrelated R = 1."""
CLOSING_SIGMAS = 3.0
"""A closing is a relative velocity change beyond this many noise standard deviations."""


@dataclass(frozen=True)
class ImpactClassification:
    """``kind`` (``free_to_roll`` or ``coupled``), ``confidence`` in [0, 1] (0 at the
    threshold, 1 at ρ = 1 or ρ = 0), the zero-frequency ratio ρ and the threshold."""

    kind: str
    confidence: float
    zero_frequency_ratio: float
    threshold: float


def zero_frequency_ratio(relative_acceleration: ArrayLike, dt: float, *, pad_factor: int = 8, baseline_samples: int = 0) -> float:
    """``ρ = |A(0)| / max_f |A(f)|`` of the relative acceleration spectrum ``A``.

    ``A(f) = Σ a_k e^{−i2πf k dt} dt`` (``rfft`` zero-padded to ``pad_factor·N`` so
    that resonance peaks are resolved); ``A(0) = ∫ a dt`` is the change of the
    relative velocity over the record. Since ``|A(f)| ≤ ∫|a| dt`` with equality at
    f = 0 iff ``a`` keeps one sign, ``ρ = 1`` for a free-to-roll (compression-only)
    impact, where the coupler only pushes; for coupled cars the relative
    acceleration oscillates and ``ρ ≈ 1/max|H|``, ``H(iω) = (ω0² + 2iζω0ω)/(ω0² − ω² +
    2iζω0ω)``: about 0.1 at ζ = 0.05, 0.5 at ζ = 0.3, 0.7 at ζ = 0.5 — so the method
    separates the kinds for coupler damping ratios below ≈ 0.6. Noise spreads over
    all frequencies and barely moves ρ. ``baseline_samples`` > 0 subtracts the mean
    of the first samples (sensor offset; a record should then start before impact).
    """
    a = _checks.record("relative_acceleration", relative_acceleration, min_length=4)
    _checks.sample_step("dt", dt)
    if int(pad_factor) != pad_factor or pad_factor < 1:
        raise ValueError(f"pad_factor must be an integer >= 1, got {pad_factor!r}")
    if baseline_samples < 0 or baseline_samples > a.size:
        raise ValueError(f"baseline_samples must be in [0, {a.size}], got {baseline_samples!r}")
    if baseline_samples:
        a = a - a[:baseline_samples].mean()
    spectrum = np.abs(np.fft.rfft(a, n=int(pad_factor) * a.size))
    peak = spectrum.max()
    if peak == 0.0:
        raise ValueError("relative_acceleration is identically zero: nothing to classify")
    return float(spectrum[0] / peak)


def classify_impact(
    relative_acceleration: ArrayLike,
    dt: float,
    *,
    threshold: float = 0.9,
    pad_factor: int = 8,
    baseline_samples: int = 0,
) -> ImpactClassification:
    """Free to roll if ``ρ ≥ threshold``, else coupled (docs/formulas.md §B; ρ in
    :func:`zero_frequency_ratio`). Confidence ``(ρ − t)/(1 − t)`` above the threshold
    ``t``, ``(t − ρ)/t`` below. The relative acceleration is ``a2 − a1`` (either sign);
    tests/reduced/test_signal_tools.py.
    """
    t = _checks.finite("threshold", threshold)
    if not 0.0 < t < 1.0:
        raise ValueError(f"threshold must be in (0, 1), got {t!r}")
    rho = zero_frequency_ratio(relative_acceleration, dt, pad_factor=pad_factor, baseline_samples=baseline_samples)
    if rho >= t:
        return ImpactClassification("free_to_roll", min(1.0, (rho - t) / (1.0 - t)), rho, t)
    return ImpactClassification("coupled", (t - rho) / t, rho, t)


@dataclass(frozen=True)
class MomentumEvidence:
    """The momentum ratio ``ratio`` (R) against its ``threshold``, and the largest relative velocity change
    ``velocity_change`` (m/s) against its noise std ``velocity_noise`` (m/s) (:func:`momentum_evidence`)."""

    ratio: float
    threshold: float
    velocity_change: float
    velocity_noise: float

    @property
    def internal(self) -> bool:
        """Whether the forces are internal to the line and the coupler closed: a coupler impact."""
        return self.ratio <= self.threshold < MAX_THRESHOLD and self.velocity_change > CLOSING_SIGMAS * self.velocity_noise

    @property
    def basis(self) -> str:
        """The evidence in words."""
        return (f"momentum ratio R = {self.ratio:.3g} against {self.threshold:.3g}; relative velocity change {self.velocity_change:.3g} m/s "
                f"against its noise {self.velocity_noise:.2g} m/s (a closing needs > {CLOSING_SIGMAS:g}×)"
                + ("" if self.threshold < MAX_THRESHOLD else f"; the noise could make R reach {MAX_THRESHOLD:g}: no impact stands out of it"))


def momentum_evidence(accelerations: ArrayLike, masses: ArrayLike, noise_std: ArrayLike, dt: float, *, corner: float | None,
                      mass_tolerance: float | ArrayLike, rear: int = 0) -> MomentumEvidence:
    """``R = ∫(Σ_k m_k ā_k)² dt / ∫Σ_k (m_k ā_k)² dt`` and ``Δv = max_t |∫(a_{rear+1} − a_rear) dt|``.

    ``ā`` each car's acceleration (rows of ``accelerations``, m/s², a common axis) low-passed below ``corner``
    (Hz; None: unfiltered), under the cars' first elastic mode. Couplers are internal forces: ``Σ m_k a_k = 0`` for
    the rigid motion, so ``R ≈ 0`` for an impact; forces from outside give ``R ≈ 1`` uncorrelated (a knock on one car,
    a joint's jolts one car after the next), ``R ≈ n`` for the same deceleration of all ``n`` cars (brakes).
    An impact's ``R`` is at most ``R_i = Σ_k τ_k²/(1 − max τ)² + k E_n/E`` (``n τ²/(1 − τ)²`` for one ``τ``):
    declared masses ``m̂_k = m_k (1 + δ_k)``, ``|δ_k| ≤ τ_k`` (``mass_tolerance``, one or one per car — a car weighed
    has its own) leave ``|Σ m̂ a|² = |Σ δ_k m_k a_k|² ≤ Σ τ_k² Σ (m a)²`` (Cauchy–Schwarz) against
    ``Σ (m̂ a)² ≥ (1 − max τ)² Σ (m a)²``, white noise ``σ_k`` (``noise_std``) adds ``E_n = T Σ m_k² σ_k² min(1, 2 f_c dt)``
    against the measured ``E = ∫Σ (m ā)²`` (``k`` = :data:`NOISE_ENERGY_FACTOR`). The threshold ``t = √R_i``, the geometric
    mean of ``R_i`` and the uncorrelated 1, leaves both the same factor; from ``t`` ≥ :data:`MAX_THRESHOLD` the noise alone
    could give the ``R`` of an impact, and none is seen. The coupler between cars ``rear``
    and ``rear + 1`` closes: ``Δv`` beyond :data:`CLOSING_SIGMAS` × ``σ_rel √(dt T)`` (a random walk's std at ``T``)."""
    a = np.asarray(accelerations, dtype=float)
    m = np.asarray(masses, dtype=float)
    sigma = np.asarray(noise_std, dtype=float)
    if a.ndim != 2 or a.shape[0] != m.size or sigma.size != m.size or a.shape[0] < 2 or a.shape[1] < 16:
        raise ValueError(f"accelerations must be (cars ≥ 2, samples ≥ 16) with a mass and noise per car, got {a.shape}, {m.size}, {sigma.size}")
    _checks.sample_step("dt", dt)
    nyquist = 0.5 / dt
    band = 1.0 if corner is None or corner >= nyquist else 2.0 * corner * dt
    if corner is None or corner >= nyquist:
        low = a
    else:
        from scipy.signal import butter, sosfiltfilt  # scipy.signal costs ~0.5 s to import: only where a record is filtered

        low = sosfiltfilt(butter(4, corner, fs=1.0 / dt, output="sos"), a, axis=1)
    forces = m[:, None] * low
    energy = float(np.sum(forces**2) * dt)
    if energy == 0.0:
        raise ValueError("the accelerations are identically zero: nothing to classify")
    duration = a.shape[1] * dt
    noise_energy = duration * float(np.sum(m**2 * sigma**2)) * band
    tolerance = np.asarray(mass_tolerance, dtype=float)
    tolerance = np.full(m.shape, float(tolerance)) if tolerance.ndim == 0 else tolerance if tolerance.shape == m.shape else None
    if tolerance is None or not np.all(np.isfinite(tolerance)) or np.any(tolerance < 0.0) or np.any(tolerance >= 1.0):
        raise ValueError(f"mass_tolerance must be one number or one per car, each in [0, 1), got {mass_tolerance!r}")
    threshold = math.sqrt(float(np.sum(tolerance**2)) / (1.0 - float(np.max(tolerance))) ** 2 + NOISE_ENERGY_FACTOR * noise_energy / energy)
    relative = a[rear + 1] - a[rear]
    velocity = np.cumsum(0.5 * (relative[1:] + relative[:-1])) * dt
    velocity_noise = math.hypot(sigma[rear], sigma[rear + 1]) * math.sqrt(dt * duration)
    return MomentumEvidence(float(np.sum(forces.sum(axis=0) ** 2) * dt / energy), threshold, float(np.max(np.abs(velocity))), velocity_noise)


__all__ = ["CLOSING_SIGMAS", "IMPACT_KINDS", "MAX_THRESHOLD", "NOISE_ENERGY_FACTOR", "NOT_AN_IMPACT", "ImpactClassification", "MomentumEvidence", "classify_impact",
           "momentum_evidence", "zero_frequency_ratio"]
