"""Outputs that cannot go stale or be lost (issue 18).

* every command that writes checks its output path before any work: exit 2, a message
  naming the option and the rule, nothing written; the files a case names (records, CSV loads,
  networks), a sweep's or study's base case and a study's ``initial`` networks are inputs too;
* a result and its XDMF + HDF5 field files are published together: field files first,
  the result last, the result recording the field files' SHA-256 (a stale pair is detected);
* temporaries are named ``.<final name>.femref-<pid>[.<part>].tmp``; a later write of the same
  name removes those of dead processes and keeps a live process's;
* a ``kill -9`` between writing the temporaries and renaming them leaves the previous pair intact;
* an older femref's randomly named temporaries (``tmp*`` field-file folders, ``.<name>.<random>.tmp``)
  are removed only when their content is femref's and nothing uses them, and named otherwise;
* xarray opens every history group with its axis as the coordinate.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import femref.core.publishing
import femref.results
from femref.cli import main
from femref.results import TEST_PAUSE_VARIABLE, ModelResult, field_files_match, write_results
from femref.core.publishing import leftovers, temporary_path

from support.paths import CASES

FIELD_SUFFIXES = ("_fem_fields.xdmf", "_fem_fields.h5")


def small_case(fields: bool = True) -> dict:
    """A rod under a half-sine load, 8 elements, 40 steps: a run of well under a second."""
    return {
        "kind": "transient",
        "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9, "axial_viscosity": 1.0e6},
        "loads": {"F2": {"half_sine": {"amplitude": -1.0e6, "duration": 0.05}}},
        "time": {"end": 0.02, "dt": 5.0e-4},
        "models": ["fem", "rigid"],
        "fem": {"elements": 8, "fields": fields},
    }


def write_case(folder: Path, name: str = "case.yaml", data: dict | None = None) -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump(data or small_case()))
    return path


def listing(folder: Path) -> dict[str, str]:
    """Every entry under ``folder`` (recursively) with the SHA-256 of the files' bytes."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "folder"
        for p in sorted(folder.rglob("*"))
    }


def dead_pid() -> int:
    """The pid of a process that has ended (and been reaped)."""
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


@pytest.fixture
def runner():
    return CliRunner()


@pytest.fixture
def no_run(monkeypatch):
    """Fail the test if the command starts the run: the output check must come first."""
    import femref.run

    def refuse(*args, **kwargs):
        raise AssertionError("the run started before the output path was checked")

    monkeypatch.setattr(femref.run, "run_scene", refuse)


# ---------------------------------------------------------------------------------------------
# The output path, checked before any work


def _missing_folder(tmp_path, case):
    return ["-o", str(tmp_path / "missing" / "out.h5")], "the folder", "does not exist"


def _output_is_folder(tmp_path, case):
    (tmp_path / "out").mkdir()
    return ["-o", str(tmp_path / "out")], "'-o' / '--output'", "is a directory"


def _output_is_case(tmp_path, case):
    return ["-o", str(case)], "is the input CASE", "may not overwrite an input"


def _output_is_case_relative(tmp_path, case):
    (tmp_path / "sub").mkdir()
    return ["-o", os.path.relpath(tmp_path / "sub" / ".." / case.name)], "is the input CASE", "may not overwrite an input"


def _output_is_case_symlink(tmp_path, case):
    (tmp_path / "link.yaml").symlink_to(case)
    return ["-o", str(tmp_path / "link.yaml")], "is the input CASE", "may not overwrite an input"


def _output_is_case_hardlink(tmp_path, case):
    os.link(case, tmp_path / "other.yaml")
    return ["-o", str(tmp_path / "other.yaml")], "is the input CASE", "may not overwrite an input"


