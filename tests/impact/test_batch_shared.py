"""Runs of one car pool stepped side by side (femref.impact.kernels.batch_shared: one copy of the matrices, the runs'
states as columns) against each run stepped alone by femref.impact.kernels.loop.solve_compiled: every history,
counter, message and car setting the same number, bit for bit (each run's sums in the same order) — on rods, on cars
that bend, with coupler laws that differ per run, and with runs whose coupler iteration fails at different steps."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from femref.core.body import Body
from femref.core.profiles import Uniform
from femref.fem import INTEGRATORS
from femref.fem.build import FemSettings
from femref.impact.kernels import batch
from femref.impact.kernels.batch import solve_batch
from femref.impact.kernels.batch_shared import shares_matrices
from femref.impact.kernels.loop import prepare_run, solve_compiled
from femref.models import model_form
from femref.run.timestep import impact_time_step
from femref.scene.build import scene_from_case
from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from femref.sweep import parse_sweep
from reduced.couplers import Coupling, HystereticTable
from tests.sweep.test_run import base_case


def assert_same_response(batched, alone) -> None:
    """Every history and counter of ``batched`` equals ``alone``'s, bit for bit (NaN where alone is NaN)."""
    assert (batched.status, batched.message, batched.steps) == (alone.status, alone.message, alone.steps)
    assert (batched.newton_iterations, batched.newton_iterations_max, batched.contact_changes) == \
        (alone.newton_iterations, alone.newton_iterations_max, alone.contact_changes)
    assert batched.car_settings == alone.car_settings
    np.testing.assert_array_equal(batched.time, alone.time)
    np.testing.assert_array_equal(batched.coupler_work, alone.coupler_work)
    for name, history in alone.energy.items():
        np.testing.assert_array_equal(batched.energy[name], history, err_msg=name)
    for name, coupler in alone.couplers.items():
        for quantity, history in coupler.items():
            np.testing.assert_array_equal(batched.couplers[name][quantity], history, err_msg=f"{name}/{quantity}")
    assert alone.sensors
    for probe, outputs in alone.sensors.items():
        for quantity, history in outputs.items():
            np.testing.assert_array_equal(batched.sensors[probe][quantity], history, err_msg=f"{probe}/{quantity}")


def shared_and_alone(scenes: list[ImpactScene], fidelity: tuple[str, ...], dt: float | None = None):
    """The runs of ``scenes`` at ``fidelity`` stepped side by side (solve_batch, asserted to take the shared path) and
    each alone."""
    integrator = INTEGRATORS[scenes[0].integrator](scenes[0].rho_inf)
    steps = [dt or impact_time_step(scene, scene.runs[0])[0] for scene in scenes]
    systems = [[model_form(f, "impact")(car, scene, step) for car, f in zip(scene.cars, fidelity)] for scene, step in zip(scenes, steps)]
    runs = [prepare_run(scene, cars, integrator, step) for scene, cars, step in zip(scenes, systems, steps)]
    assert shares_matrices(runs)
    return solve_batch(runs), [solve_compiled(scene, cars, integrator, step) for scene, cars, step in zip(scenes, systems, steps)]


def swept_scenes(parameters: dict, samples: int = 5, **body) -> list[ImpactScene]:
    case = base_case()
    for car in case["cars"]:
        car["body"].update(body)
    if body:
        for car in case["cars"]:
            car["coupler_offset"] = [0.6, 0.6]
    sweep = parse_sweep({"case": case, "samples": samples, "seed": 7, "parameters": parameters})
    return [scene_from_case(sweep.sample_case(sweep.sample(i)), sweep.base_dir) for i in range(sweep.size)]


@pytest.mark.parametrize("fidelity, order", [(("fem", "fem"), 2), (("fem", "rigid"), 1), (("modal", "modal"), 1)])
def test_runs_of_drawn_speeds_and_coupler_dampings_equal_each_run_alone(fidelity, order):
    """Five samples of a two-rod impact, the hammer's speed and the coupler's damping drawn (the laws differ per run,
    the cars' matrices do not): each run as alone."""
    scenes = swept_scenes({"cars.0.velocity": {"uniform": [1.0, 3.0]}, "couplers.0.law.kelvin_voigt.damping": {"uniform": [1.0e5, 6.0e5]}})
    scenes = [dataclasses.replace(scene, fem=dataclasses.replace(scene.fem, order=order)) for scene in scenes]
    for batched, alone in zip(*shared_and_alone(scenes, fidelity)):
        assert alone.status == 0
        assert_same_response(batched, alone)


