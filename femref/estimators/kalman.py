"""The kalman estimator: the joint input-state estimate of every coupler's force of the line (:mod:`reduced.kalman`:
each force a random walk acting equal and opposite on its two cars), one band per coupler — the envelope over the
declared cars' tolerances (:func:`reduced.kalman.estimate_forces_with_variants`: the corners of
:func:`reduced.kalman.corner_models` at the nominal's force-rate level, widened for the masses: their common scale
and, in a line of three or more cars or where the cars' tolerances differ, each car's own mass corners) — and the
contact instant found in each force. A car whose mass was measured (the case's ``cars[i].mass_tolerance``) enters
the mass corners at its own tolerance, the others at the declared ``kalman.mass_tolerance``; the common scale is the
smallest (a scale of every mass by ``s`` stays inside the box only for ``|s − 1| ≤ min_i m_i``). The force scales
with the mass, so the mass part of the band is ``≈ m P``: measured to ±0.5 % rather than declared to ±5 %, a tenth.

The model is the cars the case's couplers join (:func:`line_cars`): each its rigid mode and ``model.modes``
elastic free-free modes of its fem mesh (:data:`KALMAN_FEM`, no static correction), loaded at its ends by the
couplers it touches as the impact loop loads a line of rods (``B_c``: the rear car's ``F2`` and the front car's
``F1`` are ``−P``), observed at its recorded sensors through their recorders' declared anti-alias filters — a car
with no recorded sensor moves with the line and is not observed (virtual sensing of its couplers). Two cars and
one coupler are the special case, to the same numbers. The sensor noise sets the channels' weights and its scale
is estimated (model error shows as noise, not as force).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from femref.estimators.protocol import Recorded
from femref.events import ForceEstimate
from femref.fem.build import FemSettings
from femref.models.modal import modal_car
from femref.scene.impact import Car
from femref.scene.measured import KalmanModel
from femref.sensing.contact import ContactEstimate, onset_time
from femref.sensing.recordings import AntiAlias
from reduced import kalman

KALMAN_FEM = FemSettings(elements=64, order=2)
"""The mesh whose free-free modes make the kalman estimator's car model."""
KALMAN_NIS_RANGE = (0.25, 1.0e4)
"""Accepted noise scale λ̂ of the kalman filter (innovation variance over the sensor noise variance): below,
the records are smoother than their own quiet stretch; above 1e4 (innovations a hundred times the sensor
noise) the records are not of the declared cars at all (swapped channels, a wrong unit), and no number is
given. Measured on simulated yard impacts: λ̂ up to 54 with the declared cars exact (four modes and no
anti-alias filter in the model, against 64-element fem cars), up to 860 with cars off by their tolerances
(mass ±5 %, mode frequencies ±15 %, viscosity × 0.6–1.6, lading spread) while the peak stayed within 5 %."""


