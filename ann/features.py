"""Feature extraction from acceleration records for the force networks.

A record is one measured event: an array ``(channels, samples)`` of accelerations
sampled at ``rate`` Hz.  The pipeline turns a stack of records ``(N, channels,
samples)`` into a feature matrix ``(N, features)``:

1. check the input (finite values, the sampling rate and sample count the
   pipeline was built for) — a network trained at one rate silently gives
   nonsense at another, so a mismatch is an error, never a warning;
2. optional zero-phase low-pass (4th-order Butterworth, ``sosfiltfilt``), which
   also serves as the anti-alias filter before resampling;
3. linear resampling of each record to ``length`` samples over its duration;
4. optional normalisation, so shape and amplitude enter the network separately
   (:class:`FeatureSettings`); logarithms suit force estimation: ``P = M a`` makes
   ``log P = log M + log A`` additive (``log_target`` in :mod:`ann.networks`);
5. optional ``|rfft|`` magnitudes of the resampled channels;
6. optional known scalar inputs (``extras``, e.g. the car masses a railroad
   has from the waybill), appended as ``log`` values — they must be positive;
7. standardisation ``(f - mean) / std`` with mean and std fitted on the
   training records only (never on validation or test data).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

NORMALISATIONS = ("peak", "channel_peak", "none")
#: Floor of a channel peak before its logarithm (a channel that never moved).
TINY_AMPLITUDE = 1e-12
_RATE_RTOL = 1e-9


@dataclass(frozen=True)
class FeatureSettings:
    """What the feature pipeline computes; saved with the network weights.

    Attributes
    ----------
    length : samples per channel after resampling.
    rate : sampling rate of the input records, Hz; records at another rate are
        rejected.
    lowpass : cut-off of the zero-phase low-pass in Hz, or ``None`` for none;
        must lie below the Nyquist frequency ``rate / 2``.
    spectrum : append the ``|rfft|`` magnitudes of each resampled channel.
    normalise : ``"peak"`` (divide each record by its peak and append the peak),
        ``"channel_peak"`` (divide each channel by its peak and append the log
        peaks) or ``"none"``.
    extras : names of the known positive scalar inputs given with the records
        (e.g. ``("car_mass/hammer", "car_mass/anvil")``, kg), appended as logs;
        the names tell a user of the saved network what to pass, in order.
    """

    length: int
    rate: float
    lowpass: float | None = None
    spectrum: bool = False
    normalise: str = "none"
    extras: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if int(self.length) != self.length or self.length < 2:
            raise ValueError(f"FeatureSettings.length must be an integer >= 2, got {self.length!r}")
        if not np.isfinite(self.rate) or self.rate <= 0:
            raise ValueError(f"FeatureSettings.rate must be a positive number of Hz, got {self.rate!r}")
        if self.lowpass is not None and not (0 < self.lowpass < 0.5 * self.rate):
            raise ValueError(
                f"FeatureSettings.lowpass must lie in (0, rate/2 = {0.5 * self.rate:g}) Hz, got {self.lowpass!r}"
            )
        if self.normalise not in NORMALISATIONS:
            raise ValueError(
                f"FeatureSettings.normalise must be one of {NORMALISATIONS}, got {self.normalise!r}"
            )
        if len(set(self.extras)) != len(self.extras) or not all(isinstance(e, str) and e for e in self.extras):
            raise ValueError(f"FeatureSettings.extras must be distinct non-empty names, got {self.extras!r}")


class FeaturePipeline:
    """Records ``(N, channels, samples)`` → standardised features ``(N, features)``.

    ``fit`` fixes the record layout (channels, samples) and the per-feature
    mean/std from the training records; ``transform`` applies exactly the same
    steps to new records and refuses records of another layout or rate.
    """

    def __init__(self, settings: FeatureSettings) -> None:
        self.settings = settings
        self.channels: int | None = None
        self.samples: int | None = None
        self.mean_: np.ndarray | None = None
        self.scale_: np.ndarray | None = None

    @property
    def fitted(self) -> bool:
        """True once ``fit`` (or a load) has set the scaler."""
        return self.mean_ is not None

    def fit(self, records: np.ndarray, rate: float, extras: np.ndarray | None = None) -> FeaturePipeline:
        """Fix the record layout and fit the scaler on these (training) records.

        ``extras`` (N, len(settings.extras)): the known scalar inputs of each record.
        """
        records = self._check(records, rate, layout_known=False)
        self.channels, self.samples = records.shape[1], records.shape[2]
        raw = self._raw_features(records, self._check_extras(extras, records.shape[0]))
        self.mean_ = raw.mean(axis=0)
        std = raw.std(axis=0)
        # Constant features carry no information; scale 1 keeps them at zero.
        self.scale_ = np.where(std > 0, std, 1.0)
        return self

    def transform(self, records: np.ndarray, rate: float, extras: np.ndarray | None = None) -> np.ndarray:
        """Features of ``records`` (and ``extras``) standardised with the training mean and std."""
        if not self.fitted:
            raise ValueError("FeaturePipeline.transform called before fit; fit it on training records first")
        records = self._check(records, rate, layout_known=True)
        return (self._raw_features(records, self._check_extras(extras, records.shape[0])) - self.mean_) / self.scale_

    def fit_transform(self, records: np.ndarray, rate: float, extras: np.ndarray | None = None) -> np.ndarray:
        """``fit`` then ``transform`` on the same (training) records."""
        return self.fit(records, rate, extras).transform(records, rate, extras)

    # -- steps ---------------------------------------------------------------

    def _check(self, records: np.ndarray, rate: float, *, layout_known: bool) -> np.ndarray:
        records = np.asarray(records, dtype=float)
        if records.ndim != 3:
            raise ValueError(
                f"records must have shape (N, channels, samples), got an array of shape {records.shape}"
            )
        if records.shape[0] == 0:
            raise ValueError("records is empty (N = 0)")
        if not np.isclose(rate, self.settings.rate, rtol=_RATE_RTOL, atol=0.0):
            raise ValueError(
                f"records sampled at {rate!r} Hz but the pipeline expects {self.settings.rate!r} Hz; "
                "resample the records before use"
            )
        if layout_known:
            if records.shape[1] != self.channels:
                raise ValueError(
                    f"records have {records.shape[1]} channels but the pipeline was fitted on {self.channels}"
                )
            if records.shape[2] != self.samples:
                raise ValueError(
                    f"records have {records.shape[2]} samples but the pipeline was fitted on {self.samples} "
                    f"samples at {self.settings.rate:g} Hz"
                )
        elif records.shape[2] < 2:
            raise ValueError(f"records need at least 2 samples, got {records.shape[2]}")
        bad = ~np.isfinite(records)
        if bad.any():
            first = np.argwhere(bad)[0]
            raise ValueError(
                f"records contain {int(bad.sum())} NaN/inf values (first at record {first[0]}, "
                f"channel {first[1]}, sample {first[2]})"
            )
        return records

    def _check_extras(self, extras: np.ndarray | None, n: int) -> np.ndarray:
        names = self.settings.extras
        if not names:
            if extras is not None and np.size(extras):
                raise ValueError("extras given, but the pipeline takes none (FeatureSettings.extras is empty)")
            return np.empty((n, 0))
        if extras is None:
            raise ValueError(f"the pipeline needs the extras {', '.join(names)} with the records")
        extras = np.asarray(extras, dtype=float)
        if extras.shape != (n, len(names)):
            raise ValueError(f"extras must have shape ({n}, {len(names)}) for {', '.join(names)}, got {extras.shape}")
        if not np.all(np.isfinite(extras)) or np.any(extras <= 0.0):
            raise ValueError(f"extras ({', '.join(names)}) must be finite and positive (they enter as logarithms)")
        return extras

    def _raw_features(self, records: np.ndarray, extras: np.ndarray) -> np.ndarray:
        s = self.settings
        x = records
        if s.lowpass is not None:
            sos = signal.butter(4, s.lowpass, btype="low", fs=s.rate, output="sos")
            padlen = min(3 * (2 * len(sos) + 1), x.shape[-1] - 1)
            x = signal.sosfiltfilt(sos, x, axis=-1, padlen=padlen)
        x = _resample_linear(x, s.length)
        parts = []
        if s.normalise == "peak":
            peak = np.abs(x).max(axis=(1, 2))
            x = x / np.where(peak > 0, peak, 1.0)[:, None, None]
            parts.append(peak[:, None])
        elif s.normalise == "channel_peak":
            peak = np.maximum(np.abs(x).max(axis=2), TINY_AMPLITUDE)
            x = x / peak[:, :, None]
            parts.append(np.log(peak))
        parts.append(x.reshape(x.shape[0], -1))
        if s.spectrum:
            parts.append(np.abs(np.fft.rfft(x, axis=-1)).reshape(x.shape[0], -1))
        parts.append(np.log(extras))
        return np.concatenate(parts, axis=1)

    # -- plain-array state (for ann.storage) ---------------------------------

    def to_arrays(self) -> dict[str, np.ndarray]:
        """State as plain arrays (no objects), for ``numpy.savez``."""
        if not self.fitted:
            raise ValueError("cannot store an unfitted FeaturePipeline")
        s = self.settings
        return {
            "length": np.array(s.length, dtype=np.int64),
            "rate": np.array(s.rate, dtype=float),
            "lowpass": np.array(np.nan if s.lowpass is None else s.lowpass, dtype=float),
            "spectrum": np.array(s.spectrum, dtype=bool),
            "normalise": np.array(s.normalise),
            "extras": np.array(s.extras, dtype=str),
            "channels": np.array(self.channels, dtype=np.int64),
            "samples": np.array(self.samples, dtype=np.int64),
            "mean": self.mean_,
            "scale": self.scale_,
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> FeaturePipeline:
        """Rebuild a fitted pipeline from ``to_arrays`` output."""
        lowpass = float(arrays["lowpass"])
        settings = FeatureSettings(
            length=int(arrays["length"]),
            rate=float(arrays["rate"]),
            lowpass=None if np.isnan(lowpass) else lowpass,
            spectrum=bool(arrays["spectrum"]),
            normalise=str(arrays["normalise"]),
            extras=tuple(str(e) for e in arrays.get("extras", np.array([], dtype=str))),
        )
        pipeline = cls(settings)
        pipeline.channels = int(arrays["channels"])
        pipeline.samples = int(arrays["samples"])
        pipeline.mean_ = np.asarray(arrays["mean"], dtype=float)
        pipeline.scale_ = np.asarray(arrays["scale"], dtype=float)
        return pipeline


def _resample_linear(x: np.ndarray, length: int) -> np.ndarray:
    """Linear interpolation of the last axis onto ``length`` points spanning the
    same duration (first and last samples kept).  Linear rather than FFT
    resampling because impact records are not periodic; anti-aliasing is the
    job of the ``lowpass`` step."""
    samples = x.shape[-1]
    if samples == length:
        return x
    position = np.linspace(0.0, samples - 1, length)
    left = np.minimum(np.floor(position).astype(int), samples - 2)
    frac = position - left
    return x[..., left] * (1.0 - frac) + x[..., left + 1] * frac
