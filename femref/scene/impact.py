"""A resolved impact scene: cars in a line, couplers between neighbours, model runs.

Geometry and signs (docs/design.md §2, §3): coupler ``j`` joins the front (``x = +l``) of car ``rear`` to
the back (``x = −l``) of car ``rear + 1``. Its closure ``δ = u_rear(+l) − u_front(−l)`` is positive when the
coupler is compressed, and its force ``P`` is positive in compression (buff): the rear car carries the end
load ``F2 = −P``, the front car ``F1 = −P`` (internal axial force at the end, tension positive).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from femref.core.body import Body
from femref.fem.build import FemSettings
from femref.sensing.measurement import Measurement
from femref.sensing.network import NetworkEstimator
from reduced.couplers import Coupling


#: What a sensor records, in the order of a car's sensor outputs: every sensor's axial motion, then — on a
#: car that bends — every sensor's vertical motion, then its pitch. Result names: ``<prefix>displacement``
#: and ``<prefix>acceleration`` (m, m/s²; pitch: rad, rad/s²).
AXIAL, VERTICAL, PITCH = "", "vertical_", "pitch_"


@dataclass(frozen=True, eq=False)
class Car:
    """One car body (a rod on ``x ∈ [−l, l]``), its initial velocity (m/s) and sensors (name → x, m).

    ``bending`` is the body's bending as a beam on the same axis (same length and mass; None: the car
    does not bend); ``coupler_offset`` the height (m) of the neutral axis above the coupler line at the
    rear (−l) and front (+l) end: the coupler force ``F`` there also loads the car with the end moment
    ``offset · F``; ``coupler_slope`` the inclination of the coupler at each end (up toward the front):
    its force also pushes the car vertically, ``slope · F`` (docs/design.md §2)."""

    name: str
    body: Body
    velocity: float
    sensors: dict[str, float]
    bending: Body | None = None
    coupler_offset: tuple[float, float] = (0.0, 0.0)
    coupler_slope: tuple[float, float] = (0.0, 0.0)

    @property
    def mass(self) -> float:
        """Total mass ``M = ∫ m dx`` (kg)."""
        return self.body.total_mass

    @property
    def bends(self) -> bool:
        return self.bending is not None

    @property
    def channels(self) -> tuple[tuple[str, str], ...]:
        """``(probe, quantity prefix)`` of each sensor output row, in row order (:data:`AXIAL`, :data:`VERTICAL`,
        :data:`PITCH`)."""
        kinds = (AXIAL, VERTICAL, PITCH) if self.bends else (AXIAL,)
        return tuple((f"{self.name}/{sensor}", kind) for kind in kinds for sensor in self.sensors)

    @property
    def sensor_x(self) -> np.ndarray:
        return np.array(list(self.sensors.values()), dtype=float)


@dataclass(frozen=True, eq=False)
class Coupler:
    """Coupler ``name`` between car ``rear`` (its +l end) and car ``rear + 1`` (its −l end)."""

    name: str
    rear: int
    coupling: Coupling

    @property
    def front(self) -> int:
        return self.rear + 1


@dataclass(frozen=True)
class ModelRun:
    """One model run of the scene: its result-group name and the fidelity of each car (line order)."""

    name: str
    fidelity: tuple[str, ...]

    @property
    def uniform(self) -> str | None:
        """The fidelity shared by every car, or None for a mixed run."""
        return self.fidelity[0] if len(set(self.fidelity)) == 1 else None


@dataclass(frozen=True, eq=False)
class ImpactScene:
    """A resolved impact scene: ``dt`` None when the runner is to choose it; ``modal_modes`` elastic modes per modal
    car; the inverse ``estimators`` (by name) and loaded ``networks`` run on the fem sensor records."""

    cars: tuple[Car, ...]
    couplers: tuple[Coupler, ...]
    runs: tuple[ModelRun, ...]
    end: float
    dt: float | None = None
    output_stride: int = 1
    integrator: str = "generalized_alpha"
    rho_inf: float = 0.8
    fem: FemSettings = field(default_factory=FemSettings)
    modal_modes: int = 4
    measurement: Measurement | None = None
    estimators: tuple[str, ...] = ()
    networks: tuple[NetworkEstimator, ...] = ()

    kind = "impact"

    @property
    def models(self) -> tuple[str, ...]:
        return tuple(run.name for run in self.runs)

    @property
    def probes(self) -> dict[str, tuple[int, float]]:
        """``"<car>/<sensor>"`` → (car index, x)."""
        return {f"{car.name}/{name}": (i, x) for i, car in enumerate(self.cars) for name, x in car.sensors.items()}

    @property
    def channels(self) -> tuple[tuple[str, str], ...]:
        """Every car's sensor output rows in line order: ``(probe, quantity prefix)`` (:attr:`Car.channels`)."""
        return tuple(channel for car in self.cars for channel in car.channels)

    def contact_time(self) -> float:
        """Shortest rigid-body contact half-period ``π √(M_eff / k)`` over the couplers (s), ``M_eff = M_rear M_front /
        (M_rear + M_front)``, ``k`` the law's reference stiffness: the pulse's time scale, for ε and the time step."""
        times = []
        for c in self.couplers:
            m1, m2 = self.cars[c.rear].mass, self.cars[c.front].mass
            times.append(math.pi * math.sqrt(m1 * m2 / (m1 + m2) / c.coupling.law.reference_stiffness))
        return min(times, default=math.inf)

    @property
    def wave_travel_time(self) -> float:
        """The longest wave travel time of the cars (s): axial ``l√(m/EA)``, and ``l²√(m/EI)`` of a car that
        bends (its first bending mode is usually far below its first axial one)."""
        return max(max(car.body.wave_travel_time, car.bending.wave_travel_time if car.bending is not None else 0.0) for car in self.cars)

    @property
    def epsilon(self) -> float:
        """``ε = (T_wave / T_load)²`` of the softest car (axially or, if it bends, in bending), ``T_load`` the
        contact time (the pulse length)."""
        return (self.wave_travel_time / self.contact_time()) ** 2

    def facts(self) -> dict[str, float | str]:
        """The ``/scene`` attributes of the result file (docs/design.md §4); ``load_time`` is the contact time (s)."""
        return {
            "kind": self.kind,
            "epsilon": float(self.epsilon),
            "wave_travel_time": self.wave_travel_time,
            "load_time": self.contact_time(),
        }
