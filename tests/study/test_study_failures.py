"""``femref study`` when a step fails, and a study that needs scikit-learn where it is missing ("ready for real users").

* a failure other than bad input or an interrupt (the sweep machinery, a full disk while saving a network) is a clean
  ``error: study failed: <type>: <message>``, exit 1, no traceback, and no file half-written under its final name;
* an interrupt outside the sweeps (during training) exits 130 with the sweeps' resume note;
* a study whose networks train with scikit-learn (an MLP with solver sgd, adam or lbfgs; an RBF network) is refused
  when the study file is validated if scikit-learn (the extra ``femref[train]``) is missing: exit 2 at
  ``networks.<name>.mlp.solver`` / ``networks.<name>.rbf`` naming the extra, before any sweep, nothing written.

The study steps are replaced by fakes (no sweep runs here): the sweeps of a real study are tested in test_study.py.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from support.ann_data import RATE, pulse_problem
from support.paths import CASES, REPO

import femref.study.run
import femref.study.spec
from femref.cli import main
from femref.study.spec import parse_study

#: A tiny study of the free-roll case whose network trains without scikit-learn (solver: momentum).
MOMENTUM_NETWORK = {"mlp": {"hidden": [4], "activation": "tanh", "solver": "momentum", "max_iter": 5}}


def study_file(folder: Path, networks: dict | None = None) -> Path:
    """``folder/study.yaml``: two sets of a few samples of cases/impact_free_roll.yaml and ``networks``."""
    data = {
        "base": str(CASES / "impact_free_roll.yaml"),
        "sets": {"train": {"samples": 4, "seed": 1}, "test": {"samples": 2, "seed": 2}},
        "car_masses": False,
        "networks": networks or {"m": MOMENTUM_NETWORK},
    }
    path = folder / "study.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def files(folder: Path) -> list[str]:
    """Every file under ``folder`` (temporaries included), relative, sorted."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_a_failing_step_is_a_clean_error_exit_1(tmp_path, monkeypatch) -> None:
    """The sweep machinery fails (run_sweep raises): ``error: study failed: RuntimeError: …`` on stderr, exit 1, no
    traceback; the study folder holds the sweep files written before the failure and no study.h5 or study.md."""

    def broken(*args, **kwargs):
        raise RuntimeError("the scheduler at tcp://10.0.0.9:8786 went away")

    monkeypatch.setattr(femref.study.run, "run_sweep", broken)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["study", str(study_file(tmp_path)), "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert "error: study failed: RuntimeError: the scheduler at tcp://10.0.0.9:8786 went away" in result.stderr
    assert "run again to resume" in result.stderr and "Traceback" not in result.output
    assert not isinstance(result.exception, RuntimeError)  # handled, not raised through click
    assert files(out) == ["test.sweep.yaml", "train.sweep.yaml"]


def fake_set(n: int = 24) -> SimpleNamespace:
    """A stored set of ``n`` ok samples as femref.study.run.read_set returns it: one channel of sin² pulses (their
    amplitudes the peak forces of coupler c1), no scenes (the study gives the networks no car masses)."""
    records, peaks = pulse_problem(n=n, seed=4)
    data = SimpleNamespace(
        probes=["anvil/center"], couplers=["c1"], records={"fem": records}, peak_coupler_force={"fem": peaks[:, None] * 1e6},
        record_rate=RATE, record_length=records.shape[-1], record_end=records.shape[-1] / RATE, record_source="fem",
        measurement=None, path="train.h5", spec_hash="0" * 16,
    )
    return femref.study.run.SetData(sweep=None, data=data, index=np.arange(n), scenes=())


@pytest.mark.filterwarnings("ignore:MomentumMLP stopped after")  # 5 epochs: a network to save, not a good one
def test_a_network_file_is_never_half_written(tmp_path, monkeypatch) -> None:
    """Saving a trained network fails half-way (a full disk): exit 1 naming the error, and neither the network file
    nor a temporary of it is left under networks/."""
    import ann.storage

    real_save = ann.storage.save

    def disk_full(path, *args, **kwargs):
        real_save(path, *args, **kwargs)
        with open(path, "r+b") as handle:  # what was written before the disk filled up: half the archive
            handle.truncate(os.path.getsize(path) // 2)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(femref.study.run, "run_sweep", lambda *args, **kwargs: SimpleNamespace(wall_time_s=0.0))
    monkeypatch.setattr(femref.study.run, "read_set", lambda sweep, path: fake_set())
    monkeypatch.setattr(ann.storage, "save", disk_full)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["study", str(study_file(tmp_path)), "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert "error: study failed: OSError: [Errno 28] No space left on device" in result.stderr
    assert files(out) == ["test.sweep.yaml", "train.sweep.yaml"]  # networks/ holds nothing: no .npz, no temporary


def test_an_interrupt_during_training_exits_130(tmp_path, monkeypatch) -> None:
    """Ctrl-C after the sweeps (while training): exit 130 with the resume note, no traceback, no study.h5."""

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(femref.study.run, "run_sweep", lambda *args, **kwargs: SimpleNamespace(wall_time_s=0.0))
    monkeypatch.setattr(femref.study.run, "read_set", lambda sweep, path: fake_set())
    monkeypatch.setattr(femref.study.run, "train_networks", interrupted)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["study", str(study_file(tmp_path)), "-o", str(out)])
    assert result.exit_code == 130, result.output
    assert "interrupted: the sweeps keep what they stored; run again to resume" in result.stderr
    assert not (out / "study.h5").exists()


# --- scikit-learn, the extra femref[train], checked when the study file is validated ---------------------------


NEEDS_SKLEARN = {
    "lbfgs": {"mlp": {"hidden": [4], "activation": "tanh", "solver": "lbfgs"}},
    "adam": {"mlp": {"hidden": [4], "solver": "adam"}},
    "r": {"rbf": {"centres": 4}},
    "m": MOMENTUM_NETWORK,
}


def test_networks_that_train_with_sklearn_are_refused_without_it(monkeypatch) -> None:
    """Without scikit-learn: a CaseError with a line per network that needs it — at networks.<name>.mlp.solver for the
    scikit-learn solvers, at networks.<name>.rbf for an RBF network — naming the extra; a momentum MLP needs none."""
    from femref.case import CaseError

    base = {"base": "b.yaml", "sets": {"train": {"samples": 4, "seed": 1}, "test": {"samples": 2, "seed": 2}}}
    monkeypatch.setattr(femref.study.spec, "training_dependency_available", lambda: False)
    with pytest.raises(CaseError) as raised:
        parse_study({**base, "networks": NEEDS_SKLEARN}, source="s.yaml")
    assert [problem.key_path for problem in raised.value.problems] == ["networks.lbfgs.mlp.solver", "networks.adam.mlp.solver", "networks.r.rbf"]
    lines = str(raised.value).splitlines()
    assert lines[0] == ("s.yaml: networks.lbfgs.mlp.solver: solver lbfgs trains with scikit-learn, which is not installed: it is the "
                        "optional extra femref[train] (pip install 'femref[train]'); or use solver: momentum, which trains without it; got 'lbfgs'")
    assert lines[2].startswith("s.yaml: networks.r.rbf: an RBF network trains (its k-means centres) with scikit-learn") and "pip install 'femref[train]'" in lines[2]
    assert parse_study({**base, "networks": {"m": MOMENTUM_NETWORK}}).networks["m"].solver == "momentum"
    monkeypatch.setattr(femref.study.spec, "training_dependency_available", lambda: True)
    assert set(parse_study({**base, "networks": NEEDS_SKLEARN}).networks) == set(NEEDS_SKLEARN)


#: Prepended to the child script: an import system that refuses ``sklearn`` (as tests/ann/test_optional_training.py).
BLOCK_SKLEARN = """
import importlib.abc, sys
class _NoSklearn(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "sklearn":
            raise ModuleNotFoundError(f"No module named {name!r} (blocked by the test)", name=name)
        return None
sys.meta_path.insert(0, _NoSklearn())
"""


def test_femref_study_without_sklearn_exits_2_before_any_sweep(tmp_path) -> None:
    """``femref study`` of the shipped study (an lbfgs MLP and an RBF network) in an interpreter without scikit-learn:
    exit 2 naming networks.mlp.mlp.solver, networks.rbf.rbf and the extra, before any sweep; nothing written."""
    study = yaml.safe_load((CASES / "studies" / "ann_study.yaml").read_text())
    study["base"] = str(CASES / "impact_free_roll.yaml")
    path = tmp_path / "ann_study.yaml"
    path.write_text(yaml.safe_dump(study, sort_keys=False))
    code = BLOCK_SKLEARN + "from femref.cli import main\nmain(['study', sys.argv[1], '-o', sys.argv[2]])\n"
    done = subprocess.run([sys.executable, "-c", code, str(path), str(tmp_path / "out")], capture_output=True, text=True, cwd=REPO,
                          timeout=120, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert done.returncode == 2, done.stderr[-3000:]
    assert f"{path}: networks.mlp.mlp.solver: solver lbfgs trains with scikit-learn, which is not installed" in done.stderr
    assert f"{path}: networks.rbf.rbf: an RBF network trains" in done.stderr and "pip install 'femref[train]'" in done.stderr
    assert "Traceback" not in done.stderr and sorted(p.name for p in tmp_path.iterdir()) == ["ann_study.yaml"]
