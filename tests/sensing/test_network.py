"""Network (``ann``) estimators in an impact case: ``estimators: [{name: ann_<name>, network: file.npz}]``.

A small RBF network is trained here on the measured fem records of a two-car impact at
eight speeds (their peak coupler forces as targets) and saved with ``ann.storage`` and
the metadata contract of :mod:`femref.sensing.network`. ``femref run`` through the
command line's code path must then write its peak estimate and its score, built from
exactly the records :func:`femref.sensing.records.fixed_length_records` makes of the fem
run's measured records; every broken file or mismatch with the case is exit 2 with the
key path, and nothing written.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import ann.storage as storage
from ann.features import FeaturePipeline, FeatureSettings
from ann.networks import RBFNetwork
from support.case_helpers import DELETE, edited_copy
from support.network_case import PROBES, RECORD_END, RECORD_LENGTH, TWO_CARS
from femref.case import CaseError, load_case, parse_case, resolved_yaml
from femref.cli import main
from femref.sensing.records import acceleration_histories, fixed_length_records, record_rate
from femref.run import run_scene
from femref.run.scoring import score_impact, score_peak_estimates
from femref.results import ModelResult
from femref.scene.build import scene_from_case

CHAIN = {"rate": 1000.0, "lowpass": 100.0, "noise": 0.05, "seed": 1}

#: A two-car free-roll impact, coarse fem (fast), records through a measurement chain.
CASE: dict[str, Any] = {
    **TWO_CARS,
    "time": {"end": RECORD_END},
    "models": ["fem", "rigid"],
    "fem": {"elements": 8, "order": 1},
    "measurement": CHAIN,
    "estimators": ["inverse_rigid", {"name": "ann_x", "network": "net.npz"}],
}

METADATA: dict[str, Any] = {
    "target": "peak_coupler_force",
    "coupler": "c1",
    "probes": PROBES,
    "record_length": RECORD_LENGTH,
    "record_end": RECORD_END,
    "record_source": "measured",
    "measurement": CHAIN,
    "training": {"source_model": "fem", "samples": 8, "speeds": [1.0, 3.0]},
}


def case(edits: dict[str, Any] | None = None) -> dict[str, Any]:
    return edited_copy(CASE, edits or {})


_TRAINING: dict[str, np.ndarray] = {}


def trained_records() -> tuple[np.ndarray, np.ndarray]:
    """Measured fem records ``(8, channels, RECORD_LENGTH)`` of the case at 8 speeds (1–3 m/s) and their peak forces."""
    if not _TRAINING:
        records, peaks = [], []
        for k, speed in enumerate(np.linspace(1.0, 3.0, 8)):
            data = case({"cars.0.velocity": float(speed), "models": ["fem"], "estimators": [], "measurement.seed": 10 + k})
            fem = run_scene(scene_from_case(parse_case(data))).results[0]
            time, histories = acceleration_histories(fem)
            records.append(fixed_length_records(time, histories, PROBES, RECORD_LENGTH, RECORD_END))
            peaks.append(float(np.max(fem.couplers["c1"]["force"])))
        _TRAINING.update(records=np.array(records), peaks=np.array(peaks))
    return _TRAINING["records"], _TRAINING["peaks"]


@pytest.fixture(scope="module")
def trained() -> tuple[FeaturePipeline, RBFNetwork]:
    """Pipeline and RBF network fitted on the measured fem records of the case at 8 speeds (1–3 m/s).

    The records scale with the speed and so does the peak force: the multiquadric network
    interpolates them to a few 0.1 % (checked at 1.3, 2.2 and 2.9 m/s while writing this test).
    """
    records, peaks = trained_records()
    rate = record_rate(RECORD_LENGTH, RECORD_END)
    pipeline = FeaturePipeline(FeatureSettings(length=32, rate=rate)).fit(records, rate)
    network = RBFNetwork(centres=8, basis="multiquadric", width_factor=3.0, seed=0).fit(pipeline.transform(records, rate), peaks)
    return pipeline, network


def save_network(path: Path, trained, metadata: dict[str, Any] | None = None) -> Path:
    storage.save(path, *trained, METADATA if metadata is None else metadata)
    return path


def write_case(directory: Path, data: dict[str, Any]) -> Path:
    path = directory / "case.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def run_output(trained, tmp_path_factory) -> tuple[Path, Path, str]:
    """``femref run case.yaml -o out.h5`` with the network beside the case; (file, network, stdout)."""
    directory = tmp_path_factory.mktemp("ann_run")
    network = save_network(directory / "net.npz", trained)
    output = directory / "out.h5"
    result = CliRunner().invoke(main, ["run", str(write_case(directory, case())), "-o", str(output)])
    assert result.exit_code == 0, result.output
    return output, network, result.output


# The run: peak estimate, score, summary


def test_run_writes_the_peak_estimate_and_its_score(run_output) -> None:
    """``/ann_x/couplers/c1/peak_force`` (N) and ``/scores/ann_x`` with |P̂ − max P_fem| / max P_fem from the file."""
    output, network, _ = run_output
    with h5py.File(output) as h5:
        group = h5["ann_x"]
        assert group.attrs["status"] == "ok", group.attrs["message"]
        assert "time" not in group and "probes" not in group
        dataset = group["couplers/c1/peak_force"]
        assert dataset.attrs["units"] == "N (compression positive)" and dataset.size == 1
        peak = float(np.asarray(dataset[()]).reshape(-1)[0])
        peak_fem = float(np.max(h5["fem/couplers/c1/force"][()]))
        scores = dict(h5["scores/ann_x"].attrs)
        settings = json.loads(group.attrs["settings"])
    expected = abs(peak - peak_fem) / peak_fem
    assert scores["coupler_force_peak_error_c1"] == pytest.approx(expected, rel=1e-12)
    assert scores["coupler_force_peak_error_max"] == scores["coupler_force_peak_error_c1"]
    assert scores["reference"] == "fem" and scores["wall_time_s"] > 0.0 and scores["speedup"] > 0.0
    assert not any("rms" in key or "time_error" in key or "acceleration" in key for key in scores), sorted(scores)
    assert expected < 0.03  # trained on fem records at neighbouring speeds
    assert settings["network"] == str(network.resolve()) and settings["kind"] == "rbf"
    assert settings["record_source"] == "measured" and settings["records"] == "fem (measured)"
    assert settings["record_rate"] == pytest.approx(record_rate(RECORD_LENGTH, RECORD_END))
    assert settings["training"] == {"source_model": "fem", "samples": 8}  # scalars only


def test_network_reads_fixed_length_records_of_the_fem_measured_records(run_output) -> None:
    """The stored estimate is ``predict`` on ``fixed_length_records`` of ``/fem/measured``, and not of the
    unmeasured ``/fem/probes`` accelerations (which give another value)."""
    output, network, _ = run_output
    estimator, _ = storage.load_estimator(network)
    rate = record_rate(RECORD_LENGTH, RECORD_END)
    with h5py.File(output) as h5:
        peak = float(np.asarray(h5["ann_x/couplers/c1/peak_force"][()]).reshape(-1)[0])
        measured = {p: h5[f"fem/measured/{p}/acceleration"][()] for p in PROBES}
        unmeasured = {p: h5[f"fem/probes/{p}/acceleration"][()] for p in PROBES}
        t_measured, t_model = h5["fem/measured/time"][()], h5["fem/time"][()]
    records = fixed_length_records(t_measured, measured, PROBES, RECORD_LENGTH, RECORD_END)
    assert estimator.predict(records[None], rate)[0] == pytest.approx(peak, rel=1e-12)
    records_model = fixed_length_records(t_model, unmeasured, PROBES, RECORD_LENGTH, RECORD_END)
    assert abs(estimator.predict(records_model[None], rate)[0] - peak) > 1e-9 * peak


def test_summary_shows_the_network_row(run_output) -> None:
    """The ann row has its peak and peak error; no steps, peak-time or rms columns."""
    output, _, text = run_output
    row = next(line for line in text.splitlines() if "ann_x" in line)
    with h5py.File(output) as h5:
        peak_kn = float(np.asarray(h5["ann_x/couplers/c1/peak_force"][()]).reshape(-1)[0]) / 1e3
        error = h5["scores/ann_x"].attrs["coupler_force_peak_error_c1"]
    cells = [cell.strip() for cell in re.split(r"[│|]", row) if cell.strip()]
    assert f"{peak_kn:.1f} @c1" in cells and f"{error:.2%}" in cells
    assert cells[:2] == ["ann_x", "ok"]
    assert len(cells) == 6  # model, status, wall time, speed-up, peak, peak error


# The case file


def test_resolved_case_round_trips_with_the_network_path_absolute(trained, tmp_path: Path) -> None:
    save_network(tmp_path / "net.npz", trained)
    loaded = load_case(write_case(tmp_path, case()))
    text = resolved_yaml(loaded)
    resolved = yaml.safe_load(text)
    assert resolved["estimators"] == ["inverse_rigid", {"name": "ann_x", "network": str((tmp_path / "net.npz").resolve())}]
    assert parse_case(resolved, base_dir=Path("/")) == loaded
    assert resolved_yaml(parse_case(resolved)) == text


def test_builder_holds_the_loaded_network_beside_the_inverse_estimators(trained, tmp_path: Path) -> None:
    save_network(tmp_path / "net.npz", trained)
    scene = scene_from_case(load_case(write_case(tmp_path, case())), tmp_path)
    assert scene.estimators == ("inverse_rigid",)
    (network,) = scene.networks
    assert network.name == "ann_x" and network.coupler == "c1" and network.contract.probes == tuple(PROBES)
    assert network.estimator.network.kind == "rbf"


def test_noise_and_seed_of_the_case_may_differ_from_training(trained, tmp_path: Path) -> None:
    """Testing a network on noisier records is legitimate: only rate and lowpass must match."""
    save_network(tmp_path / "net.npz", trained)
    path = write_case(tmp_path, case({"measurement": {**CHAIN, "noise": 0.5, "seed": 7}}))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 0, result.output


def test_network_file_changed_after_validation_is_a_case_error(trained, tmp_path: Path) -> None:
    save_network(tmp_path / "net.npz", trained)
    loaded = load_case(write_case(tmp_path, case()))
    save_network(tmp_path / "net.npz", trained, {**METADATA, "probes": list(reversed(PROBES))})
    with pytest.raises(CaseError, match=re.escape("estimators[1].network: network file") + ".*changed since the case was validated"):
        scene_from_case(loaded, tmp_path)


# One network per impact type


def _doubled(trained) -> tuple[FeaturePipeline, RBFNetwork]:
    """The fixture's network refitted to twice the peak forces: a second network whose estimate differs."""
    records, peaks = trained_records()
    pipeline = trained[0]
    network = RBFNetwork(centres=8, basis="multiquadric", width_factor=3.0, seed=0).fit(pipeline.transform(records, record_rate(RECORD_LENGTH, RECORD_END)), 2.0 * peaks)
    return pipeline, network


