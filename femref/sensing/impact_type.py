"""The impact type of a set of sensor records: free to roll or coupled (docs/formulas.md §B).

A free-to-roll impact changes the cars' relative velocity for good, so the relative
acceleration ``a_front − a_rear`` of a coupler's two cars has a zero-frequency component; a
coupled impact (cars coupled before and after) returns it, and the zero harmonic vanishes.
:func:`reduced.signal_tools.classify_impact` decides on the ratio ``ρ = |A(0)|/max_f |A(f)|``;
here each car's acceleration is read at its sensor nearest the centre (the rigid-body motion:
a node of its first axial mode). Measured events (:mod:`femref.run.measured`) and the network
estimator that keeps one network per impact type (:class:`femref.sensing.network.ImpactTypeNetworks`)
both classify this way.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from reduced.signal_tools import ImpactClassification, classify_impact


class SensedCar(Protocol):
    name: str
    sensors: dict[str, float]


class CarPair(Protocol):
    rear: int

    @property
    def front(self) -> int: ...


def central_record(car: SensedCar, records: Mapping[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """The car's record at its sensor nearest the centre (``"<car>/<sensor>"`` in ``records``)."""
    sensor = min(car.sensors, key=lambda name: abs(car.sensors[name]))
    return np.asarray(records[f"{car.name}/{sensor}"], dtype=float)


def relative_acceleration(cars: Sequence[SensedCar], coupler: CarPair, records: Mapping[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """``a_front − a_rear`` of the coupler's two cars, each at its sensor nearest the centre (m/s²)."""
    return central_record(cars[coupler.front], records) - central_record(cars[coupler.rear], records)


def classify_records(cars: Sequence[SensedCar], coupler: CarPair, time: NDArray[np.float64],
                     records: Mapping[str, NDArray[np.float64]]) -> ImpactClassification:
    """The impact type at ``coupler`` from records on the uniform ``time`` (s): the zero harmonic of
    :func:`relative_acceleration` (:func:`reduced.signal_tools.classify_impact`; ValueError when the
    records cannot be classified)."""
    return classify_impact(relative_acceleration(cars, coupler, records), float(time[1] - time[0]))


__all__ = ["central_record", "classify_records", "relative_acceleration"]
