"""A sweep's stored rows against independent paths: each sample run alone by ``femref run`` of its case file, and
the same sweep on 1 and 2 local workers and on a scheduler given by address; the work budget checked once per
worker only where no sample can change it."""

import dataclasses
import os

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.api import open_result
from femref.case import parse_case
from femref.cli import main
from femref.run.budget import predict
from femref.scene.build import scene_from_case
from femref.sweep import parse_sweep, read_sweep, run_sweep
from femref.sweep.worker import run_samples

distributed = pytest.importorskip("distributed")

RECORD, FORCE, END = 30, 25, 0.3


def base_case() -> dict:
    rod = {"type": "rod", "length": 16.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
    return {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": {**rod, "mass_per_length": {"piecewise": {"breaks": [-6.0, 6.0], "values": [3500.0, 8000.0, 3500.0]}}},
             "velocity": 2.0, "sensors": {"center": 0.0, "front": 7.5}},
            {"name": "anvil", "body": {**rod, "mass_per_length": 6000.0}, "velocity": 0.0, "sensors": {"rear": -7.5}},
        ],
        "couplers": [{"name": "c1", "between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
        "time": {"end": END},
        "models": ["fem", "rigid"],
        "fem": {"elements": 6, "order": 1},
        "measurement": {"rate": 1000.0, "lowpass": 100.0, "noise": 0.01, "seed": 3},
    }


PARAMETERS = {
    "cars.0.velocity": {"uniform": [1.0, 3.0]},  # a velocity
    "cars.1.body.mass_per_length": {"uniform": [5000.0, 7000.0]},  # a mass
    "couplers.0.law.kelvin_voigt.damping": {"log_uniform": [1.0e5, 6.0e5]},  # a coupler law parameter
    "cars.0.body.mass_per_length.piecewise.values.1": {"uniform": [6000.0, 9000.0]},  # a profile value
}


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("paths")


@pytest.fixture(scope="module")
def sweep(folder):
    return parse_sweep({"case": base_case(), "samples": 4, "seed": 21, "parameters": PARAMETERS,
                        "outputs": {"record_length": RECORD, "force_length": FORCE}}, source="paths.yaml", base_dir=folder)


@pytest.fixture(scope="module")
def one_worker(sweep, folder):
    output = folder / "one.h5"
    summary = run_sweep(sweep, output, workers=1)
    assert summary.complete and summary.failed == 0
    return output


def test_stored_rows_equal_femref_run_of_each_sample_case(sweep, one_worker, folder):
    """Each sample's case written as a case file and run by ``femref run``; its records, forces and peaks from the
    result file by the rule of femref.sensing.records (np.interp onto k·end/(length − 1))."""
    data = read_sweep(one_worker)
    for index in range(sweep.size):
        rows = {f"{model}/{name}": getattr(data, name)[model][index] for model in data.models for name in ("records", "coupler_force", "peak_coupler_force")}
        case = _assert_rows_equal_femref_run(sweep, index, rows, data.probes, folder)
        assert parse_case(yaml.safe_load(case.read_text())).cars[1].body.mass_per_length.value == data.parameters["cars.1.body.mass_per_length"][index]


def test_a_chunk_of_mixed_structures_equals_femref_run_of_each_sample(folder):
    """One task's chunk whose samples draw the mesh too: its fem runs are stepped in a group per structure, its rigid
    runs in one; each sample's record equals ``femref run`` of its case."""
    mixed = parse_sweep({"case": base_case(), "samples": 4, "seed": 21, "parameters": {**PARAMETERS, "fem.elements": {"choice": [4, 6]}},
                         "outputs": {"record_length": RECORD, "force_length": FORCE}}, source="mixed.yaml", base_dir=folder)
    samples = [mixed.sample(i) for i in range(mixed.size)]
    assert {s.values["fem.elements"] for s in samples} == {4, 6}
    records = run_samples(mixed, [(s.index, s.substitutions) for s in samples])
    for index, record in enumerate(records):
        assert record["error"] == ""
        _assert_rows_equal_femref_run(mixed, index, record, record["probes"], folder / "mixed")


def _assert_rows_equal_femref_run(sweep, index: int, rows: dict, probes: list[str], folder):
    """``rows`` (``<model>/records``, ``/coupler_force``, ``/peak_coupler_force``) of sample ``index`` against
    ``femref run`` of its case file; the case file."""
    folder.mkdir(parents=True, exist_ok=True)
    case = folder / f"sample_{index}.yaml"
    case.write_text(yaml.safe_dump(sweep.sample_data(sweep.sample(index)), sort_keys=False))
    result = folder / f"sample_{index}.h5"
    run = CliRunner().invoke(main, ["run", str(case), "-o", str(result)])
    assert run.exit_code == 0, run.output
    for model in ("fem", "rigid"):
        alone = open_result(result, model)
        records = [np.interp(np.linspace(0.0, END, RECORD), alone["measured_time"], alone["measured_acceleration"].sel(probe=p)) for p in probes]
        np.testing.assert_allclose(rows[f"{model}/records"], records, rtol=1e-12, atol=1e-9)
        force = alone["force"].sel(coupler="c1").values
        np.testing.assert_allclose(rows[f"{model}/coupler_force"][0], np.interp(np.linspace(0.0, END, FORCE), alone["time"], force), rtol=1e-12, atol=1e-6)
        assert rows[f"{model}/peak_coupler_force"][0] == pytest.approx(force.max(), rel=1e-12)
    return case


def _rows(path) -> dict:
    """Every dataset but the wall times, and the root attributes but the creation time."""
    rows = {}
    with h5py.File(path, "r") as h5:
        h5.visititems(lambda name, item: rows.__setitem__(name, item[...]) if isinstance(item, h5py.Dataset) and not name.endswith("wall_time_s") else None)
        rows.update({f"@{k}": v for k, v in h5.attrs.items() if k != "created"})
    return rows


def test_one_and_two_workers_and_a_scheduler_address_give_the_same_file(sweep, one_worker, folder):
    two = folder / "two.h5"
    assert run_sweep(sweep, two, workers=2).complete
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None) as cluster:
        remote = folder / "remote.h5"
        assert run_sweep(sweep, remote, scheduler=cluster.scheduler_address).complete
    expected = _rows(one_worker)
    assert len(expected) > 20
    for other in (two, remote):
        rows = _rows(other)
        assert rows.keys() == expected.keys()
        for name, value in expected.items():
            assert np.array_equal(rows[name], value), name