@pytest.mark.parametrize(("contact", "kind"), [("compression_only", "free_to_roll"), ("bilateral", "coupled")])
def test_one_network_per_impact_type_reads_each_impact_with_its_own(trained, tmp_path: Path, contact: str, kind: str) -> None:
    """``network: {free_to_roll: a.npz, coupled: b.npz}``: the fem records are classified by the zero harmonic
    of the relative acceleration (free to roll with the compression-only coupler, coupled with the bilateral
    one) and read by that type's network — its estimate is the plain estimator's of the same file to the last
    bit, and the result says which type it read; an estimator without a network for the type gives no number,
    with the reason."""
    save_network(tmp_path / "free.npz", trained)
    save_network(tmp_path / "coupled.npz", _doubled(trained))
    data = case({
        "couplers.0.contact": contact,
        "models": ["fem"],
        "estimators": [
            {"name": "ann_free", "network": "free.npz"},
            {"name": "ann_coupled", "network": "coupled.npz"},
            {"name": "ann_typed", "network": {"free_to_roll": "free.npz", "coupled": "coupled.npz"}},
            {"name": "ann_other", "network": {"coupled" if kind == "free_to_roll" else "free_to_roll": "free.npz"}},
        ],
    })
    scene = scene_from_case(load_case(write_case(tmp_path, data)), tmp_path)
    results = {r.model: r for r in run_scene(scene).results}
    typed, plain = results["ann_typed"], results["ann_free" if kind == "free_to_roll" else "ann_coupled"]
    assert typed.ok and typed.settings["impact_type"] == kind
    assert typed.couplers["c1"]["peak_force"] == plain.couplers["c1"]["peak_force"]
    assert results["ann_coupled"].couplers["c1"]["peak_force"] == pytest.approx(2.0 * results["ann_free"].couplers["c1"]["peak_force"], rel=1e-6)
    other = results["ann_other"]
    assert other.status == "failed" and f"has no network for {kind.replace('_', '-')} impacts" in other.message


