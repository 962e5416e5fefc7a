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
whose quiet-stretch noise refutes it, by a one-sided test that allows for the estimate's own
sampling error at 1 % false rejects per event: :mod:`femref.sensing.noise_gate`), and the impact
type (a compression-only coupler's impacts are free to roll, a bilateral one's coupled; an event
classified otherwise is outside). The closing speed is an interval (:mod:`femref.sensing.closing_speed`):
an event is outside the calibrated speeds only when its interval lies wholly outside them, and an
interval that straddles an edge is said (:meth:`Calibration.edge_notes`).

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

from femref.sensing.noise_gate import FALSE_REJECT, QuietNoise, exceedance, noise_limit

QUANTILES = (0.025, 0.975)
"""The band's quantiles of the relative peak error: a 95 % band."""


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

    def outside(self, closing_speed: tuple[float, float], masses: dict[str, float], lowpass: dict[str, float | None] | None = None,
                noise: dict[str, QuietNoise] | None = None, impact_type: str | None = None) -> list[str]:
        """Why an event is outside the calibrated ranges (empty when inside): its closing-speed interval
        ``(lower, upper)`` (m/s; outside only when it lies wholly outside the calibrated speeds), car masses
        (kg), and — when given — each channel's anti-alias corner (Hz, None: unfiltered) against the
        calibration's chain, each channel's quiet-stretch noise against the largest calibrated one
        (:meth:`noise_outside`), and its impact type against the calibration's."""
        reasons = []
        if impact_type is not None and impact_type != self.impact_type:
            reasons.append(f"a {impact_type} impact; the calibration's impacts were {self.impact_type}")
        lo, hi = self.closing_speed
        lower, upper = closing_speed
        if not (math.isfinite(lower) and math.isfinite(upper)):
            reasons.append(f"no closing speed to check against the calibrated [{lo:.3g}, {hi:.3g}] m/s")
        elif upper < lo or lower > hi:
            reasons.append(f"closing speed [{lower:.3g}, {upper:.3g}] m/s outside the calibrated [{lo:.3g}, {hi:.3g}] m/s")
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
        return reasons + self.noise_outside(noise or {})

    def noise_outside(self, noise: dict[str, QuietNoise]) -> list[str]:
        """The channels whose quiet-stretch noise refutes the largest calibrated noise ``σ_cal``: ``σ̂ > r σ_cal``,
        ``r`` the one-sided limit of :func:`femref.sensing.noise_gate.noise_limit` for the channel's effective
        quiet samples, the channels tested together at :data:`femref.sensing.noise_gate.FALSE_REJECT` per event.
        A channel without quiet samples cannot be checked and is said."""
        reasons = []
        calibrated = self.noise[1]
        for probe, found in noise.items():
            if not found.measured:
                reasons.append(f"{probe}'s noise was not measured (no quiet samples before the trigger): the calibrated noise cannot be checked")
                continue
            limit = noise_limit(found.effective_samples, len(noise)) * calibrated
            if found.std > limit:
                p = exceedance(found.std / calibrated, found.effective_samples) if calibrated > 0.0 else 0.0
                reasons.append(f"{probe}'s noise {found.std:.3g} m/s² exceeds the calibrated {calibrated:.3g} m/s² beyond its sampling scatter "
                               f"(limit {limit:.3g} m/s² for {found.effective_samples:.0f} effective quiet samples at {FALSE_REJECT:.0%} false rejects "
                               f"per event; p = {p:.2g})")
        return reasons

    def edge_notes(self, closing_speed: tuple[float, float]) -> list[str]:
        """A closing-speed interval ``(lower, upper)`` (m/s) that straddles an edge of the calibrated speeds:
        inside, but the band may hold for a speed the calibration did not cover."""
        lo, hi = self.closing_speed
        lower, upper = closing_speed
        return [f"the closing speed [{lower:.3g}, {upper:.3g}] m/s straddles the calibrated edge {edge:.3g} m/s"
                for edge in (lo, hi) if lower < edge < upper]


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


__all__ = ["QUANTILES", "Calibration", "CalibrationFileError", "read_calibration", "write_calibration"]
