"""An estimator plugged in through the protocol (femref.estimators): a toy member, added by one entry in
``FAMILIES``, runs on a simulated scene (a result beside the models') and on each event of a measured case (an
estimate beside the others), through the same capture as the shipped estimators."""

from __future__ import annotations

import dataclasses

import numpy as np
from support.measured import yard_case_with_inverse_estimators
from support.paths import CASES

from femref.case import load_case
from femref.estimators import FAMILIES, Recorded
from femref.events import ForceEstimate
from femref.run import run_scene
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case


class CarAheadInertia:
    """Toy: each coupler's force ``P = M a`` of the car ahead at its sensor nearest the centre — on a two-car line
    what ``inverse_rigid`` gives, to the bit."""

    name = "toy"
    coupler = None
    history = True

    def estimate(self, recorded: Recorded) -> list[ForceEstimate]:
        estimates = []
        for coupler in recorded.couplers:
            car = recorded.cars[coupler.front]
            sensor = min(car.sensors, key=lambda name: abs(car.sensors[name]))
            force = car.mass * np.asarray(recorded.records[f"{car.name}/{sensor}"], dtype=float)
            nan = np.full(force.size, np.nan)
            estimates.append(ForceEstimate(self.name, coupler.name, recorded.time, force, nan, nan.copy()))
        return estimates


def test_a_toy_estimator_runs_on_a_simulated_scene_and_on_a_measured_case(monkeypatch, tmp_path) -> None:
    monkeypatch.setitem(FAMILIES, "toy", lambda scene: CarAheadInertia())

    simulated = scene_from_case(load_case(CASES / "impact_free_roll.yaml"))
    simulated = dataclasses.replace(simulated, runs=tuple(r for r in simulated.runs if r.name == "fem"), estimators=("inverse_rigid", "toy"))
    results = {r.model: r for r in run_scene(simulated).results}
    toy, rigid = results["toy"], results["inverse_rigid"]
    assert toy.ok and toy.settings["records"] == rigid.settings["records"] and toy.wall_time_s > 0.0
    np.testing.assert_array_equal(toy.axes["time"], rigid.axes["time"])
    np.testing.assert_array_equal(toy.couplers["c1"]["force"], rigid.couplers["c1"]["force"])

    measured = scene_from_case(load_case(yard_case_with_inverse_estimators(tmp_path)), tmp_path)
    events = run_measured(dataclasses.replace(measured, estimators=("inverse_rigid", "toy"))).events
    assert len(events) == 2
    for event in events:
        rigid, toy = event.estimates
        assert (toy.estimator, toy.coupler, toy.status, toy.bound) == ("toy", "c1", "ok", "none")
        np.testing.assert_array_equal(toy.force, rigid.force)
        assert toy.peak[0] == rigid.peak[0]
