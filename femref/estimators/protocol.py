"""One estimator protocol for simulated and measured runs: ``estimate(recorded) -> [ForceEstimate per coupler]``.

An estimator reads what a railroad has (:class:`Recorded`) and gives each coupler it serves a
:class:`femref.events.ForceEstimate`: a force history with its 95 % band (or a peak only), its bound and status.
The simulated runner hands it the fem run's records, a measured run each event's, both through
:func:`femref.estimators.capture`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from femref.events import ForceEstimate


@dataclass(frozen=True)
class Recorded:
    """What an estimator reads: ``records`` (``"<car>/<sensor>"`` → m/s²) on ``time`` (s), the line of ``cars``
    (name, mass, body, sensors) and ``couplers`` (name, rear, front) they come from, the sensor noise std per probe
    (m/s²; None: equal on every channel), the event's impact type (None: not classified, an estimator that needs it
    classifies the records), the estimates of the event so far (``earlier``, in which a network finds the contact)
    and the contacts found in them, per coupler (``contacts``, filled by the first estimator that needs one)."""

    time: NDArray[np.float64]
    records: Mapping[str, NDArray[np.float64]]
    cars: Sequence[Any]
    couplers: Sequence[Any]
    noise_std: Mapping[str, float] | None = None
    impact_type: str | None = None
    earlier: Sequence[ForceEstimate] = ()
    contacts: dict[str, Any] = field(default_factory=dict)


class Estimator(Protocol):
    """``name``; the ``coupler`` it serves (None: every coupler of the line); whether it gives a force ``history``
    (else a peak only, at one sample); ``estimate(recorded)`` → one :class:`ForceEstimate` per coupler served."""

    name: str
    coupler: str | None
    history: bool

    def estimate(self, recorded: Recorded) -> list[ForceEstimate]: ...


__all__ = ["Estimator", "Recorded"]
