"""Sweeps on a real dask.distributed cluster: the stored arrays, resume, failures, the CLI.

One local cluster of two single-threaded worker processes on loopback (the session's, tests/conftest.py)
serves every test of the module. The base case is small (2 cars, 8 P1 elements, 0.3 s): a sample takes
well under a second, so each sweep here runs in a few seconds.
"""

import hashlib
import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.case import CaseError, parse_case
from femref.cli import main
from femref.sensing.records import acceleration_histories, fixed_length_records, record_times
from femref.run import run_scene
from femref.scene.build import scene_from_case
from femref.sweep import SweepInterrupted, load_sweep, parse_sweep, read_sweep, run_sweep
from femref.sweep import worker
from femref.sweep.store import FAILED, NOT_RUN, OK, partial_path

distributed = pytest.importorskip("distributed")

SAMPLES = 8
PROBES = ["hammer/center", "hammer/front", "anvil/rear", "anvil/center"]


def base_case() -> dict:
    body = {"type": "rod", "length": 16.0, "mass_per_length": 6000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
    return {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": dict(body), "velocity": 2.0, "sensors": {"center": 0.0, "front": 7.5}},
            {"name": "anvil", "body": dict(body), "velocity": 0.0, "sensors": {"rear": -7.5, "center": 0.0}},
        ],
        "couplers": [{"name": "c1", "between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
        "time": {"end": 0.3},
        "models": ["fem", "rigid"],
        "fem": {"elements": 8, "order": 1},
        "measurement": {"rate": 1000.0, "lowpass": 100.0, "noise": 0.01, "seed": 3},
    }


def sweep_data(**change) -> dict:
    data = {
        "base": "base.yaml",
        "samples": SAMPLES,
        "seed": 11,
        "parameters": {
            "cars.0.velocity": {"uniform": [1.0, 3.0]},
            "cars.1.body.axial_stiffness": {"log_uniform": [2.0e9, 5.0e9]},
            "couplers.0.law.kelvin_voigt.stiffness": {"choice": [3.0e7, 6.0e7]},
        },
        "outputs": {"record_length": 50, "force_length": 40},
    }
    data.update(change)
    return data


def write_sweep(folder: Path, name: str = "sweep.yaml", **change) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "base.yaml").write_text(yaml.safe_dump(base_case(), sort_keys=False))
    path = folder / name
    path.write_text(yaml.safe_dump(sweep_data(**change), sort_keys=False))
    return path


def file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def client(dask_client):
    return dask_client


@pytest.fixture(scope="module")
def cluster(dask_client):
    return dask_client.cluster


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("sweeps")


@pytest.fixture(scope="module")
def full(client, folder):
    """An uninterrupted sweep of SAMPLES samples: (sweep path, output, summary)."""
    path = write_sweep(folder)
    output = folder / "full.h5"
    summary = run_sweep(path, output, client=client)
    return path, output, summary


def test_sweep_stores_every_sample_with_shapes_and_units(full):
    path, output, summary = full
    assert (summary.total, summary.run, summary.skipped, summary.failed, summary.complete) == (SAMPLES, SAMPLES, 0, 0, True)
    assert output.exists() and not partial_path(output).exists()
    data = read_sweep(output)
    assert data.complete and data.ok.all() and data.error == [""] * SAMPLES
    assert (data.models, data.probes, data.couplers) == (["fem", "rigid"], PROBES, ["c1"])
    assert (data.record_length, data.force_length, data.record_end) == (50, 40, 0.3)
    assert data.record_rate == pytest.approx(49 / 0.3, rel=1e-15)
    assert data.record_source == "measured" and data.measurement["rate"] == 1000.0
    assert data.seed == 11 and data.spec_hash == load_sweep(path).spec_hash
    assert yaml.safe_load(data.sweep_yaml)["parameters"]["cars.0.velocity"] == {"uniform": {"low": 1.0, "high": 3.0}}
    assert parse_case(yaml.safe_load(data.base_case_yaml)).estimators == ()
    for model in data.models:
        assert data.records[model].shape == (SAMPLES, 4, 50) and np.isfinite(data.records[model]).all()
        assert data.coupler_force[model].shape == (SAMPLES, 1, 40)
        assert data.peak_coupler_force[model].shape == (SAMPLES, 1)
        assert (data.wall_time_s[model] > 0).all()
    # the hammer hits the anvil: compression, of the size of a rigid two-mass impact (P ≈ v √(k m/2))
    peak = data.peak_coupler_force["fem"][:, 0]
    v, k = data.parameters["cars.0.velocity"], np.array(data.parameters["couplers.0.law.kelvin_voigt.stiffness"])
    assert np.all((peak > 0.5 * v * np.sqrt(k * 48e3)) & (peak < 1.5 * v * np.sqrt(k * 48e3)))
    with h5py.File(output, "r") as h5:
        assert h5["fem/records"].attrs["units"] == "m/s^2" and h5["fem/coupler_force"].attrs["units"].startswith("N")
        assert h5["samples/status"].dtype == np.int8 and h5["fem/records"].maxshape[0] is None
        assert h5["parameters/cars.0.velocity"].dtype == np.float64
        choice = h5["parameters/couplers.0.law.kelvin_voigt.stiffness"]
        assert choice.dtype == np.int64 and json.loads(choice.attrs["values"]) == [3.0e7, 6.0e7]
        assert json.loads(choice.attrs["distribution"]) == {"choice": {"values": [3.0e7, 6.0e7]}}
        assert json.loads(h5.attrs["probes"]) == PROBES and h5.attrs["record_source"] == "measured"


def test_stored_arrays_equal_an_in_process_run_of_the_sample(full):
    """The same sample case run by ``run_scene`` here gives the stored peak force, forces and records."""
    path, output, _ = full
    sweep, data = load_sweep(path), read_sweep(output)
    for index in (0, SAMPLES - 1):
        sample = sweep.sample(index)
        scene = scene_from_case(sweep.sample_case(sample), sweep.base_dir)
        outcome = run_scene(scene)
        for result in outcome.results:
            force = result.couplers["c1"]["force"]
            np.testing.assert_allclose(data.peak_coupler_force[result.model][index, 0], np.max(force), rtol=1e-12, atol=0)
            np.testing.assert_allclose(data.coupler_force[result.model][index, 0], np.interp(record_times(40, 0.3), result.axes["time"], force), rtol=1e-12, atol=1e-6)
            records = fixed_length_records(*acceleration_histories(result), PROBES, 50, 0.3)
            np.testing.assert_allclose(data.records[result.model][index], records, rtol=1e-12, atol=1e-9)
        assert data.parameters["cars.0.velocity"][index] == sample.values["cars.0.velocity"]


def test_complete_file_runs_nothing(full, client):
    path, output, _ = full
    digest = file_digest(output)
    summary = run_sweep(path, output, client=client)
    assert (summary.run, summary.skipped, summary.complete) == (0, SAMPLES, True)
    assert file_digest(output) == digest


def test_resume_after_limit_gives_the_uninterrupted_file(full, client, folder):
    path, reference, _ = full
    output = folder / "resumed.h5"
    first = run_sweep(path, output, client=client, limit=3)
    assert (first.run, first.skipped, first.complete) == (3, 0, False)
    assert partial_path(output).exists() and not output.exists()
    interrupted = read_sweep(partial_path(output))
    assert np.count_nonzero(interrupted.status != NOT_RUN) == 3 and not interrupted.complete
    assert np.isnan(interrupted.records["fem"][interrupted.status == NOT_RUN]).all()

    second = run_sweep(path, output, client=client)
    assert (second.run, second.skipped, second.complete) == (SAMPLES - 3, 3, True)
    assert output.exists() and not partial_path(output).exists()
    a, b = read_sweep(reference), read_sweep(output)
    assert (a.spec_hash, a.sweep_yaml, a.base_case_yaml) == (b.spec_hash, b.sweep_yaml, b.base_case_yaml)
    np.testing.assert_array_equal(a.status, b.status)
    assert a.error == b.error and a.parameters.keys() == b.parameters.keys()
    assert all(np.array_equal(a.parameters[k], b.parameters[k]) for k in a.parameters)
    for field in ("records", "coupler_force", "peak_coupler_force"):
        for model in a.models:
            np.testing.assert_array_equal(getattr(a, field)[model], getattr(b, field)[model], err_msg=f"{model}/{field}")


def test_more_samples_extend_the_file(full, client, folder):
    path, reference, _ = full
    output = folder / "extended.h5"
    shutil.copy(reference, output)
    more = write_sweep(folder, "more.yaml", samples=SAMPLES + 2)
    summary = run_sweep(more, output, client=client)
    assert (summary.total, summary.run, summary.skipped, summary.complete) == (SAMPLES + 2, 2, SAMPLES, True)
    a, b = read_sweep(reference), read_sweep(output)
    assert b.size == SAMPLES + 2 and b.ok.all()
    np.testing.assert_array_equal(a.records["fem"], b.records["fem"][:SAMPLES])
    assert yaml.safe_load(b.sweep_yaml)["samples"] == SAMPLES + 2


def test_another_sweep_into_the_same_file_is_refused_and_leaves_it(full, client, folder):
    path, reference, _ = full
    output = folder / "guarded.h5"
    shutil.copy(reference, output)
    digest = file_digest(output)
    other = write_sweep(folder, "other.yaml", seed=12)
    with pytest.raises(CaseError, match="holds another sweep"):
        run_sweep(other, output, client=client)
    assert file_digest(output) == digest and not partial_path(output).exists()
    run_sweep(path, folder / "partly.h5", client=client, limit=1)  # a .partial of another sweep: refused too
    digest = file_digest(partial_path(folder / "partly.h5"))
    with pytest.raises(CaseError, match="holds another sweep"):
        run_sweep(other, folder / "partly.h5", client=client)
    assert file_digest(partial_path(folder / "partly.h5")) == digest
    (folder / "results.h5").write_bytes(b"not hdf5")
    with pytest.raises(CaseError, match="not an HDF5 file"):
        run_sweep(path, folder / "results.h5", client=client)


def test_failed_samples_are_stored_with_their_error_and_not_rerun(client, folder):
    """A normal without clip draws negative stiffnesses; a choice of law removes a later key path."""
    path = write_sweep(
        folder / "failing",
        samples=10,
        parameters={
            "cars.1.body.axial_stiffness": {"normal": {"mean": 2.0e9, "std": 2.0e9}},
            "couplers.0.law": {"choice": [{"kelvin_voigt": {"stiffness": 4.0e7}}, {"draft_gear": {"gear_stiffness": 1.7e7, "stroke": 0.165}}]},
            "couplers.0.law.kelvin_voigt.damping": {"uniform": [1.0e5, 4.0e5]},
        },
    )
    output = folder / "failing.h5"
    summary = run_sweep(path, output, client=client)
    data = read_sweep(output)
    stiffness = data.parameters["cars.1.body.axial_stiffness"]
    law = np.array([next(iter(v)) for v in data.parameters["couplers.0.law"]])
    expected_failed = (stiffness <= 0) | (law == "draft_gear")
    assert 0 < expected_failed.sum() < 10 and summary.complete
    np.testing.assert_array_equal(data.status, np.where(expected_failed, FAILED, OK))
    assert sorted(i for i, _ in summary.failures) == list(np.flatnonzero(expected_failed))
    for i in np.flatnonzero(expected_failed):
        if law[i] == "draft_gear":
            assert "parameters.couplers.0.law.kelvin_voigt.damping: no key 'kelvin_voigt'" in data.error[i]
        else:
            assert f"sample {i}: cars[1].body.axial_stiffness: must be > 0" in data.error[i]
        assert np.isnan(data.records["fem"][i]).all() and np.isnan(data.peak_coupler_force["rigid"][i]).all()
    assert np.isfinite(data.records["fem"][~expected_failed]).all() and all(data.error[i] == "" for i in np.flatnonzero(~expected_failed))
    again = run_sweep(path, output, client=client)
    assert again.run == 0
    retried = run_sweep(path, output, client=client, retry_failed=True)
    assert (retried.run, retried.failed, retried.skipped) == (expected_failed.sum(), expected_failed.sum(), 10 - expected_failed.sum())


def test_worker_records_run_time_failures(monkeypatch):
    """``sample_records`` never raises: an exception or a failed model run comes back as the sample's error (a sample
    that breaks a rule: tests/sweep/test_derive.py)."""
    sweep = parse_sweep({"case": base_case(), "samples": 1, "seed": 0})
    case = parse_case(sweep.sample_data(sweep.sample(0)), source="<sample>", base_dir=sweep.base_dir)
    ok = worker.sample_records(case, sweep.base_dir, 20, 20)
    assert ok["error"] == "" and ok["fem/records"].shape == (4, 20) and ok["rigid/coupler_force"].shape == (1, 20)

    def broken(scenes):
        raise RuntimeError("the stepper diverged")

    monkeypatch.setattr(worker, "run_models", broken)
    assert worker.sample_records(case, sweep.base_dir, 20, 20) == {"error": "RuntimeError: the stepper diverged"}
    monkeypatch.undo()

    import femref.sweep.batch

    solve = femref.sweep.batch.solve_batch

    def fem_fails(runs):
        if runs[0].systems[0].fidelity == "fem":
            raise FloatingPointError("non-finite acceleration")
        return solve(runs)

    monkeypatch.setattr(femref.sweep.batch, "solve_batch", fem_fails)
    assert worker.sample_records(case, sweep.base_dir, 20, 20) == {"error": "model fem failed: FloatingPointError: non-finite acceleration"}


@pytest.mark.filterwarnings("ignore:Port 8787 is already in use")  # the module's cluster has it
def test_a_worker_failure_is_stored_and_the_sweep_goes_on(folder, monkeypatch):
    """On an in-process cluster (so the monkeypatch reaches the worker): samples above 2 m/s fail at run time."""

    import femref.sweep.batch

    prepare = femref.sweep.batch.prepare_run

    def fast_ones_fail(scene, systems, integrator, dt):
        if scene.cars[0].velocity > 2.0:
            raise RuntimeError("run-time failure")
        return prepare(scene, systems, integrator, dt)

    monkeypatch.setattr(femref.sweep.batch, "prepare_run", fast_ones_fail)
    path = write_sweep(folder / "inprocess")
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as local, distributed.Client(local) as threads:
        summary = run_sweep(path, folder / "inprocess.h5", client=threads)
    data = read_sweep(folder / "inprocess.h5")
    fast = data.parameters["cars.0.velocity"] > 2.0
    assert 0 < fast.sum() < SAMPLES and summary.complete and summary.failed == fast.sum()
    np.testing.assert_array_equal(data.status, np.where(fast, FAILED, OK))
    assert all(data.error[i] == "model fem failed: RuntimeError: run-time failure" for i in np.flatnonzero(fast))


def test_interrupt_cancels_and_keeps_the_stored_samples(client, folder):
    path = write_sweep(folder / "interrupted")
    output = folder / "interrupted.h5"

    def interrupt_after_two(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(SweepInterrupted) as raised:
        run_sweep(path, output, client=client, progress=interrupt_after_two)
    assert raised.value.summary.run == 2 and not raised.value.summary.complete
    data = read_sweep(partial_path(output))
    assert np.count_nonzero(data.status == OK) == 2 and not output.exists()
    assert run_sweep(path, output, client=client).run == SAMPLES - 2


def test_cli_sweep_on_a_scheduler_resumes_and_renames(cluster, folder):
    path = write_sweep(folder / "cli")
    output = folder / "cli" / "cli.h5"
    runner = CliRunner()
    first = runner.invoke(main, ["sweep", str(path), "--scheduler", cluster.scheduler_address, "-o", str(output), "--limit", "3"])
    assert first.exit_code == 0, first.output
    assert f"samples: {SAMPLES} total, 3 run now, 0 skipped (already stored), 0 failed" in first.output and "runs/s" in first.output
    assert "(incomplete: run again to resume)" in first.output and partial_path(output).exists() and not output.exists()
    second = runner.invoke(main, ["sweep", str(path), "--scheduler", cluster.scheduler_address, "-o", str(output)])
    assert second.exit_code == 0, second.output
    assert f"{SAMPLES - 3} run now, 3 skipped (already stored)" in second.output and f"wrote {output}\n" in second.output
    assert output.exists() and not partial_path(output).exists() and read_sweep(output).ok.all()
    third = runner.invoke(main, ["sweep", str(path), "--scheduler", cluster.scheduler_address, "-o", str(output)])
    assert third.exit_code == 0 and f"all {SAMPLES} samples already stored" in third.output

    digest = file_digest(output)
    other = write_sweep(folder / "cli", "other.yaml", seed=5)
    refused = runner.invoke(main, ["sweep", str(other), "--scheduler", cluster.scheduler_address, "-o", str(output)])
    assert refused.exit_code == 2 and "holds another sweep" in refused.output and str(output) in refused.output
    assert file_digest(output) == digest


def test_cli_sweep_default_output_and_machinery_failure(folder, monkeypatch):
    import dask

    path = write_sweep(folder / "default")
    monkeypatch.chdir(folder / "default")
    result = CliRunner().invoke(main, ["sweep", str(path), "--scheduler", "tcp://127.0.0.1:9", "--limit", "0"])
    assert result.exit_code == 0, result.output  # nothing to run: no scheduler needed, the file is laid out
    assert (folder / "default" / "sweep.h5.partial").exists()
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        failed = CliRunner().invoke(main, ["sweep", str(path), "--scheduler", "tcp://127.0.0.1:9"])
    assert failed.exit_code == 1 and "error: sweep failed" in failed.output
    assert (folder / "default" / "sweep.h5.partial").exists()


def test_batch_size_grows_with_the_samples_per_thread_and_is_capped():
    from femref.sweep.run import MAX_BATCH, batch_size

    assert batch_size(8, 2) == 1 and batch_size(0, 2) == 1  # few samples: one per task, rows stream in
    assert batch_size(200, 2) == 200 // (4 * 2 * 2)  # every thread still gets four batches or more
    assert batch_size(10**5, 2) == MAX_BATCH and batch_size(10**5, 10**6) == 1


def test_batched_samples_are_stored_as_one_sample_per_task_stores_them(full, client, folder, monkeypatch):
    """Batches of 3 (the last one short; a retry's failed samples are not contiguous): the same rows, the same
    failures, and the same retry, as the unbatched sweeps of the tests above."""
    import femref.sweep.run as sweep_run

    monkeypatch.setattr(sweep_run, "batch_size", lambda samples, threads: 3)
    path, reference, _ = full
    output = folder / "batched.h5"
    summary = run_sweep(path, output, client=client)
    assert (summary.run, summary.failed, summary.complete) == (SAMPLES, 0, True)
    a, b = read_sweep(reference), read_sweep(output)
    np.testing.assert_array_equal(a.status, b.status)
    assert a.error == b.error and all(np.array_equal(a.parameters[k], b.parameters[k]) for k in a.parameters)
    for field in ("records", "coupler_force", "peak_coupler_force"):
        for model in a.models:
            np.testing.assert_array_equal(getattr(a, field)[model], getattr(b, field)[model], err_msg=f"{model}/{field}")

    failing = write_sweep(
        folder / "failing-batched",
        samples=10,
        parameters={"cars.1.body.axial_stiffness": {"normal": {"mean": 1.0e9, "std": 2.0e9}}},
    )
    output = folder / "failing-batched.h5"
    first = run_sweep(failing, output, client=client)
    data = read_sweep(output)
    expected_failed = data.parameters["cars.1.body.axial_stiffness"] <= 0
    assert 1 < expected_failed.sum() < 9 and first.complete
    assert np.any(np.diff(np.flatnonzero(expected_failed)) > 1)  # the retry's batch is not a contiguous range
    np.testing.assert_array_equal(data.status, np.where(expected_failed, FAILED, OK))
    assert sorted(i for i, _ in first.failures) == list(np.flatnonzero(expected_failed))
    assert np.isnan(data.records["fem"][expected_failed]).all() and np.isfinite(data.records["fem"][~expected_failed]).all()
    retried = run_sweep(failing, output, client=client, retry_failed=True)
    assert (retried.run, retried.failed) == (expected_failed.sum(), expected_failed.sum())
    np.testing.assert_array_equal(read_sweep(output).status, data.status)