def test_velocity_and_noise_leave_the_budget_prediction_as_it_was(sweep):
    """What lets a worker check the budget once for a sweep that draws only these (femref.sweep.worker.BUDGET_NEUTRAL)."""
    base = scene_from_case(sweep.base_case, sweep.base_dir)
    case = sweep.base_case
    changed = case.model_copy(update={"cars": (case.cars[0].model_copy(update={"velocity": 7.0}), case.cars[1]),
                                      "measurement": case.measurement.model_copy(update={"noise": 2.0, "seed": 99})})
    assert [dataclasses.astuple(c) for c in predict(scene_from_case(changed, sweep.base_dir))] == [dataclasses.astuple(c) for c in predict(base)]


def test_a_budget_checked_once_follows_the_budget(folder, monkeypatch):
    """A velocity-only sweep: within the budget its samples run; with FEMREF_BUDGET tiny each is refused by name."""
    neutral = parse_sweep({"case": base_case(), "samples": 2, "seed": 1, "parameters": {"cars.0.velocity": {"uniform": [1.0, 3.0]}}},
                          source="neutral.yaml", base_dir=folder)
    samples = [(i, neutral.sample(i).substitutions) for i in range(2)]
    assert [r["error"] for r in run_samples(neutral, samples)] == ["", ""]
    monkeypatch.setenv("FEMREF_BUDGET", "1e-9")
    refused = run_samples(neutral, samples)
    assert all(r["error"].startswith(f"CaseError: neutral.yaml sample {i}: ") and "budget" in r["error"] for i, r in enumerate(refused))
    monkeypatch.delenv("FEMREF_BUDGET")
    assert [r["error"] for r in run_samples(neutral, samples)] == ["", ""]


def test_forked_workers_start_with_the_default_signal_handlers(monkeypatch):
    """A command's SIGTERM handler (an interrupt) stays in the command: a forked worker terminates on SIGTERM."""
    import signal

    from femref.core.cluster import dask_client

    def command_handler(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, command_handler)
    try:
        with dask_client(workers=1, fork=True) as client:
            handlers = next(iter(client.run(lambda: repr((signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)))).values()))
            pid = next(iter(client.run(os.getpid).values()))
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert "command_handler" not in handlers and pid != os.getpid()


def test_a_worker_unpickles_each_sweep_once(sweep, folder):
    import pickle

    from femref.sweep.worker import sweep_of

    other = parse_sweep({"case": base_case(), "samples": 2, "seed": 22, "parameters": PARAMETERS}, source="other.yaml", base_dir=folder)
    first = sweep_of(pickle.dumps(sweep))
    assert sweep_of(pickle.dumps(sweep)) is first and first.spec_hash == sweep.spec_hash
    assert sweep_of(pickle.dumps(other)).spec_hash == other.spec_hash != sweep.spec_hash
