"""The command line: exit codes, messages, result-file layout, atomic writes."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import femref.results
from femref.cli import main


@pytest.fixture
def runner():
    return CliRunner()


def write_case(tmp_path: Path, data: dict, name: str = "case.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def small_transient() -> dict:
    return {
        "kind": "transient",
        "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9, "axial_viscosity": 1.0e6},
        "loads": {"F2": {"half_sine": {"amplitude": -1.0e6, "duration": 0.05}}},
        "time": {"end": 0.1, "dt": 5.0e-4},
        "models": ["fem", "rigid"],
        "fem": {"elements": 16},
    }


def test_validate_prints_resolved_case(runner, tmp_path):
    result = runner.invoke(main, ["validate", str(write_case(tmp_path, small_transient()))])
    assert result.exit_code == 0, result.output
    resolved = yaml.safe_load(result.output)
    assert resolved["integrator"] == {"scheme": "generalized_alpha", "rho_inf": 0.8}
    assert resolved["probes"] == {"left": -8.0, "center": 0.0, "right": 8.0}


def test_bad_input_exits_2_with_key_path_and_writes_nothing(runner, tmp_path):
    data = small_transient()
    data["body"]["mass_per_length"] = -1.0
    output = tmp_path / "out.h5"
    result = runner.invoke(main, ["run", str(write_case(tmp_path, data)), "-o", str(output)])
    assert result.exit_code == 2
    assert "body.mass_per_length" in result.output and "must be > 0" in result.output
    assert not output.exists()
    assert list(tmp_path.iterdir()) == [tmp_path / "case.yaml"]


def test_missing_case_file_exits_2(runner, tmp_path):
    result = runner.invoke(main, ["validate", str(tmp_path / "nope.yaml")])
    assert result.exit_code == 2
    assert "nope.yaml" in result.output


def test_run_writes_design_layout(runner, tmp_path):
    output = tmp_path / "out.h5"
    result = runner.invoke(main, ["run", str(write_case(tmp_path, small_transient())), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output) as h5:
        assert h5.attrs["femref_version"] and "kind: transient" in h5.attrs["case_yaml"] and h5.attrs["created"]
        fem = h5["fem"]
        assert fem.attrs["status"] == "ok" and fem.attrs["wall_time_s"] > 0.0
        settings = json.loads(fem.attrs["settings"])
        assert settings["dt"] == 5.0e-4 and settings["steps"] == 200 and settings["element"] == "P2"
        time = fem["time"][()]
        assert time.shape == (201,) and fem["time"].attrs["units"] == "s"
        for probe in ("left", "center", "right"):
            for quantity in ("acceleration", "displacement", "axial_force"):
                assert fem[f"probes/{probe}/{quantity}"].shape == time.shape
        assert fem["energy"].attrs is not None and fem["energy/kinetic"].shape == time.shape
        assert np.allclose(h5["rigid/time"][()], time)
        scores = h5["scores/rigid"].attrs
        assert scores["reference"] == "fem"
        assert 0.0 < scores["acceleration_max_error_center"] < 1.0
        assert scores["speedup"] > 0.0


def test_automatic_step_is_recorded(runner, tmp_path):
    data = small_transient()
    del data["time"]["dt"]
    output = tmp_path / "out.h5"
    assert runner.invoke(main, ["run", str(write_case(tmp_path, data)), "-o", str(output)]).exit_code == 0
    with h5py.File(output) as h5:
        settings = json.loads(h5["fem"].attrs["settings"])
        assert settings["dt"] > 0.0 and settings["dt_rule"].startswith("automatic")


def test_failed_model_is_recorded_and_exits_1(runner, tmp_path, monkeypatch):
    from femref.models import rigid

    def explode(self, scene, progress=None):
        raise FloatingPointError("synthetic failure")

    monkeypatch.setattr(rigid.RigidModel, "transient", explode)
    output = tmp_path / "out.h5"
    result = runner.invoke(main, ["run", str(write_case(tmp_path, small_transient())), "-o", str(output)])
    assert result.exit_code == 1
    assert "synthetic failure" in result.output
    with h5py.File(output) as h5:
        assert h5["rigid"].attrs["status"] == "failed"
        assert "synthetic failure" in h5["rigid"].attrs["message"]
        assert h5["fem"].attrs["status"] == "ok"


def test_impact_run_that_fails_mid_way_exits_1_saying_where(runner, tmp_path):
    """A coupler iteration that fails mid-run (a 20 kg car between two 2 t cars, friction-gear tables both sides,
    at 2 m/s: the Gauss–Seidel sweeps crawl at t = 0.029 s, each gear moving the light car for the other — the
    step tests/impact/test_compiled.py also fails): exit 1, the message names the coupler and the time, and the
    result file keeps that run's histories up to the failing step (NaN after)."""
    gear = {"table": {"closure": [0.0, 0.0119, 0.0188, 0.0495, 0.125, 0.135], "loading": [0.0, 0.0, 1.2e5, 6.8e5, 1.35e6, 3.35e6],
                      "unloading": [0.0, 0.0, 3.6e4, 2.04e5, 4.05e5, 2.405e6]}}
    body = lambda mass: {"type": "rod", "length": 17.0, "mass_per_length": mass / 17.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}  # noqa: E731
    case = {
        "kind": "impact",
        "cars": [{"name": name, "body": body(mass), "velocity": speed, "sensors": {"center": 0.0}}
                 for name, mass, speed in (("a", 2000.0, 2.0), ("b", 20.0, 0.0), ("c", 2000.0, 0.0))],
        "couplers": [{"name": "c1", "between": ["a", "b"], "law": gear}, {"name": "c2", "between": ["b", "c"], "law": gear}],
        "time": {"end": 0.1, "dt": 1e-3},
        "models": ["rigid"],
    }
    output = tmp_path / "out.h5"
    result = runner.invoke(main, ["run", str(write_case(tmp_path, case)), "-o", str(output)])
    assert result.exit_code == 1
    assert "error: model rigid failed: coupler c1 did not converge at t = 0.029 s (step 29 of 100)" in result.output
    with h5py.File(output) as h5:
        assert h5["rigid"].attrs["status"] == "failed"
        force = h5["rigid/couplers/c1/force"][()]
        assert force.size == 101 and np.all(np.isfinite(force[:29])) and np.all(np.isnan(force[29:]))


