"""Measured events in numbers: simulated yard impacts of both types, recorded through the measurement chain
and read back through measured cases, against the fem forces they were made from.

Each event: two hoppers (17 m, lading ±20 % between the bolsters), the hammer at 1–3 m/s; free to roll
through the default scene's draft gear, or coupled (bilateral, the friction-gear table of
cases/impact_coupled.yaml). The default run checks a few events; ``pytest -m slow`` runs the study
the issue asks for (40 events, and 20 with declared cars that differ from the real ones).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

import distributed
import numpy as np
import pytest
import yaml
from scipy.stats import binom

from femref.case import load_case
from femref.case.defaults import default_scene_data
from femref.run.measured import run_measured
from femref.scene.build import scene_from_case
from support.measured import simulated_event

COUPLED_LAW = {"table": {"closure": [0.0, 0.0119, 0.0188, 0.0495, 0.125], "loading": [0.0, 1.0e4, 1.2e5, 6.8e5, 1.35e6],
                         "unloading": [0.0, 3.0e3, 3.6e4, 2.04e5, 4.05e5], "damping": 2.0e4}}


def impact(kind: str, rng: np.random.Generator) -> dict:
    """A random two-car impact case of ``kind`` (module docstring), with the default measurement chain."""
    data = default_scene_data()
    data["cars"][0]["velocity"] = float(rng.uniform(1.0, 3.0))
    for car in data["cars"]:
        values = car["body"]["mass_per_length"]["piecewise"]["values"]
        values[1] *= float(rng.uniform(0.8, 1.2))
    if kind == "coupled":
        data["couplers"][0].update(law=COUPLED_LAW, contact="bilateral", tension_slack=0.025)
        data["time"] = {"end": 1.0}
    else:
        data["time"] = {"end": 0.6}  # the network reads 0.5 s from contact
    return data


@dataclass
class Outcome:
    kind: str
    found: str
    truth: float
    peak: float
    lower: float
    upper: float
    rigid: float
    inverse: dict[str, tuple[float, float, float, str]] = field(default_factory=dict)  # name -> (peak, lower, upper, bound)

    @property
    def error(self) -> float:
        return self.peak / self.truth - 1.0

    @property
    def covered(self) -> bool:
        return self.lower <= self.truth <= self.upper


def study(tmp_path, events: int, seed: int, declared=None, calibration=None) -> list[Outcome]:
    """``events`` random impacts, half of each kind; ``declared(case, rng)`` may change the declared cars;
    ``calibration`` (a file of femref calibrate) gives the inverse estimators their bands."""
    rng = np.random.default_rng(seed)
    outcomes = []
    for k in range(events):
        kind = ("free_to_roll", "coupled")[k % 2]
        folder = tmp_path / f"event{k}"
        folder.mkdir()
        event = simulated_event(folder, impact(kind, rng), estimators=("kalman", *INVERSE, {"name": "ann_fem", "network": str(NETWORK)}), seed=k)
        if declared is not None or calibration is not None:
            case = copy.deepcopy(event.case)
            if declared is not None:
                declared(case, rng)
            if calibration is not None:
                case["calibration"] = str(calibration)
            event.path.write_text(yaml.safe_dump(case, sort_keys=False))
        (found,) = run_measured(scene_from_case(load_case(event.path))).events  # one impact, one event: its ringing is no event of its own
        assert 0.0 <= found.trigger_time - event.contact_time < 0.05  # the level is crossed within pre of the contact
        estimates = {e.estimator: e for e in found.estimates}
        peak, lower, upper = estimates["kalman"].peak
        truth = float(np.max(event.force))
        inverse = {name: (*estimates[name].peak, estimates[name].bound) for name in CALIBRATED}
        outcomes.append(Outcome(kind, found.impact_type, truth, peak, lower, upper, estimates["inverse_rigid"].peak[0] / truth - 1.0, inverse))
    return outcomes


INVERSE = ("inverse_rigid", "inverse_quasi_rigid")
CALIBRATED = (*INVERSE, "ann_fem")
NETWORK = Path(__file__).parents[2] / "cases" / "networks" / "fem_mlp.npz"


def calibration_file(tmp_path) -> Path:
    """femref calibrate on a 30-sample sweep of the free-to-roll impacts of :func:`impact` (1–3 m/s, lading
    ±20 % on both cars, the default measurement chain)."""
    from femref.sensing.calibration import write_calibration
    from femref.sensing.network import AnnEstimator
    from femref.study.calibration import calibrate
    from femref.sweep.run import run_sweep
    from femref.sweep.spec import load_sweep

    base = default_scene_data()
    base.update(models=["fem"], estimators=[])
    lading = {f"cars.{k}.body.mass_per_length.piecewise.values.1": {"uniform": [0.8 * v, 1.2 * v]}
              for k, v in enumerate(car["body"]["mass_per_length"]["piecewise"]["values"][1] for car in base["cars"])}
    sweep = {"case": base, "samples": 30, "seed": 11, "models": ["fem"],
             "parameters": {"cars.0.velocity": {"uniform": [1.0, 3.0]}, **lading}, "outputs": {"record_length": 501, "force_length": 101}}
    (tmp_path / "cal.yaml").write_text(yaml.safe_dump(sweep, sort_keys=False))
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        assert run_sweep(tmp_path / "cal.yaml", tmp_path / "cal.h5", client=client).complete
    network = AnnEstimator.load("ann_fem", NETWORK)
    return write_calibration(calibrate(load_sweep(tmp_path / "cal.yaml"), tmp_path / "cal.h5", networks=[network]), tmp_path / "calibration.h5")


def calibrated_summary(outcomes: list[Outcome]) -> tuple[str, dict[str, tuple[int, int]]]:
    """Per calibrated estimator (the inverse ones and the fem-trained network): how many events were inside the calibration (bound calibrated), the band's
    coverage of fem there, the median half-width and median |error|; and per estimator (events covered, events inside)."""
    lines, coverage = [], {}
    for name in CALIBRATED:
        inside = [o for o in outcomes if o.inverse[name][3] == "calibrated"]
        if not inside:
            lines.append(f"{name}: no event inside the calibration")
            continue
        count = sum(o.inverse[name][1] <= o.truth <= o.inverse[name][2] for o in inside)
        covered = count / len(inside)
        half = np.median([(o.inverse[name][2] - o.inverse[name][1]) / 2 / o.truth for o in inside])
        error = np.median([abs(o.inverse[name][0] / o.truth - 1.0) for o in inside])
        coverage[name] = (count, len(inside))
        coupled = sum(o.found == "coupled" for o in outcomes)
        lines.append(f"{name}: calibrated band on {len(inside)}/{len(outcomes)} events (outside: {coupled} coupled, "
                     f"{len(outcomes) - len(inside) - coupled} free to roll beyond the calibrated speeds or masses), "
                     f"covers fem {covered:.0%}, median half-width {half:.1%}, |error| median {error:.1%}")
    return "; ".join(lines), coverage


def summary(outcomes: list[Outcome]) -> str:
    errors = np.abs([o.error for o in outcomes])
    half = np.median([(o.upper - o.lower) / 2 / o.truth for o in outcomes])
    return (f"{len(outcomes)} events: classified right {np.mean([o.kind == o.found for o in outcomes]):.0%}; kalman |error| median "
            f"{np.median(errors):.2%}, max {np.max(errors):.2%}; band covers fem {np.mean([o.covered for o in outcomes]):.0%}, median "
            f"half-width {half:.1%}; rigid inverse |error| median {np.median(np.abs([o.rigid for o in outcomes])):.1%}")


def check(outcomes: list[Outcome], error: float, coverage: float) -> None:
    text = summary(outcomes)
    print(text)
    assert np.mean([o.kind == o.found for o in outcomes]) >= 0.95, text
    assert np.median(np.abs([o.error for o in outcomes])) <= error, text
    assert np.mean([o.covered for o in outcomes]) >= coverage, text


def mismatched(case: dict, rng: np.random.Generator) -> None:
    """Declared cars that differ from the recorded ones: total mass ±5 %, stiffness (first mode) ±15 %,
    viscosity × 0.6–1.6, and the lading spread over the whole car instead of between the bolsters."""
    for car in case["cars"]:
        body = car["body"]
        piecewise = body["mass_per_length"]["piecewise"]
        total = 2 * 3500.0 * 2.0 + piecewise["values"][1] * 13.0
        body["mass_per_length"] = float(total * rng.uniform(0.95, 1.05) / body["length"])
        body["axial_stiffness"] *= float(rng.uniform(0.85, 1.15) ** 2)
        body["axial_viscosity"] *= float(rng.uniform(0.6, 1.6))


def test_a_few_events_of_each_type(tmp_path):
    check(study(tmp_path, 6, seed=1), error=0.03, coverage=0.9)


@pytest.mark.slow
def test_forty_events_of_both_types(tmp_path):
    """The issue's numbers: classification >= 95 %, kalman within 3 % median, its band covering >= 90 %;
    the inverse estimators' and the fem-trained network's calibrated 95 % bands (a calibration sweep of the
    free-to-roll impacts) consistent with 95 % coverage on the events inside the calibration — the count
    covered not in the lower 1 % tail of Binomial(n, 0.95): at least 13 of 16, 17 of 20 (a fixed 90 % on 16
    events fails a true 95 % band one time in five) — the coupled ones outside it (no band)."""
    outcomes = study(tmp_path, 40, seed=2, calibration=calibration_file(tmp_path))
    check(outcomes, error=0.03, coverage=0.9)
    text, coverage = calibrated_summary(outcomes)
    print(text)
    assert set(coverage) == set(CALIBRATED), text
    for name, (covered, inside) in coverage.items():
        assert binom.cdf(covered, inside, 0.95) >= 0.01, f"{name}: {covered} of {inside} covered; {text}"
    assert all(o.inverse[name][3] == "none" for o in outcomes if o.kind == "coupled" for name in CALIBRATED)


@pytest.mark.slow
def test_declared_cars_that_differ_from_the_real_ones(tmp_path):
    """Within 5 % median and the band covering >= 80 % when the declared cars are off by their tolerances."""
    check(study(tmp_path, 20, seed=3, declared=mismatched), error=0.05, coverage=0.8)
