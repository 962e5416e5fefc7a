"""Measured events in numbers: simulated yard impacts of both types, recorded through the measurement chain
and read back through measured cases, against the fem forces they were made from.

Each event: two hoppers (17 m, lading ±20 % between the bolsters), the hammer at 1–3 m/s; free to roll
through the default scene's draft gear, or coupled (bilateral, the friction-gear table of
cases/impact_coupled.yaml). The default run checks a few events; ``pytest -m slow`` runs the study
the issue asks for (40 events, and 20 with declared cars that differ from the real ones).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import pytest
import yaml

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

    @property
    def error(self) -> float:
        return self.peak / self.truth - 1.0

    @property
    def covered(self) -> bool:
        return self.lower <= self.truth <= self.upper


def study(tmp_path, events: int, seed: int, declared=None) -> list[Outcome]:
    """``events`` random impacts, half of each kind; ``declared(case, rng)`` may change the declared cars."""
    rng = np.random.default_rng(seed)
    outcomes = []
    for k in range(events):
        kind = ("free_to_roll", "coupled")[k % 2]
        folder = tmp_path / f"event{k}"
        folder.mkdir()
        event = simulated_event(folder, impact(kind, rng), estimators=("kalman", "inverse_rigid"), seed=k)
        if declared is not None:
            case = copy.deepcopy(event.case)
            declared(case, rng)
            event.path.write_text(yaml.safe_dump(case, sort_keys=False))
        found = run_measured(scene_from_case(load_case(event.path))).events[0]  # coupled cars may ring past the window: a later, truncated event
        assert 0.0 <= found.trigger_time - event.contact_time < 0.05  # the level is crossed within pre of the contact
        estimates = {e.estimator: e for e in found.estimates}
        peak, lower, upper = estimates["kalman"].peak
        truth = float(np.max(event.force))
        outcomes.append(Outcome(kind, found.impact_type, truth, peak, lower, upper, estimates["inverse_rigid"].peak[0] / truth - 1.0))
    return outcomes


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
    """The issue's numbers: classification >= 95 %, kalman within 3 % median, its band covering >= 90 %."""
    check(study(tmp_path, 40, seed=2), error=0.03, coverage=0.9)


@pytest.mark.slow
def test_declared_cars_that_differ_from_the_real_ones(tmp_path):
    """Within 5 % median and the band covering >= 80 % when the declared cars are off by their tolerances."""
    check(study(tmp_path, 20, seed=3, declared=mismatched), error=0.05, coverage=0.8)