@pytest.mark.parametrize(
    "make",
    [_missing_folder, _output_is_folder, _output_is_case, _output_is_case_relative, _output_is_case_symlink, _output_is_case_hardlink],
    ids=["missing-folder", "output-is-folder", "output-is-case", "case-by-relative-path", "case-by-symlink", "case-by-hard-link"],
)
def test_run_refuses_a_bad_output_before_running(runner, tmp_path, monkeypatch, no_run, make):
    case = write_case(tmp_path)
    monkeypatch.chdir(tmp_path)
    args, *messages = make(tmp_path, case)
    before = listing(tmp_path)
    result = runner.invoke(main, ["run", str(case), *args])
    assert result.exit_code == 2, result.output
    for message in messages:
        assert message in result.output
    assert listing(tmp_path) == before  # nothing written, the case untouched


def test_default_output_that_is_a_folder_is_refused(runner, tmp_path, monkeypatch, no_run):
    """No -o: the default output (CASE stem + .h5) is checked the same way, and the message says it is the default."""
    case = write_case(tmp_path)
    (tmp_path / "case.h5").mkdir()
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(main, ["run", str(case)])
    assert result.exit_code == 2
    assert "error: -o (default) case.h5: is a folder; the output is a file; nothing was written" in result.output


def test_unwritable_folder_is_refused(runner, tmp_path, no_run):
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        if os.access(folder, os.W_OK):
            pytest.skip("running as a user whom chmod does not deny (root)")
        result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(folder / "out.h5")])
        assert result.exit_code == 2
        assert f"the folder {folder} is not writable" in result.output
        assert list(folder.iterdir()) == []
    finally:
        folder.chmod(0o700)


def test_unwritable_folder_message(runner, tmp_path, monkeypatch, no_run):
    """The same rule where chmod cannot deny (root): the folder reported not writable by os.access."""
    import femref.cli.common

    folder = tmp_path / "locked"
    folder.mkdir()
    real_access = os.access
    monkeypatch.setattr(femref.cli.common.os, "access", lambda path, mode: False if Path(path) == folder else real_access(path, mode))
    result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(folder / "out.h5")])
    assert result.exit_code == 2
    assert f"error: -o {folder / 'out.h5'}: the folder {folder} is not writable (the output's folder must be writable)" in result.output
    assert list(folder.iterdir()) == []


COMMANDS = {  # args (in a folder holding sweeps/, studies/, the free-roll case and a result r.h5), message
    "sweep": (["sweep", "sweeps/free_roll_speeds.yaml", "-o", "missing/out.h5"], "the folder missing does not exist"),
    "sweep-onto-its-SWEEP": (["sweep", "sweeps/free_roll_speeds.yaml", "-o", "sweeps/free_roll_speeds.yaml"], "is the input SWEEP"),
    "study-into-a-file": (["study", "studies/ann_study.yaml", "-o", "impact_free_roll.yaml"], "is a file"),
    "study-under-a-missing-folder": (["study", "studies/ann_study.yaml", "-o", "missing/study"], "the folder missing does not exist"),
    "calibrate": (["calibrate", "sweeps/free_roll_speeds.yaml", "r.h5", "-o", "missing/out.h5"], "the folder missing does not exist"),
    "calibrate-onto-its-SWEEP_FILE": (["calibrate", "sweeps/free_roll_speeds.yaml", "r.h5", "-o", "r.h5"], "is the input SWEEP_FILE"),
    "sweep-onto-its-base-case": (["sweep", "sweeps/free_roll_speeds.yaml", "-o", "impact_free_roll.yaml"], "is the input base of SWEEP"),
    "calibrate-onto-the-base-case": (["calibrate", "sweeps/free_roll_speeds.yaml", "r.h5", "-o", "impact_free_roll.yaml"], "is the input base of SWEEP"),
    "study-writing-onto-its-initial-network": (["study", "initial_study.yaml", "-o", "earlier"],
                                               "would write earlier/networks/fem_mlp.npz, which is the input networks.mlp.mlp.initial of STUDY"),
    "bench": (["bench", "impact_free_roll.yaml", "-o", "missing/out.h5"], "the folder missing does not exist"),
    "bench-plot-onto-its-CASE": (["bench", "impact_free_roll.yaml", "-o", "b.h5", "--plot", "impact_free_roll.yaml"], "--plot impact_free_roll.yaml: is the input CASE"),
    "report": (["report", "r.h5", "-o", "missing/out.html"], "the folder missing does not exist"),
    "report-onto-its-results": (["report", "r.h5", "-o", "r.h5"], "overwrite"),
    "figures-under-a-missing-folder": (["figures", "-o", "missing/figures"], "the folder missing does not exist"),
}


