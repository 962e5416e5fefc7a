"""A car fidelity is its catalog entry and its module: one registered at run time, and nowhere else, reaches the time
step, the work budget, the model choice's ladder and the bench, and runs (femref.models.base.CarFidelity)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from femref.bench.configurations import bench_plan
from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.choice.ladder import ladder_costs, model_ladder
from femref.core import catalog
from femref.impact.systems import SecondOrderSystem
from femref.models import CAR_FIDELITIES, REGISTRY
from femref.models.base import CarFidelity
from femref.run.budget import approximate_step, coupler_line_cost, predict
from femref.run.runner import load_compiled_loop, run_model
from femref.run.timestep import impact_candidates, impact_time_step
from femref.scene import ModelRun
from femref.scene.build import scene_from_case

RULE = "lumped mode period / 20"


class LumpedModel(CarFidelity):
    """Two masses, half the car's at each end, joined by its static stiffness ``k = 1/∫ dx/EA``."""

    name = "lumped"
    setup_us = (900.0,)
    step_us = (2.5,)

    @staticmethod
    def parts(car) -> tuple[float, float]:
        x, w = car.body.quadrature()
        return float(np.sum(w * car.body.mass_per_length(x))), 1.0 / float(np.sum(w / car.body.stiffness(x)))

    def car(self, car, scene, dt):
        mass, k = self.parts(car)
        stiffness = k * np.array([[1.0, -1.0], [-1.0, 1.0]])
        share = (car.sensor_x + car.body.half_length) / (2.0 * car.body.half_length)
        return SecondOrderSystem(self.name, 0.5 * mass * np.eye(2), np.zeros((2, 2)), stiffness, np.array([[-1.0, 0.0], [0.0, 1.0]]), np.eye(2),
                                 np.column_stack([1.0 - share, share]), translation=np.ones(2))

    def step_candidates(self, car, scene, elements, speed):
        mass, k = self.parts(car)
        return {RULE: 2.0 * math.pi * math.sqrt(mass / (4.0 * k)) / 20.0}


@pytest.fixture
def lumped(monkeypatch):
    """The toy registered as the catalog, the registry and the fidelities hold a model (its entry and its module)."""
    model = LumpedModel()
    monkeypatch.setitem(catalog.MODELS, model.name, catalog.ModelEntry(model.name, catalog.IMPACT_KINDS, "two lumped masses"))
    monkeypatch.setitem(REGISTRY, model.name, model)
    monkeypatch.setitem(CAR_FIDELITIES, model.name, model)
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    run = ModelRun(model.name, (model.name,) * len(scene.cars))
    return model, dataclasses.replace(scene, runs=(*scene.runs, run)), run


def test_the_toy_enters_the_time_step(lumped):
    model, scene, run = lumped
    candidates = impact_candidates(scene, run, scene.fem.elements, lambda body: 1.0)
    assert candidates[RULE] == min(model.step_candidates(car, scene, 0, None)[RULE] for car in scene.cars)
    mixed = ModelRun("mixed", ("fem", model.name))
    assert {RULE, "mesh wave transit time"} <= set(impact_candidates(scene, mixed, scene.fem.elements, lambda body: 1.0))
    assert impact_time_step(scene, run)[0] <= candidates[RULE]


def test_the_toy_is_priced_by_its_own_coefficients(lumped):
    model, scene, run = lumped
    cost = next(c for c in predict(scene) if c.model == model.name)
    steps = math.ceil(scene.end / approximate_step(scene, run) - 1e-9)
    line_step, line_setup, _ = coupler_line_cost(scene)
    cars = len(scene.cars)
    assert cost.work == pytest.approx(1e-6 * cars * 0.5 * (model.setup_us[0] + steps * model.step_us[0]) + steps * line_step + line_setup, rel=1e-12)
    assert "fem.elements" not in cost.factors


def test_the_toy_is_a_rung_of_the_ladder_and_a_row_of_the_bench(lumped):
    model, scene, _ = lumped
    ladder = model_ladder(scene)
    rung = ladder[model.name]
    assert rung.family == model.name and rung.resolution == 0 and ladder.partner(model.name) is None
    assert rung.cost == pytest.approx(len(scene.cars) * 0.5 * (model.setup_us[0] + math.ceil(scene.end / rung.dt - 1e-9) * model.step_us[0]), rel=1e-6)
    assert model.name in [c.model for c in ladder_costs(scene)]
    assert ladder.expansion == ("rigid", "quasi_rigid")
    rows = [c for c in bench_plan(scene).configurations if c.family == model.name]
    assert len(rows) == 1 and rows[0].label == model.name and rows[0].run.fidelity == (model.name,) * len(scene.cars)


def test_the_toy_runs(lumped):
    model, scene, run = lumped
    load_compiled_loop(scene)
    result = run_model(scene, run)
    assert result.ok, result.message
    rigid = run_model(scene, scene.runs[[r.name for r in scene.runs].index("rigid")])
    peak, rigid_peak = (max(float(np.max(out["force"])) for out in r.couplers.values()) for r in (result, rigid))
    assert peak == pytest.approx(rigid_peak, rel=0.1)  # a stiff two-mass car is nearly rigid against a soft gear
