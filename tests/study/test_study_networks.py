"""Study networks as the source study used them (issue 17): a unit per layer, back-propagation with
momentum, training continued from a saved network, the loss per epoch stored and drawn.

The end-to-end part is a tiny study on an in-process Dask client (40 rigid training impacts,
6 fem test impacts on an 8-element mesh; a few seconds): it checks the plumbing — what is
trained, saved, continued, stored and drawn — not accuracy (tests/study/test_study.py does that).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from femref.case import CaseError
from femref.study.run import run_study
from femref.study.spec import SKLEARN_UNITS, UNIT_NAMES, load_study, parse_study

from support.paths import CASES

DEEP = {"hidden": [6, 3], "activation": ["tanh", "tanh", "logistic"], "solver": "momentum", "learning_rate": 0.05, "max_iter": 200, "batch_size": 8}


def study_data(networks: dict) -> dict:
    data = yaml.safe_load((CASES / "studies" / "ann_study.yaml").read_text())
    data["base"] = str(CASES / "impact_free_roll.yaml")
    data["networks"] = networks
    return data


# ------------------------------------------------------------------ the study file


def test_unit_names_are_those_of_ann() -> None:
    """The study file's unit names are the trainers' (one registry each side of the ann/femref boundary)."""
    from ann.backprop import UNITS
    from ann.networks import ACTIVATIONS

    assert set(UNIT_NAMES) == set(UNITS)
    assert set(SKLEARN_UNITS) == set(ACTIVATIONS)


@pytest.mark.parametrize(
    ("activation", "units"),
    [("tanh", ("tanh", "tanh", "linear")), (["tanh", "step"], ("tanh", "step", "linear")), (["tanh", "tanh", "logistic"], ("tanh", "tanh", "logistic"))],
)
def test_momentum_entries_build_their_trainer(activation, units) -> None:
    study = parse_study(study_data({"deep": {"mlp": {**DEEP, "activation": activation}}}))
    network = study.networks["deep"].build()
    assert network.kind == "momentum_mlp" and network.units == units
    assert (network.hidden, network.epochs, network.batch_size, network.learning_rate) == ((6, 3), 200, 8, 0.05)
    assert network.log_target


@pytest.mark.parametrize(
    ("entry", "key_path", "rule"),
    [
        ({"activation": "gaussian"}, "networks.n.mlp.activation", "gaussian units need solver: momentum; lbfgs (scikit-learn) takes logistic, tanh, relu"),
        ({"activation": ["tanh", "tanh"]}, "networks.n.mlp.activation", "a unit per layer needs solver: momentum"),
        ({"batch_size": 16}, "networks.n.mlp.batch_size", "batch_size needs solver: momentum"),
        ({"initial": "a.npz"}, "networks.n.mlp.initial", "initial needs solver: momentum"),
        ({"solver": "momentum", "activation": ["tanh"] * 4}, "networks.n.mlp.activation", "needs one name, or 2 (one per hidden layer), or 3 (the last for the output unit)"),
        ({"solver": "momentum", "activation": ["tanh", "tanh", "relu"]}, "networks.n.mlp.activation", "the output unit must be one of ('linear', 'logistic', 'tanh')"),
        ({"solver": "momentum", "activation": ["tanh", "sigmoid"]}, "networks.n.mlp.activation[1]", "must be one of 'logistic', 'tanh', 'relu', 'linear', 'gaussian' or 'step'"),
        ({"solver": "momentum", "activation": []}, "networks.n.mlp.activation", "must be a unit name or a non-empty list of unit names"),
        ({"solver": "momentum", "batch_size": 0}, "networks.n.mlp.batch_size", "must be >= 1"),
        ({"solver": "newton"}, "networks.n.mlp.solver", "must be one of 'sgd', 'adam', 'lbfgs' or 'momentum'"),
    ],
)
def test_bad_network_entries_name_the_key_and_rule(entry, key_path: str, rule: str) -> None:
    with pytest.raises(CaseError) as error:
        parse_study(study_data({"n": {"mlp": {"hidden": [4, 2], **entry}}}), source="s.yaml")
    assert f"s.yaml: {key_path}: " in str(error.value) and rule in str(error.value), str(error.value)


def test_inverse_multiquadric_basis_is_a_study_choice() -> None:
    study = parse_study(study_data({"r": {"rbf": {"basis": "inverse_multiquadric"}}}))
    assert study.networks["r"].build().basis == "inverse_multiquadric"


# ------------------------------------------------------------------ a tiny study, end to end


def write_study(folder: Path, name: str, networks: dict) -> Path:
    data = study_data(networks)
    data["base_overrides"] = {"fem.elements": 8}
    data["sets"] = {"train": {"samples": 40, "seed": 11, "models": ["rigid"]}, "test": {"samples": 6, "seed": 12, "models": ["fem"]}}
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed")
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as local:
        yield local


@pytest.fixture(scope="module")
def studies(client, tmp_path_factory):
    """A first study training ``deep`` for 200 epochs, then a second continuing it for 100 more
    (``initial: out/networks/rigid_deep.npz``, relative to the study file; same folder, so the
    sweeps are found stored)."""
    folder = tmp_path_factory.mktemp("networks_study")
    first = write_study(folder, "first", {"deep": {"mlp": DEEP}})
    run_study(*load_study(first), folder / "out", source=str(first), client=client)
    saved = np.load(folder / "out" / "networks" / "rigid_deep.npz", allow_pickle=False)
    first_curve = np.array(saved["network/loss_curve"])
    first_pipeline = {k: np.array(saved[k]) for k in saved.files if k.startswith("pipeline/")}
    second = write_study(folder, "second", {"more": {"mlp": {**DEEP, "max_iter": 100, "initial": "out/networks/rigid_deep.npz"}}})
    outcome = run_study(*load_study(second), folder / "out", source=str(second), client=client)
    return folder, first_curve, first_pipeline, outcome


def test_loss_per_epoch_is_saved_with_the_network_and_in_the_study_file(studies) -> None:
    """At most 200 epochs (fewer when the loss settled first), one finite loss each, saved with the network."""
    folder, first_curve, _, _ = studies
    assert 0 < first_curve.size <= 200 and np.all(np.isfinite(first_curve))
    with np.load(folder / "out" / "networks" / "rigid_deep.npz", allow_pickle=False) as saved:
        assert str(saved["network_kind"]) == "momentum_mlp"
        assert list(saved["network/units"]) == ["tanh", "tanh", "logistic"]
        assert int(saved["network/n_iter"]) == first_curve.size


def test_continued_network_keeps_the_pipeline_and_goes_on_from_the_saved_loss(studies) -> None:
    """The continued network's loss curve is the saved one followed by up to 100 more epochs; the
    first of them starts where the saved run stopped (within a tenth of the drop from the first
    epoch, where a fresh start would be); its feature pipeline is the saved one, unrefitted."""
    folder, first_curve, first_pipeline, outcome = studies
    (trained,) = outcome.networks
    curve, stopped = trained.loss_curve, first_curve.size
    assert stopped < curve.size <= stopped + 100
    np.testing.assert_array_equal(curve[:stopped], first_curve)
    assert abs(curve[stopped] - curve[stopped - 1]) < 0.1 * (curve[0] - curve[stopped - 1])
    with np.load(folder / "out" / "networks" / "rigid_more.npz", allow_pickle=False) as saved:
        for key, value in first_pipeline.items():
            np.testing.assert_array_equal(saved[key], value)
        assert int(saved["network/n_iter"]) == curve.size
    with h5py.File(folder / "out" / "study.h5") as h5:
        np.testing.assert_array_equal(h5["networks/rigid_more/loss_curve"][()], curve)


def test_study_report_draws_the_loss_of_every_network(studies, tmp_path) -> None:
    """``femref report study.h5``: the error table and one loss-per-epoch figure per network."""
    from click.testing import CliRunner

    from femref.cli import main

    folder, _, _, outcome = studies
    page = tmp_path / "study.html"
    result = CliRunner().invoke(main, ["report", str(folder / "out" / "study.h5"), "-o", str(page)])
    assert result.exit_code == 0, result.output
    html = page.read_text()
    assert "<h2>Training loss</h2>" in html and "Peak-force errors" in html
    assert html.count('<img src="data:image/png;base64,') == 1  # rigid_more, the one network of this study file
    assert "rigid_more (network more, trained on rigid records" in html
    assert f"{outcome.networks[0].loss_curve.size} epochs" in html


@pytest.mark.parametrize(
    ("entry", "rule"),
    [
        ({"hidden": [6, 2]}, "cannot continue from a network with hidden layers (6, 3)"),
        ({"activation": ["tanh", "tanh"]}, "units ('tanh', 'tanh', 'logistic')"),
        ({"initial": "out/networks/none.npz"}, "saved network file not found"),
    ],
)
def test_a_mismatched_initial_network_is_refused_before_the_sweeps(studies, client, entry, rule) -> None:
    folder, _, _, _ = studies
    path = write_study(folder, "bad", {"x": {"mlp": {**DEEP, "initial": "out/networks/rigid_deep.npz", **entry}}})
    with pytest.raises(CaseError) as error:
        run_study(*load_study(path), folder / "bad_out", source=str(path), client=client)
    assert f"{path}: networks.x.mlp.initial: " in str(error.value) and rule in str(error.value), str(error.value)
    assert not (folder / "bad_out").exists()


def test_an_initial_network_with_other_features_is_refused(studies, client) -> None:
    folder, _, _, _ = studies
    data = study_data({"x": {"mlp": {**DEEP, "initial": "out/networks/rigid_deep.npz"}}})
    data["features"]["length"] = 20
    with pytest.raises(CaseError, match=r"networks.x.mlp.initial: .*its feature pipeline \(length 30, .*is not this study's \(length 20"):
        run_study(parse_study(data), folder, folder / "bad_out", client=client)


def test_a_network_without_a_loss_curve_says_why() -> None:
    """An RBF network (least squares) or an lbfgs-trained MLP has no epochs: the page says so instead of drawing."""
    from femref.report.study import NetworkData, loss_picture

    picture = loss_picture(NetworkData("fem_rbf", {"network": "rbf", "source": "fem"}))
    assert picture.png is None and "no loss per epoch recorded" in picture.problem
    drawn = loss_picture(NetworkData("fem_mlp", {"network": "mlp", "source": "fem"}, np.array([1.0, 0.5, 0.25])))
    assert drawn.png is not None and "3 epochs, last 0.25" in drawn.caption


# ------------------------------------------------------------------ one network per impact type


def test_a_network_per_impact_type_is_trained_and_reads_its_type(client, tmp_path) -> None:
    """``impact_types: true`` on a train set whose coupler contact is drawn (compression-only: free to roll;
    bilateral: coupled): each training record is classified, a network trained per type and saved as
    ``<source>_<network>_<type>.npz``; on the test set every fem record is classified as its generating
    contact says (the independent answer), and the routed estimate ``<source>_<network>`` is, record by record,
    the estimate of its type's network; the pair loads into a case as ``network: {free_to_roll, coupled}``."""
    from femref.case import parse_case
    from femref.study.run import impact_types, prepare_sweeps, read_set

    data = study_data({"r": {"rbf": {"centres": 6, "basis": "multiquadric", "width_factor": 3.0}}})
    data["base_overrides"] = {"fem.elements": 8}
    data["parameters"]["couplers.0.contact"] = {"choice": ["compression_only", "bilateral"]}
    data["sets"] = {"train": {"samples": 40, "seed": 11, "models": ["rigid"]}, "test": {"samples": 8, "seed": 12, "models": ["fem"]}}
    data["impact_types"] = True
    path = tmp_path / "typed.yaml"
    path.write_text(yaml.safe_dump(data))
    study, folder = load_study(path)
    outcome = run_study(study, folder, tmp_path / "out", source=str(path), client=client)
    assert {(t.name, t.impact_type) for t in outcome.networks} == {("rigid_r_free_to_roll", "free_to_roll"), ("rigid_r_coupled", "coupled")}
    test = read_set(prepare_sweeps(study, folder, tmp_path / "out")["test"], tmp_path / "out" / "test.h5")
    kinds = impact_types(study, test, "fem")
    truth = ["coupled" if scene.couplers[0].coupling.contact == "bilateral" else "free_to_roll" for scene in test.scenes]
    assert list(kinds) == truth and len(set(truth)) == 2
    routed = outcome.sets["test"].estimates["rigid_r"]
    records = test.records("fem", list(test.data.probes))
    for trained in outcome.networks:
        rows = np.flatnonzero(kinds == trained.impact_type)
        mine = trained.estimator.predict(records[rows], test.data.record_rate, test.car_masses[rows])
        assert np.array_equal(routed[rows], mine)
    assert outcome.sets["test"].summaries["rigid_r"].samples == kinds.size
    case = yaml.safe_load((CASES / "impact_free_roll.yaml").read_text())
    case.update(models=["fem"], estimators=[{"name": "ann_typed", "network": {kind: str(tmp_path / "out" / "networks" / f"rigid_r_{kind}.npz")
                                                                                for kind in ("free_to_roll", "coupled")}}])
    parse_case(case, source="case.yaml")


def test_impact_types_refuses_a_continued_network() -> None:
    data = study_data({"n": {"mlp": {**DEEP, "initial": "a.npz"}}})
    data["impact_types"] = True
    with pytest.raises(CaseError, match="networks.n.mlp.initial: impact_types trains a network per type from scratch"):
        parse_study(data, source="s.yaml")
