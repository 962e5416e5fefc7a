"""Samples stepped together: the batched runs of a sweep's samples against each run alone (femref.run.run_model,
``femref run``'s path), number for number; a batch of mixed scene structures; a values-only sample's scene."""

import numpy as np
import pytest

from femref.fem import INTEGRATORS
from femref.impact.kernels.batch import solve_batch, structure_of
from femref.impact.kernels.batch_shared import shares_matrices
from femref.impact.kernels.loop import prepare_run
from femref.models import model_form
from femref.run import run_model
from femref.run.timestep import impact_time_step
from femref.scene.build import scene_from_case
from femref.sweep import parse_sweep
from femref.sweep.batch import run_models
from femref.sweep.worker import run_samples, sample_records, scene_with_values
from tests.sweep.test_run import base_case


def sweep_of(parameters: dict, samples: int = 4, **change):
    case = base_case()
    case.update(change)
    return parse_sweep({"case": case, "samples": samples, "seed": 5, "parameters": parameters})


def scenes_of(sweep):
    return [scene_from_case(sweep.sample_case(sweep.sample(i)), sweep.base_dir) for i in range(sweep.size)]


def assert_same_run(batched, alone):
    """Every history and counter of a batched run equals the run alone (bit for bit: the same kernel on the same arrays)."""
    assert (batched.model, batched.status, batched.message) == (alone.model, alone.status, alone.message)
    np.testing.assert_array_equal(batched.axes["time"], alone.axes["time"])
    for name, coupler in alone.couplers.items():
        for quantity, history in coupler.items():
            np.testing.assert_array_equal(batched.couplers[name][quantity], history, err_msg=f"{name}/{quantity}")
    for probe, outputs in alone.probes.items():
        for quantity, history in outputs.items():
            np.testing.assert_array_equal(batched.probes[probe][quantity], history, err_msg=f"{probe}/{quantity}")
    for name, history in alone.energy.items():
        np.testing.assert_array_equal(batched.energy[name], history, err_msg=name)
    for key in ("dt", "dt_rule", "steps", "newton_iterations", "contact_changes", "energy_balance_error", "cars"):
        assert batched.settings[key] == alone.settings[key], key


@pytest.mark.parametrize("parameters, structures", [
    ({"cars.0.velocity": {"uniform": [1.0, 3.0]}, "couplers.0.law.kelvin_voigt.damping": {"choice": [3.0e5, 6.0e5]}}, 1),
    ({"cars.0.velocity": {"uniform": [1.0, 3.0]}, "fem.elements": {"choice": [6, 8]}}, 2),
], ids=["one structure", "mixed structures"])
def test_batched_runs_equal_each_run_alone(parameters, structures):
    """Velocities and coupler dampings drawn (one structure per model: a batch each, its cars the same matrices: side
    by side), or the fem mesh drawn too (its fem runs in two batches, its rigid runs in one): each run as
    femref.run.run_model gives it alone."""
    scenes = scenes_of(sweep_of(parameters, samples=6))
    integrator = INTEGRATORS[scenes[0].integrator](scenes[0].rho_inf)
    fem = [prepare_run(scene, [model_form(f, "impact")(car, scene, dt) for car, f in zip(scene.cars, scene.runs[0].fidelity)], integrator, dt)
           for scene in scenes for dt in [impact_time_step(scene, scene.runs[0])[0]]]
    assert len({structure_of(run) for run in fem}) == structures
    if structures == 1:
        assert shares_matrices(fem)
    for batched, scene in zip(run_models(scenes), scenes):
        for result, run in zip(batched, scene.runs):
            assert_same_run(result, run_model(scene, run))