def _two_couplers(path: Path, trained) -> None:
    save_network(path, trained)
    save_network(path.with_name("other.npz"), trained, {**METADATA, "coupler": "c9"})


#: id → (network file writer, case edits, key path, rule (regex)): one network per impact type.
BAD_BY_TYPE: dict[str, tuple[Any, dict[str, Any], str, str]] = {
    "unknown impact type": (None, {"estimators.1.network": {"free_roll": "net.npz"}}, "estimators[1].network.free_roll", "unknown key"),
    "no impact type": (None, {"estimators.1.network": {}}, "estimators[1].network", "give a network file for free_to_roll, coupled or both"),
    "a list of files": (None, {"estimators.1.network": ["net.npz"]}, "estimators[1].network", r"must be a network file or \{free_to_roll: file\.npz, coupled: file\.npz\}"),
    "one file missing": (None, {"estimators.1.network": {"free_to_roll": "net.npz", "coupled": "gone.npz"}}, "estimators[1].network.coupled", r"network file \S+gone\.npz does not exist"),
    "two couplers": (_two_couplers, {"estimators.1.network": {"free_to_roll": "net.npz", "coupled": "other.npz"}}, "estimators[1].network",
                     "the networks of one estimator must estimate one coupler; free_to_roll estimates c1, coupled estimates c9"),
    "a type's network against the case": (lambda p, t: save_network(p, t, _metadata(probes=[*PROBES[:3], "anvil/front"])),
                                          {"estimators.1.network": {"coupled": "net.npz"}}, "estimators[1].network.coupled", r"the network reads probe\(s\) anvil/front"),
}