@pytest.fixture(scope="module")
def command_folder(tmp_path_factory):
    """A sweep, a study, an impact case and a result file r.h5, as the commands' inputs."""
    import shutil

    folder = tmp_path_factory.mktemp("commands")
    shutil.copytree(CASES / "sweeps", folder / "sweeps")
    shutil.copytree(CASES / "studies", folder / "studies")
    shutil.copy(CASES / "impact_free_roll.yaml", folder / "impact_free_roll.yaml")
    (folder / "earlier" / "networks").mkdir(parents=True)  # a study continuing a network of its own output folder
    (folder / "earlier" / "networks" / "fem_mlp.npz").write_bytes(b"a saved network")
    study = {"base": "impact_free_roll.yaml", "sets": {"train": {"samples": 2, "seed": 1}, "test": {"samples": 1, "seed": 2}},
             "networks": {"mlp": {"mlp": {"hidden": [4], "activation": "tanh", "solver": "momentum", "initial": "earlier/networks/fem_mlp.npz"}}}}
    (folder / "initial_study.yaml").write_text(yaml.safe_dump(study))
    data = small_case(fields=False)  # no field map to render in the report
    data["models"] = ["rigid"]
    result = CliRunner().invoke(main, ["run", str(write_case(folder, data=data)), "-o", str(folder / "r.h5")])
    assert result.exit_code == 0, result.output
    return folder


@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_writing_command_checks_its_output(runner, command_folder, monkeypatch, command):
    """sweep, study, calibrate, bench (-o and --plot) and report: exit 2, the rule, nothing written."""
    import femref.bench.run
    import femref.study.run
    import femref.sweep

    def refuse(*args, **kwargs):
        raise AssertionError("the work started before the output path was checked")

    for module, name in ((femref.sweep, "run_sweep"), (femref.study.run, "run_study"), (femref.bench.run, "run_bench")):
        monkeypatch.setattr(module, name, refuse)
    monkeypatch.chdir(command_folder)
    args, message = COMMANDS[command]
    before = listing(command_folder)
    result = runner.invoke(main, args)
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert listing(command_folder) == before


def measured_case_folder(folder: Path) -> Path:
    """cases/measured_yard.yaml with its record files and networks in ``folder`` (relative paths, as shipped)."""
    import shutil

    shutil.copytree(CASES / "data" / "measured", folder / "data" / "measured")
    shutil.copytree(CASES / "networks", folder / "networks")
    shutil.copy(CASES / "measured_yard.yaml", folder / "measured.yaml")
    return folder / "measured.yaml"


def csv_case_folder(folder: Path) -> Path:
    """cases/rod_transient_csv.yaml with its load CSV in ``folder``."""
    import shutil

    (folder / "data").mkdir()
    shutil.copy(CASES / "data" / "coupler_force.csv", folder / "data" / "coupler_force.csv")
    shutil.copy(CASES / "rod_transient_csv.yaml", folder / "case.yaml")
    return folder / "case.yaml"