def test_runs_of_different_structures_are_refused_together():
    scenes = scenes_of(sweep_of({"fem.elements": {"choice": [6, 8]}}, samples=4))
    integrator = INTEGRATORS[scenes[0].integrator](scenes[0].rho_inf)
    runs = [prepare_run(scene, [model_form("fem", "impact")(car, scene, 1e-4) for car in scene.cars], integrator, 1e-4) for scene in scenes]
    assert len({structure_of(run) for run in runs}) == 2
    with pytest.raises(ValueError, match="share their structure"):
        solve_batch(runs)


def test_a_failed_run_fails_alone_in_its_batch(monkeypatch):
    """A run whose set-up raises is that sample's failure; the other samples of the batch are stored."""
    import femref.sweep.batch as batch

    sweep = sweep_of({"cars.0.velocity": {"uniform": [1.0, 3.0]}})
    prepare = batch.prepare_run

    def fast_fem_fails(scene, systems, integrator, dt):
        if scene.cars[0].velocity > 2.0 and systems[0].fidelity == "fem":
            raise FloatingPointError("non-finite acceleration")
        return prepare(scene, systems, integrator, dt)

    monkeypatch.setattr(batch, "prepare_run", fast_fem_fails)
    samples = [(i, sweep.sample(i).substitutions) for i in range(sweep.size)]
    fast = [sweep.sample(i).values["cars.0.velocity"] > 2.0 for i in range(sweep.size)]
    assert 0 < sum(fast) < len(fast)
    for record, failed in zip(run_samples(sweep, samples), fast):
        assert record["error"] == ("model fem failed: FloatingPointError: non-finite acceleration" if failed else "")


def test_values_only_samples_share_the_base_scene_and_run_as_built_from_their_case():
    """A sample that draws only velocities and measurement values: its scene is the base scene with them (its bodies
    shared), and its record is that of the scene built from its case."""
    sweep = sweep_of({"cars.0.velocity": {"uniform": [1.0, 3.0]}, "measurement.noise": {"uniform": [0.0, 0.1]}})
    base = scene_from_case(sweep.base_case, sweep.base_dir)
    for i in range(sweep.size):
        case = sweep.sample_case(sweep.sample(i))
        built, derived = scene_from_case(case, sweep.base_dir), scene_with_values(base, case)
        assert derived.cars[0].body is base.cars[0].body and derived.measurement != base.measurement
        assert repr(derived) == repr(built) != repr(base)  # every field, car, body and coupler, floats exactly
    samples = [(i, sweep.sample(i).substitutions) for i in range(sweep.size)]
    for i, record in enumerate(run_samples(sweep, samples)):
        alone = sample_records(sweep.sample_case(sweep.sample(i)), sweep.base_dir, sweep.spec.outputs.record_length, sweep.spec.outputs.force_length)
        assert record["error"] == alone["error"] == ""
        for key, value in alone.items():
            if not key.endswith("wall_time_s"):
                np.testing.assert_array_equal(record[key], value, err_msg=key)


def test_a_sweep_says_it_compiles_its_batched_kernels_in_the_client_before_its_workers_start(tmp_path, monkeypatch):
    """`femref sweep` with the batched kernels not cached: the client says "compiling femref's batched impact kernels,
    once" on stderr before any worker runs (the kernels are loaded in the client, whose forks the local workers are);
    cached, it says nothing about compiling."""
    import yaml
    from click.testing import CliRunner

    import femref.sweep.batch as batch
    from femref.cli import main

    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump({"case": base_case(), "samples": 2, "seed": 5, "parameters": {"cars.0.velocity": {"uniform": [1.0, 3.0]}}}))
    said = {}
    for cached in (False, True):
        monkeypatch.setattr(batch, "_loaded", False)
        monkeypatch.setattr(batch.cache, "cached", lambda dispatchers, cached=cached: cached)
        result = CliRunner().invoke(main, ["sweep", str(path), "--workers", "1", "-o", str(tmp_path / f"out_{cached}.h5")])
        assert result.exit_code == 0, result.output
        said[cached] = result.output
    assert "compiling femref's batched impact kernels, once (cached in" in said[False]
    assert "compiling" not in said[True]
