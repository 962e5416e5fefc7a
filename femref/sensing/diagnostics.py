"""What an event's records say about themselves: the source's data-quality diagnostics (docs/formulas.md §B2).

**The end sensors of a car** (:func:`end_agreement`). With ``a₁`` read at the car's rear-most sensor and ``a₂`` at its
front-most, the rate at which the body between them lengthens is

    ė(t) = ∫_{t₀}^{t} (a₂ − a₁) dt          (m/s),   D(f) = ∫ (a₂ − a₁) e^{−i2πft} dt,   D(0) = ė(T)

A body that rings returns to its length: ė oscillates about zero once the contact is over, and the spectrum of
``a₂ − a₁`` starts at the origin — the check the source wished it had made (its least-squares ``k₁`` of
``F₁″ = k₁ (a₂ − a₁) + k₂ a₁″`` came out with the wrong sign). A gain mismatch ``g`` between the two sensors adds
``g a_rigid`` to ``a₂ − a₁``, so ``ė → g Δv`` (``Δv = ∫ a_rigid dt`` the car's velocity change); an offset ``δ`` that
moves at the trigger adds ``δ (t − t_trigger)``. The check: ``ē``, the mean of ``ė`` over the record's tail (its last
:data:`TAIL` after the trigger; a ringing of a few periods averages out there), stays within

    |ē| ≤ max(GAIN_TOLERANCE |Δv|,  SIGMAS σ_d dt √(N τ))

(σ_d² = σ₁² + σ₂² the white noise of the difference, ``N`` samples, ``τ`` its correlation time in samples: the
random walk's std at the record's end bounds that of the tail mean). Beyond, the car is flagged ``end sensors
disagree``: ``inverse_quasi_rigid`` reads the force from ``a₂ − a₁`` and takes the leak for elastic strain.

**A channel's offset and drift** (:func:`channel_zero`). Before the trigger the cars stand or roll freely; the median
there is the channel's offset (removed before any estimator runs: :func:`femref.sensing.noise_gate.quiet_corrected`),
the least-squares slope ``b`` there its drift. An offset beyond :data:`OFFSET_LIMIT` is a wrong zero, not a grade
(flagged ``offset``); a drift that both stands out of the noise (``|b| > SIGMAS σ_b``) and moves the velocity
integrated over the event window by ``b T²/2 > GAIN_TOLERANCE |Δv|`` is flagged ``drift``: removing a constant offset
leaves it in every integral of the record.

**Spectra** (:func:`amplitude_spectrum`): ``|A(f)| = |Σ a_k e^{−i2πf k dt}| dt`` of ``a₁``, ``a₂ − a₁`` and the primary
force, for the report to draw.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from femref.sensing.noise_gate import QuietNoise

TAIL = 0.25
"""The share of the samples after the trigger, at the record's end, over which ``ė`` is averaged."""
GAIN_TOLERANCE = 0.01
"""The gain mismatch between two accelerometers the diagnostics accept: 1 %, the calibration tolerance of a
laboratory-calibrated piezoelectric or MEMS accelerometer; also the drift's allowed share of ``|Δv|``."""
SIGMAS = 4.0
"""Noise standard deviations a statistic must exceed before it is evidence."""
OFFSET_LIMIT = 0.1 * 9.80665
"""m/s²: the largest offset a level or graded car explains. A DC accelerometer along the car reads ``g sin θ``: the
steepest mainline grade (3.5 %) gives 0.34 m/s², a hump yard's ~2 % less; 0.1 g is a zero error or a tilted mount."""


@dataclass(frozen=True)
class EndAgreement:
    """A car's end sensors ``rear``/``front`` over an event: ``zero_ratio`` ``|D(0)|/max_f |D(f)|`` of ``a₂ − a₁``, the
    tail mean ``elongation_rate`` ``ē`` (m/s), the car's ``velocity_change`` Δv (m/s), the ``allowed`` |ē| (m/s),
    and the finding in words."""

    car: str
    rear: str
    front: str
    zero_ratio: float
    elongation_rate: float
    velocity_change: float
    allowed: float

    @property
    def agree(self) -> bool:
        return abs(self.elongation_rate) <= self.allowed

    @property
    def basis(self) -> str:
        share = f" ({abs(self.elongation_rate / self.velocity_change):.2%} of Δv = {self.velocity_change:.3g} m/s)" if self.velocity_change else ""
        verdict = "within" if self.agree else "beyond"
        return (f"{self.car}: the ends' velocities differ by {self.elongation_rate:.3g} m/s after the contact{share}, {verdict} the "
                f"{self.allowed:.3g} m/s allowed; |D(0)|/max|D| of a2 − a1 = {self.zero_ratio:.3g}")


