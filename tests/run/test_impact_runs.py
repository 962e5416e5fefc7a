"""Impact scenes through the case schema and the runner: fidelities side by side, scores, results."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from femref.case import load_case, parse_case
from femref.case.defaults import DEFAULT_SCENE_SOURCE, default_scene_data
from femref.run import run_scene
from femref.results import write_results
from femref.scene.build import scene_from_case

FIDELITIES = ["fem", "modal", "quasi_rigid", "rigid"]


def pair(ea: float = 3.0e9, ca: float = 2.0e6, law=None, contact: str = "compression_only", models=FIDELITIES, **extra):
    data = {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": ea, "axial_viscosity": ca}, "velocity": 2.2},
            {"name": "anvil", "body": {"type": "rod", "length": 17.0, "mass_per_length": 5900.0, "axial_stiffness": ea, "axial_viscosity": ca}, "velocity": 0.0,
             "sensors": {"rear": -8.5, "center": 0.0, "front": 8.5}},
        ],
        "couplers": [{"between": ["hammer", "anvil"], "law": law or {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}, "contact": contact}],
        "time": {"end": 0.25, "dt": 2.5e-4},
        "models": models,
        "fem": {"elements": 16, "order": 2},
    }
    data.update(extra)
    return scene_from_case(parse_case(data))


@pytest.mark.parametrize("law", [None, {"draft_gear": {"gear_stiffness": 1.7e7, "gear_damping": 2.5e5, "stroke": 0.165, "solid_stiffness": 1.0e8}}], ids=["kelvin_voigt", "draft_gear"])
def test_very_stiff_cars_agree_on_coupler_force_whatever_their_fidelity(law):
    """EA × 1e4: every car is rigid to 1e-4 of its deformation, so all four fidelities give the same force."""
    outcome = run_scene(pair(ea=3.0e13, ca=2.0e10, law=law))
    assert not outcome.failed
    for model in ("modal", "quasi_rigid", "rigid"):
        score = outcome.scores[model]
        assert score["coupler_force_peak_error_c1"] < 1e-3, (model, score)
        assert score["coupler_force_rms_error_c1"] < 1e-3, (model, score)


def test_realistic_cars_rank_the_fidelities():
    """On a 17 m car (ε ≈ 0.01) modal is closest to fem, then quasi-rigid, then rigid (peak and rms force)."""
    outcome = run_scene(pair())
    rms = {m: outcome.scores[m]["coupler_force_rms_error_c1"] for m in ("modal", "quasi_rigid", "rigid")}
    assert rms["modal"] < rms["quasi_rigid"] < rms["rigid"] < 0.2, rms


def test_mixed_fidelity_run_and_estimators_are_scored_and_written(tmp_path):
    scene = pair(
        models=["fem", "rigid", {"name": "rigid_fem_anvil", "fidelity": "rigid", "cars": {"anvil": "fem"}}],
        measurement={"rate": 1000.0, "lowpass": 100.0, "noise": 0.02, "seed": 3},
        estimators=["inverse_rigid", "inverse_quasi_rigid"],
    )
    outcome = run_scene(scene)
    assert not outcome.failed
    mixed = next(r for r in outcome.results if r.model == "rigid_fem_anvil")
    assert mixed.settings["fidelity"] == {"hammer": "rigid", "anvil": "fem"}
    # a fem anvil answers closer to the fem reference than a rigid one
    assert outcome.scores["rigid_fem_anvil"]["coupler_force_rms_error_c1"] < outcome.scores["rigid"]["coupler_force_rms_error_c1"]
    assert outcome.scores["inverse_rigid"]["coupler_force_peak_error_c1"] < 0.15
    # the dashpot's force jump at contact rings the anvil's first mode, which the two-term
    # inverse reads as force: scored, but far off (73 %) — see the draft-gear default scene
    assert np.isfinite(outcome.scores["inverse_quasi_rigid"]["coupler_force_peak_error_c1"])
    path = tmp_path / "impact.h5"
    write_results(path, "kind: impact\n", outcome.results, outcome.scores)
    with h5py.File(path) as h5:
        assert h5["fem/couplers/c1/force"].attrs["units"] == "N (compression positive)"
        assert h5["fem/probes/anvil/front/acceleration"].shape == h5["fem/time"].shape
        measured = h5["fem/measured/time"][()]
        assert np.allclose(np.diff(measured), 1e-3)
        assert h5["fem/measured/anvil/front/acceleration"].shape == measured.shape
        assert h5["inverse_rigid/couplers/c1/force"].shape == measured.shape
        assert h5["fem/energy"].attrs["balance_error"] < 1e-4
        assert set(h5["scores"]) == {"rigid", "rigid_fem_anvil", "inverse_rigid", "inverse_quasi_rigid"}


def test_default_scene_is_the_free_roll_case():
    """The built-in default and cases/impact_free_roll.yaml describe the same scene."""
    default = scene_from_case(parse_case(default_scene_data(), source=DEFAULT_SCENE_SOURCE))
    case = scene_from_case(load_case("cases/impact_free_roll.yaml"))
    assert [c.name for c in default.cars] == [c.name for c in case.cars]
    for a, b in zip(default.cars, case.cars):
        assert a.mass == pytest.approx(b.mass, rel=1e-5) and a.sensors == b.sensors and a.velocity == b.velocity
    assert default.couplers[0].coupling == case.couplers[0].coupling
    assert default.measurement == case.measurement and default.estimators == case.estimators
    assert default.models == case.models


def test_every_impact_run_records_its_set_up_and_stepping_times():
    """Settings hold the building of the cars and the stepping apart (s), both positive, and
    together no more than the run's wall time; the steps taken beside them."""
    outcome = run_scene(pair())
    for result in outcome.results:
        if "fidelity" not in result.settings:
            continue  # an estimator: no cars, no steps
        setup, stepping = result.settings["setup_time_s"], result.settings["stepping_time_s"]
        assert setup > 0.0 and stepping > 0.0 and setup + stepping <= result.wall_time_s
        assert result.settings["steps"] > 0
