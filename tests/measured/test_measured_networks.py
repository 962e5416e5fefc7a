"""Saved networks on measured records: the default scene at 1.5 and 2.5 m/s recorded through the
measurement chain the shipped networks were trained on (1 kHz, 100 Hz 4th-order anti-alias filter,
0.05 m/s² noise), exported to CSV and read back through a measured case with ``kalman`` and two
networks (cases/networks: one trained on fem impacts, one on rigid ones)."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from femref.case import load_case
from femref.case.defaults import default_scene_data
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from support.measured import simulated_event, write_events

NETWORKS = Path(__file__).parents[2] / "cases" / "networks"


@pytest.mark.parametrize("speed", [1.5, 2.5])
def test_networks_read_measured_records_from_the_contact(tmp_path, speed):
    """The contact read from the kalman force within 1 ms (measured +0.1, +0.3 ms); the fem-trained
    network within 2 % of the fem peak (measured −0.6 %, −0.03 %; from the trigger's instant instead,
    10 ms late, it was 9 % low); the rigid-trained one 30–40 % high — its file reports 0.7 % on its own
    training source, which is no bound here: both have ``bound`` none and say so. A network's
    estimate is a peak, not a history: the closure and closing speed come from kalman. An estimator with one
    network per impact type reads this free-to-roll event with its free-to-roll network."""
    data = default_scene_data()
    data["cars"][0]["velocity"] = speed
    data["time"] = {"end": 0.6}  # the networks read 0.5 s from contact
    networks = ({"name": "ann_fem", "network": str(NETWORKS / "fem_mlp.npz")}, {"name": "ann_rigid", "network": str(NETWORKS / "rigid_mlp.npz")},
                {"name": "ann_typed", "network": {"free_to_roll": str(NETWORKS / "fem_mlp.npz"), "coupled": str(NETWORKS / "rigid_mlp.npz")}})
    event = simulated_event(tmp_path, data, estimators=("kalman", *networks))
    found = run_measured(scene_from_case(load_case(event.path))).events[0]
    estimates = {e.estimator: e for e in found.estimates}
    assert all(e.ok for e in estimates.values()), [e.message for e in estimates.values()]
    truth = float(np.max(event.force))
    fem_net, rigid_net = estimates["ann_fem"], estimates["ann_rigid"]
    assert abs(fem_net.peak[0] / truth - 1.0) < 0.02
    assert 0.2 < rigid_net.peak[0] / truth - 1.0 < 0.5
    for estimate in (fem_net, rigid_net):
        assert estimate.bound == "none" and np.isnan(estimate.peak[1]) and estimate.time.size == 1
        assert "not a bound here" in estimate.message
        assert abs(estimate.settings["contact_time"] - event.contact_time) < 1e-3
    typed = estimates["ann_typed"]  # one network per impact type: this free-to-roll event goes to the fem-trained one
    assert found.impact_type == "free_to_roll" and typed.settings["impact_type"] == "free_to_roll"
    assert typed.peak[0] == fem_net.peak[0]
    assert found.closures[0].estimator == "kalman"
    path = write_events(tmp_path / "events.h5", {}, [found])
    with h5py.File(path) as h5:
        group = h5["events/0/ann_fem/c1"]
        assert group.attrs["bound"] == "none" and group["force"].shape == (1,)
        assert group.attrs["peak_force"] == pytest.approx(fem_net.peak[0])
