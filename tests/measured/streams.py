"""Synthetic recordings of a yard's impacts for the streaming tests: two recorders, one per car, written as a logger
writes them (a sequence of files), with the truth they were made from.

Two 80 t cars (``a`` behind ``b``) meet in half-sine coupler pulses (1 MN, 80 ms): car ``a`` decelerates by ``P/m``,
car ``b`` accelerates by as much (the rigid-body pulses equal and opposite), each channel rings after the contact
(an 18 Hz mode decaying in 0.3 s) and carries 0.05 m/s² of seeded noise. Recorder ``r1`` (``a/front``, ``a/center``)
keeps the reference time; recorder ``r2`` (``b/rear``, ``b/center``, ``b/front``) samples at 1 kHz on its own clock,
which gains ``drift`` ppm and is ``offset`` s ahead, ``τ = offset + (1 + drift·1e-6) t``, and may restart after a gap
with another offset (a logger rebooted and re-synced). Every file holds its time dataset in s (HDF5) or column (CSV).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
import yaml

RATE = 1000.0  # Hz
MASS = 8.0e4  # kg, each car
PEAK, CONTACT = 1.0e6, 0.08  # N, s
RING, RING_FREQUENCY, RING_DECAY = 0.6, 18.0, 0.3  # m/s², Hz, s
NOISE = 0.05  # m/s²
PROBES = {"r1": ("a/front", "a/center"), "r2": ("b/rear", "b/center", "b/front")}


@dataclass(frozen=True)
class Restart:
    """Recorder r2 stops at ``time`` (s, true time) for ``gap`` s and comes back with clock offset ``offset`` (s)."""

    time: float
    gap: float
    offset: float


@dataclass(frozen=True)
class Stream:
    """The written stream: the case file, the impacts' contact times (s, true time) and r2's clock."""

    case: Path
    impacts: np.ndarray
    drift: float
    offset: float
    restart: Restart | None

    def correction(self, tau: float) -> float:
        """The true correction (s) of r2's clock reading ``tau``: the true time less ``tau``."""
        offset = self.offset
        if self.restart is not None and tau > self.offset + (1 + self.drift * 1e-6) * self.restart.time:
            offset = self.restart.offset
        return (tau - offset) / (1 + self.drift * 1e-6) - tau


def impact_times(duration: float, count: int, seed: int) -> np.ndarray:
    """``count`` contact times (s) spread over ``duration``, at least 25 s apart and 20 s from the ends."""
    rng = np.random.default_rng(seed)
    base = np.linspace(30.0, duration - 30.0, count)
    spacing = base[1] - base[0] if count > 1 else duration
    return np.sort(base + rng.uniform(-0.2, 0.2, count) * min(spacing - 25.0, 40.0))


def accelerations(t: np.ndarray, impacts: np.ndarray, sign: float, probes: tuple[str, ...], rng: np.random.Generator) -> np.ndarray:
    """The probes' accelerations (probes × samples, m/s²) at the true times ``t``: each impact's rigid-body pulse
    ``sign · P/m``, each channel's ringing, and noise."""
    a = rng.normal(0.0, NOISE, (len(probes), t.size))
    for contact in impacts:
        lo, hi = np.searchsorted(t, [contact, contact + 3.0])
        s = t[lo:hi] - contact
        pulse = sign * PEAK / MASS * np.where(s < CONTACT, np.sin(np.pi * s / CONTACT), 0.0)
        for k in range(len(probes)):
            a[k, lo:hi] += pulse + RING * np.exp(-s / RING_DECAY) * np.sin(2 * np.pi * RING_FREQUENCY * s + 0.7 * k)
    return a


def write_stream(folder: Path, duration: float, impacts: np.ndarray, *, files: int = 1, cuts: list[float] | None = None, drift: float = 0.0,
                 offset: float = 0.0, restart: Restart | None = None, estimate: bool = False, fmt: str = "h5", seed: int = 0) -> Stream:
    """The two recorders' files in ``folder`` (``r1_<k>``, ``r2_<k>``; ``files`` of equal length each, or cut at the
    true times ``cuts``) and the measured case reading them (``case.yaml``; r2's clock estimated with ``estimate``)."""
    rng = np.random.default_rng(seed)
    t1 = np.arange(int(duration * RATE)) / RATE
    scale = 1 + drift * 1e-6
    tau = offset + np.arange(int(duration * RATE * scale)) / RATE
    true = (tau - offset) / scale
    if restart is not None:
        before = true < restart.time
        tau_after = restart.offset + scale * (restart.time + restart.gap) + np.arange(int((duration - restart.time - restart.gap) * RATE * scale)) / RATE
        tau = np.concatenate([tau[before], tau_after])
        true = np.concatenate([true[before], (tau_after - restart.offset) / scale])
    keep = true < duration
    tau, true = tau[keep], true[keep]
    recorded = {"r1": (t1, t1, accelerations(t1, impacts, -1.0, PROBES["r1"], rng)), "r2": (tau, true, accelerations(true, impacts, 1.0, PROBES["r2"], rng))}
    records = []
    for name, (clock, truth, a) in recorded.items():
        bounds = np.searchsorted(truth, cuts) if cuts is not None else np.linspace(0, clock.size, files + 1).astype(int)[1:-1]
        if restart is not None and name == "r2" and cuts is None:
            bounds = np.searchsorted(truth, [restart.time])
        for k, (times, values) in enumerate(zip(np.split(clock, bounds), np.split(a, bounds, axis=1))):
            _write(folder / f"{name}_{k:02d}.{fmt}", times, dict(zip(PROBES[name], values)))
        key = "dataset" if fmt == "h5" else "column"
        records.append({"recorder": name, "files": [f"{name}_*.{fmt}"], "time": {key: "t", "unit": "s"},
                        "channels": {probe: {key: probe.replace("/", "_"), "unit": "m/s^2"} for probe in PROBES[name]},
                        **({"clock_drift": "estimate"} if estimate and name == "r2" else {})})
    case = {
        "kind": "measured",
        "records": records,
        "cars": [{"name": "a", "mass": MASS, "length": 17.0, "sensors": {"front": 8.0, "center": 0.0}},
                 {"name": "b", "mass": MASS, "length": 17.0, "sensors": {"rear": -8.0, "center": 0.0, "front": 8.0}}],
        "couplers": [{"name": "c1", "between": ["a", "b"]}],
        "events": {"trigger": 3.0, "pre": 0.05, "post": 0.5},
        "estimators": ["inverse_rigid"],
    }
    path = folder / "case.yaml"
    path.write_text(yaml.safe_dump(case, sort_keys=False))
    return Stream(path, impacts, drift, offset, restart)


def _write(path: Path, t: np.ndarray, channels: dict[str, np.ndarray]) -> None:
    if path.suffix == ".h5":
        with h5py.File(path, "w") as h5:
            h5["t"] = t
            for probe, a in channels.items():
                h5[probe.replace("/", "_")] = a
        return
    header = ",".join(["t", *(probe.replace("/", "_") for probe in channels)])
    np.savetxt(path, np.column_stack([t, *channels.values()]), delimiter=",", header=header, comments="", fmt="%.17g")
