"""Estimators of coupler forces from acceleration records: one protocol (:mod:`.protocol`) that simulated and
measured runs share, one module per family — :mod:`.inverse`, :mod:`.kalman`, :mod:`.network` — and what both runs
call: :func:`plug_ins` (a scene's estimators), :func:`capture` (one never-raising call) and :func:`fail_if_not_finite`
(one non-finite policy)."""

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from femref.estimators.inverse import ESTIMATORS, InverseEstimator
from femref.estimators.kalman import KalmanEstimator
from femref.estimators.network import NetworkPeak
from femref.estimators.protocol import Estimator, Recorded
from femref.events import ForceEstimate


def _kalman(scene: Any) -> KalmanEstimator:
    return KalmanEstimator(scene.kalman, scene.anti_alias)


FAMILIES: dict[str, Callable[[Any], Estimator]] = {**{name: (lambda scene, name=name: InverseEstimator(name)) for name in ESTIMATORS},
                                                    "kalman": _kalman}
"""Estimator name → its plug-in for a scene: the inverse ones, ``kalman`` (a measured scene's kalman model and
declared anti-alias filters). A new member is one module of the protocol and one entry here."""


def plug_ins(scene: Any) -> list[Estimator]:
    """The estimators ``scene`` names (:data:`FAMILIES`), in its order, then its saved networks (on a measured scene
    reading the records from the contact in the kalman force)."""
    contact_from = _kalman(scene) if scene.kind == "measured" else None
    return [*(FAMILIES[name](scene) for name in scene.estimators), *(NetworkPeak(network, contact_from) for network in scene.networks)]


def capture(estimator: Estimator, recorded: Recorded) -> list[ForceEstimate]:
    """``estimator.estimate(recorded)``, never raising: each estimate with its share of the wall time (s) and held to
    :func:`fail_if_not_finite`; an exception makes every coupler's estimate (the estimator's coupler, or each of the
    line's) ``failed`` with the exception's message."""
    started = time.perf_counter()
    try:
        estimates = estimator.estimate(recorded)
    except Exception as error:  # recorded as the estimate's status, never swallowed silently
        nan = np.full(recorded.time.size, np.nan)
        couplers = [c.name for c in recorded.couplers] if estimator.coupler is None else [estimator.coupler]
        estimates = [ForceEstimate(estimator.name, coupler, recorded.time, nan, nan, nan, status="failed", message=f"{type(error).__name__}: {error}")
                     for coupler in couplers]
    elapsed = time.perf_counter() - started
    for estimate in estimates:
        estimate.wall_time_s = elapsed / len(estimates)
        fail_if_not_finite(estimate)
    return estimates


def fail_if_not_finite(estimate: ForceEstimate) -> None:
    """An ok estimate whose force holds NaN or infinity is ``failed``, with no number; ``settings["not_finite"]`` keeps
    how many samples and the first one (``[count, sample]``)."""
    bad = np.flatnonzero(~np.isfinite(estimate.force))
    if estimate.ok and bad.size:
        estimate.settings["not_finite"] = [int(bad.size), int(bad[0])]
        estimate.drop_number("failed", f"the {estimate.estimator} force is not finite (NaN or infinity) at {bad.size} of "
                                       f"{estimate.force.size} samples, from t = {estimate.time[bad[0]]:g} s")


__all__ = ["FAMILIES", "Estimator", "InverseEstimator", "KalmanEstimator", "NetworkPeak", "Recorded", "capture", "fail_if_not_finite", "plug_ins"]
