"""What one model run of an impact scene gives: histories at the output steps, counters, times, status.

Both engines of :func:`femref.impact.solver.solve_impact` return it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from femref.core.energy import energy_balance_error
from femref.scene.impact import PITCH


@dataclass
class ImpactResponse:
    """Histories at the output steps of one model run of an impact scene.

    ``sensors[probe]`` holds ``displacement``, ``velocity`` and ``acceleration`` (probe ``"<car>/<sensor>"``;
    on a car that bends also ``vertical_displacement``, ``vertical_velocity``, ``vertical_acceleration``,
    ``pitch_displacement`` (rad), ``pitch_rate`` (rad/s) and ``pitch_acceleration`` (rad/s²)),
    ``couplers[name]`` ``force`` (N, compression positive) and ``closure`` (m), ``energy``
    the bookkeeping (J): ``kinetic``, ``strain``, ``body_dissipated``, ``coupler_stored``,
    ``coupler_dissipated``, ``total``; ``coupler_work`` the work the cars did on the couplers so far
    (J, ``Σ P̄ Δδ``; None from older callers). ``wall_time`` is the stepping (s); ``setup_time`` the
    building of the cars (added by whoever built them) and, compiled, their packing and factorisation.
    ``status`` is 0 when the run reached the end time, −1 when a step failed (``message`` says where;
    the histories are NaN after it).
    """

    time: NDArray[np.float64]
    sensors: dict[str, dict[str, NDArray[np.float64]]]
    couplers: dict[str, dict[str, NDArray[np.float64]]]
    energy: dict[str, NDArray[np.float64]]
    steps: int = 0
    newton_iterations: int = 0
    newton_iterations_max: int = 0
    contact_changes: int = 0
    wall_time: float = 0.0
    setup_time: float = 0.0
    car_settings: list[dict] = field(default_factory=list)
    status: int = 0
    message: str = ""
    coupler_work: NDArray[np.float64] | None = None

    @property
    def ok(self) -> bool:
        """The run reached the end time (``status == 0``)."""
        return self.status == 0

    @property
    def energy_balance_error(self) -> float:
        """:func:`energy_balance_error` of the whole line, cars and couplers: closed (``W = 0``), ``E`` the total of
        every account — the coupler forces are internal, their work on the cars is what the couplers store and
        dissipate. 0 when nothing moves."""
        return energy_balance_error(self.energy["total"])

    @property
    def car_energy_balance_error(self) -> float:
        """:func:`energy_balance_error` of the cars alone: the work of the coupler forces on them, ``−coupler_work``,
        against the change of their kinetic, strain and body-dissipated energy; it does not lean on the couplers'
        own accounts (NaN without ``coupler_work``)."""
        if self.coupler_work is None:
            return float("nan")
        cars = self.energy["kinetic"] + self.energy["strain"] + self.energy["body_dissipated"]
        return energy_balance_error(cars, -np.asarray(self.coupler_work, dtype=float))


def sensor_histories(channels: tuple[tuple[str, str], ...], displacement: NDArray[np.float64], velocity: NDArray[np.float64],
                     acceleration: NDArray[np.float64]) -> dict[str, dict[str, NDArray[np.float64]]]:
    """Column ``k`` of the output histories (``n_out × channels``) as ``sensors[probe][prefix + quantity]``,
    ``(probe, prefix)`` the k-th channel (:attr:`femref.scene.ImpactScene.channels`); a pitch row's velocity
    is its ``pitch_rate``."""
    sensors: dict[str, dict[str, NDArray[np.float64]]] = {}
    for k, (probe, prefix) in enumerate(channels):
        sensors.setdefault(probe, {})[prefix + "displacement"] = displacement[:, k]
        sensors[probe][rate_name(prefix)] = velocity[:, k]
        sensors[probe][prefix + "acceleration"] = acceleration[:, k]
    return sensors


def rate_name(prefix: str) -> str:
    """The velocity output of a channel prefix: ``velocity``, ``vertical_velocity``, and ``pitch_rate`` for pitch."""
    return "pitch_rate" if prefix == PITCH else prefix + "velocity"


def failure_message(coupler: str, step: int, steps: int, dt: float, detail: str) -> str:
    """The status message of a run whose coupler iteration failed at ``step`` (of ``steps``, step ``dt``)."""
    return f"coupler {coupler} did not converge at t = {step * dt:.6g} s (step {step} of {steps}): {detail}"


__all__ = ["ImpactResponse", "failure_message", "rate_name", "sensor_histories"]
