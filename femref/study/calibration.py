"""A calibration run: each inverse estimator on the fem records of a sweep, its relative peak errors kept.

:func:`calibrate` reads a sweep's result file (the sweep's impacts — speeds, cars, gears,
measurement chain — are the distribution the bounds hold for), rebuilds each ok sample's scene,
runs every inverse estimator (:mod:`femref.models.inverse`) on the sample's stored fixed-length
fem records (through the measurement chain when the sweep has one) and keeps

    e = P̂ / P − 1      (P̂ the estimator's peak, P fem's peak of the coupler)

per sample, with the ranges the sweep covered: the closing speed ``v_rear − v_front`` of the
coupler's cars, every car's mass, its measurement chain (one anti-alias corner; the sensor
noise range) and its impact type (one coupler contact). :mod:`femref.sensing.calibration` holds and reads the
result; a measured case names the file under ``calibration:``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femref.core.catalog import ESTIMATORS as INVERSE_ESTIMATORS
from femref.sensing.calibration import Calibration
from femref.sensing.records import record_times
from femref.study.run import read_set
from femref.sweep.spec import Sweep


def calibrate(sweep: Sweep, results: Path, coupler: str | None = None) -> Calibration:
    """The calibration of every inverse estimator on the ok samples of ``sweep``'s result file ``results``
    (``coupler``: default the first). ValueError when the sweep has no fem run or too few samples."""
    from femref.models.inverse import ESTIMATORS

    data = read_set(sweep, Path(results))
    if "fem" not in data.data.models:
        raise ValueError(f"{results}: the sweep has no fem run (models: {', '.join(data.data.models)}); the errors are measured against fem")
    if data.index.size < 20:
        raise ValueError(f"{results}: {data.index.size} usable samples; a 95 % band needs at least 20")
    coupler = coupler or data.data.couplers[0]
    t = record_times(data.data.record_length, data.data.record_end)
    truth = data.peaks("fem", coupler)
    records = data.data.records["fem"]
    errors = {name: np.empty(data.index.size) for name in INVERSE_ESTIMATORS}
    for row, (i, scene) in enumerate(zip(data.index, data.scenes)):
        sample = {p: records[i, c] for c, p in enumerate(data.data.probes)}
        for name in INVERSE_ESTIMATORS:
            errors[name][row] = float(np.max(ESTIMATORS[name](scene, t, sample)[coupler])) / truth[row] - 1.0
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


__all__ = ["calibrate"]