@pytest.mark.parametrize(("writer", "edits", "key_path", "rule"), list(BAD_BY_TYPE.values()), ids=list(BAD_BY_TYPE))
def test_bad_networks_by_impact_type_exit_2_naming_the_key(trained, tmp_path: Path, writer, edits, key_path: str, rule: str) -> None:
    (writer or save_network)(tmp_path / "net.npz", trained)
    path = write_case(tmp_path, case(edits))
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert re.search(rf"{re.escape(f'{path}: {key_path}: ')}[^\n]*{rule}", result.output), result.output
    assert not output.exists()


def _mass_network(extras: tuple[str, ...]) -> tuple[FeaturePipeline, RBFNetwork]:
    """The fixture's network retrained on the same records with car masses as extra inputs."""
    records, peaks = trained_records()
    rate = record_rate(RECORD_LENGTH, RECORD_END)
    masses = np.tile([7000.0 * 17.0, 6500.0 * 15.0][: len(extras)], (len(peaks), 1)) * np.linspace(0.9, 1.1, len(peaks))[:, None]
    settings = FeatureSettings(length=32, rate=rate, normalise="channel_peak", extras=extras)
    with_masses = FeaturePipeline(settings).fit(records, rate, masses)
    network = RBFNetwork(centres=8, basis="gaussian", width_factor=4.0, seed=0, log_target=True).fit(with_masses.transform(records, rate, masses), peaks)
    return with_masses, network


def test_network_with_car_mass_inputs_gets_the_case_masses(tmp_path: Path) -> None:
    """A network taking ``car_mass/anvil`` and ``car_mass/hammer`` predicts with the masses of the case's cars (kg)."""
    pair = _mass_network(("car_mass/anvil", "car_mass/hammer"))
    save_network(tmp_path / "net.npz", pair)
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(write_case(tmp_path, case())), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output) as h5:
        peak = float(np.asarray(h5["ann_x/couplers/c1/peak_force"][()]).reshape(-1)[0])
        measured = {p: h5[f"fem/measured/{p}/acceleration"][()] for p in PROBES}
        t_measured = h5["fem/measured/time"][()]
        assert json.loads(h5["ann_x"].attrs["settings"])["extras"] == ["car_mass/anvil", "car_mass/hammer"]
    records = fixed_length_records(t_measured, measured, PROBES, RECORD_LENGTH, RECORD_END)
    masses = np.array([[6500.0 * 15.0, 7000.0 * 17.0]])
    expected = storage.Estimator(*pair).predict(records[None], record_rate(RECORD_LENGTH, RECORD_END), masses)[0]
    assert peak == pytest.approx(expected, rel=1e-12)
    swapped = storage.Estimator(*pair).predict(records[None], record_rate(RECORD_LENGTH, RECORD_END), masses[:, ::-1])[0]
    assert abs(swapped - peak) > 1e-6 * peak