def test_cars_that_bend_step_side_by_side_as_alone():
    """The rods of the other tests made Euler–Bernoulli beams with their couplers 0.6 m below the neutral axis (more
    end loads and outputs per car, vertical and pitch sensors): each run as alone."""
    scenes = swept_scenes({"cars.0.velocity": {"uniform": [1.0, 3.0]}}, samples=3, bending_stiffness=4.5e9, bending_viscosity=2.9e6)
    batched, alone = shared_and_alone(scenes, ("fem", "fem"))
    assert any("pitch_displacement" in outputs for outputs in alone[0].sensors.values())
    for one, other in zip(batched, alone):
        assert_same_response(one, other)


def test_runs_whose_coupler_iteration_fails_stop_alone_and_the_others_carry_on():
    """A 20 kg car between two 2 t cars, friction gears both sides (tests/impact/test_compiled.py): at 1 and 2 m/s
    the Gauss–Seidel sweeps crawl and the run stops (at different steps), at 0.2 and 0.5 m/s it reaches its end. Side
    by side, each stops where it stops alone, with its message, its histories NaN after and its car settings as they
    were then; the others run to the end as alone. Every third step recorded (the runs that stop keep their output
    row, the others go on)."""
    light = lambda mass: Body("rod", 8.5, Uniform(mass / 17.0), Uniform(3.0e9), Uniform(2.0e6), 8.5 * math.sqrt(mass / 17.0 / 3.0e9))  # noqa: E731
    table = HystereticTable.friction_gear_envelope()
    fidelity = ("fem", "rigid", "fem")
    scenes = [ImpactScene((Car("a", light(2000.0), speed, {"center": 0.0}), Car("b", light(20.0), 0.0, {"center": 0.0}),
                           Car("c", light(2000.0), 0.0, {"center": 0.0})),
                          (Coupler("c1", 0, Coupling(table)), Coupler("c2", 1, Coupling(table))),
                          (ModelRun("run", fidelity),), end=0.1, integrator="newmark", rho_inf=1.0, fem=FemSettings(elements=4, order=1),
                          output_stride=3)
              for speed in (1.0, 0.2, 2.0, 0.5)]
    batched, alone = shared_and_alone(scenes, fidelity, dt=1e-3)
    assert [response.status for response in alone] == [-1, 0, -1, 0]
    assert alone[0].steps != alone[2].steps
    for one, other in zip(batched, alone):
        assert_same_response(one, other)


def test_runs_whose_cars_differ_step_each_on_its_own_pool():
    """A drawn axial stiffness (other matrices), and a state-space car (quasi_rigid): not side by side; solve_batch
    steps them each on its own pool (the run_batch path), as alone."""
    stiff = swept_scenes({"cars.1.body.axial_stiffness": {"uniform": [2.0e9, 4.0e9]}}, samples=2)
    same = swept_scenes({"cars.0.velocity": {"uniform": [1.0, 3.0]}}, samples=2)
    for scenes, fidelity in ((stiff, ("fem", "fem")), (same, ("quasi_rigid", "rigid"))):
        integrator = INTEGRATORS[scenes[0].integrator](scenes[0].rho_inf)
        dt = impact_time_step(scenes[0], scenes[0].runs[0])[0]
        systems = [[model_form(f, "impact")(car, scene, dt) for car, f in zip(scene.cars, fidelity)] for scene in scenes]
        runs = [prepare_run(scene, cars, integrator, dt) for scene, cars in zip(scenes, systems)]
        assert not shares_matrices(runs)
        for one, scene, cars in zip(solve_batch(runs), scenes, systems):
            assert_same_response(one, solve_compiled(scene, cars, integrator, dt))


def test_a_batch_of_one_is_not_stepped_side_by_side(monkeypatch):
    """One run goes the run_batch path (nothing to share)."""
    scenes = swept_scenes({"cars.0.velocity": {"uniform": [1.0, 3.0]}}, samples=1)
    integrator = INTEGRATORS[scenes[0].integrator](scenes[0].rho_inf)
    run = prepare_run(scenes[0], [model_form("rigid", "impact")(car, scenes[0], 1e-3) for car in scenes[0].cars], integrator, 1e-3)
    assert not shares_matrices([run])
    monkeypatch.setattr(batch, "solve_shared", lambda runs: pytest.fail("a batch of one stepped side by side"))
    assert solve_batch([run])[0].status == 0