@pytest.mark.parametrize(
    ("make", "target", "key"),
    [
        (measured_case_folder, "data/measured/hammer.csv", "records[0].file of CASE"),
        (measured_case_folder, "data/measured/anvil.csv", "records[1].file of CASE"),
        (measured_case_folder, "networks/fem_mlp.npz", "estimators[3].network of CASE"),
        (csv_case_folder, "data/coupler_force.csv", "loads.F2.csv.path of CASE"),
    ],
    ids=["measured-record", "second-record", "network", "csv-load"],
)
def test_run_refuses_to_overwrite_a_file_the_case_names(runner, tmp_path, monkeypatch, no_run, make, target, key):
    """``femref run case.yaml -o <a record file | network | load CSV the case reads>``: exit 2 before any work, the
    message names -o, the case key and the input, and every file is unchanged — by its own path or a symbolic link."""
    import femref.run.measured

    monkeypatch.setattr(femref.run.measured, "run_measured", lambda *args, **kwargs: pytest.fail("the run started"))
    case = make(tmp_path)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "link").symlink_to(tmp_path / target)
    before = listing(tmp_path)
    for output in (target, "link"):
        result = runner.invoke(main, ["run", str(case), "-o", output])
        assert result.exit_code == 2, result.output
        assert f"error: -o {output}: is the input {key} {tmp_path / target} (the output may not overwrite an input); nothing was written" in result.stderr
    assert listing(tmp_path) == before


def test_case_inputs_walk_every_file_path_of_a_case(tmp_path):
    """femref.case.inputs.case_inputs: every file path of the validated case by its case-file key path, absolute
    (records, networks — also one per impact type — and a CSV load); none for a case that names no file."""
    from femref.case import load_case
    from femref.case.inputs import case_inputs

    case = measured_case_folder(tmp_path)
    data = yaml.safe_load(case.read_text())
    typed = {"free_to_roll": "networks/fem_mlp.npz", "coupled": "networks/rigid_mlp.npz"}
    data["estimators"].append({"name": "ann_typed", "network": typed})
    case.write_text(yaml.safe_dump(data))
    assert case_inputs(load_case(case)) == {
        "records[0].file": tmp_path / "data" / "measured" / "hammer.csv",
        "records[1].file": tmp_path / "data" / "measured" / "anvil.csv",
        "estimators[3].network": tmp_path / "networks" / "fem_mlp.npz",
        "estimators[4].network.free_to_roll": tmp_path / "networks" / "fem_mlp.npz",
        "estimators[4].network.coupled": tmp_path / "networks" / "rigid_mlp.npz",
    }
    assert case_inputs(load_case(CASES / "rod_transient_csv.yaml")) == {"loads.F2.csv.path": CASES / "data" / "coupler_force.csv"}
    assert case_inputs(load_case(CASES / "impact_free_roll.yaml")) == {}


# ---------------------------------------------------------------------------------------------
# Publishing a result with its field files


def test_field_files_are_published_before_the_result_with_their_checksums(runner, tmp_path, monkeypatch):
    renamed = []
    real_replace = os.replace

    def recording_replace(source, target):
        renamed.append(Path(target).name)
        real_replace(source, target)

    monkeypatch.setattr(femref.results.os, "replace", recording_replace)
    output = tmp_path / "out.h5"
    result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(output)])
    assert result.exit_code == 0, result.output
    assert renamed == ["out_fem_fields.h5", "out_fem_fields.xdmf", "out.h5"]  # the result last
    with h5py.File(output) as h5:
        recorded = json.loads(h5["fem/fields"].attrs["field_files"])
    assert recorded == {name: hashlib.sha256((tmp_path / name).read_bytes()).hexdigest() for name in ("out_fem_fields.h5", "out_fem_fields.xdmf")}
    assert field_files_match(output) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.yaml", "out.h5", "out_fem_fields.h5", "out_fem_fields.xdmf"]  # no temporaries