@pytest.mark.parametrize(
    ("extras", "rule"),
    [
        (("car_mass/tender",), r"the network takes the mass of car\(s\) tender, which this case does not have; cars: hammer, anvil"),
        (("speed",), r"the network takes the input\(s\) speed; femref supplies only car_mass/<car>"),
    ],
)
def test_network_inputs_femref_cannot_supply_exit_2(tmp_path: Path, extras, rule) -> None:
    save_network(tmp_path / "net.npz", _mass_network(extras))
    path = write_case(tmp_path, case())
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 2, result.output
    assert re.search(rf"{re.escape(f'{path}: {NETWORK}: ')}[^\n]*{rule}", result.output), result.output
    assert not (tmp_path / "out.h5").exists()


# Bad input: exit 2, the key path, nothing written


def _metadata(**changes: Any) -> dict[str, Any]:
    return {key: value for key, value in {**METADATA, **changes}.items() if value is not DELETE}


def _bad_version(path: Path, trained) -> None:
    save_network(path, trained)
    with np.load(path, allow_pickle=False) as data:
        arrays = {key: data[key] for key in data.files}
    arrays["format_version"] = np.array(storage.FORMAT_VERSION + 1)
    with open(path, "wb") as handle:
        np.savez(handle, **arrays)


NETWORK = "estimators[1].network"

#: id → (network file writer or None for no file, case edits, key path, rule (regex)).
BAD: dict[str, tuple[Any, dict[str, Any], str, str]] = {
    "file missing": (None, {}, NETWORK, r"network file \S+net\.npz does not exist"),
    "not an npz file": (lambda p, t: p.write_text("not a network\n"), {}, NETWORK, r"net\.npz is not an ann network file \(ann\.storage \.npz\): not an \.npz archive"),
    "npz of other arrays": (lambda p, t: np.savez(p, x=np.zeros(3)), {}, NETWORK, r"not a usable ann network file \(ann\.storage \.npz\): \S+net\.npz is not an ann model file \(no format_version\)"),
    "another format version": (_bad_version, {}, NETWORK, rf"has ann model format version {storage.FORMAT_VERSION + 1}, but this code reads version {storage.FORMAT_VERSION}"),
    "metadata lacks probes": (_metadata(probes=DELETE), {}, NETWORK, r"the network metadata lacks the required key\(s\) probes"),
    "metadata lacks the chain": (_metadata(measurement=DELETE, record_source=DELETE), {}, NETWORK, r"lacks the required key\(s\) record_source, measurement"),
    "another target": (_metadata(target="peak_acceleration"), {}, NETWORK, "metadata target is 'peak_acceleration'; femref reads networks of target peak_coupler_force"),
    "unknown record source": (_metadata(record_source="field"), {}, NETWORK, "metadata record_source must be one of measured, model"),
    "pipeline rate": (_metadata(record_length=RECORD_LENGTH + 1), {}, NETWORK, r"the network's pipeline reads records at 252 Hz, but record_length 65 over record_end 0\.25 s makes 256 Hz"),
    "coupler not in the case": (_metadata(coupler="c9"), {}, NETWORK, "the network estimates coupler 'c9', which this case does not have; couplers: c1"),
    "probe not a sensor": (_metadata(probes=[*PROBES[:3], "anvil/front"]), {}, NETWORK, "the network reads probe\\(s\\) anvil/front, which are not sensors of this case"),
    "records beyond time.end": (_metadata(), {"time.end": 0.2}, NETWORK, r"the network reads records over \[0, 0\.25\] s, beyond time\.end = 0\.2 s"),
    "measured network, no measurement": (_metadata(), {"measurement": DELETE}, NETWORK, r"the network was trained on measured records \(rate 1000 Hz, lowpass 100 Hz\); add that measurement"),
    "model network, a measurement": (_metadata(record_source="model", measurement=None), {}, NETWORK, "the network was trained on the model's own sensor accelerations"),
    "another rate": (_metadata(), {"measurement.rate": 2000.0}, NETWORK, r"trained on records measured at rate 1000 Hz, lowpass 100 Hz; this case measures at rate 2000 Hz, lowpass 100 Hz"),
    "another lowpass": (_metadata(), {"measurement.lowpass": 50.0}, NETWORK, r"this case measures at rate 1000 Hz, lowpass 50 Hz \(rate and lowpass must match"),
    "no uniform fem run": (_metadata(), {"models": ["rigid"]}, "estimators", r"the estimators run on the fem sensor records; add fem"),
    "name not ann": (_metadata(), {"estimators.1.name": "net"}, "estimators[1].name", "network estimators are named ann or ann_<name>"),
    "two networks of one name": (
        _metadata(),
        {"estimators": ["inverse_rigid", {"name": "ann_x", "network": "net.npz"}, {"name": "ann_x", "network": "net.npz"}]},
        "estimators[2].name",
        "duplicate estimator name; 'ann_x' is already used at index 1",
    ),
    "network written as a name": (_metadata(), {"estimators": ["inverse_rigid", "ann_x"]}, "estimators[1]", r"unknown estimator \(a network estimator is a mapping \{name: ann_x, network: file\.npz\}\)"),
    "unknown key": (_metadata(), {"estimators.1.path": "net.npz"}, "estimators[1].path", "unknown key"),
    "ann as a model": (_metadata(), {"models": ["fem", "ann"]}, "models[1]", "ann cannot serve this case: a network is an estimator on the fem sensor records, not a model run"),
}


