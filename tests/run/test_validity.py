"""Where the quasi-rigid cars are outside their range (femref.run.validity): an end force changing slope within one
wave travel time of the car. The local parameter on known forces, and the intervals a run records."""

from __future__ import annotations

import numpy as np
import pytest

from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.models.quasi_rigid import QuasiRigidModel
from femref.run import run_scene
from femref.run.validity import local_epsilon, outside_intervals, within
from femref.scene.build import scene_from_case

EPSILON_LIMIT = QuasiRigidModel.range_limit

T = 0.013  # s, a car's wave travel time


def test_smooth_pulse_gives_its_epsilon() -> None:
    """A sin² pulse of duration T_p (smooth at both ends): ε_loc = |P(t + T) − 2P(t) + P(t − T)|/max P ≈ T²|P̈| at most
    2π² (T/T_p)² (within 5 %: 0.5 s pulse, ε = 1.3e-2) — the expansion's own parameter; the same on a 10× coarser grid."""
    t_p = 0.5
    expected = 2.0 * np.pi**2 * (T / t_p) ** 2
    for samples in (20001, 2001):
        t = np.linspace(0.0, t_p, samples)
        eps = local_epsilon(t, np.sin(np.pi * t / t_p) ** 2, T)
        assert np.max(eps) == pytest.approx(expected, rel=0.05)
    assert expected < EPSILON_LIMIT


@pytest.mark.parametrize("dt", [2e-4, 1e-3])
def test_a_jump_and_a_kink_are_outside_whatever_the_step(dt: float) -> None:
    """A force that jumps by 0.3 of its peak at t = 0.05 s: outside within one wave travel time either side of it
    (ε = 0.3); a ramp of 50 peaks per second from 0.2 s to 0.214 s (kinks at both ends, up to T × 50 = 0.65): outside
    only within the two kinks' windows, each kink instant covered; in range elsewhere; the same at either step."""
    t = np.arange(0.0, 0.4, dt)
    force = np.where(t >= 0.05, 0.3, 0.0) + np.where(t >= 0.2, np.minimum(50.0 * (t - 0.2), 0.7), 0.0)
    sharp = local_epsilon(t, force, T) > EPSILON_LIMIT
    (jump_start, jump_end), *ramp = outside_intervals(t, sharp)
    assert jump_start == pytest.approx(0.05 - T, abs=2 * dt) and jump_end == pytest.approx(0.05 + T, abs=2 * dt)
    assert ramp and all(0.2 - T < a and b < 0.214 + T for a, b in ramp), ramp
    for kink in (0.2, 0.214):
        assert any(a <= kink <= b for a, b in ramp), (kink, ramp)
    (a, b), (c, d) = outside_intervals(t, within(t, sharp, T))  # one wave travel time around each: the run's marking
    assert a == pytest.approx(0.05 - 2 * T, abs=2 * dt) and b == pytest.approx(0.05 + 2 * T, abs=2 * dt)
    assert c < 0.2 - T / 2 and d > 0.214 + T


def _run(models=("fem", "quasi_rigid"), **coupler) -> dict:
    data = default_scene_data()
    data.update(models=list(models), estimators=[])
    data.pop("measurement", None)
    if coupler:
        data["couplers"][0]["law"] = coupler
        data["time"] = {"end": 0.8}
    return {r.model: r for r in run_scene(scene_from_case(parse_case(data, source="<validity>"))).results}


def test_the_default_impact_marks_the_quasi_rigid_onset_and_separation() -> None:
    """The default scene (M-901E-class gear with series springs: the force starts with a slope of v/D, 4e8 N/s,
    a kink) — the quasi-rigid run records its onset, from contact for at most three wave travel times of its longer
    car (the sharp bends and one wave travel time around them), and its separation, as outside its range; its
    largest acceleration (the onset spike) lies inside the onset interval and its spike at separation inside the
    other; fem records nothing."""
    results = _run()
    qr = results["quasi_rigid"]
    marked = qr.settings["quasi_rigid_range"]
    wave = max(marked["cars"].values())
    t, force = qr.axes["time"], qr.couplers["c1"]["force"]
    separation = t[np.flatnonzero(force > 0.0)[-1]]
    (onset, after) = marked["outside"]
    assert onset[0] == 0.0 and onset[1] <= 3 * wave and marked["epsilon_max"] > EPSILON_LIMIT
    assert after[0] <= separation <= after[1] <= separation + 3 * wave
    acceleration = np.abs(qr.probes["hammer/front"]["acceleration"])
    assert onset[0] <= t[np.argmax(acceleration)] <= onset[1]
    late = t > 0.5 * separation
    assert after[0] <= t[late][np.argmax(acceleration[late])] <= after[1]
    assert "quasi_rigid_range" not in results["fem"].settings


