"""The runner: every model on one scene, scored against the reference."""

import numpy as np
import pytest

from femref.case import parse_case
from femref.run import run_scene
from femref.scene.build import scene_from_case


def harmonic_rod(lambdas, models):
    return parse_case(
        {
            "kind": "harmonic",
            "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9, "axial_viscosity": 1.0e6},
            "loads": {"F2": 1.0},
            "frequency": {"lambda": {"start": lambdas[0], "stop": lambdas[1], "num": 5}},
            "models": models,
        }
    )


def test_scores_rank_the_models_at_low_frequency():
    """At λ ≤ 0.2 the quasi-rigid error (∝ λ⁴) is far below the rigid one (∝ λ²), and the FEM's below both."""
    outcome = run_scene(scene_from_case(harmonic_rod((0.05, 0.2), ["fem", "exact", "quasi_rigid", "rigid"])))
    assert not outcome.failed
    scores = outcome.scores
    assert {s["reference"] for s in scores.values()} == {"exact"}
    rigid, quasi, fem = (scores[m]["acceleration_max_error_max"] for m in ("rigid", "quasi_rigid", "fem"))
    assert fem < 1e-6
    assert quasi < 1e-3 and quasi < rigid / 10
    assert rigid == pytest.approx(0.2**2 * 8 / 6, rel=0.05)  # loaded end: M a(l)/F2 = 1 + 8q²/6 + … (docs/formulas.md §X)


def test_fem_is_the_reference_without_exact():
    outcome = run_scene(scene_from_case(harmonic_rod((0.1, 1.0), ["fem", "rigid"])))
    assert outcome.scores["rigid"]["reference"] == "fem"
    assert np.isfinite(outcome.scores["rigid"]["acceleration_rms_error_center"])


def test_transient_models_share_the_time_grid():
    case = parse_case(
        {
            "kind": "transient",
            "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9, "axial_viscosity": 2.0e6},
            "loads": {"F2": {"half_sine": {"amplitude": -1.0e6, "duration": 0.2}}},
            "time": {"end": 0.4, "output_stride": 3},
            "models": ["fem", "exact", "quasi_rigid", "rigid"],
            "fem": {"elements": 32},
        }
    )
    outcome = run_scene(scene_from_case(case))
    assert not outcome.failed
    grids = [r.axes["time"] for r in outcome.results]
    assert all(np.array_equal(g, grids[0]) for g in grids)
    assert outcome.results[0].settings["dt_rule"].startswith("automatic")
    # ε ≈ 0.002: at the centre quasi-rigid beats rigid in the RMS sense
    assert outcome.scores["quasi_rigid"]["acceleration_rms_error_center"] < outcome.scores["rigid"]["acceleration_rms_error_center"]