@pytest.mark.parametrize(("writer", "edits", "key_path", "rule"), list(BAD.values()), ids=list(BAD))
def test_bad_network_or_mismatch_exits_2_naming_the_key(trained, tmp_path: Path, writer, edits, key_path: str, rule: str) -> None:
    network = tmp_path / "net.npz"
    if isinstance(writer, dict):
        save_network(network, trained, writer)
    elif writer is not None:
        writer(network, trained)
    path = write_case(tmp_path, case(edits))
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert re.search(rf"{re.escape(f'{path}: {key_path}: ')}[^\n]*{rule}", result.output), result.output
    assert not output.exists() and [p.name for p in tmp_path.iterdir() if p.suffix == ".h5"] == []


# Scoring of peak estimates


def _history(model: str, time: np.ndarray, force: np.ndarray) -> ModelResult:
    result = ModelResult(model)
    result.axes = {"time": time}
    result.couplers = {"c1": {"force": force}}
    return result


def _peaks(model: str, **peaks: Any) -> ModelResult:
    result = ModelResult(model)
    result.couplers = {c: {"peak_force": np.asarray(p)} for c, p in peaks.items()}
    return result


def test_peak_estimate_scores() -> None:
    """Reference peak 2 MN (sin pulse): an estimate of 2.1 MN is 5 % high; tension only gives NaN and no aggregate."""
    t = np.linspace(0.0, 0.2, 201)
    reference = _history("fem", t, 2.0e6 * np.sin(np.pi * t / 0.2))
    reference.couplers["c2"] = {"force": -1.0e5 * np.sin(np.pi * t / 0.2)}
    scores = score_impact(reference, _peaks("ann_a", c1=2.1e6, c2=[3.0e4]))
    assert scores == {"coupler_force_peak_error_c1": pytest.approx(0.05, rel=1e-12), "coupler_force_peak_error_c2": pytest.approx(math.nan, nan_ok=True), "coupler_force_peak_error_max": pytest.approx(0.05, rel=1e-12)}
    only_tension = score_peak_estimates(reference, _peaks("ann_b", c2=0.0))
    assert math.isnan(only_tension["coupler_force_peak_error_c2"]) and "coupler_force_peak_error_max" not in only_tension


def test_peak_estimate_of_several_values_is_refused() -> None:
    t = np.linspace(0.0, 0.2, 21)
    with pytest.raises(ValueError, match=r"coupler c1 peak_force has shape \(2,\), expected one value"):
        score_impact(_history("fem", t, np.sin(t)), _peaks("ann_a", c1=[1.0, 2.0]))
