"""Calibrated bands of the inverse estimators: femref calibrate on a sweep's fem records, then a measured
case that names the file gets calibrated bands inside the calibrated ranges and none outside."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import yaml
from click.testing import CliRunner

from femref.case import load_case
from femref.case.defaults import default_scene_data
from femref.cli import main
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from femref.sensing.calibration import read_calibration
from support.measured import run_calibration_sweep, simulated_event


def test_inverse_bands_from_a_calibration_sweep(tmp_path):
    run_calibration_sweep(tmp_path, 24, 501, 101)
    network = str(Path(__file__).parents[2] / "cases" / "networks" / "fem_mlp.npz")
    result = CliRunner().invoke(main, ["calibrate", str(tmp_path / "cal.yaml"), str(tmp_path / "cal.h5"), "-o", str(tmp_path / "calibration.h5"),
                                       "--network", f"ann_fem={network}"])
    assert result.exit_code == 0, result.output
    assert "inverse_rigid: peak error 95 % band" in result.output and "valid for closing speeds" in result.output
    calibration = read_calibration(tmp_path / "calibration.h5")
    e_lo, e_hi = calibration.error_band("inverse_rigid")
    assert calibration.errors["inverse_rigid"].size == 24 and e_lo < e_hi and 1.5 <= calibration.closing_speed[0] < calibration.closing_speed[1] <= 3.0

    assert calibration.lowpass == 100.0 and calibration.noise == (0.05, 0.05)
    assert calibration.errors["ann_fem"].size == 3 * 24  # each sample at the contact and ±0.5 ms

    def measured(speed: float, folder, noise: float = 0.05, declare_filter: bool = True, network: bool = False):
        folder.mkdir()
        data = copy.deepcopy(default_scene_data())
        data["cars"][0]["velocity"] = speed
        data["measurement"]["noise"] = noise
        estimators = ("inverse_rigid",)
        if network:
            data["time"] = {"end": 0.6}  # the network reads 0.5 s from contact
            estimators += ("kalman", {"name": "ann_fem", "network": network})
        event = simulated_event(folder, data, estimators=estimators)
        case = copy.deepcopy(event.case)
        case["calibration"] = str(tmp_path / "calibration.h5")
        if not declare_filter:
            for record in case["records"]:
                record.pop("anti_alias")
        event.path.write_text(yaml.safe_dump(case, sort_keys=False))
        found = run_measured(scene_from_case(load_case(event.path))).events[0]
        if network:
            return next(e for e in found.estimates if e.estimator == "ann_fem"), float(np.max(event.force))
        return found.estimates[0], float(np.max(event.force))

    inside, truth = measured(2.2, tmp_path / "inside")
    peak, lower, upper = inside.peak
    assert inside.bound == "calibrated" and inside.in_calibrated_range is True, inside.message
    assert lower <= truth <= upper and np.isclose(lower, peak / (1 + e_hi)) and np.isclose(upper, peak / (1 + e_lo))
    outside, _ = measured(3.8, tmp_path / "outside")
    assert outside.bound == "none" and outside.in_calibrated_range is False and np.isnan(outside.peak[1])
    assert "closing speed" in outside.message and "outside the calibrated" in outside.message
    # the measurement chain is part of the range: another filter, or twice the calibrated noise, is outside
    unfiltered, _ = measured(2.2, tmp_path / "unfiltered", declare_filter=False)
    assert unfiltered.bound == "none" and "recorded unfiltered (no anti_alias declared); the calibration's records were through a 100 Hz low-pass" in unfiltered.message
    noisy, _ = measured(2.2, tmp_path / "noisy", noise=0.1)
    assert noisy.bound == "none" and "exceeds the calibrated 0.05 m/s²" in noisy.message
    # a saved network calibrated on the same sweep: a calibrated band on its peak inside the range
    net, truth = measured(2.2, tmp_path / "network", network=network)
    e_lo, e_hi = calibration.error_band("ann_fem")
    assert net.bound == "calibrated" and np.isclose(net.peak[1], net.peak[0] / (1 + e_hi)) and net.peak[1] <= truth <= net.peak[2], net.message
