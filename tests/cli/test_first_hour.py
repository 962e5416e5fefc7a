"""A fast, friendly first hour (issue 18): light ``--help``, tables that fit the terminal with a legend,
progress on request, and the Python API (:mod:`femref.api`) reading a result with its time axis."""

from __future__ import annotations

import re
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from rich.cells import cell_len

from femref.api import open_frames, open_result, result_models, run_case
from femref.case.defaults import default_scene_data
from femref.cli import main

from support.paths import CASES, REPO

#: What ``femref --help`` (and every command's) must not import: numerics, solvers, file formats, plots,
#: clusters. Each command imports these when it runs (femref/cli/common.py).
HEAVY = ("numpy", "scipy", "sklearn", "h5py", "numba", "matplotlib", "dask", "distributed", "pandas", "xarray", "pyvista",
         "meshio", "skfem", "pydantic")
COMMANDS = ("run", "validate", "sweep", "study", "calibrate", "bench", "report", "figures", "fleet")


def small_impact_case() -> dict:
    """The default scene, coarse and short: fem (8 elements, the reference) and rigid, no measurement chain."""
    data = default_scene_data()
    data.pop("measurement")
    data.pop("estimators")
    data["fem"]["elements"] = 8
    data["models"] = ["fem", "rigid"]
    data["time"] = {"end": 0.1}
    return data


# --- --help stays light ------------------------------------------------------------------------------


