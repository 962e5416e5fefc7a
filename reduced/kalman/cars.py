"""The cars as the caller declares them: each car's linear dynamics and accelerometers
(:class:`CarDynamics`), the recorders' anti-alias low-pass (:class:`SensorFilter`), the pair
joined by one coupler force (:class:`CoupledCars`) and a line of cars joined by ``n_c`` coupler
forces (:class:`ConsistCars`); the model's equations open :mod:`reduced.kalman`.

Recorders' anti-alias filter (:class:`SensorFilter`, ``CoupledCars.sensor_filter``): a channel
that passes an analogue low-pass before it is sampled is modelled as such — the filter's
states ``w`` join the state (before ``P``), driven by the channel's acceleration, and the
sample is the filter's output, ``ẇ = A_f w + b_f (H z)``, ``y = c_f w + v``. Ignored, a
100 Hz 4th-order filter delays the force by its group delay (≈ 4 ms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from reduced import _checks

FloatArray = NDArray[np.float64]


def _matrix(name: str, value: ArrayLike, shape: tuple[int, int]) -> FloatArray:
    a = np.atleast_2d(np.asarray(value, dtype=float))
    if a.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values")
    return a


@dataclass(frozen=True, eq=False)
class CarDynamics:
    """One car: ``M q̈ + C q̇ + K q = B L``, ``L = B_c P``, accelerometers ``a = O q̈``.

    ``mass`` M (n × n, symmetric positive definite), ``damping`` C and ``stiffness`` K
    (n × n, symmetric; K positive semi-definite, its null space the rigid-body motion,
    which C must not damp), ``load_map`` B (n × J: generalised force of each end load),
    ``sensor_map`` O (S × n), ``coupler_load`` B_c (J × n_c: end loads per unit
    compression-positive force ``P_c`` of each coupler of the line; a vector of J is one
    coupler — a rod's rear car ``(0, −1)``, front car ``(−1, 0)``; in a line of rods, car ``i``
    has ``(−1, 0)`` in column ``i − 1``, the coupler at its −l end, and ``(0, −1)`` in column
    ``i``, the coupler at its +l end).
    """

    mass: FloatArray
    damping: FloatArray
    stiffness: FloatArray
    load_map: FloatArray
    sensor_map: FloatArray
    coupler_load: FloatArray

    def __post_init__(self) -> None:
        m = np.atleast_2d(np.asarray(self.mass, dtype=float))
        n = m.shape[0]
        bmap = np.asarray(self.load_map, dtype=float)
        bmap = bmap.reshape(n, -1) if bmap.ndim <= 1 else bmap
        omap = np.atleast_2d(np.asarray(self.sensor_map, dtype=float))
        b = np.asarray(self.coupler_load, dtype=float)
        object.__setattr__(self, "mass", _matrix("mass", m, (n, n)))
        object.__setattr__(self, "damping", _matrix("damping", self.damping, (n, n)))
        object.__setattr__(self, "stiffness", _matrix("stiffness", self.stiffness, (n, n)))
        object.__setattr__(self, "load_map", _matrix("load_map", bmap, (n, bmap.shape[-1])))
        object.__setattr__(self, "sensor_map", _matrix("sensor_map", omap, (omap.shape[0], n)))
        j = self.load_map.shape[1]
        if b.ndim not in (1, 2) or b.shape[0] != j or b.size == 0 or not np.all(np.isfinite(b)):
            raise ValueError(f"coupler_load must be finite, {j} end loads (× couplers), got shape {b.shape}")
        object.__setattr__(self, "coupler_load", b)
        for name in ("mass", "damping", "stiffness"):
            a = getattr(self, name)
            if not np.allclose(a, a.T, rtol=1e-10, atol=1e-12 * np.max(np.abs(a), initial=0.0)):
                raise ValueError(f"{name} must be symmetric")

    @property
    def channels(self) -> int:
        """Number of accelerometer channels S."""
        return int(self.sensor_map.shape[0])

    @property
    def coupler_map(self) -> FloatArray:
        """``B_c`` as J × n_c (a one-coupler vector as its column)."""
        return self.coupler_load.reshape(self.coupler_load.shape[0], -1)


@dataclass(frozen=True)
class SensorFilter:
    """The analogue anti-alias low-pass every channel passes before it is sampled: a Butterworth of
    ``order`` at ``corner`` Hz, ``|H(iω)|² = 1/(1 + (ω/ω_c)^{2N})``, ``ω_c = 2π corner``.

    As states (unit DC gain): for ``k = 1 … ⌊N/2⌋`` a second-order section with damping ratio
    ``ζ_k = sin((2k − 1)π/(2N))`` and states ``(x, v = ẋ/ω_c)``::

        ẋ = ω_c v,   v̇ = ω_c (u − x − 2 ζ_k v)

    and, for odd ``N``, a first-order section ``ẋ = ω_c (u − x)``; the sections in cascade, the
    channel's model acceleration ``u`` into the first, the last section's ``x`` sampled. The poles
    are ``ω_c e^{iπ(2k+N−1)/(2N)}``, the analogue Butterworth's.
    """

    corner: float
    order: int = 4

    def __post_init__(self) -> None:
        _checks.positive("corner", self.corner)
        if not isinstance(self.order, int) or isinstance(self.order, bool) or not 1 <= self.order <= 8:
            raise ValueError(f"order must be an integer in 1 … 8, got {self.order!r}")

    def state_space(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(A_f, b_f, c_f)`` of one channel: ``ẇ = A_f w + b_f u``, sampled output ``c_f w``."""
        n, omega = self.order, 2.0 * math.pi * self.corner
        a, b = np.zeros((n, n)), np.zeros(n)
        previous = None  # state index of the previous section's output x
        row = 0
        for k in range(1, n // 2 + 1):
            zeta = math.sin((2 * k - 1) * math.pi / (2 * n))
            a[row, row + 1] = omega
            a[row + 1, row], a[row + 1, row + 1] = -omega, -2.0 * zeta * omega
            if previous is None:
                b[row + 1] = omega
            else:
                a[row + 1, previous] = omega
            previous, row = row, row + 2
        if n % 2:
            a[row, row] = -omega
            if previous is None:
                b[row] = omega
            else:
                a[row, previous] = omega
            previous = row
        out = np.zeros(n)
        out[previous] = 1.0
        return a, b, out


class _FilteredChannels:
    """What a line of cars derives from its ``sensor_filter`` and ``channels`` (both :class:`CoupledCars` and
    :class:`ConsistCars`)."""

    sensor_filter: SensorFilter | tuple[SensorFilter | None, ...] | None
    channels: int

    @property
    def channel_filters(self) -> tuple[SensorFilter | None, ...]:
        """Each channel's anti-alias filter (None: unfiltered)."""
        if isinstance(self.sensor_filter, tuple):
            return self.sensor_filter
        return (self.sensor_filter,) * self.channels


@dataclass(frozen=True, eq=False)
class CoupledCars(_FilteredChannels):
    """The rear (hammer) and front (anvil) car joined by the coupler force ``P``.

    Accelerometer channels are ordered rear first, then front: a record is
    ``N × (S_rear + S_front)``. ``sensor_filter``: the recorders' anti-alias low-pass, one for
    every channel or one per channel (None: sampled unfiltered).
    """

    rear: CarDynamics
    front: CarDynamics
    sensor_filter: SensorFilter | tuple[SensorFilter | None, ...] | None = None

    def __post_init__(self) -> None:
        for name, car in (("rear", self.rear), ("front", self.front)):
            if car.coupler_map.shape[1] != 1:
                raise ValueError(f"{name}.coupler_load: one coupler between two cars, got {car.coupler_map.shape[1]} (ConsistCars)")
        if isinstance(self.sensor_filter, tuple) and len(self.sensor_filter) != self.channels:
            raise ValueError(f"sensor_filter: one per channel ({self.channels}), got {len(self.sensor_filter)}")

    @property
    def channels(self) -> int:
        """Total number of accelerometer channels."""
        return self.rear.channels + self.front.channels

    @property
    def cars(self) -> tuple[CarDynamics, ...]:
        """The cars in channel order: rear, front."""
        return (self.rear, self.front)

    @property
    def couplers(self) -> int:
        """One coupler force."""
        return 1

    def with_cars(self, cars: tuple[CarDynamics, ...]) -> CoupledCars:
        """This model with ``cars`` (rear, front) in place of its own, its sensor filter kept."""
        return CoupledCars(*cars, self.sensor_filter)


@dataclass(frozen=True, eq=False)
class ConsistCars(_FilteredChannels):
    """A line of cars joined by ``n_c`` coupler forces ``P_1 … P_{n_c}``: every car's
    ``coupler_load`` is J × n_c over the same couplers (a car a coupler does not touch has a zero
    column). Channels are ordered car by car; a car with no channel (``sensor_map`` 0 × n) is
    uninstrumented and still moves with the line. ``sensor_filter`` as in :class:`CoupledCars`.
    """

    cars: tuple[CarDynamics, ...]
    sensor_filter: SensorFilter | tuple[SensorFilter | None, ...] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "cars", tuple(self.cars))
        if len(self.cars) < 2 or not all(isinstance(c, CarDynamics) for c in self.cars):
            raise ValueError(f"cars must be two or more CarDynamics, got {len(self.cars)}")
        counts = {c.coupler_map.shape[1] for c in self.cars}
        if len(counts) != 1:
            raise ValueError(f"cars[*].coupler_load: every car over the same couplers, got counts {sorted(counts)}")
        if self.channels == 0:
            raise ValueError("cars[*].sensor_map: no car is instrumented")
        if isinstance(self.sensor_filter, tuple) and len(self.sensor_filter) != self.channels:
            raise ValueError(f"sensor_filter: one per channel ({self.channels}), got {len(self.sensor_filter)}")

    @property
    def channels(self) -> int:
        """Total number of accelerometer channels."""
        return sum(c.channels for c in self.cars)

    @property
    def couplers(self) -> int:
        """Number of coupler forces n_c."""
        return int(self.cars[0].coupler_map.shape[1])

    def with_cars(self, cars: tuple[CarDynamics, ...]) -> ConsistCars:
        """This line with ``cars`` in place of its own, its sensor filter kept."""
        return ConsistCars(cars, self.sensor_filter)


__all__ = [
    "CarDynamics",
    "ConsistCars",
    "CoupledCars",
    "SensorFilter",
]