@dataclass(frozen=True)
class KalmanEstimator:
    """The kalman estimator of the cars ``model`` declares, observed through the recorders' ``anti_alias`` filters
    (``"<car>/<sensor>"`` → filter, None: not declared). Fails on every coupler of the line when it fails."""

    model: KalmanModel
    anti_alias: Mapping[str, AntiAlias | None]
    name: str = "kalman"
    coupler: None = None
    history: bool = True

    def cars(self, recorded: Recorded) -> tuple[kalman.ConsistCars, list[str]]:
        """The model of the line's couplers and the cars they join (:func:`line_cars`) and the probes in channel order."""
        dynamics, probes = [], []
        for index, loads in line_cars(len(recorded.cars), [c.rear for c in recorded.couplers]):
            car = _impact_car(recorded.cars[index], recorded.records)
            system = modal_car(car, KALMAN_FEM, self.model.modes, static_correction=False)
            dynamics.append(kalman.CarDynamics(system.mass, system.damping, system.stiffness, system.load_matrix, system.sensor_outputs, loads))
            probes += [f"{car.name}/{sensor}" for sensor in car.sensors]
        filters = tuple(None if self.anti_alias.get(p) is None else kalman.SensorFilter(self.anti_alias[p].corner, self.anti_alias[p].order) for p in probes)
        return kalman.ConsistCars(tuple(dynamics), filters), probes

    def estimate(self, recorded: Recorded) -> list[ForceEstimate]:
        """Every coupler's force; a likelihood optimum at the edge of the force-rate range, innovations outside
        :data:`KALMAN_NIS_RANGE` times the sensor noise variance, or a coupler force the records cannot observe give
        every coupler status ``untrusted`` and no number. In a line of couplers each force's contact instant
        (:meth:`contact`) is in its settings (``contact_time``, s on the records' clock, and ``contact_fit_residual``;
        NaN and ``contact_note`` where the fit found none) and in ``recorded.contacts``, where the networks read it;
        one coupler's is found when a network asks for it (a third more work on every two-car event otherwise)."""
        t, model = recorded.time, self.model
        cars, probes = self.cars(recorded)
        y = np.column_stack([recorded.records[probe] for probe in probes])
        noise = _noise(recorded, probes)
        masses = self.car_masses(recorded)
        tolerances = [tolerance for _, tolerance, _ in masses]
        per_car = len(cars.cars) > 2 or len(set(tolerances)) > 1  # two cars at one tolerance: the common scale is the box
        found = kalman.estimate_forces_with_variants(
            [cars, *kalman.corner_models(cars, model.frequency_tolerance, model.damping_factors)], t, y, noise,
            variant_force_rate="nominal", mass_tolerance=min(tolerances), car_mass_corners=tolerances if per_car else False,
            nis_range=KALMAN_NIS_RANGE)
        nominal = found[0].nominal
        settings = {"modes": model.modes, "force_rate": nominal.force_rate, "noise_scale": nominal.noise_scale, "probes": probes,
                    "declared_force_rate": nominal.force_rate / nominal.noise_scale**2,
                    "anti_alias": [None if f is None else [f.corner, f.order] for f in cars.channel_filters],
                    "mass_tolerance": model.mass_tolerance, "frequency_tolerance": model.frequency_tolerance,
                    "damping_factors": list(model.damping_factors)}
        if any(source == "measured" for _, _, source in masses):
            settings["car_masses"] = {name: {"tolerance": tolerance, "source": source} for name, tolerance, source in masses}
        names = [c.name for c in recorded.couplers]
        if found[0].status != "ok":
            nan = np.full(t.size, np.nan)
            return [ForceEstimate(self.name, name, t, nan.copy(), nan.copy(), nan.copy(), bound="covariance", status="untrusted",
                                  message=found[0].status, settings=dict(settings)) for name in names]
        estimates = [ForceEstimate(self.name, name, t, band.force, band.lower, band.upper, bound="covariance", settings=dict(settings))
                     for name, band in zip(names, found)]
        for estimate, contact in zip(estimates, self._contacts(cars, noise, recorded, estimates) if len(estimates) > 1 else ()):
            if isinstance(contact, ValueError):  # kept as a network keeps a contact it could not find
                recorded.contacts[estimate.coupler] = note = f"{type(contact).__name__}: {contact}"
                estimate.settings.update(contact_time=math.nan, contact_note=note)
            else:  # each coupler's contact, where the networks read it
                recorded.contacts[estimate.coupler] = contact
                estimate.settings.update(contact_time=contact.time, contact_fit_residual=contact.residual)
        return estimates

    def car_masses(self, recorded: Recorded) -> list[tuple[str, float, str]]:
        """``(name, relative mass tolerance, "measured" | "declared")`` of each car of the line (:func:`line_cars`): its own
        measured tolerance (``model.car_mass_tolerances``), else the declared ``model.mass_tolerance``."""
        return [(recorded.cars[index].name, *self.model.mass_tolerance_of(index))
                for index, _ in line_cars(len(recorded.cars), [c.rear for c in recorded.couplers])]

    def contact(self, recorded: Recorded, estimate: ForceEstimate) -> ContactEstimate:
        """The contact instant in this estimator's force ``estimate`` of its coupler (:func:`femref.sensing.contact.onset_time`,
        docs/formulas.md §K2): the chain the rise is fitted through is the smoother itself, its responses to a unit
        step and ramp of that coupler's force (the others at rest) the model's forced response estimated back at the
        event's force-rate level (:func:`reduced.kalman.smoothed_responses`; the smoothed mean is linear in the
        records). ValueError when the force has no rise to fit."""
        cars, probes = self.cars(recorded)
        found = self._contacts(cars, _noise(recorded, probes), recorded, [estimate])[0]
        if isinstance(found, ValueError):
            raise found
        return found

    def _contacts(self, cars: kalman.ConsistCars, noise: list[float], recorded: Recorded,
                  estimates: list[ForceEstimate]) -> list[ContactEstimate | ValueError]:
        """:meth:`contact` of each estimate (the same force rate), or the error saying why there is none; one filter for all."""
        t = recorded.time
        names = [c.name for c in recorded.couplers]
        lags = t - t[t.size // 2]
        shapes = (np.where(lags > 0.0, 1.0, 0.0), np.maximum(lags, 0.0) / (t[-1] - t[0]))
        columns, scales, forces = [names.index(e.coupler) for e in estimates], [float(np.nanmax(e.force)) for e in estimates], []
        for column, scale in zip(columns, scales):
            for shape in shapes:
                force = np.zeros((t.size, cars.couplers))
                force[:, column] = scale * shape
                forces.append(force)
        rate = float(estimates[0].settings["declared_force_rate"])
        responses = kalman.smoothed_responses(cars, t, forces, noise, rate)
        found: list[ContactEstimate | ValueError] = []
        for k, (estimate, column, scale) in enumerate(zip(estimates, columns, scales)):
            step, ramp = responses[2 * k][:, column] / scale, responses[2 * k + 1][:, column] / scale
            try:
                found.append(onset_time(t, np.nan_to_num(estimate.force), lags, step, ramp * (t[-1] - t[0])))
            except ValueError as error:
                found.append(error)
        return found


def line_cars(cars: int, rears: Sequence[int]) -> list[tuple[int, np.ndarray]]:
    """``(car index, B_c)`` of each car the couplers join, in line order, for the couplers whose rear cars are ``rears``
    (coupler ``j`` between car ``rears[j]`` and the next): ``B_c`` (2 × n_c) the end loads ``(F1, F2)`` per unit
    compression-positive force ``P_j`` — ``F2 = −P_j`` on the rear car, ``F1 = −P_j`` on the front car (the impact
    loop's coupler maps, :func:`femref.impact.kernels.loop.coupler_maps`). A car no coupler touches is left out."""
    loads = [np.zeros((2, len(rears))) for _ in range(cars)]
    for j, rear in enumerate(rears):
        loads[rear][1, j] = -1.0
        loads[rear + 1][0, j] = -1.0
    return [(i, b) for i, b in enumerate(loads) if np.any(b)]


def _noise(recorded: Recorded, probes: list[str]) -> list[float]:
    return [1.0 if recorded.noise_std is None else recorded.noise_std[probe] for probe in probes]


def _impact_car(car, records: Mapping[str, np.ndarray]) -> Car:
    """The recorded car as an impact car with its recorded sensors (at rest: a modal reduction needs no velocity)."""
    if car.body is None:
        raise ValueError(f"car {car.name!r} has no body: the kalman estimator needs one")
    return Car(car.name, car.body, 0.0, {name: x for name, x in car.sensors.items() if f"{car.name}/{name}" in records})


__all__ = ["KALMAN_FEM", "KALMAN_NIS_RANGE", "KalmanEstimator", "line_cars"]