def test_a_stale_field_file_is_detected(runner, tmp_path, monkeypatch):
    """The next run killed between publishing its field files and its result leaves new field files beside the
    previous result: simulated by putting the previous run's field file back beside the new result."""
    import femref.report.build
    from femref.report.read import read_result_file

    monkeypatch.setattr(femref.report.build, "field_map_picture", lambda model: None)  # no rendering: only the warning matters

    case = write_case(tmp_path)
    output = tmp_path / "out.h5"
    assert runner.invoke(main, ["run", str(case), "-o", str(output)]).exit_code == 0
    previous = (tmp_path / "out_fem_fields.h5").read_bytes()
    data = small_case()
    data["loads"]["F2"]["half_sine"]["amplitude"] = -2.0e6
    write_case(tmp_path, data=data)
    assert runner.invoke(main, ["run", str(case), "-o", str(output)]).exit_code == 0
    assert field_files_match(output) == []
    (tmp_path / "out_fem_fields.h5").write_bytes(previous)
    problems = field_files_match(output)
    assert problems == [f"{tmp_path / 'out_fem_fields.h5'}: field file of model fem is not the one out.h5 was written with (SHA-256 differs): another run's"]
    assert read_result_file(output).field_file_problems == tuple(problems)
    (tmp_path / "out_fem_fields.xdmf").unlink()
    assert f"{tmp_path / 'out_fem_fields.xdmf'}: field file of model fem missing" in field_files_match(output)
    report = runner.invoke(main, ["report", str(output), "-o", str(tmp_path / "out.html")])
    assert report.exit_code == 0, report.output
    assert "warning: " in report.output and "another run's" in report.output


@pytest.mark.parametrize("recorded", [True, False], ids=["names-recorded", "written-before-names-were-recorded"])
def test_report_refuses_to_overwrite_a_field_file_of_its_result(runner, tmp_path, monkeypatch, recorded):
    """``femref report run.h5 -o run_fem_fields.h5`` (or .xdmf): exit 2, the message names -o, the field file as an
    input of RESULTS.h5 and the rule, and nothing is written — whether the result records the field files' names
    or (an older result) not: then femref's names for them are protected."""
    import femref.report.build

    monkeypatch.setattr(femref.report.build, "field_map_picture", lambda model: None)  # no rendering: refused before
    monkeypatch.chdir(tmp_path)
    assert runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", "run.h5"]).exit_code == 0
    if not recorded:
        with h5py.File(tmp_path / "run.h5", "a") as h5:
            del h5["fem/fields"].attrs["field_files"]
    before = listing(tmp_path)
    for suffix, kind in ((".h5", "HDF5"), (".xdmf", "XDMF")):
        target = f"run_fem_fields{suffix}"
        result = runner.invoke(main, ["report", "run.h5", "-o", target])
        assert result.exit_code == 2, result.output
        assert (f"error: -o {target}: is the input {kind} field file of model fem of RESULTS.h5 {target} "
                "(the output may not overwrite an input); nothing was written") in result.stderr
    assert listing(tmp_path) == before


# ---------------------------------------------------------------------------------------------
# Temporaries and their leftovers


def test_leftovers_of_dead_runs_are_removed_and_live_ones_kept(runner, tmp_path):
    output = tmp_path / "out.h5"
    dead = dead_pid()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        dead_file = tmp_path / f".out.h5.femref-{dead}.tmp"
        dead_folder = tmp_path / f".out.h5.femref-{dead}.fields.tmp"
        live_other = tmp_path / f".out.h5.femref-{sleeper.pid}.tmp"
        live_own = temporary_path(output)  # this process: the CLI runs in it
        other_name = tmp_path / f".other.h5.femref-{dead}.tmp"  # a dead run's, of another final name
        for path in (dead_file, live_other, live_own, other_name):
            path.write_bytes(b"partial")
        dead_folder.mkdir()
        (dead_folder / "out_fem_fields.xdmf").write_text("partial")
        assert leftovers(output) == sorted([dead_file, dead_folder])
        result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(output)])
        assert result.exit_code == 0, result.output
        assert not dead_file.exists() and not dead_folder.exists()
        assert live_other.read_bytes() == live_own.read_bytes() == other_name.read_bytes() == b"partial"
        assert field_files_match(output) == []
        assert not [p for p in tmp_path.iterdir() if p.name.startswith("tmp")]  # no anonymous temporary folders
    finally:
        sleeper.kill()
        sleeper.wait()


def _age(*paths: Path, seconds: float = 3600.0) -> None:
    """Set the modification time of ``paths`` (files first, then their folder) ``seconds`` into the past."""
    then = time.time() - seconds
    for path in paths:
        os.utime(path, (then, then))