def test_help_of_every_command_imports_nothing_heavy() -> None:
    """``python -X importtime``: importing femref.cli and printing every command's --help loads none of HEAVY."""
    script = "\n".join([
        "from femref.cli import main",
        f"for command in [(), *[(c,) for c in {COMMANDS!r}]]:",
        "    try:",
        "        main([*command, '--help'], standalone_mode=False)",
        "    except SystemExit:",
        "        pass",
    ])
    done = subprocess.run([sys.executable, "-X", "importtime", "-c", script], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    imported = {line.split("|")[-1].strip() for line in done.stderr.splitlines() if line.startswith("import time:")}
    heavy = sorted(m for m in imported if m.split(".")[0] in HEAVY)
    assert not heavy, f"--help imports {heavy[:10]}: import them inside the command that uses them"
    assert "Usage: main run" in done.stdout or "Usage: " in done.stdout


def test_every_command_help_states_its_exit_codes_and_what_its_output_may_not_be() -> None:
    """Each command's --help ends with its exit codes (0, and 2 for bad input, where nothing is written); each command
    that writes a file says its -o is refused when it is an input; every command is covered (a new one must say too)."""
    assert set(main.commands) == set(COMMANDS)
    for command in COMMANDS:
        result = CliRunner().invoke(main, [command, "--help"], terminal_width=200)
        assert result.exit_code == 0, result.output
        text = " ".join(result.output.split())
        assert "Exit codes: 0 " in text and re.search(r"\b2 (bad|not)\b", text), (command, text)
        if command in ("run", "sweep", "study", "calibrate", "bench", "report", "fleet"):
            assert "refused if" in text, (command, text)
    progress = " ".join(CliRunner().invoke(main, ["--help"], terminal_width=200).output.split())
    assert "--progress / --no-progress" in progress and "FEMREF_PROGRESS" in progress


#: Environment variables of femref that are test hooks only, not for users (not listed under ``femref --help``).
TEST_ONLY_VARIABLES = {"FEMREF_TEST_PAUSE_BEFORE_PUBLISH"}


def test_main_help_lists_the_exit_codes_and_every_environment_variable() -> None:
    """``femref --help`` ends with the exit codes 0, 1, 2, 130 and the environment variables a user may set: every
    ``FEMREF_<NAME>`` the code reads (found by grepping femref/ and ann/, test hooks aside), each with what it does."""
    text = CliRunner().invoke(main, ["--help"], terminal_width=200).output
    epilog = text[text.index("Exit codes:"):]
    codes = dict(re.findall(r"^\s+(\d+)\s+(\S.*)$", epilog.split("Environment:")[0], flags=re.M))
    assert list(codes) == ["0", "1", "2", "130"], epilog
    assert "nothing is written" in " ".join(epilog.split()) and codes["130"].startswith("interrupted")
    in_code = {name for package in ("femref", "ann") for file in (REPO / package).rglob("*.py")
               for name in re.findall(r"FEMREF_[A-Z_]+", file.read_text(encoding="utf-8"))}
    assert {"FEMREF_BUDGET", "FEMREF_SELF_CHECK", "FEMREF_PROGRESS"} <= in_code
    environment = epilog.split("Environment:")[1]
    listed = set(re.findall(r"^\s+(FEMREF_[A-Z_]+)=\S+\s+\S", environment, flags=re.M))
    assert listed == in_code - TEST_ONLY_VARIABLES, environment
    for name, says in (("FEMREF_BUDGET", "work budget"), ("FEMREF_SELF_CHECK", "checks its own discretisation"), ("FEMREF_PROGRESS", "--progress")):
        entry = " ".join(environment.split(name, 1)[1].split("FEMREF_")[0].split())
        assert says in entry, (name, entry)


# --- tables fit the terminal -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def impact_case(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("first_hour") / "small.yaml"
    path.write_text(yaml.safe_dump(small_impact_case()))
    return path


def _run(case: Path, out: Path, env: dict, *options: str):
    result = CliRunner().invoke(main, [*options, "run", str(case), "-o", str(out)], env=env)
    assert result.exit_code == 0, result.output
    return result


@pytest.mark.parametrize("width", [80, 200])
@pytest.mark.parametrize("case", ["impact", "rod_harmonic.yaml"])
def test_run_table_fits_the_width_and_defines_every_column(impact_case, tmp_path, width, case) -> None:
    """With COLUMNS=80 or 200 no line of the run summary is wider; the legend under the table names every
    short header; every relative error is a percentage with two decimals."""
    path = impact_case if case == "impact" else CASES / case
    result = _run(path, tmp_path / "out.h5", {"COLUMNS": str(width)})
    lines = [line for line in result.stdout.splitlines() if not line.startswith("wrote ")]  # a path is one word, not cut
    assert max(cell_len(line) for line in lines) <= width, [line for line in lines if cell_len(line) > width]
    text = result.stdout
    headers = ("wall ms", "speed-up", "P peak kN", "P peak err", "t peak err ms", "P rms err", "a rms err", "E err") if case == "impact" \
        else ("wall ms", "work", "|a| peak", "|F| peak", "a err max", "a err rms")
    flat = " ".join(text.split())
    for header in headers:
        assert f"{header}: " in flat, header  # in the legend (the header itself may wrap in a narrow table)
    percents = re.findall(r"\d+(?:\.\d+)?%", text)
    assert percents and all(re.fullmatch(r"\d+\.\d\d%", p) for p in percents), percents


def test_piped_table_keeps_whole_rows(impact_case, tmp_path) -> None:
    """Piped without COLUMNS no width is forced: every row is one line with all its cells (grep-able)."""
    result = _run(impact_case, tmp_path / "out.h5", {"COLUMNS": None})
    lines = result.stdout.splitlines()
    header = next(line for line in lines if line.startswith("┃ model"))
    rigid = next(line for line in lines if line.startswith("│ rigid"))
    assert rigid.count("│") == header.count("┃") == 12  # 11 columns, on one line each
    cells = [cell.strip() for cell in rigid.split("│")[1:-1]]
    assert cells[1] == "ok" and re.fullmatch(r"\d+\.\d\d%", cells[6]), cells


# --- progress ----------------------------------------------------------------------------------------


def test_progress_option_prints_status_lines_on_a_piped_stderr(impact_case, tmp_path) -> None:
    """``femref --progress run``: a line per model on stderr when stderr is not a terminal; stdout unchanged."""
    quiet = _run(impact_case, tmp_path / "a.h5", {"COLUMNS": None})
    shown = _run(impact_case, tmp_path / "b.h5", {"COLUMNS": None}, "--progress")
    assert "running" not in quiet.stderr
    for model in ("fem", "rigid"):
        assert f"{model}: running" in shown.stderr and re.search(rf"{model}: done in \d+\.\d s", shown.stderr), shown.stderr
    assert [line.split("│")[1] for line in shown.stdout.splitlines() if line.startswith("│ ")] == \
        [line.split("│")[1] for line in quiet.stdout.splitlines() if line.startswith("│ ")]
    env = _run(impact_case, tmp_path / "c.h5", {"COLUMNS": None, "FEMREF_PROGRESS": "1"})
    assert "fem: running" in env.stderr


def test_sweep_and_bench_progress_lines_when_forced() -> None:
    """With ``--progress`` and stderr piped: a line per tenth of the samples, a line per bench configuration;
    without it, no callback at all (the sweep and bench skip the calls)."""
    import io

    import click
    from rich.console import Console

    from femref.cli.common import PROGRESS_KEY, configuration_progress, sample_progress

    console = Console(file=io.StringIO(), width=100)
    with click.Context(main) as context:
        with sample_progress(console) as progress:
            assert progress is None
        context.meta[PROGRESS_KEY] = True
        with sample_progress(console) as progress:
            for done in range(21):
                progress(done, 20)
        with configuration_progress(console) as progress:
            progress("fem N=8")
            progress("rigid")
    lines = console.file.getvalue().splitlines()
    assert lines == [f"sweep: {done}/20 samples" for done in range(0, 21, 2)] + ["bench: fem N=8", "bench: rigid"]


# --- the Python API ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def api_result(tmp_path_factory):
    out = tmp_path_factory.mktemp("api") / "small.h5"
    return run_case(small_impact_case(), output=out), out


def test_run_case_from_python_writes_what_the_cli_writes(api_result) -> None:
    """run_case(mapping, output): every model ok, scored against fem, and the file holds them."""
    outcome, out = api_result
    assert [r.model for r in outcome.results] == ["fem", "rigid"] and not outcome.failed
    assert outcome.scores["rigid"]["reference"] == "fem"
    assert result_models(out) == ["fem", "rigid"]
    with h5py.File(out) as h5:
        assert yaml.safe_load(h5.attrs["case_yaml"])["models"] == ["fem", "rigid"]


def test_open_result_has_the_time_coordinate(api_result) -> None:
    """open_result: an xarray Dataset on the model's own time axis (s), force per coupler, acceleration per probe,
    values and units as in the file; the rigid model's scores in its attributes."""
    pytest.importorskip("xarray")
    _, out = api_result
    fem = open_result(out)
    with h5py.File(out) as h5:
        time, force = h5["fem/time"][()], h5["fem/couplers/c1/force"][()]
        acceleration = h5["fem/probes/anvil/front/acceleration"][()]
    assert fem.attrs["model"] == "fem" and fem.attrs["status"] == "ok"
    np.testing.assert_array_equal(fem["time"].values, time)
    assert fem["time"].attrs["units"] == "s"
    np.testing.assert_array_equal(fem["force"].sel(coupler="c1").values, force)
    np.testing.assert_array_equal(fem["acceleration"].sel(probe="anvil/front").values, acceleration)
    assert fem["force"].dims == ("time", "coupler") and fem["force"].attrs["units"].startswith("N")
    rigid = open_result(out, "rigid")
    assert rigid.attrs["scores"]["reference"] == "fem"
    peak = float(rigid["force"].sel(coupler="c1").max())
    assert abs(peak - force.max()) / force.max() == pytest.approx(rigid.attrs["scores"]["coupler_force_peak_error_c1"], rel=1e-9)
    with pytest.raises(KeyError, match="no model 'modal'; the file holds fem, rigid"):
        open_result(out, "modal")


def test_open_frames_are_indexed_by_time(api_result) -> None:
    pd = pytest.importorskip("pandas")
    _, out = api_result
    frames = open_frames(out)
    assert set(frames) == {"fem", "rigid"}
    fem = frames["fem"]
    assert isinstance(fem.index, pd.Index) and fem.index.name == "time"
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(fem.index.to_numpy(), h5["fem/time"][()])
        np.testing.assert_array_equal(fem["couplers/c1/force"].to_numpy(), h5["fem/couplers/c1/force"][()])
    assert "energy/total" in fem and fem.attrs["status"] == "ok"


def test_open_result_without_xarray_names_the_extra(api_result, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "xarray", None)  # import xarray raises ImportError
    with pytest.raises(ImportError, match=re.escape("pip install 'femref[xarray]'")):
        open_result(api_result[1])


def test_run_case_reads_a_case_file(tmp_path) -> None:
    """A path runs with its folder as base; a harmonic result opens on its ω axis. A tolerance on a case that is not
    an impact is refused (CaseError) as ``--tolerance`` is."""
    pytest.importorskip("xarray")
    from femref.case import CaseError

    outcome = run_case(CASES / "rod_harmonic.yaml", output=tmp_path / "rod.h5")
    assert not outcome.failed
    model = outcome.results[0].model
    ds = open_result(tmp_path / "rod.h5", model)
    assert "omega" in ds.coords and ds.sizes["omega"] == outcome.results[0].axes["omega"].size
    with pytest.raises(CaseError, match="--tolerance: model choice serves impact cases"):
        run_case(CASES / "rod_harmonic.yaml", tolerance=0.01)


def _datasets(path: Path) -> dict[str, np.ndarray]:
    """Every dataset of an HDF5 file by its path, but the measured wall times (run-dependent)."""
    found: dict[str, np.ndarray] = {}

    def visit(name: str, item) -> None:
        if isinstance(item, h5py.Dataset) and name.rsplit("/", 1)[-1] != "wall_time_s":
            found[name] = item[()]

    with h5py.File(path, "r") as h5:
        h5.visititems(visit)
    return found


def _same_datasets(a: Path, b: Path) -> None:
    left, right = _datasets(a), _datasets(b)
    assert left.keys() == right.keys()
    for name, values in left.items():
        assert np.array_equal(values, right[name], equal_nan=values.dtype.kind == "f"), name


def test_run_case_runs_a_measured_case_and_writes_what_the_cli_writes(tmp_path) -> None:
    """run_case(cases/measured_yard.yaml, output) returns its two events and writes the file ``femref run -o`` writes
    (every dataset equal, wall times aside); without an output the events keep their histories."""
    outcome = run_case(CASES / "measured_yard.yaml", output=tmp_path / "api.h5")
    assert len(outcome.events) == 2
    result = CliRunner().invoke(main, ["run", str(CASES / "measured_yard.yaml"), "-o", str(tmp_path / "cli.h5")])
    assert result.exit_code == 0, result.output
    _same_datasets(tmp_path / "api.h5", tmp_path / "cli.h5")
    with h5py.File(tmp_path / "api.h5", "r") as h5:
        assert len(h5["events"]) == len(outcome.events)
    kept = run_case(CASES / "measured_yard.yaml")
    assert [event.index for event in kept.events] == [event.index for event in outcome.events] and not list(tmp_path.glob("*.tmp"))


def test_run_case_with_a_tolerance_returns_the_chosen_model(tmp_path) -> None:
    """A case with ``tolerance:`` climbs the ladder as ``femref run`` does: the choice comes back (the chosen model
    among the runs made, met) and the file holds it; ``tolerance=`` overrides the case's value as --tolerance does."""
    data = default_scene_data()
    data["tolerance"] = 0.01
    choice = run_case(data, output=tmp_path / "choice.h5")
    assert choice.met and choice.tolerance == 0.01 and choice.chosen in {result.model for result in choice.results}
    with h5py.File(tmp_path / "choice.h5", "r") as h5:
        assert h5["choice"].attrs["chosen"] == choice.chosen and h5[choice.chosen].attrs["status"] == "ok"
    result = CliRunner().invoke(main, ["run", "--tolerance", "0.01", "-o", str(tmp_path / "cli.h5")])
    assert result.exit_code == 0, result.output
    _same_datasets(tmp_path / "choice.h5", tmp_path / "cli.h5")
    assert run_case(data, tolerance=0.2).tolerance == 0.2


def test_api_is_documented_and_typed() -> None:
    """femref.api names what it exports; py.typed is shipped (package data); the xarray extra exists."""
    import femref.api

    assert {"run_case", "run_scene", "open_result", "open_frames", "RunOutcome"} <= set(femref.api.__all__)
    assert (REPO / "femref" / "py.typed").is_file()
    config = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "py.typed" in config["tool"]["setuptools"]["package-data"]["femref"]
    assert "xarray" in config["project"]["optional-dependencies"]


def _tree(folder: Path) -> dict[str, bytes | None]:
    """Every entry under ``folder`` with its bytes (None for a folder)."""
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in sorted(folder.rglob("*"))}


