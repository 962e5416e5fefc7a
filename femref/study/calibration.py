"""A calibration run: each inverse estimator (and saved network) on the fem records of a sweep, its relative peak errors kept.

:func:`calibrate` reads a sweep's result file (the sweep's impacts — speeds, cars, gears,
measurement chain — are the distribution the bounds hold for), rebuilds each ok sample's scene,
runs every inverse estimator (:mod:`femref.estimators.inverse`), and any saved networks given, on the
sample's stored fixed-length fem records (through the measurement chain when the sweep has one;
they start at contact: a network also reads them started ±:data:`CONTACT_JITTER` from it, the
error of finding the contact in measured records) and keeps

    e = P̂ / P − 1      (P̂ the estimator's peak, P fem's peak of the coupler)

per sample, with the ranges the sweep covered: the closing speed ``v_rear − v_front`` of the
coupler's cars, every car's mass, its measurement chain (one anti-alias corner; the sensor
noise range) and its impact type (one coupler contact). :mod:`femref.sensing.calibration` holds and reads the
result; a measured case names the file under ``calibration:``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from femref.core.catalog import ESTIMATORS as INVERSE_ESTIMATORS
from femref.models import ProgressFor
from femref.sensing.calibration import Calibration
from femref.sensing.measurement import Measurement
from femref.sensing.network import AnnEstimator
from femref.sensing.records import record_times
from femref.study.run import read_set
from femref.sweep.spec import Sweep


CONTACT_JITTER = 5.0e-4
"""s: how far the contact a measured case finds for a network may be off (``femref.estimators.kalman.KalmanEstimator.contact``:
within 0.5 ms on the default scene at 1–3 m/s). A network is calibrated on each sample's records started at
the contact and at ± this, so its band carries that error too."""


def calibrate(sweep: Sweep, results: Path, coupler: str | None = None, networks: Sequence[AnnEstimator] = (),
              progress_for: ProgressFor | None = None) -> Calibration:
    """The calibration of every inverse estimator, and of the saved ``networks``, on the ok samples of
    ``sweep``'s result file ``results`` (``coupler``: default the first). ValueError when the sweep has no
    fem run or too few samples, or a network cannot read the sweep's records (another coupler, probes
    the sweep did not record, records shorter than it reads, another measurement chain).

    ``progress_for(stage)``, if given, is called when a stage starts — ``read <results name>`` (the
    samples read and their scenes rebuilt), then each estimator's and network's name — and the
    callback it may return gets ``(done, total)`` samples after each sample of that stage.
    """
    from femref.estimators.inverse import ESTIMATORS

    def stage(label: str) -> Callable[[int, int], None]:
        callback = progress_for(label) if progress_for is not None else None
        return callback if callback is not None else lambda done, total: None

    step = stage(f"read {Path(results).name}")
    data = read_set(sweep, Path(results))
    step(1, 1)
    if "fem" not in data.data.models:
        raise ValueError(f"{results}: the sweep has no fem run (models: {', '.join(data.data.models)}); the errors are measured against fem")
    if data.index.size < 20:
        raise ValueError(f"{results}: {data.index.size} usable samples; a 95 % band needs at least 20")
    coupler = coupler or data.data.couplers[0]
    t = record_times(data.data.record_length, data.data.record_end)
    truth = data.peaks("fem", coupler)
    records = data.data.records["fem"]
    samples = [{p: records[i, c] for c, p in enumerate(data.data.probes)} for i in data.index]
    count = data.index.size
    errors = {name: np.empty(count) for name in INVERSE_ESTIMATORS}
    for name in INVERSE_ESTIMATORS:
        step = stage(name)
        for row, scene in enumerate(data.scenes):
            errors[name][row] = float(np.max(ESTIMATORS[name](scene, t, samples[row])[coupler])) / truth[row] - 1.0
            step(row + 1, count)
    masses_of = [{name: float(data.car_masses[row, k]) for k, name in enumerate(data.car_names)} for row in range(count)]
    for network in networks:
        _check_network(network, coupler, data.data.probes, data.data.record_end, data.scenes[0].measurement, results)
        step = stage(network.name)
        found = []
        for row in range(count):
            found += [network.peak_force(t - shift, samples[row], masses_of[row]) / truth[row] - 1.0 for shift in (-CONTACT_JITTER, 0.0, CONTACT_JITTER)]
            step(row + 1, count)
        errors[network.name] = np.array(found)
    pair = next(c for c in data.scenes[0].couplers if c.name == coupler)
    speeds = [scene.cars[pair.rear].velocity - scene.cars[pair.front].velocity for scene in data.scenes]
    masses = data.car_masses
    chains = [scene.measurement for scene in data.scenes]
    corners = {None if chain is None else chain.lowpass for chain in chains}
    if len(corners) > 1:
        raise ValueError(f"{results}: the sweep's samples went through different anti-alias filters ({', '.join(map(str, corners))}); calibrate one chain at a time")
    noise = [0.0 if chain is None else chain.noise for chain in chains]
    contacts = {next(c for c in scene.couplers if c.name == coupler).coupling.contact for scene in data.scenes}
    if len(contacts) > 1:
        raise ValueError(f"{results}: the sweep's coupler {coupler} is compression-only in some samples and bilateral in others; calibrate one impact type at a time")
    return Calibration(
        coupler=coupler,
        errors=errors,
        closing_speed=(float(min(speeds)), float(max(speeds))),
        masses={name: (float(masses[:, k].min()), float(masses[:, k].max())) for k, name in enumerate(data.car_names)},
        lowpass=corners.pop(),
        noise=(float(min(noise)), float(max(noise))),
        impact_type="free_to_roll" if contacts.pop() == "compression_only" else "coupled",
        sweep_yaml=data.data.sweep_yaml,
    )


def _check_network(network: AnnEstimator, coupler: str, probes: Sequence[str], record_end: float, chain: Measurement | None, results: Path) -> None:
    """A network calibrated on a sweep reads its coupler, from probes the sweep recorded, over a span it
    stored, through the chain it was trained on."""
    contract = network.contract
    if contract.coupler != coupler:
        raise ValueError(f"network {network.name} estimates coupler {contract.coupler}, not the calibrated {coupler}")
    missing = [p for p in contract.probes if p not in probes]
    if missing:
        raise ValueError(f"network {network.name} reads {', '.join(missing)}, which {results} did not record")
    if contract.record_end > record_end + 1e-12:
        raise ValueError(f"network {network.name} reads {contract.record_end:g} s of records; {results} stored {record_end:g} s")
    trained = contract.measurement
    same = (trained is None) == (chain is None) and (trained is None or trained.lowpass == chain.lowpass)  # type: ignore[union-attr]
    if not same:
        raise ValueError(f"network {network.name} was trained on records through {trained}; {results}'s went through {chain}")


__all__ = ["CONTACT_JITTER", "calibrate"]