def _old_field_folder(folder: Path, name: str, files: dict[str, bytes], seconds: float = 3600.0) -> Path:
    """A ``tempfile.mkdtemp`` folder of an older femref holding ``files``, unchanged for ``seconds``."""
    (folder / name).mkdir()
    for file, content in files.items():
        (folder / name / file).write_bytes(content)
    _age(*[folder / name / file for file in files], folder / name, seconds=seconds)
    return folder / name


def test_an_older_femrefs_temporaries_are_removed_only_when_certainly_theirs_and_unused(runner, tmp_path):
    """Before pid-named temporaries femref left ``tmp<random>`` folders of field files and ``.<name>.<random>.tmp``
    result files. A later write of the same result removes those whose content is femref's (field files of this
    result, HDF5 and XDMF by their first bytes), unchanged for 10 minutes and open in no process, saying so on stderr;
    it names and keeps one that also holds other files, one that changed recently and one a process holds open; it
    does not touch or mention a ``tmp*`` folder of someone else or an older femref's folder of another result."""
    h5py.File(tmp_path / "seed.h5", "w").close()
    hdf5 = (tmp_path / "seed.h5").read_bytes()
    (tmp_path / "seed.h5").unlink()
    xdmf = b'<Xdmf Version="3.0"><Domain /></Xdmf>'
    theirs = _old_field_folder(tmp_path, "tmpa1b2c3d4", {"out_fem_fields.h5": hdf5, "out_fem_fields.xdmf": xdmf})
    partial = _old_field_folder(tmp_path, "tmpe5f6g7h8", {"out_modal_fields.h5": hdf5[:8]})  # killed while writing
    result_tmp = tmp_path / ".out.h5.x9y8z7w6.tmp"
    result_tmp.write_bytes(hdf5)
    _age(result_tmp)
    mixed = _old_field_folder(tmp_path, "tmpmixed123", {"out_fem_fields.h5": hdf5, "notes.txt": b"mine"})
    recent = _old_field_folder(tmp_path, "tmprecent12", {"out_fem_fields.h5": hdf5}, seconds=5.0)
    held = _old_field_folder(tmp_path, "tmpheld1234", {"out_fem_fields.h5": hdf5})
    someone = _old_field_folder(tmp_path, "tmpsomeone1", {"data.bin": b"not femref's"})
    other_result = _old_field_folder(tmp_path, "tmpother123", {"other_fem_fields.h5": hdf5})
    holder = subprocess.Popen([sys.executable, "-c", f"import sys, time; f = open({str(held / 'out_fem_fields.h5')!r}, 'rb'); print('open', flush=True); time.sleep(60)"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "open"
        result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(tmp_path / "out.h5")])
    finally:
        holder.kill()
        holder.wait()
    assert result.exit_code == 0, result.output
    for removed in (theirs, partial, result_tmp):
        assert not removed.exists(), removed
        assert f"note: removed {removed}: a temporary of out.h5 left by an older femref run" in result.stderr
    for kept, why in ((mixed, "it also holds notes.txt, which femref does not write there"), (recent, "it changed"),
                      (held, "a running process uses it")):
        assert kept.is_dir(), kept
        assert f"note: kept {kept}: it looks like an older femref's temporary of out.h5, but {why}" in result.stderr
    for untouched in (someone, other_result):
        assert untouched.is_dir() and str(untouched) not in result.stderr
    assert field_files_match(tmp_path / "out.h5") == []


def test_without_proc_an_older_femrefs_temporaries_are_only_named(runner, tmp_path, monkeypatch):
    """Where no /proc tells whether a process uses them, nothing is removed: each is named on stderr, one line."""
    h5py.File(tmp_path / "seed.h5", "w").close()
    folder = _old_field_folder(tmp_path, "tmpa1b2c3d4", {"out_fem_fields.h5": (tmp_path / "seed.h5").read_bytes()})
    monkeypatch.setattr(femref.core.publishing, "_paths_in_use", lambda entries: None)
    result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 0, result.output
    assert folder.is_dir() and (folder / "out_fem_fields.h5").is_file()
    notes = [line for line in result.stderr.splitlines() if str(folder) in line]
    assert notes == [f"note: kept {folder}: it looks like an older femref's temporary of out.h5, but whether a process uses it "
                     "cannot be checked here (no /proc); remove it yourself if no femref run is writing it"]