@pytest.fixture
def refuse_to_run(monkeypatch):
    """Fail the test if run_case starts the run: the output is checked before any work."""
    import femref.api

    monkeypatch.setattr(femref.api, "run_plan", lambda *args, **kwargs: pytest.fail("the run started before the output was checked"))


@pytest.mark.parametrize(
    ("output", "message"),
    [
        ("missing/out.h5", "the folder {tmp}/missing does not exist (the output's folder must exist)"),
        ("case.yaml", "is the input case {tmp}/case.yaml (the output may not overwrite an input)"),
        ("sub", "is a folder; the output is a file"),
        ("data/coupler_force.csv", "is the input loads.F2.csv.path of the case {tmp}/data/coupler_force.csv (the output may not overwrite an input)"),
    ],
    ids=["missing-folder", "the-case-file", "a-folder", "a-file-the-case-names"],
)
def test_run_case_checks_its_output_like_the_cli(tmp_path, refuse_to_run, output, message) -> None:
    """api.run_case(case, output) refuses an output ``femref run -o`` refuses, by the same rule (femref.results): an
    OutputPathError (a ValueError) naming ``output``, the path and the rule, before any work, nothing written."""
    import shutil

    from femref.core.publishing import OutputPathError

    (tmp_path / "data").mkdir()
    (tmp_path / "sub").mkdir()
    shutil.copy(CASES / "data" / "coupler_force.csv", tmp_path / "data")
    shutil.copy(CASES / "rod_transient_csv.yaml", tmp_path / "case.yaml")
    before = _tree(tmp_path)
    with pytest.raises(OutputPathError) as raised:
        run_case(tmp_path / "case.yaml", output=tmp_path / output)
    assert isinstance(raised.value, ValueError)
    assert str(raised.value) == f"output {tmp_path / output}: {message.format(tmp=tmp_path)}; nothing was written"
    assert _tree(tmp_path) == before


