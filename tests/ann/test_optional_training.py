"""scikit-learn is the optional extra ``femref[train]``: needed to train ``MLPForceRegressor`` and ``RBFNetwork``,
not to import :mod:`ann.networks`, load a saved network, predict with it, train a ``MomentumMLP``, or run a case
with a network estimator. Each check runs in a fresh interpreter whose import system refuses ``sklearn`` and
records every attempt to import it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from sklearn.exceptions import ConvergenceWarning
from support.ann_data import RATE, pulse_problem
from support.paths import CASES, REPO

import ann.storage as storage
from ann.features import FeaturePipeline, FeatureSettings
from ann.networks import MLPForceRegressor, MomentumMLP, RBFNetwork, TrainingDependencyError

#: Prepended to every child script: a meta-path finder that refuses ``sklearn`` and records each attempt.
BLOCK_SKLEARN = """
import importlib.abc, sys
class _NoSklearn(importlib.abc.MetaPathFinder):
    asked = []
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "sklearn":
            _NoSklearn.asked.append(name)
            raise ModuleNotFoundError(f"No module named {name!r} (blocked by the test)", name=name)
        return None
sys.meta_path.insert(0, _NoSklearn())
"""


def _without_sklearn(script: str, *args: str, timeout: float = 120) -> dict:
    """Run ``script`` in a fresh interpreter without scikit-learn; it leaves its findings in the dict ``out``,
    returned with ``asked`` (the sklearn imports attempted) and ``loaded`` (whether any sklearn module loaded)."""
    code = BLOCK_SKLEARN + "out = {}\n" + script + (
        "\nimport json\nout['asked'] = _NoSklearn.asked\nout['loaded'] = any(m.split('.')[0] == 'sklearn' for m in sys.modules)\n"
        "print('RESULT ' + json.dumps(out))\n"
    )
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=REPO, timeout=timeout,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert done.returncode == 0, done.stderr[-3000:]
    line = next(line for line in done.stdout.splitlines() if line.startswith("RESULT "))
    return json.loads(line.removeprefix("RESULT "))


@pytest.fixture(scope="module")
def saved(tmp_path_factory) -> tuple[Path, dict[str, list[float]]]:
    """Small trained networks of every kind saved to .npz, test records, and the predictions made with sklearn loaded."""
    folder = tmp_path_factory.mktemp("networks")
    records, amplitude = pulse_problem(n=120, seed=3)
    pipeline = FeaturePipeline(FeatureSettings(length=16, rate=RATE)).fit(records[:100], RATE)
    X = pipeline.transform(records[:100], RATE)
    with pytest.warns(ConvergenceWarning):
        mlp = MLPForceRegressor(hidden=(8,), seed=0, max_iter=20).fit(X, amplitude[:100])
    networks = {
        "mlp": mlp,
        "rbf": RBFNetwork(centres=10, seed=0).fit(X, amplitude[:100]),
        "momentum_mlp": MomentumMLP(hidden=(6,), epochs=10, tol=None, seed=0).fit(X, amplitude[:100]),
    }
    np.save(folder / "records.npy", records[100:])
    expected = {}
    for kind, network in networks.items():
        storage.save(folder / f"{kind}.npz", pipeline, network, {"trained_on": "sin² pulses"})
        expected[kind] = storage.Estimator(pipeline, network).predict(records[100:], RATE).tolist()
    return folder, expected


def test_saved_networks_predict_without_sklearn(saved):
    """Loading each kind of saved network and predicting gives the same forces as with scikit-learn loaded, and
    nothing asks for scikit-learn."""
    folder, expected = saved
    found = _without_sklearn(
        "import numpy as np, ann.networks, ann.storage as storage\n"
        "records = np.load(sys.argv[1] + '/records.npy')\n"
        "for kind in ('mlp', 'rbf', 'momentum_mlp'):\n"
        "    estimator, _ = storage.load_estimator(sys.argv[1] + f'/{kind}.npz')\n"
        f"    out[kind] = estimator.predict(records, {RATE}).tolist()\n",
        str(folder),
    )
    assert found["asked"] == [] and not found["loaded"]
    for kind, forces in expected.items():
        np.testing.assert_allclose(found[kind], forces, rtol=1e-12, err_msg=kind)


def test_training_without_sklearn_names_the_extra(saved):
    """MLPForceRegressor.fit and RBFNetwork.fit raise TrainingDependencyError, an ImportError saying
    pip install 'femref[train]'; MomentumMLP needs no scikit-learn and warns with its own category."""
    found = _without_sklearn(
        "import warnings, numpy as np\n"
        "from ann.networks import MLPForceRegressor, MomentumMLP, NetworkConvergenceWarning, RBFNetwork, TrainingDependencyError\n"
        "X, y = np.random.default_rng(0).random((40, 3)), np.linspace(1.0, 2.0, 40)\n"
        "for name, network in (('mlp', MLPForceRegressor(hidden=(4,))), ('rbf', RBFNetwork(centres=4))):\n"
        "    try:\n"
        "        network.fit(X, y)\n"
        "    except TrainingDependencyError as error:\n"
        "        out[name] = [str(error), isinstance(error, ImportError)]\n"
        "with warnings.catch_warnings(record=True) as caught:\n"
        "    warnings.simplefilter('always')\n"
        "    net = MomentumMLP(hidden=(4,), epochs=3, tol=1e-30, n_iter_no_change=50).fit(X, y)\n"
        "out['momentum'] = [net.n_iter_, [issubclass(w.category, NetworkConvergenceWarning) for w in caught]]\n"
    )
    for name, network in (("mlp", "MLPForceRegressor"), ("rbf", "RBFNetwork")):
        message, is_import_error = found[name]
        assert is_import_error and f"training a {network} needs scikit-learn" in message and "pip install 'femref[train]'" in message
    assert found["momentum"] == [3, [True]]
    assert not found["loaded"]


def test_a_case_with_a_network_estimator_runs_without_sklearn(tmp_path):
    """``femref run`` of the measured yard case (its ann_fem estimator reads networks/fem_mlp.npz) exits 0
    and writes its result without trying to import scikit-learn; so does ``femref --help``."""
    out = tmp_path / "yard.h5"
    found = _without_sklearn(
        "from femref.cli import main\n"
        "for args in (['--help'], ['run', sys.argv[1], '-o', sys.argv[2]]):\n"
        "    try:\n"
        "        main(args)\n"
        "    except SystemExit as stop:\n"
        "        out[args[0]] = stop.code\n",
        str(CASES / "measured_yard.yaml"), str(out),
    )
    assert found["--help"] == 0 and found["run"] == 0, found
    assert found["asked"] == [] and not found["loaded"]
    assert out.exists()


def test_sklearn_is_the_train_extra_and_dev_pulls_it_in():
    """pyproject: scikit-learn is not a core dependency; the extra ``train`` has it, and so does ``dev``."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]

    def names(requirements: list[str]) -> set[str]:
        return {r.split(">")[0].split("=")[0].split("[")[0].strip() for r in requirements}

    assert "scikit-learn" not in names(project["dependencies"])
    assert "scikit-learn" in names(extras["train"])
    assert "scikit-learn" in names(extras["dev"]) or "femref[train]" in extras["dev"]


def test_the_error_is_an_import_error():
    """Code that guards training with ``except ImportError`` catches it."""
    assert issubclass(TrainingDependencyError, ImportError)