@dataclass(frozen=True)
class ChannelZero:
    """A channel's zero before the trigger: its ``offset`` (m/s²), its ``drift`` slope (m/s³) and the slope's standard
    error ``drift_error``, and what that drift does to the velocity over the window (``velocity_error``, m/s)."""

    probe: str
    offset: float
    drift: float
    drift_error: float
    velocity_error: float
    allowed: float

    @property
    def offset_flag(self) -> bool:
        return abs(self.offset) > OFFSET_LIMIT

    @property
    def drift_flag(self) -> bool:
        return abs(self.drift) > SIGMAS * self.drift_error and abs(self.velocity_error) > self.allowed


@dataclass(frozen=True)
class Diagnostics:
    """One event's diagnostics: each car's end agreement, each channel's zero, and the flags they raise."""

    ends: tuple[EndAgreement, ...]
    zeros: tuple[ChannelZero, ...]

    @property
    def flags(self) -> tuple[str, ...]:
        found = [f"end sensors disagree: {end.basis}" for end in self.ends if not end.agree]
        found += [f"offset: {z.probe} reads {z.offset:.3g} m/s² at rest (more than the {OFFSET_LIMIT:.3g} m/s² a grade explains)"
                  for z in self.zeros if z.offset_flag]
        found += [f"drift: {z.probe} drifts {z.drift:.3g} m/s³ before the trigger ({z.drift / z.drift_error:.1f} σ), "
                  f"{z.velocity_error:.3g} m/s over the window (allowed {z.allowed:.3g})" for z in self.zeros if z.drift_flag]
        return tuple(found)

    def record(self) -> dict[str, Any]:
        """The diagnostics as JSON-ready data (the event file's ``diagnostics`` attribute): each car's ends and each
        channel's zero, every field with its unit in ``units``."""
        return {"ends": [{**dataclasses.asdict(end), "agree": end.agree} for end in self.ends],
                "zeros": [{**dataclasses.asdict(z), "offset_flag": z.offset_flag, "drift_flag": z.drift_flag} for z in self.zeros],
                "units": {"zero_ratio": "1", "elongation_rate": "m/s", "velocity_change": "m/s", "allowed": "m/s", "offset": "m/s^2",
                          "drift": "m/s^3", "drift_error": "m/s^3", "velocity_error": "m/s"}}