def test_run_case_refuses_field_files_onto_an_input(tmp_path, refuse_to_run) -> None:
    """With fem.fields the run writes <stem>_fem_fields.xdmf/.h5 beside the output: an output whose field file would
    replace a file the case names is refused (a CSV load named like one), nothing written."""
    import shutil

    from femref.core.publishing import OutputPathError

    shutil.copy(CASES / "data" / "coupler_force.csv", tmp_path / "run_fem_fields.h5")
    data = yaml.safe_load((CASES / "rod_transient_csv.yaml").read_text())
    data["loads"]["F2"]["csv"]["path"] = "run_fem_fields.h5"
    before = _tree(tmp_path)
    with pytest.raises(OutputPathError, match=r"would write .*run_fem_fields\.h5, which is the input loads\.F2\.csv\.path of the case"):
        run_case(data, output=tmp_path / "run.h5", base_dir=tmp_path)
    assert _tree(tmp_path) == before


def test_run_case_removes_the_leftovers_of_killed_and_older_runs(tmp_path) -> None:
    """Before writing, run_case removes the temporaries of its output that a killed femref run (a dead pid) and an
    older femref (``.<name>.<random>.tmp``, an HDF5 file unchanged for an hour) left, as the CLI does."""
    import os
    import subprocess as sp

    from femref.core.publishing import HDF5_SIGNATURE

    process = sp.Popen([sys.executable, "-c", "pass"])
    process.wait()
    out = tmp_path / "small.h5"
    killed = out.with_name(f".{out.name}.femref-{process.pid}.tmp")
    older = out.with_name(f".{out.name}.k3x9_q2z.tmp")
    for leftover in (killed, older):
        leftover.write_bytes(HDF5_SIGNATURE + b"half a result")
        os.utime(leftover, (time.time() - 3600, time.time() - 3600))
    data = small_impact_case()
    data["models"] = ["rigid"]
    run_case(data, output=out)
    assert not killed.exists() and not older.exists()
    assert result_models(out) == ["rigid"]