def test_crash_while_writing_leaves_no_file(runner, tmp_path, monkeypatch):
    def broken(group, result):
        raise OSError("disk full")

    monkeypatch.setattr(femref.results, "_write_model", broken)
    output = tmp_path / "out.h5"
    result = runner.invoke(main, ["run", str(write_case(tmp_path, small_transient())), "-o", str(output)])
    assert result.exit_code != 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.yaml"]


def test_default_scene_runs_without_case(runner, tmp_path, monkeypatch):
    """The built-in free-to-roll impact: every model ok, scores against fem, rigid cars obey M a = ±P."""
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(main, ["run"])
    assert result.exit_code == 0, result.output
    with h5py.File(tmp_path / "default.h5") as h5:
        for model in ("fem", "modal", "quasi_rigid", "rigid", "inverse_rigid", "inverse_quasi_rigid"):
            assert h5[model].attrs["status"] == "ok", model
        force = h5["rigid/couplers/c1/force"][()]
        anvil = h5["rigid/probes/anvil/center/acceleration"][()]
        assert np.max(force) > 1.0e6
        np.testing.assert_allclose(100.0e3 * anvil, force, atol=1e-9 * np.max(force))
        assert h5["scores/rigid"].attrs["reference"] == "fem"
        assert "coupler_force_peak_error_c1" in h5["scores/quasi_rigid"].attrs
        assert h5["fem/energy"].attrs["balance_error"] < 1e-3


def test_the_command_imports_no_machinery_before_a_command_runs():
    """``femref --help`` must stay light: importing the command loads no case schema (pydantic), no
    solver, no plotting and no scipy.signal; each command imports what it drives when it runs."""
    import subprocess
    import sys

    heavy = ("pydantic", "femref.case", "femref.run", "femref.fem", "matplotlib", "scipy.signal", "dask", "skfem")
    code = "import sys, femref.cli; print(' '.join(m for m in " + repr(heavy) + " if m in sys.modules))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert loaded == []
