"""Calibrated error bounds of the inverse estimators: what a calibration run found, and its file.

A calibration runs each inverse estimator on the fem records of a sweep — impacts drawn from a
declared distribution of speeds, cars, gears and measurement chains — and keeps, per estimator,
the relative peak errors ``e = P̂ / P − 1`` of its samples and the ranges the sweep covered
(:func:`femref.study.calibration.calibrate` makes it). A measured event inside those ranges gets
the band

    P ∈ [P̂ / (1 + e_hi), P̂ / (1 + e_lo)],   e_lo, e_hi the 2.5 % and 97.5 % quantiles of e

(``bound = calibrated``); outside them the bound is ``none`` and the event says why — a band
calibrated on other impacts is not made up for this one. The ranges are the closing speeds and
car masses the sweep covered, and its measurement chain: the anti-alias corner its records went
through (a recorder with another filter is outside) and the largest sensor noise (an event
noisier than 1.25 × that is outside), and the impact type (a compression-only coupler's
impacts are free to roll, a bilateral one's coupled; an event classified otherwise is outside).

File (written atomically)::

    /  attrs: femref_version, created, sweep_yaml, coupler, samples, quantiles (JSON),
              closing_speed (JSON [lo, hi], m/s), masses (JSON {car: [lo, hi]}, kg),
              lowpass (JSON, Hz or null: the chain's anti-alias corner), noise (JSON [lo, hi], m/s²),
              impact_type (free_to_roll | coupled: the coupler's contact in the sweep)
    /errors/<estimator>   (samples,) relative peak errors
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

QUANTILES = (0.025, 0.975)
"""The band's quantiles of the relative peak error: a 95 % band."""
NOISE_MARGIN = 1.25
"""An event's channel noise may exceed the largest calibrated noise by this factor (a std measured on
50 quiet samples scatters by about 10 %)."""


class CalibrationFileError(ValueError):
    """A calibration file that cannot be read: the message names the file and the rule."""


@dataclass(frozen=True, eq=False)
class Calibration:
    """Per estimator the relative peak errors of the calibration samples, and the ranges they covered."""

    coupler: str
    errors: dict[str, NDArray[np.float64]]
    closing_speed: tuple[float, float]
    masses: dict[str, tuple[float, float]]
    lowpass: float | None = None
    noise: tuple[float, float] = (0.0, 0.0)
    impact_type: str = "free_to_roll"
    sweep_yaml: str = ""

    def error_band(self, estimator: str) -> tuple[float, float]:
        """``(e_lo, e_hi)``: the :data:`QUANTILES` of the estimator's relative peak errors."""
        lo, hi = np.quantile(self.errors[estimator], QUANTILES)
        return float(lo), float(hi)

    def outside(self, closing_speed: float, masses: dict[str, float], lowpass: dict[str, float | None] | None = None,
                noise: dict[str, float] | None = None, impact_type: str | None = None) -> list[str]:
        """Why an event is outside the calibrated ranges (empty when inside): its closing speed (m/s), car
        masses (kg), and — when given — each channel's anti-alias corner (Hz, None: unfiltered) against the
        calibration's chain, each channel's noise std (m/s²) against :data:`NOISE_MARGIN` × the largest
        calibrated one, and its impact type against the calibration's."""
        reasons = []
        if impact_type is not None and impact_type != self.impact_type:
            reasons.append(f"a {impact_type} impact; the calibration's impacts were {self.impact_type}")
        lo, hi = self.closing_speed
        if not (math.isfinite(closing_speed) and lo <= closing_speed <= hi):
            reasons.append(f"closing speed {closing_speed:.3g} m/s outside the calibrated [{lo:.3g}, {hi:.3g}] m/s")
        for car, mass in masses.items():
            if car not in self.masses:
                reasons.append(f"car {car} was not in the calibration (its cars: {', '.join(self.masses)})")
                continue
            lo, hi = self.masses[car]
            if not lo <= mass <= hi:
                reasons.append(f"car {car}'s mass {mass:.4g} kg outside the calibrated [{lo:.4g}, {hi:.4g}] kg")
        for probe, corner in (lowpass or {}).items():
            if not (corner is None and self.lowpass is None or corner is not None and self.lowpass is not None
                    and math.isclose(corner, self.lowpass, rel_tol=1e-6)):
                reasons.append(f"{probe} is recorded {_chain(corner)}; the calibration's records were {_chain(self.lowpass)}")
        limit = NOISE_MARGIN * self.noise[1]
        noisy = {probe: std for probe, std in (noise or {}).items() if std > limit}
        if noisy:
            worst = max(noisy, key=noisy.__getitem__)
            reasons.append(f"{worst}'s noise {noisy[worst]:.3g} m/s² exceeds the calibrated {self.noise[1]:.3g} m/s² (× {NOISE_MARGIN:g})")
        return reasons


def _chain(corner: float | None) -> str:
    return "unfiltered (no anti_alias declared)" if corner is None else f"through a {corner:g} Hz low-pass"


def write_calibration(calibration: Calibration, path: str | Path) -> Path:
    """Write ``calibration`` to ``path`` (atomically)."""
    from femref import __version__
    from femref.core.publishing import atomic_path

    path = Path(path)
    with atomic_path(path) as temporary, h5py.File(temporary, "w") as h5:
        h5.attrs.update(femref_version=__version__, created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                        sweep_yaml=calibration.sweep_yaml, coupler=calibration.coupler,
                        samples=int(min((e.size for e in calibration.errors.values()), default=0)),
                        quantiles=json.dumps(list(QUANTILES)), closing_speed=json.dumps(list(calibration.closing_speed)),
                        masses=json.dumps({car: list(r) for car, r in calibration.masses.items()}),
                        lowpass=json.dumps(calibration.lowpass), noise=json.dumps(list(calibration.noise)),
                        impact_type=calibration.impact_type)
        for name, errors in calibration.errors.items():
            h5.create_dataset(f"errors/{name}", data=np.asarray(errors, dtype=float))
    return path


def read_calibration(path: str | Path) -> Calibration:
    """The calibration in ``path``; CalibrationFileError for a missing or malformed file."""
    path = Path(path)
    if not path.is_file():
        raise CalibrationFileError(f"calibration file {path} not found")
    try:
        with h5py.File(path, "r") as h5:
            attrs = dict(h5.attrs)
            errors = {name: np.asarray(ds[()], dtype=float) for name, ds in h5["errors"].items()}
            calibration = Calibration(
                coupler=str(attrs["coupler"]),
                errors=errors,
                closing_speed=tuple(json.loads(attrs["closing_speed"])),  # type: ignore[arg-type]
                masses={car: tuple(r) for car, r in json.loads(attrs["masses"]).items()},  # type: ignore[misc]
                lowpass=json.loads(attrs["lowpass"]),
                noise=tuple(json.loads(attrs["noise"])),  # type: ignore[arg-type]
                impact_type=str(attrs["impact_type"]),
                sweep_yaml=str(attrs.get("sweep_yaml", "")),
            )
    except (OSError, KeyError, ValueError, TypeError) as error:
        raise CalibrationFileError(f"{path}: not a femref calibration file ({type(error).__name__}: {error})") from None
    short = [name for name, e in calibration.errors.items() if e.size < 20 or not np.all(np.isfinite(e))]
    if short:
        raise CalibrationFileError(f"{path}: estimators {', '.join(short)} have fewer than 20 finite calibration errors: no 95 % band")
    return calibration


__all__ = ["NOISE_MARGIN", "QUANTILES", "Calibration", "CalibrationFileError", "read_calibration", "write_calibration"]