def test_a_killed_runs_leftover_removal_is_said(runner, tmp_path):
    """The pid-named leftovers of a dead process are named on stderr when removed."""
    dead_file = tmp_path / f".out.h5.femref-{dead_pid()}.tmp"
    dead_file.write_bytes(b"partial")
    result = runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 0, result.output
    assert not dead_file.exists()
    assert f"note: removed {dead_file}: a temporary of out.h5 left by a killed femref run" in result.stderr


def test_temporary_names():
    path = Path("/results/run 1.h5")
    assert temporary_path(path) == Path(f"/results/.run 1.h5.femref-{os.getpid()}.tmp")
    assert temporary_path(path, "fields") == Path(f"/results/.run 1.h5.femref-{os.getpid()}.fields.tmp")


def test_kill_9_while_publishing_keeps_the_previous_pair(runner, tmp_path):
    """A run killed (SIGKILL) between writing its temporaries and renaming them: the previous result and field files
    are intact and match, no final name is new or changed, and the next run removes the leftovers and publishes a
    matching pair."""
    case = write_case(tmp_path)
    output = tmp_path / "out.h5"
    assert runner.invoke(main, ["run", str(case), "-o", str(output)]).exit_code == 0
    previous = listing(tmp_path)
    data = small_case()
    data["loads"]["F2"]["half_sine"]["amplitude"] = -2.0e6
    write_case(tmp_path, data=data)
    finals = listing(tmp_path)

    env = {**os.environ, TEST_PAUSE_VARIABLE: "60"}
    command = [sys.executable, "-c", "from femref.cli import main; main()", "run", str(case), "-o", str(output)]
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    staging = tmp_path / f".out.h5.femref-{process.pid}.fields.tmp"
    result_temporary = tmp_path / f".out.h5.femref-{process.pid}.tmp"
    try:
        deadline = time.monotonic() + 120.0
        while not (result_temporary.exists() and {p.name for p in staging.iterdir()} >= {"out_fem_fields.xdmf", "out_fem_fields.h5"}):
            assert process.poll() is None, "the run ended before publishing"
            assert time.monotonic() < deadline, "the run never reached its field files"
            time.sleep(0.05)
        time.sleep(0.2)  # into the pause (or still writing the result: the outcome must be the same)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    after = listing(tmp_path)
    assert {k: v for k, v in after.items() if not k.startswith(".")} == finals  # previous result and field files intact
    assert field_files_match(output) == []
    assert leftovers(output) == [staging, result_temporary]

    assert runner.invoke(main, ["run", str(case), "-o", str(output)]).exit_code == 0
    assert leftovers(output) == [] and not staging.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.yaml", "out.h5", "out_fem_fields.h5", "out_fem_fields.xdmf"]
    assert field_files_match(output) == []
    assert listing(tmp_path)["out.h5"] != previous["out.h5"]


# ---------------------------------------------------------------------------------------------
# xarray


def _result(model: str, axis: str, n: int) -> ModelResult:
    values = np.linspace(0.0, 1.0, n)
    result = ModelResult(model=model, axes={axis: values})
    if axis == "omega":
        result.axes["lambda"] = values / 2.0
    result.set_probe_outputs(["left", "car/front"], {"acceleration": np.outer(values, [1.0, 2.0]), "displacement": np.outer(values, [3.0, 4.0])})
    if axis == "time":
        result.couplers = {"c1": {"force": 5.0 * values, "peak_force": np.asarray(5.0)}}
        result.energy = {"kinetic": values, "total": 2.0 * values}
        result.measured = {"time": np.linspace(0.0, 1.0, 7), "left": np.arange(7.0)}
        result.fields = {"x": np.linspace(0.0, 2.0, 3), "time": values[::2], "u": np.zeros((values[::2].size, 3))}
    return result


