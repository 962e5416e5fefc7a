"""A resolved measured scene: recorded cars in a line, the couplers whose forces are sought, the estimators.

Geometry and signs are those of impact scenes (:mod:`femref.scene.impact`).
"""

from __future__ import annotations

from dataclasses import dataclass

from femref.core.body import Body
from femref.sensing.calibration import Calibration
from femref.sensing.findings import StatedSpeed
from femref.sensing.network import NetworkEstimator
from femref.sensing.recordings import AntiAlias, RecordFile


@dataclass(frozen=True, eq=False)
class MeasuredCar:
    """A recorded car: its body (None when only the mass and length are known), mass (kg), length (m) and
    sensors (name → x, m)."""

    name: str
    body: Body | None
    mass: float
    length: float
    sensors: dict[str, float]

    @property
    def half_length(self) -> float:
        return 0.5 * self.length


@dataclass(frozen=True)
class MeasuredCoupler:
    """Coupler ``name`` between car ``rear`` and car ``rear + 1``."""

    name: str
    rear: int

    @property
    def front(self) -> int:
        return self.rear + 1


@dataclass(frozen=True)
class Checks:
    """The alarm force limit (N), the gear's rated closure force (N) and the wear tolerance (fraction); None: not checked."""

    alarm: float | None = None
    rated_closure_force: float | None = None
    wear_tolerance: float = 0.15


@dataclass(frozen=True)
class KalmanModel:
    """The kalman estimator's cars — rigid mode and ``modes`` elastic modes — and the tolerances of the
    declared cars: masses ±``mass_tolerance``, mode frequencies ±``frequency_tolerance``, viscosity × the
    ``damping_factors`` (low, high); ``car_mass_tolerances`` per car the tolerance of its measured mass (None, or
    no entry: declared)."""

    modes: int = 4
    mass_tolerance: float = 0.05
    frequency_tolerance: float = 0.15
    damping_factors: tuple[float, float] = (0.6, 1.6)
    car_mass_tolerances: tuple[float | None, ...] = ()

    def mass_tolerance_of(self, car: int) -> tuple[float, str]:
        """Car ``car``'s relative mass tolerance and whether its mass was ``measured`` (its own) or ``declared`` (the
        common ``mass_tolerance``)."""
        stated = self.car_mass_tolerances[car] if car < len(self.car_mass_tolerances) else None
        return (self.mass_tolerance, "declared") if stated is None else (stated, "measured")


@dataclass(frozen=True, eq=False)
class MeasuredScene:
    """Record files, cars and couplers, how events are cut (``trigger`` and ``rearm`` m/s², None: the default
    re-arm level; ``pre``, ``post``, ``quiet``, ``max_window`` s; :mod:`femref.sensing.trigger`), the
    estimators run on each event (by name; the saved ``networks`` run after them), the kalman estimator's
    car model and the checks; the closing speeds the user has (radar, wayside), which replace the estimates."""

    records: tuple[RecordFile, ...]
    cars: tuple[MeasuredCar, ...]
    couplers: tuple[MeasuredCoupler, ...]
    trigger: float
    pre: float
    post: float
    rearm: float | None
    quiet: float
    max_window: float
    estimators: tuple[str, ...]
    kalman: KalmanModel = KalmanModel()
    networks: tuple[NetworkEstimator, ...] = ()
    checks: Checks = Checks()
    calibration: Calibration | None = None
    closing_speeds: tuple[StatedSpeed, ...] = ()

    kind = "measured"

    @property
    def anti_alias(self) -> dict[str, AntiAlias | None]:
        """``"<car>/<sensor>"`` → the anti-alias filter its recorder declared (None: not declared)."""
        return {source.probe: record.anti_alias for record in self.records for source in record.channels}

    @property
    def probes(self) -> dict[str, tuple[int, float]]:
        """``"<car>/<sensor>"`` → (car index, x)."""
        return {f"{car.name}/{name}": (i, x) for i, car in enumerate(self.cars) for name, x in car.sensors.items()}

    def facts(self) -> dict[str, list[str]]:
        """The ``/scene`` attributes of the event file (:class:`femref.events.EventWriter`): the cars', couplers' and
        estimators' names."""
        return {"cars": [car.name for car in self.cars], "couplers": [c.name for c in self.couplers], "estimators": list(self.estimators)}


__all__ = ["Checks", "KalmanModel", "MeasuredCar", "MeasuredCoupler", "MeasuredScene"]
