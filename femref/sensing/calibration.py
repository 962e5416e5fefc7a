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
classified otherwise is outside). The closing speed is an interval (:mod:`femref.sensing.findings`):
an event is outside the calibrated speeds only when its interval lies wholly outside them, and an
interval that straddles an edge is said (:meth:`Calibration.edge_notes`). Masses and speeds are
compared with the relative tolerance :data:`RANGE_RTOL` (a sweep that held a car's mass fixed
calibrates a zero-width range, which the case's own mass must meet to rounding, not bit for bit).

The file (written atomically) and what :func:`read_calibration` checks before anything large is read:
docs/design.md §4.5 (hard links and plain datasets only: :mod:`femref.sensing.hdf5_checks`). The case checks the
cars and the coupler the calibration is of against its own (:mod:`femref.case.measured`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

from femref.events import ForceEstimate
from femref.sensing.hdf5_checks import HDF5ObjectError, check_plain_dataset, check_regular_file, hard_link, members
from femref.sensing.noise_gate import FALSE_REJECT, QuietNoise, exceedance, noise_limit

QUANTILES = (0.025, 0.975)
"""The band's quantiles of the relative peak error: a 95 % band."""


RANGE_RTOL = 1e-6
"""Relative tolerance of the range compares: a car mass or closing speed within ``RANGE_RTOL`` of a calibrated
edge is inside (a sweep that held a car's mass fixed calibrates the zero-width range ``[m, m]``, and the case
gives ``m`` through its own profile quadrature and rounding). It is the anti-alias corner's tolerance too."""


def within(value: float, lo: float, hi: float) -> bool:
    """``lo − RANGE_RTOL |lo| <= value <= hi + RANGE_RTOL |hi|`` (an infinite edge is no bound)."""
    return (lo == -math.inf or value >= lo - RANGE_RTOL * abs(lo)) and (hi == math.inf or value <= hi + RANGE_RTOL * abs(hi))


class CalibrationFileError(ValueError):
    """A calibration file that cannot be read: the message names the file and the rule."""


@dataclass(frozen=True, eq=False)
class Calibration:
    """Per estimator the relative peak errors of the calibration samples, and the ranges they covered (module docstring)."""

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
        """Why an event is outside the calibrated ranges (module docstring; empty when inside): its closing-speed
        interval ``(lower, upper)`` (m/s), car masses (kg), and when given each channel's anti-alias corner (Hz, None:
        unfiltered), quiet-stretch noise (:meth:`noise_outside`) and the impact type."""
        reasons = []
        if impact_type is not None and impact_type != self.impact_type:
            reasons.append(f"a {impact_type} impact; the calibration's impacts were {self.impact_type}")
        lo, hi = self.closing_speed
        lower, upper = closing_speed
        if not (math.isfinite(lower) and math.isfinite(upper)):
            reasons.append(f"no closing speed to check against the calibrated [{lo:.3g}, {hi:.3g}] m/s")
        elif not (within(upper, lo, math.inf) and within(lower, -math.inf, hi)):
            reasons.append(f"closing speed [{lower:.3g}, {upper:.3g}] m/s outside the calibrated [{lo:.3g}, {hi:.3g}] m/s")
        for car, mass in masses.items():
            if car not in self.masses:
                reasons.append(f"car {car} was not in the calibration (its cars: {', '.join(self.masses)})")
                continue
            lo, hi = self.masses[car]
            if not within(mass, lo, hi):
                reasons.append(f"car {car}'s mass {mass:.6g} kg outside the calibrated [{lo:.6g}, {hi:.6g}] kg "
                               f"(relative tolerance {RANGE_RTOL:g})")
        for probe, corner in (lowpass or {}).items():
            if not (corner is None and self.lowpass is None or corner is not None and self.lowpass is not None
                    and math.isclose(corner, self.lowpass, rel_tol=RANGE_RTOL)):
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

    def band(self, estimates: Sequence[ForceEstimate], closing_speed: tuple[float, float], masses: dict[str, float],
             lowpass: dict[str, float | None], noise: dict[str, QuietNoise], impact_type: str) -> None:
        """Calibrated bands on the ok estimates of the calibrated estimators and coupler: ``P ∈ [P̂/(1 + e_hi),
        P̂/(1 + e_lo)]`` inside the calibrated ranges (:meth:`outside`; an interval that straddles an edge is said in the
        message); outside, no band, ``in_calibrated_range`` false and the reason."""
        outside = self.outside(closing_speed, masses, lowpass, noise, impact_type)
        notes = "".join(f"; {note}" for note in self.edge_notes(closing_speed))
        for estimate in estimates:
            if estimate.estimator not in self.errors or estimate.coupler != self.coupler or not estimate.ok:
                continue
            estimate.in_calibrated_range = not outside
            if outside:
                estimate.message = "outside the calibrated range: " + "; ".join(outside) + ": no band"
                continue
            e_lo, e_hi = self.error_band(estimate.estimator)
            low, high = estimate.force / (1.0 + e_hi), estimate.force / (1.0 + e_lo)
            estimate.lower, estimate.upper = np.minimum(low, high), np.maximum(low, high)
            estimate.bound = "calibrated"
            estimate.message = f"calibrated peak error 95 % band [{e_lo:+.1%}, {e_hi:+.1%}]" + notes


def _chain(corner: float | None) -> str:
    return "unfiltered (no anti_alias declared)" if corner is None else f"through a {corner:g} Hz low-pass"


def write_calibration(calibration: Calibration, path: str | Path) -> Path:
    """Write ``calibration`` to ``path`` (atomically)."""
    from femref import __version__
    from femref.core.hdf5_writing import hdf5_writer
    from femref.core.publishing import atomic_path

    path = Path(path)
    with atomic_path(path) as temporary, hdf5_writer(temporary) as h5:
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


#: Largest calibration file read (bytes): it bounds the text attributes, whose length HDF5 does not declare.
MAX_FILE_BYTES = 2**28
#: Most estimators (members of ``/errors``) and most calibration errors in all, checked before any is read.
MAX_ESTIMATORS = 64
MAX_ERRORS = 2**24
#: Longest text attribute (characters): the JSON ranges, the sweep's YAML.
MAX_TEXT = 2**20
#: Fewest finite errors of an estimator that make a 95 % band.
MIN_ERRORS = 20
#: Attributes a calibration file must hold, and those it may.
REQUIRED_ATTRIBUTES = ("coupler", "closing_speed", "masses", "lowpass", "noise", "impact_type")
OPTIONAL_ATTRIBUTES = ("femref_version", "created", "sweep_yaml", "samples", "quantiles")
#: The impact types a calibration's sweep may have had (``reduced.signal_tools.IMPACT_KINDS``).
IMPACT_TYPES = ("free_to_roll", "coupled")


def read_calibration(path: str | Path) -> Calibration:
    """The calibration in ``path``, checked before anything large is read (module docstring); a
    :class:`CalibrationFileError` naming the file, the attribute or dataset and the rule otherwise."""
    path = Path(path)
    try:
        check_regular_file(path, MAX_FILE_BYTES)
    except HDF5ObjectError as error:
        raise CalibrationFileError(f"calibration file {path} {error}") from None
    try:
        with h5py.File(path, "r") as h5:
            return _calibration_of(h5)
    except (CalibrationFileError, HDF5ObjectError) as error:
        raise CalibrationFileError(f"{path}: {error}") from None
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as error:
        raise CalibrationFileError(f"{path}: not a readable femref calibration file ({type(error).__name__}: {error})") from None


def _calibration_of(h5: h5py.File) -> Calibration:
    """The calibration of an open file (:func:`read_calibration`'s checks; messages without the file)."""
    unknown = [name for name in h5.keys() if name != "errors"]
    if unknown:
        raise CalibrationFileError(f"unknown member(s) {', '.join('/' + n for n in unknown)}; a calibration file holds only /errors")
    names = list(h5.attrs.keys())
    missing = [name for name in REQUIRED_ATTRIBUTES if name not in names]
    extra = [name for name in names if name not in REQUIRED_ATTRIBUTES + OPTIONAL_ATTRIBUTES]
    if missing or extra:
        what = ([f"lacks the attribute(s) {', '.join(missing)}"] if missing else []) + ([f"has unknown attribute(s) {', '.join(extra)}"] if extra else [])
        known = ", ".join(REQUIRED_ATTRIBUTES + OPTIONAL_ATTRIBUTES)
        raise CalibrationFileError(f"not a femref calibration file: it {' and '.join(what)} (attributes: {known})")
    if "samples" in names:
        _check_count_attribute(h5, "samples")
    for name in ("femref_version", "created", "sweep_yaml"):
        if name in names:
            _text_attribute(h5, name)
    if "quantiles" in names:
        _range(_json_attribute(h5, "quantiles"), "attribute quantiles", "", 0.0, upper=1.0)
    coupler = _text_attribute(h5, "coupler")
    if not coupler:
        raise CalibrationFileError("attribute coupler is empty: it names the coupler the calibration's estimates are of")
    impact_type = _text_attribute(h5, "impact_type")
    if impact_type not in IMPACT_TYPES:
        raise CalibrationFileError(f"attribute impact_type is {impact_type!r}; it must be one of {', '.join(IMPACT_TYPES)}")
    masses = _json_attribute(h5, "masses")
    if not isinstance(masses, dict) or not masses:
        raise CalibrationFileError(f"attribute masses must be a JSON mapping {{car: [lo, hi]}} (kg) of at least one car, got {_shown(masses)}")
    lowpass = _json_attribute(h5, "lowpass")
    if lowpass is not None and not (_number(lowpass) and math.isfinite(lowpass) and lowpass > 0.0):
        raise CalibrationFileError(f"attribute lowpass must be null or a finite corner frequency > 0 (Hz), got {_shown(lowpass)}")
    return Calibration(
        coupler=coupler,
        errors=_errors(h5),
        closing_speed=_range(_json_attribute(h5, "closing_speed"), "attribute closing_speed", "m/s", 0.0),
        masses={car: _range(span, f"attribute masses, car {car}", "kg", 0.0, positive=True) for car, span in masses.items()},
        lowpass=None if lowpass is None else float(lowpass),
        noise=_range(_json_attribute(h5, "noise"), "attribute noise", "m/s²", 0.0),
        impact_type=impact_type,
        sweep_yaml=_text_attribute(h5, "sweep_yaml") if "sweep_yaml" in names else "",
    )


def _errors(h5: h5py.File) -> dict[str, NDArray[np.float64]]:
    """``/errors/<estimator>``: 1-D real datasets stored in the file, checked before they are read."""
    group = hard_link(h5, "errors")
    if not isinstance(group, h5py.Group):
        raise CalibrationFileError("/errors must be a group of one dataset per estimator")
    datasets = members(group, MAX_ESTIMATORS)
    if not datasets:
        raise CalibrationFileError("/errors holds no estimator's errors")
    for name, dataset in datasets.items():
        if not isinstance(dataset, h5py.Dataset):
            raise CalibrationFileError(f"/errors/{name} must be a dataset of relative peak errors, not a group")
        check_plain_dataset(dataset, MAX_ERRORS)
        if len(dataset.shape or ()) != 1:
            raise CalibrationFileError(f"/errors/{name} has shape {dataset.shape}; an estimator's errors are 1-D (samples,)")
    declared = sum(dataset.shape[0] for dataset in datasets.values())
    if declared > MAX_ERRORS:
        raise CalibrationFileError(f"/errors declares {declared} values in all, more than the {MAX_ERRORS} a calibration file may hold (refused unread)")
    errors = {name: np.asarray(dataset[()], dtype=float) for name, dataset in datasets.items()}
    for name, values in errors.items():
        finite = int(np.count_nonzero(np.isfinite(values)))
        if finite < values.size:
            raise CalibrationFileError(f"/errors/{name} holds {values.size - finite} non-finite value(s) (NaN or infinity)")
        if values.size < MIN_ERRORS:
            raise CalibrationFileError(f"/errors/{name} holds {values.size} errors, fewer than the {MIN_ERRORS} a 95 % band needs")
    return errors


def _attribute_id(h5: h5py.File, name: str, kind: str) -> h5py.h5a.AttrID:
    attribute = h5.attrs.get_id(name)
    if attribute.shape not in ((), (1,)):
        raise CalibrationFileError(f"attribute {name} has shape {attribute.shape}; it must be a single {kind}")
    return attribute


def _text_attribute(h5: h5py.File, name: str) -> str:
    """A scalar string attribute of at most :data:`MAX_TEXT` characters (fixed or variable length)."""
    attribute = _attribute_id(h5, name, "text")
    if h5py.check_string_dtype(attribute.dtype) is None:
        raise CalibrationFileError(f"attribute {name} holds {attribute.dtype} values; it must be text")
    value = h5.attrs[name]
    value = value.reshape(-1)[0] if isinstance(value, np.ndarray) else value
    text = value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)
    if len(text) > MAX_TEXT:
        raise CalibrationFileError(f"attribute {name} holds {len(text)} characters, more than {MAX_TEXT}")
    return text


def _check_count_attribute(h5: h5py.File, name: str) -> None:
    """A scalar integer attribute >= 0."""
    attribute = _attribute_id(h5, name, "integer")
    if attribute.dtype.kind not in "iu":
        raise CalibrationFileError(f"attribute {name} holds {attribute.dtype} values; it must be an integer")
    value = int(np.asarray(h5.attrs[name]).reshape(-1)[0])
    if value < 0:
        raise CalibrationFileError(f"attribute {name} is {value}; it must be >= 0")


def _json_attribute(h5: h5py.File, name: str) -> object:
    """A text attribute read as JSON (``NaN`` and ``Infinity`` parse, for the range checks to refuse)."""
    text = _text_attribute(h5, name)
    try:
        return json.loads(text)
    except RecursionError:
        raise CalibrationFileError(f"attribute {name} is JSON nested too deeply to read") from None
    except ValueError as error:
        raise CalibrationFileError(f"attribute {name} is not JSON text: {error}") from None


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _range(value: object, where: str, unit: str, lowest: float, *, positive: bool = False, upper: float = math.inf) -> tuple[float, float]:
    """``[lo, hi]``: two finite numbers, ``lowest <= lo <= hi <= upper`` (``lo > lowest`` when ``positive``)."""
    units = f" ({unit})" if unit else ""
    bound = f"{'>' if positive else '>='} {lowest:g}" + (f", hi <= {upper:g}" if math.isfinite(upper) else "")
    rule = f"must be [lo, hi]{units}: two finite numbers, lo {bound}, lo <= hi"
    lo, hi = (float(value[0]), float(value[1])) if isinstance(value, list) and len(value) == 2 and all(_number(v) for v in value) else (math.nan,) * 2
    if not (math.isfinite(lo) and math.isfinite(hi) and (lo > lowest if positive else lo >= lowest) and lo <= hi <= upper):
        raise CalibrationFileError(f"{where} {rule}; got {_shown(value)}")
    return lo, hi


def _shown(value: object) -> str:
    """``value`` as JSON for a message, cut at 80 characters."""
    text = json.dumps(value)
    return text if len(text) <= 80 else text[:77] + "..."


__all__ = ["QUANTILES", "RANGE_RTOL", "Calibration", "CalibrationFileError", "read_calibration", "within", "write_calibration"]