def test_xarray_opens_every_history_group_with_its_axis(tmp_path):
    """Each history group's datasets run along a dimension scale linked into the group: xarray (h5netcdf) gives
    them the model's time (harmonic: omega, with lambda) as coordinate; the measured histories get their own time;
    the whole file opens as a DataTree (no group's time clashes with an ancestor's)."""
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = tmp_path / "r.h5"
    transient, harmonic = _result("fem", "time", 11), _result("exact", "omega", 5)
    write_results(path, "kind: transient\n", [transient, harmonic])
    for group, names in (("fem/probes/left", ["acceleration", "displacement"]), ("fem/probes/car/front", ["acceleration", "displacement"]),
                         ("fem/couplers/c1", ["force"]), ("fem/energy", ["kinetic", "total"])):
        with xr.open_dataset(path, group=group, engine="h5netcdf", phony_dims="sort") as ds:
            np.testing.assert_array_equal(ds["time"].values, transient.axes["time"])
            assert ds["time"].attrs["units"] == "s"
            for name in names:
                assert ds[name].dims == ("time",), (group, name)
    with xr.open_dataset(path, group="fem/couplers/c1", engine="h5netcdf", phony_dims="sort") as ds:
        assert ds["peak_force"].dims == () and float(ds["peak_force"]) == 5.0
    with xr.open_dataset(path, group="fem/measured/left", engine="h5netcdf", phony_dims="sort") as ds:
        np.testing.assert_array_equal(ds["time"].values, transient.measured["time"])
        np.testing.assert_array_equal(ds["acceleration"].values, np.arange(7.0))
    with xr.open_dataset(path, group="fem/fields", engine="h5netcdf", phony_dims="sort") as ds:
        assert ds["u"].dims == ("time", "x") and ds["time"].size == 6
    with xr.open_dataset(path, group="exact/probes/left", engine="h5netcdf", phony_dims="sort") as ds:
        np.testing.assert_array_equal(ds["omega"].values, harmonic.axes["omega"])
        np.testing.assert_array_equal(ds["lambda"].values, harmonic.axes["lambda"])
        assert "lambda" in ds.coords and ds["acceleration"].dims == ("omega",)
    tree = xr.open_datatree(path, engine="h5netcdf", phony_dims="sort")
    np.testing.assert_array_equal(tree["fem/probes/left"]["time"].values, transient.axes["time"])
    with h5py.File(path) as h5:  # one scale object per model, stored once
        assert h5["fem/probes/left/time"].id == h5["fem/energy/time"].id
        assert h5["fem/probes/left/time"].is_scale and not h5["fem/time"].is_scale


def test_xarray_opens_a_run_of_the_cli(runner, tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    output = tmp_path / "out.h5"
    assert runner.invoke(main, ["run", str(write_case(tmp_path)), "-o", str(output)]).exit_code == 0
    with h5py.File(output) as h5:
        time_axis = h5["fem/time"][()]
    with xr.open_dataset(output, group="fem/probes/center", engine="h5netcdf", phony_dims="sort") as ds:
        np.testing.assert_array_equal(ds["time"].values, time_axis)
        assert set(ds.data_vars) == {"acceleration", "displacement", "axial_force"}


def test_run_refuses_an_output_whose_field_files_would_replace_an_input(tmp_path) -> None:
    """``femref run`` of a case with fem.fields writes <stem>_fem_fields.xdmf/.h5 beside the output: an output whose
    field file would replace a file the case names (a CSV load named like one) exits 2 naming the input before any
    work, and every file is as it was."""
    import shutil

    shutil.copy(CASES / "data" / "coupler_force.csv", tmp_path / "run_fem_fields.h5")
    data = yaml.safe_load((CASES / "rod_transient_csv.yaml").read_text())
    data["loads"]["F2"]["csv"]["path"] = "run_fem_fields.h5"
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(data))
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(tmp_path / "run.h5")])
    assert result.exit_code == 2, result.output
    assert "run_fem_fields.h5" in result.output and "loads.F2.csv.path" in result.output and "nothing was written" in result.output
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
