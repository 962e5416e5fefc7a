"""A saved network as an estimator: the peak force of its coupler from the records started at contact
(:class:`femref.sensing.network.AnnEstimator`), one network per impact type if so (:class:`ImpactTypeNetworks`).

A peak at the contact instant ``t_c``, not a history. A simulated run's records start at contact; a measured
event's are read from ``t_c`` on, on ``t − t_c``, as the training records were, ``t_c`` where the kalman force of the
network's coupler began (:meth:`femref.estimators.kalman.KalmanEstimator.contact`). Bound ``none``: the error a
network file reports is measured on its own training source, not on these records.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from femref.estimators.kalman import KalmanEstimator
from femref.estimators.protocol import Recorded
from femref.events import ForceEstimate
from femref.sensing.contact import ContactEstimate
from femref.sensing.findings import classify_records
from femref.sensing.network import ImpactTypeNetworks, NetworkEstimator


@dataclass(frozen=True)
class NetworkPeak:
    """The saved ``network`` (one, or one per impact type) as a plug-in of the estimator protocol; ``contact_from``
    the kalman estimator whose force gives a measured event's contact (None: the records start at contact)."""

    network: NetworkEstimator
    contact_from: KalmanEstimator | None = None
    history: bool = False

    @property
    def name(self) -> str:
        return self.network.name

    @property
    def coupler(self) -> str:
        return self.network.coupler

    def estimate(self, recorded: Recorded) -> list[ForceEstimate]:
        """The peak, or a failed estimate with the reason; without the event's impact type the records are classified
        at the network's coupler and the settings keep the zero-harmonic ratio."""
        t, nan = recorded.time, np.full(1, np.nan)
        settings: dict[str, Any] = dict(self.network.settings)

        def failed(at: float, why: str) -> list[ForceEstimate]:
            return [ForceEstimate(self.name, self.coupler, np.full(1, at), nan, nan, nan.copy(), status="failed", message=why, settings=settings)]

        network = self.network
        if isinstance(network, ImpactTypeNetworks):
            kind = recorded.impact_type
            if kind is None:
                coupler = next(c for c in recorded.couplers if c.name == network.coupler)
                found = classify_records(recorded.cars, coupler, t, recorded.records)
                kind, classified = found.kind, {"zero_harmonic_ratio": found.zero_frequency_ratio}
            else:
                classified = {}
            try:
                network = network.network_for(kind)
            except ValueError as error:
                return failed(t[0], str(error))
            settings = {**dict(network.settings, impact_type=kind), **classified}
        records: Any = recorded.records
        start, contact = float(t[0]), None
        if self.contact_from is not None:
            contact = self._contact(recorded, network.coupler)
            if isinstance(contact, str):
                return failed(t[0], contact)
            after = t >= contact.time
            start, t = contact.time, t[after] - contact.time
            records = {probe: recorded.records[probe][after] for probe in network.contract.probes}
        try:
            peak = network.peak_force(t, records, {car.name: car.mass for car in recorded.cars})
        except ValueError as error:
            return failed(recorded.time[0], f"{type(error).__name__}: {error}")
        if contact is not None:
            settings.update(contact_time=contact.time, contact_fit_residual=contact.residual)
        training = network.contract.training.get("validation_mean_error")
        note = f" (its file reports {training:.1%} mean error on its own training source: not a bound here)" if isinstance(training, (int, float)) else ""
        where = "records from the contact in the kalman force" if contact is not None else "records from contact"
        return [ForceEstimate(self.name, network.coupler, np.full(1, start), np.full(1, peak), nan, nan.copy(),
                              message=f"peak only, {where}; no calibration of this network: no band" + note, settings=settings)]

    def _contact(self, recorded: Recorded, coupler: str) -> ContactEstimate | str:
        """The contact in the kalman force of ``coupler`` among the event's estimates so far, found once per event
        (``recorded.contacts``), or why there is none."""
        kalman = self.contact_from
        assert kalman is not None
        source = next((e for e in recorded.earlier if e.estimator == kalman.name and e.coupler == coupler), None)
        if source is None or not source.ok:
            return f"no {kalman.name} force to find the contact in" if source is None else f"the {kalman.name} force has no number ({source.message})"
        if coupler not in recorded.contacts:
            try:
                recorded.contacts[coupler] = kalman.contact(recorded, source)
            except ValueError as error:
                recorded.contacts[coupler] = f"{type(error).__name__}: {error}"
        return recorded.contacts[coupler]


__all__ = ["NetworkPeak"]