def amplitude_spectrum(signal: NDArray[np.float64], dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``f_k = k/(N dt)`` (Hz) and ``|A(f_k)| = |Σ_n a_n e^{−i2π k n/N}| dt`` (the signal's unit × s)."""
    a = np.asarray(signal, dtype=float)
    return np.fft.rfftfreq(a.size, dt), np.abs(np.fft.rfft(a)) * dt


def end_sensors(car: Any) -> tuple[str, str] | None:
    """The names of ``car``'s rear-most and front-most sensors (``car.sensors``: name → position along the car, m), or
    None when it has fewer than two positions."""
    if len({round(x, 9) for x in car.sensors.values()}) < 2:
        return None
    return min(car.sensors, key=car.sensors.__getitem__), max(car.sensors, key=car.sensors.__getitem__)


def end_agreement(car: Any, time: NDArray[np.float64], records: Mapping[str, NDArray[np.float64]], noise: Mapping[str, QuietNoise],
                  trigger_time: float) -> EndAgreement | None:
    """``car``'s :class:`EndAgreement` (module docstring) from offset-free ``records`` on the uniform ``time`` and each
    channel's quiet noise; None when the car has no two end sensors recorded,
    or a gap (NaN) in either."""
    ends = end_sensors(car)
    if ends is None or any(f"{car.name}/{end}" not in records for end in ends):
        return None
    rear, front = (np.asarray(records[f"{car.name}/{end}"], dtype=float) for end in ends)
    if not (np.all(np.isfinite(rear)) and np.all(np.isfinite(front))):
        return None  # a gap (flagged by the stream's quality tracker) leaves no integral to check
    dt = float(time[1] - time[0])
    difference = front - rear
    elongation_rate = np.cumsum(difference) * dt
    after = np.flatnonzero(time >= trigger_time)
    tail = after[-max(1, int(TAIL * after.size)):] if after.size else np.arange(time.size)[-max(1, int(TAIL * time.size)):]
    mean_rate = float(np.mean(elongation_rate[tail]))
    velocity_change = float(np.sum(0.5 * (front + rear)) * dt)
    variance, correlation = 0.0, 1.0
    for end in ends:
        quiet = noise.get(f"{car.name}/{end}")
        if quiet is not None and quiet.samples > 0 and math.isfinite(quiet.std):
            variance += quiet.std**2
            correlation = max(correlation, quiet.correlation_time)
    noise_bound = SIGMAS * math.sqrt(variance * time.size * correlation) * dt
    spectrum = amplitude_spectrum(difference, dt)[1]
    zero_ratio = float(spectrum[0] / spectrum.max()) if spectrum.max() > 0.0 else math.nan
    return EndAgreement(car.name, ends[0], ends[1], zero_ratio, mean_rate, velocity_change,
                        max(GAIN_TOLERANCE * abs(velocity_change), noise_bound))


def channel_zero(probe: str, time: NDArray[np.float64], raw: NDArray[np.float64], trigger_time: float, velocity_change: float,
                 correlation: float = 1.0) -> ChannelZero | None:
    """``probe``'s :class:`ChannelZero` (module docstring) from its ``raw`` record (offset kept) on ``time``: the median and
    the least-squares slope of the finite samples before ``trigger_time`` (None with fewer than 10), the slope's standard error
    from the fit's residuals (× √``correlation``, the noise's correlation time in samples), the velocity error
    ``b T²/2`` over the window of length ``T``, and ``velocity_change`` the car's |Δv| that sets the allowance."""
    quiet = (time < trigger_time) & np.isfinite(raw)
    if np.count_nonzero(quiet) < 10:
        return None
    t, y = time[quiet] - float(np.mean(time[quiet])), np.asarray(raw, dtype=float)[quiet]
    spread = float(t @ t)
    slope = float(t @ (y - y.mean())) / spread
    residual = y - y.mean() - slope * t
    error = math.sqrt(float(residual @ residual) / max(y.size - 2, 1) / spread * max(correlation, 1.0))
    window = float(time[-1] - time[0])
    return ChannelZero(probe, float(np.median(y)), slope, error, 0.5 * slope * window**2, GAIN_TOLERANCE * abs(velocity_change))


def diagnose(cars: Sequence[Any], time: NDArray[np.float64], raw: Mapping[str, NDArray[np.float64]], corrected: Mapping[str, NDArray[np.float64]],
             noise: Mapping[str, QuietNoise], trigger_time: float) -> Diagnostics:
    """The event's :class:`Diagnostics`: every car's end agreement and every recorded channel's zero (``raw`` the records as
    recorded, ``corrected`` less their offsets, ``noise`` each channel's quiet noise)."""
    ends = [found for car in cars if (found := end_agreement(car, time, corrected, noise, trigger_time)) is not None]
    zeros = []
    dt = float(time[1] - time[0])
    for car in cars:
        probes = [f"{car.name}/{sensor}" for sensor in car.sensors if f"{car.name}/{sensor}" in raw]
        if not probes:
            continue
        velocity_change = abs(float(np.mean([np.nansum(corrected[p]) * dt for p in probes])))
        for probe in probes:
            quiet = noise.get(probe)
            correlation = quiet.correlation_time if quiet is not None else 1.0
            if (found := channel_zero(probe, time, raw[probe], trigger_time, velocity_change, correlation)) is not None:
                zeros.append(found)
    return Diagnostics(tuple(ends), tuple(zeros))


__all__ = ["GAIN_TOLERANCE", "OFFSET_LIMIT", "SIGMAS", "TAIL", "ChannelZero", "Diagnostics", "EndAgreement", "amplitude_spectrum",
           "channel_zero", "diagnose", "end_agreement", "end_sensors"]