def test_a_soft_spring_coupler_keeps_the_quasi_rigid_car_in_range() -> None:
    """A 2 MN/m spring on compression-only contact: the force is a half-sine w√(k m*) sin ωt with kinks at contact
    and separation, and ε_loc ≤ T ω = T √(k/m*) ≈ 0.08 < 0.1 — nothing is marked; at 20 MN/m (T ω ≈ 0.25) the
    kinks are."""
    soft = _run(("quasi_rigid",), kelvin_voigt={"stiffness": 2.0e6})["quasi_rigid"].settings["quasi_rigid_range"]
    assert soft["outside"] == [] and soft["epsilon_max"] < EPSILON_LIMIT
    stiff = _run(("quasi_rigid",), kelvin_voigt={"stiffness": 2.0e7})["quasi_rigid"].settings["quasi_rigid_range"]
    assert stiff["outside"] and stiff["epsilon_max"] > EPSILON_LIMIT


def test_the_report_shades_where_the_quasi_rigid_run_is_outside_its_range(tmp_path) -> None:
    """The intervals go to the result file with the run's settings, the report reads them back and every
    acceleration figure of a quasi-rigid run says where it shaded them."""
    from femref.report.figures import figures_for
    from femref.report.read import read_result_file
    from femref.results import write_results

    from femref.case import resolved_yaml

    data = default_scene_data()
    data.update(models=["fem", "quasi_rigid"], estimators=[])
    data.pop("measurement", None)
    case = parse_case(data, source="<validity>")
    outcome = run_scene(scene_from_case(case))
    write_results(tmp_path / "run.h5", resolved_yaml(case), outcome.results, outcome.scores, scene=outcome.scene.facts())
    result = read_result_file(tmp_path / "run.h5")
    qr = result.models["quasi_rigid"]
    recorded = next(r for r in outcome.results if r.model == "quasi_rigid").settings["quasi_rigid_range"]
    assert qr.outside_range == [tuple(i) for i in recorded["outside"]] and qr.outside_limit == EPSILON_LIMIT
    accelerations = [p for p in figures_for(result) if p.title.startswith("acceleration")]
    assert accelerations and all("where quasi_rigid is outside its range" in p.caption for p in accelerations)


def test_in_range_scores_leave_out_only_the_marked_samples() -> None:
    """``in_range_errors`` on known signals: a result equal to the reference except inside a marked interval has
    in-range errors of exactly zero while its whole-record errors are not, and the fraction outside is the marked
    share of the samples; nothing marked, nothing added."""
    from femref.results import ModelResult
    from femref.run.scoring import in_range_errors, score_impact

    t = np.linspace(0.0, 1.0, 1001)
    force = np.sin(np.pi * t) ** 2
    acceleration = np.cos(7.0 * t)
    reference = ModelResult("fem", axes={"time": t}, couplers={"c1": {"force": force}}, probes={"a/front": {"acceleration": acceleration}})
    spiky = acceleration + np.where((t >= 0.1) & (t <= 0.2), 50.0, 0.0)
    result = ModelResult("quasi_rigid", axes={"time": t}, couplers={"c1": {"force": force * np.where(t <= 0.2, 1.1, 1.0)}},
                         probes={"a/front": {"acceleration": spiky}}, settings={"quasi_rigid_range": {"outside": [[0.0, 0.2]]}})
    errors = in_range_errors(reference, result)
    assert errors["outside_range_fraction"] == pytest.approx(201 / 1001)
    assert errors["coupler_force_rms_in_range_error_c1"] == 0.0 and errors["acceleration_rms_in_range_error_a/front"] == 0.0
    assert errors["acceleration_rms_in_range_error_max"] == 0.0
    assert score_impact(reference, result)["acceleration_rms_error_a/front"] > 10.0
    result.settings["quasi_rigid_range"]["outside"] = []
    assert in_range_errors(reference, result) == {}


def test_the_default_quasi_rigid_run_is_scored_inside_its_range_too() -> None:
    """The default scene's quasi-rigid run: its whole-record acceleration error is set by the onset and separation
    spikes; inside its range the error is several times smaller (measured 284 % over the record, 34.5 % in range, 13 % of
    the samples outside), while the coupler force, which has no spike, changes little (1.0 % → 0.75 %); fem is not given in-range scores."""
    data = default_scene_data()
    data.update(models=["fem", "quasi_rigid"], estimators=[])
    data.pop("measurement", None)
    outcome = run_scene(scene_from_case(parse_case(data, source="<validity>")))
    score = outcome.scores["quasi_rigid"]
    whole, inside = score["acceleration_rms_error_max"], score["acceleration_rms_in_range_error_max"]
    assert inside < whole / 2.0, (whole, inside)
    assert 0.0 < score["outside_range_fraction"] < 0.5
    assert abs(score["coupler_force_rms_in_range_error_max"] - score["coupler_force_rms_error_max"]) < 0.5 * score["coupler_force_rms_error_max"] + 0.01
    assert not any("in_range" in name for name in outcome.scores.get("fem", {}))
